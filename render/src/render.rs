//! Direct illumination of a [`RenderScene`] with any technique of [`manylights::direct`], plus
//! image output.
//!
//! Two protocols ([`Protocol`]):
//! - **jittered** (the default): every estimate is a new shading point, as in any renderer —
//!   a primary ray through a uniformly jittered position in the pixel, the first surface it
//!   hits, and the technique's per-point set-up ([`Estimator::new`]: importances, cuts,
//!   budget) built for that one estimate. A pixel's value estimates the pixel integral
//!   (background samples count 0), and a technique's time includes its set-up at every sample.
//! - **fixed-point** (`--fixed-point`): one shading point per pixel (the ray through the pixel
//!   centre), its set-up built once and reused by all `spp` estimates, so that an image's error
//!   is the light-sampling error alone.
//!
//! Light samples cast shadow rays and BRDF rays reach only the lights in front of the first
//! surface (the scene's geometry is the core's [`manylights::Occluder`]). The lights themselves
//! are not drawn (direct illumination of surfaces only). Rows run in parallel with rayon; a
//! progress bar (indicatif, on a terminal) counts rows.
//!
//! **Time.** [`Image::seconds`] is the render's *busy time summed over threads*: each row is
//! timed on the thread that renders it, by that thread's CPU clock (`CLOCK_THREAD_CPUTIME_ID`
//! on Linux and macOS; elsewhere by the wall clock around the row), and the row times are
//! added up. Unlike the wall-clock time ([`Image::wall_seconds`], also kept), it does not
//! count threads idling at the end of a render (load imbalance), rayon's start-up, nor — with
//! the CPU clock — the time a thread waits while other processes run on its core, and it does
//! not depend on the number of threads: on a shared machine it is the stable measure. When
//! the cores are free it is about wall time × threads.
//!
//! The result is an [`Image`]; [`crate::image`] writes it out.

use crate::image::{Image, Pixel};
use crate::scene::RenderScene;
use crate::uniforms::RngUniforms;
use indicatif::{ProgressBar, ProgressStyle};
use manylights::direct::VisibilityCache;
use manylights::ShadingPoint;
use manylights::{Estimator, Params, Technique};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use std::time::Instant;

/// Where the estimates of a pixel are taken (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Protocol {
    /// A new jittered primary ray, shading point and set-up for every estimate.
    #[default]
    Jittered,
    /// One shading point per pixel (its centre), its set-up reused by every estimate.
    FixedPoint,
}

impl Protocol {
    /// The protocol's name in reports (`jittered`, `fixed-point`).
    pub fn name(self) -> &'static str {
        match self {
            Protocol::Jittered => "jittered",
            Protocol::FixedPoint => "fixed-point",
        }
    }
}

/// What to render.
#[derive(Clone, Copy, Debug)]
pub struct RenderConfig {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Estimates per pixel.
    pub spp: usize,
    /// The technique.
    pub technique: Technique,
    /// Seed of the estimates.
    pub seed: u64,
    /// Show a progress bar.
    pub progress: bool,
    /// Where the estimates are taken.
    pub protocol: Protocol,
    /// The estimators' parameters.
    pub params: Params,
    /// Learned visibility ([`Learn`]; `None`: none, the estimators as they are).
    pub learn: Option<Learn>,
}

/// Learned visibility in a render ([`manylights::direct::VisibilityCache`]): the samples of each
/// pixel are taken in passes of 1, 1, 2, 4, … (doubling, the last one what is left), every
/// pixel in each pass, and the cache is committed after each pass, so pass k samples with
/// what passes 0..k recorded. Only the techniques with a BRDF-oriented cut (`bl`, `bl-mis`,
/// `mis-equal`, `full`) are given the cache; the others render as without it. The learning's
/// cost (recording, commits) is in the render's time, and every pass's samples are in the
/// image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Learn {
    /// The grid cell's side as a fraction of the scene's extent (the diagonal of its
    /// geometry's bounding box).
    pub cell: f32,
    /// Cells of the cache's table.
    pub cells: u32,
    /// Counters per cell.
    pub slots: u32,
    /// The factors' floor.
    pub floor: f32,
}

impl Default for Learn {
    fn default() -> Self {
        Learn {
            cell: 1.0 / 64.0,
            cells: manylights::direct::VisibilityOptions::DEFAULT_CELLS,
            slots: manylights::direct::VisibilityOptions::DEFAULT_SLOTS,
            floor: manylights::direct::VisibilityOptions::DEFAULT_FLOOR,
        }
    }
}

impl Learn {
    /// Whether `technique` is given the cache (it has a BRDF-oriented cut).
    pub fn applies_to(technique: Technique) -> bool {
        matches!(
            technique,
            Technique::Bl | Technique::BlMis | Technique::MisEqual | Technique::Full
        )
    }

    /// The sample counts of the passes of an `spp` render: 1, 1, 2, 4, … , what is left.
    pub fn passes(spp: usize) -> Vec<usize> {
        let mut out = Vec::new();
        let (mut done, mut next) = (0usize, 1usize);
        while done < spp {
            let k = next.min(spp - done);
            out.push(k);
            done += k;
            if out.len() > 1 {
                next *= 2;
            }
        }
        out
    }

    /// The cache's options for `scene`.
    pub fn options(&self, scene: &RenderScene) -> manylights::direct::VisibilityOptions {
        let extent = scene.geometry.extent();
        let size = if extent > 0.0 && extent.is_finite() {
            extent * self.cell
        } else {
            1.0
        };
        manylights::direct::VisibilityOptions {
            cell_size: size,
            cells: self.cells,
            slots: self.slots,
            floor: self.floor,
        }
    }
}

/// CPU time of the calling thread, in seconds.
#[cfg(any(target_os = "linux", target_os = "macos"))]
pub fn thread_cpu_seconds() -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable `timespec`; `clock_gettime` only writes into it.
    let r = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (r == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

/// CPU time of the calling thread: not available here (rows are timed by the wall clock).
#[cfg(not(any(target_os = "linux", target_os = "macos")))]
pub fn thread_cpu_seconds() -> Option<f64> {
    None
}

/// Times `f` on the calling thread: CPU seconds if the thread's CPU clock is available,
/// wall-clock seconds otherwise.
pub fn busy_time(f: impl FnOnce()) -> f64 {
    let (cpu0, wall0) = (thread_cpu_seconds(), Instant::now());
    f();
    match (cpu0, thread_cpu_seconds()) {
        (Some(a), Some(b)) if b >= a => b - a,
        _ => wall0.elapsed().as_secs_f64(),
    }
}

/// The shading point seen through pixel (`px`, `py`) at its centre, if any.
pub fn primary(
    scene: &RenderScene,
    px: usize,
    py: usize,
    w: usize,
    h: usize,
) -> Option<ShadingPoint> {
    primary_at(scene, px, py, w, h, [0.5, 0.5])
}

/// The shading point seen through the centre of every pixel of a `w × h` image, row-major
/// ([`primary`]; `None` where the centre's ray hits nothing or grazes its surface): the
/// primary hit by which `compare` classes a pixel (its material and view angle). Under the
/// jittered protocol a pixel's own estimates take their primary hits anywhere in the pixel;
/// the centre's is the one the pixel is classed by.
pub fn centre_hits(scene: &RenderScene, w: usize, h: usize) -> Vec<Option<ShadingPoint>> {
    (0..w * h)
        .into_par_iter()
        .map(|i| primary(scene, i % w, i / w, w, h))
        .collect()
}

/// The shading point seen through position `offset` (in [0, 1)²) of pixel (`px`, `py`).
pub fn primary_at(
    scene: &RenderScene,
    px: usize,
    py: usize,
    w: usize,
    h: usize,
    offset: [f32; 2],
) -> Option<ShadingPoint> {
    let cam = &scene.camera;
    let d = cam.direction(
        (px as f32 + offset[0]) / w as f32,
        (py as f32 + offset[1]) / h as f32,
        w as f32 / h as f32,
    );
    let hit = scene.geometry.nearest(cam.eye, d, 1e-4)?;
    let wo = -d;
    let mut n = hit.normal;
    let c = n.dot(wo);
    if c.abs() < 1e-4 {
        return None;
    }
    if c < 0.0 {
        n = -n;
    }
    let p = cam.eye + d * hit.t;
    // Offset off the surface against self-intersection of shadow and BRDF rays.
    let position = p + n * (1e-4 * (1.0 + p.abs().max_element()));
    Some(ShadingPoint {
        position,
        normal: n,
        wo,
        material: hit.material,
    })
}

/// Mean and per-estimate variance of `spp` estimates (Welford, per channel), each from
/// `estimate`.
#[inline]
fn moments(spp: usize, mut estimate: impl FnMut() -> [f64; 3]) -> (Pixel, Pixel) {
    let (mut m, mut m2) = ([0f64; 3], [0f64; 3]);
    for k in 0..spp {
        let x = estimate();
        for c in 0..3 {
            let d = x[c] - m[c];
            m[c] += d / (k + 1) as f64;
            m2[c] += d * (x[c] - m[c]);
        }
    }
    let var = m2.map(|v| {
        if spp > 1 {
            (v / (spp - 1) as f64) as f32
        } else {
            0.0
        }
    });
    (m.map(|v| v as f32), var)
}

/// No light: black with no variance.
const BLACK: (Pixel, Pixel) = ([0.0; 3], [0.0; 3]);

/// One estimate at the estimator's point (the light set holds the scene's sky, if it has
/// one); an error counts in `failed` and as black.
#[inline]
fn estimate(
    scene: &RenderScene,
    est: &mut Estimator<'_>,
    rng: &mut Pcg64Mcg,
    failed: &mut u64,
) -> [f64; 3] {
    let mut u = RngUniforms(rng);
    est.estimate(&scene.geometry, &mut u).unwrap_or_else(|_| {
        *failed += 1;
        [0.0; 3]
    })
}

/// One pixel's mean and variance under `cfg`'s protocol, with its own generator; the core's
/// refusals (each counted as black) added to `failed`.
fn pixel(
    scene: &RenderScene,
    cfg: &RenderConfig,
    params: &Params,
    (px, py): (usize, usize),
    rng: &mut Pcg64Mcg,
    failed: &mut u64,
) -> (Pixel, Pixel) {
    let (w, h) = (cfg.width, cfg.height);
    match cfg.protocol {
        Protocol::FixedPoint => {
            let Some(sp) = primary(scene, px, py, w, h) else {
                return BLACK;
            };
            let Ok(mut est) = Estimator::new(&scene.lights, &sp, cfg.technique, params) else {
                *failed += cfg.spp as u64;
                return BLACK;
            };
            moments(cfg.spp, || estimate(scene, &mut est, rng, failed))
        }
        Protocol::Jittered => {
            // One estimator per pixel, moved to each new shading point (`reset`: the same
            // estimator as a new one, without copying it).
            let mut slot: Option<Estimator<'_>> = None;
            moments(cfg.spp, || {
                let offset = [rng.random::<f32>(), rng.random::<f32>()];
                let Some(sp) = primary_at(scene, px, py, w, h, offset) else {
                    return [0.0; 3];
                };
                match Estimator::reuse(&mut slot, &scene.lights, &sp, cfg.technique, params) {
                    Ok(est) => estimate(scene, est, rng, failed),
                    Err(_) => {
                        *failed += 1;
                        [0.0; 3]
                    }
                }
            })
        }
    }
}

/// [`pixel`] with learned visibility: `spp` estimates with estimators of `visibility`, set
/// up in the thread's `slot` (moved from point to point in place: [`Estimator::reset`]).
#[allow(clippy::too_many_arguments)]
fn pixel_learning<'a>(
    scene: &'a RenderScene,
    cfg: &RenderConfig,
    visibility: &'a VisibilityCache,
    slot: &mut Option<Estimator<'a>>,
    spp: usize,
    (px, py): (usize, usize),
    rng: &mut Pcg64Mcg,
    failed: &mut u64,
) -> (Pixel, Pixel) {
    let (w, h) = (cfg.width, cfg.height);
    let (set, t, params) = (&scene.lights, cfg.technique, &cfg.params);
    match cfg.protocol {
        Protocol::FixedPoint => {
            let Some(sp) = primary(scene, px, py, w, h) else {
                return BLACK;
            };
            let Ok(est) = Estimator::reuse_with_visibility(slot, set, visibility, &sp, t, params)
            else {
                *failed += spp as u64;
                return BLACK;
            };
            moments(spp, || estimate(scene, est, rng, failed))
        }
        Protocol::Jittered => moments(spp, || {
            let offset = [rng.random::<f32>(), rng.random::<f32>()];
            let Some(sp) = primary_at(scene, px, py, w, h, offset) else {
                return [0.0; 3];
            };
            match Estimator::reuse_with_visibility(slot, set, visibility, &sp, t, params) {
                Ok(est) => estimate(scene, est, rng, failed),
                Err(_) => {
                    *failed += 1;
                    [0.0; 3]
                }
            }
        }),
    }
}

/// Renders `scene` with `cfg`.
pub fn render(scene: &RenderScene, cfg: &RenderConfig) -> Image {
    render_with(scene, cfg, None)
}

/// [`render`], calling `on_row` (if any) from the rendering thread after each image row (of
/// each pass, when learning): a host's own progress report.
pub fn render_with(
    scene: &RenderScene,
    cfg: &RenderConfig,
    on_row: Option<&(dyn Fn() + Sync)>,
) -> Image {
    match cfg.learn {
        Some(learn) if Learn::applies_to(cfg.technique) => {
            render_learning(scene, cfg, &learn, on_row)
        }
        _ => render_plain(scene, cfg, on_row),
    }
}

/// The seed of pixel `i`'s generator in pass `pass` of a render learning visibility.
fn pass_seed(cfg: &RenderConfig, i: usize, pass: usize, tech_index: u64) -> u64 {
    cfg.seed
        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
        .wrapping_add((i as u64) << 8)
        .wrapping_add(tech_index)
        ^ (pass as u64).wrapping_mul(0xd1b5_4a32_d192_ed03)
}

/// [`render`] learning visibility ([`Learn`]): passes, each committed into the cache.
fn render_learning(
    scene: &RenderScene,
    cfg: &RenderConfig,
    learn: &Learn,
    on_row: Option<&(dyn Fn() + Sync)>,
) -> Image {
    let (w, h) = (cfg.width, cfg.height);
    let tech_index = Technique::ALL
        .iter()
        .position(|&t| t == cfg.technique)
        .unwrap_or(0) as u64;
    let start = Instant::now();
    let mut busy = 0.0f64;
    let mut failed = 0u64;
    let mut cache = None;
    busy += busy_time(|| cache = VisibilityCache::new(&scene.lights, learn.options(scene)).ok());
    let Some(cache) = cache else {
        return render_plain(scene, cfg, on_row);
    };
    // Per pixel: estimates so far, their sums and sums of squares (f64, per channel).
    let mut acc = vec![(0usize, [0f64; 3], [0f64; 3]); w * h];
    let passes = Learn::passes(cfg.spp);
    let bar = if cfg.progress {
        let b = ProgressBar::new((h * passes.len()) as u64);
        b.set_message(format!("{}+learn", cfg.technique.name()));
        b
    } else {
        ProgressBar::hidden()
    };
    for (pass, &k) in passes.iter().enumerate() {
        let c = &cache;
        let (t, f): (f64, u64) = acc
            .par_chunks_mut(w.max(1))
            .enumerate()
            // One estimator per worker, moved from point to point.
            .map_init(
                || None,
                |slot, (py, row)| {
                    let mut failed = 0u64;
                    let t = busy_time(|| {
                        for (px, a) in row.iter_mut().enumerate() {
                            let seed = pass_seed(cfg, py * w + px, pass, tech_index);
                            let mut rng = Pcg64Mcg::seed_from_u64(seed);
                            let (m, v) = pixel_learning(
                                scene,
                                cfg,
                                c,
                                slot,
                                k,
                                (px, py),
                                &mut rng,
                                &mut failed,
                            );
                            // Back to sums: k·m and (k − 1)·v + k·m².
                            for ch in 0..3 {
                                let (m, v) = (f64::from(m[ch]), f64::from(v[ch]));
                                a.1[ch] += k as f64 * m;
                                a.2[ch] += (k as f64 - 1.0) * v + k as f64 * m * m;
                            }
                            a.0 += k;
                        }
                    });
                    bar.inc(1);
                    if let Some(f) = on_row {
                        f();
                    }
                    (t, failed)
                },
            )
            .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        busy += t;
        failed += f;
        if pass + 1 < passes.len() {
            busy += busy_time(|| cache.commit());
        }
    }
    let wall_seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let mut mean = vec![[0f32; 3]; w * h];
    let mut var = vec![[0f32; 3]; w * h];
    for ((n, s, s2), (m, v)) in acc.iter().zip(mean.iter_mut().zip(var.iter_mut())) {
        let n = *n as f64;
        for ch in 0..3 {
            let mu = s[ch] / n;
            m[ch] = mu as f32;
            v[ch] = if n > 1.0 {
                ((s2[ch] - n * mu * mu) / (n - 1.0)).max(0.0) as f32
            } else {
                0.0
            };
        }
    }
    Image {
        width: w,
        height: h,
        mean,
        var,
        spp: cfg.spp,
        seconds: busy,
        wall_seconds,
        failed,
    }
}

/// [`render`] without learning.
fn render_plain(
    scene: &RenderScene,
    cfg: &RenderConfig,
    on_row: Option<&(dyn Fn() + Sync)>,
) -> Image {
    let (w, h) = (cfg.width, cfg.height);
    let params = cfg.params;
    let bar = if cfg.progress {
        let b = ProgressBar::new(h as u64);
        b.set_style(
            ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} rows, {elapsed}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        b.set_message(cfg.technique.name());
        b
    } else {
        ProgressBar::hidden()
    };
    let tech_index = Technique::ALL
        .iter()
        .position(|&t| t == cfg.technique)
        .unwrap_or(0) as u64;
    let start = Instant::now();
    let mut mean = vec![[0f32; 3]; w * h];
    let mut var = vec![[0f32; 3]; w * h];
    // Busy time: each row timed on its own thread, summed (see the module documentation).
    let (busy, failed): (f64, u64) = mean
        .par_chunks_mut(w.max(1))
        .zip(var.par_chunks_mut(w.max(1)))
        .enumerate()
        .map(|(py, (row_m, row_v))| {
            let mut failed = 0u64;
            let t = busy_time(|| {
                for px in 0..w {
                    let seed = cfg
                        .seed
                        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
                        .wrapping_add(((py * w + px) as u64) << 8)
                        .wrapping_add(tech_index);
                    let mut rng = Pcg64Mcg::seed_from_u64(seed);
                    (row_m[px], row_v[px]) =
                        pixel(scene, cfg, &params, (px, py), &mut rng, &mut failed);
                }
            });
            bar.inc(1);
            if let Some(f) = on_row {
                f();
            }
            (t, failed)
        })
        .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    let wall_seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    Image {
        width: w,
        height: h,
        mean,
        var,
        spp: cfg.spp,
        seconds: busy,
        wall_seconds,
        failed,
    }
}
