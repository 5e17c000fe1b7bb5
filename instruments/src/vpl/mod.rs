//! `mlmeasure vpl`: instant radiosity (Keller 1997) for the indirect diffuse light of a scene,
//! with and without the probabilistic VPL acceptance of Georgiev & Slusallek 2010 (the core's
//! [`manylights::vpl`]), gathered from every VPL at every pixel (`all`) or through a light tree
//! of the VPLs (`tree`).
//!
//! The image is the indirect light only: the radiance that the VPLs (every diffuse hit of the
//! light's random walks, [`walk`]) send through the pixel centres' camera hits, with a shadow
//! ray per VPL and pixel ([`gather`], geometry term clamped at the scene's bound). Frames
//! accumulate: each frame traces new walks, and its image is averaged into the result.
//!
//! Variants, each with its own random numbers:
//! - `plain`: every candidate is a VPL; M = N / c paths per frame (c the mean candidates per
//!   path of a pilot run), so about N VPLs a frame.
//! - `accept`: candidates go through a [`VplAcceptor`] (ε, P pixels, N VPLs, N_C importons at
//!   random pixels each frame, visibility by shadow rays); Φ̃_total is the running mean of the
//!   frames' image sums ([`VplAcceptor::update`]), so the first frame keeps everything. A frame
//!   traces M = N / (c · p̄) paths, p̄ the mean acceptance probability predicted from a sample
//!   of the previous frame's candidates with the current Φ̃_total: about N VPLs are kept. M
//!   depends only on earlier frames, so each frame stays unbiased.
//! - `tree`: the accepted VPLs of each frame built into a [`manylights::LightTree`] and a few
//!   of them sampled per pixel (TL importance, `LightTree::sample`, or split sampling), for
//!   as many frames as fit in the time `plain` took.
//!
//! Each is compared with a converged reference of the same scene (plain VPLs, tree gather,
//! split-sampling tree gather, many frames; cached under `out/reference/`). Efficiency is 1 / (MSE · time); times are
//! busy CPU seconds summed over the threads (walks, acceptance, tree builds, gathers; the
//! camera hits are computed once and shared).

pub mod gather;
pub mod scenes;
pub mod walk;

use gather::{pixel_hits, visible, Gathered, PixelHit, TreeSampling, VplTree};
use indicatif::{ProgressBar, ProgressStyle};
use manylights::vpl::AcceptStats;
use manylights::{Vpl, VplAcceptor};
use manylights_render::image::{read_raw, side_by_side_labelled, write_png, write_raw, Image};
use manylights_render::render::busy_time;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use scenes::VplScene;
use std::path::PathBuf;

/// The options of `mlmeasure vpl`.
#[derive(clap::Args, Clone, Debug)]
pub struct VplArgs {
    /// Scene: corner (a point light around a corner from the camera) or room (the light in
    /// view).
    #[arg(long, default_value = "corner")]
    pub scene: String,
    /// Frames of `plain` and `accept`.
    #[arg(long, default_value_t = 16)]
    pub frames: usize,
    /// VPLs wanted per frame (N).
    #[arg(long, default_value_t = 1000)]
    pub vpls: usize,
    /// Gather of `plain` and `accept`: all (every VPL at every pixel) or tree.
    #[arg(long, default_value = "all")]
    pub gather: String,
    /// Samples per pixel and frame of the tree gather (with split sampling: the largest cut,
    /// at most 64; the variance heuristic often stops below it).
    #[arg(long, default_value_t = 64)]
    pub tree_spp: usize,
    /// Sampling of the tree gather: tl (independent draws by TL importance) or split.
    #[arg(long, default_value = "split")]
    pub tree_sampling: String,
    /// Importons per frame (N_C).
    #[arg(long, default_value_t = manylights::vpl::DEFAULT_IMPORTONS)]
    pub importons: usize,
    /// ε of the acceptance.
    #[arg(long, default_value_t = manylights::vpl::DEFAULT_EPSILON)]
    pub epsilon: f32,
    /// Image width.
    #[arg(long, default_value_t = 128)]
    pub width: usize,
    /// Image height.
    #[arg(long, default_value_t = 96)]
    pub height: usize,
    /// Frames of the reference.
    #[arg(long, default_value_t = 1024)]
    pub ref_frames: usize,
    /// Plain VPLs per frame of the reference.
    #[arg(long, default_value_t = 4000)]
    pub ref_vpls: usize,
    /// Split-sampling clusters per pixel and frame of the reference (the largest cut).
    #[arg(long, default_value_t = 64)]
    pub ref_spp: usize,
    /// Seed of the variants (the reference has its own).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output folder (images under `vpl/<scene>/`, the reference under `reference/`).
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Print one JSON object as the last line of stdout.
    #[arg(long)]
    pub json: bool,
}

/// How a variant gathers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Gather {
    /// Every VPL at every pixel.
    All,
    /// `spp` samples per pixel from a tree of the VPLs.
    Tree {
        /// Samples (or cut size).
        spp: usize,
        /// TL draws or split sampling.
        sampling: TreeSampling,
    },
}

/// When a variant stops.
#[derive(Clone, Copy, Debug)]
pub enum Budget {
    /// After this many frames.
    Frames(usize),
    /// Once its busy time reaches this many seconds (at least one frame, at most `max`).
    Seconds {
        /// The time.
        seconds: f64,
        /// Most frames.
        max: usize,
    },
}

/// What one variant produced.
#[derive(Clone, Debug)]
pub struct Variant {
    /// Its name.
    pub name: String,
    /// The accumulated image (mean over frames) with per-pixel variance across frames.
    pub image: Image,
    /// Frames rendered.
    pub frames: usize,
    /// Busy seconds.
    pub seconds: f64,
    /// Of which: the walks, the acceptance and the frame's set-up (importons, path count).
    pub walk_seconds: f64,
    /// VPLs gathered, summed over frames.
    pub vpls: u64,
    /// Light paths traced, summed over frames.
    pub paths: u64,
    /// Decisions after the first frame (all frames for `plain`).
    pub stats: AcceptStats,
    /// Tree gather: VPLs drawn, summed over pixels and frames.
    pub tree_samples: u64,
    /// Each frame's image average.
    pub frame_means: Vec<f64>,
}

/// The fixed inputs of a run: scene, camera hits, candidates per path.
pub struct Setup {
    /// The scene.
    pub scene: VplScene,
    /// Camera hits per pixel.
    pub hits: Vec<Option<PixelHit>>,
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Mean candidates per light path (pilot run).
    pub candidates_per_path: f64,
}

impl Setup {
    /// The camera hits and the pilot run of `scene` at `width × height`.
    pub fn new(scene: VplScene, width: usize, height: usize) -> Setup {
        let hits = pixel_hits(&scene.scene, width, height);
        let candidates_per_path = walk::candidates_per_path(&scene, 20_000, 0x9170);
        Setup {
            scene,
            hits,
            width,
            height,
            candidates_per_path,
        }
    }
}

/// The parameters of a variant.
#[derive(Clone, Copy, Debug)]
pub struct VariantConfig {
    /// Acceptance on.
    pub accept: bool,
    /// Gather.
    pub gather: Gather,
    /// Stop rule.
    pub budget: Budget,
    /// VPLs wanted per frame.
    pub vpls: usize,
    /// Importons per frame.
    pub importons: usize,
    /// ε.
    pub epsilon: f32,
    /// Seed.
    pub seed: u64,
    /// Show a progress bar.
    pub progress: bool,
}

fn bar(name: &str, budget: Budget, progress: bool) -> ProgressBar {
    if !progress {
        return ProgressBar::hidden();
    }
    let len = match budget {
        Budget::Frames(f) => f as u64,
        Budget::Seconds { .. } => 0,
    };
    let b = if len > 0 {
        ProgressBar::new(len)
    } else {
        ProgressBar::no_length()
    };
    let template = if len > 0 {
        "{msg:>10} [{bar:40}] {pos}/{len} frames, {elapsed}"
    } else {
        "{msg:>10} {pos} frames, {elapsed}"
    };
    b.set_style(
        ProgressStyle::with_template(template)
            .expect("valid template")
            .progress_chars("=> "),
    );
    b.set_message(name.to_string());
    b
}

/// The paths of the next frame for about `vpls` VPLs: with acceptance, the mean acceptance
/// probability of `sample` (candidates of the previous frame, traced with `prev_paths`
/// paths) predicted with the acceptor's current Φ̃_total, solved for M by a few fixed-point
/// steps (a candidate's Φ̃_i scales as 1/M).
fn paths_for(
    setup: &Setup,
    vpls: usize,
    acc: Option<&VplAcceptor>,
    sample: &[Vpl],
    prev_paths: usize,
) -> usize {
    let base = vpls as f64 / setup.candidates_per_path.max(1e-9);
    let Some(acc) = acc else {
        return base.ceil().max(1.0) as usize;
    };
    let target = acc.target();
    if sample.is_empty() || target <= 0.0 {
        return base.ceil().max(1.0) as usize;
    }
    let g = &setup.scene.scene.geometry;
    let mut vis = |x, y| visible(g, x, y);
    let phis: Vec<f64> = sample
        .iter()
        .map(|v| f64::from(acc.estimate_with(v, &mut vis).unwrap_or(0.0)))
        .collect();
    let eps = f64::from(acc.epsilon());
    let mut m = base;
    for _ in 0..4 {
        let scale = prev_paths as f64 / m;
        let mean_p = phis
            .iter()
            .map(|&phi| (phi * scale / target + eps).min(1.0))
            .sum::<f64>()
            / phis.len() as f64;
        m = base / mean_p.max(eps.min(1.0));
    }
    m.ceil().max(1.0) as usize
}

/// Fills the acceptor's importons from `n` random pixels.
fn fill_importons(setup: &Setup, acc: &mut VplAcceptor, n: usize, rng: &mut Pcg64Mcg) {
    let im = acc.importons_mut();
    im.clear();
    for _ in 0..n {
        let i = rng.random_range(0..setup.hits.len());
        match setup.hits[i] {
            Some(h) => im
                .push_diffuse(h.position, h.normal, h.albedo)
                .expect("camera hits are valid importons"),
            None => im.push_miss(),
        }
    }
}

/// Renders one variant.
pub fn run_variant(setup: &Setup, name: &str, cfg: &VariantConfig) -> Variant {
    let (w, h) = (setup.width, setup.height);
    let npix = w * h;
    let g_max = setup.scene.g_max;
    let geometry = &setup.scene.scene.geometry;
    let mut acc = cfg.accept.then(|| {
        VplAcceptor::new(npix, cfg.vpls)
            .and_then(|a| a.with_epsilon(cfg.epsilon))
            .and_then(|a| a.with_geometry_clamp(g_max))
            .expect("the command line checks the acceptance parameters")
    });
    let (mut sum, mut sum2) = (vec![0f64; npix], vec![0f64; npix]);
    let mut rng = Pcg64Mcg::seed_from_u64(walk::mix(cfg.seed ^ 0x5eed_0ff4_a3e5));
    let mut v = Variant {
        name: name.to_string(),
        image: Image {
            width: w,
            height: h,
            mean: Vec::new(),
            var: Vec::new(),
            spp: 0,
            seconds: 0.0,
            wall_seconds: 0.0,
            failed: 0,
        },
        frames: 0,
        seconds: 0.0,
        walk_seconds: 0.0,
        vpls: 0,
        paths: 0,
        stats: AcceptStats::default(),
        tree_samples: 0,
        frame_means: Vec::new(),
    };
    let progress = bar(name, cfg.budget, cfg.progress);
    let start = std::time::Instant::now();
    let (mut sample, mut prev_paths) = (Vec::new(), 1usize);
    let mut frame_img = vec![0f32; npix];
    loop {
        let done = match cfg.budget {
            Budget::Frames(f) => v.frames >= f,
            Budget::Seconds { seconds, max } => {
                v.frames >= max || (v.frames > 0 && v.seconds >= seconds)
            }
        };
        if done {
            break;
        }
        let frame_seed = rng.random::<u64>();
        let mut paths = 0;
        let t0 = v.seconds;
        v.seconds += busy_time(|| {
            paths = paths_for(setup, cfg.vpls, acc.as_ref(), &sample, prev_paths);
            if let Some(a) = &mut acc {
                let mut r = Pcg64Mcg::seed_from_u64(walk::mix(frame_seed ^ 0x1a9));
                fill_importons(setup, a, cfg.importons, &mut r);
            }
        });
        let fv = walk::frame_vpls(&setup.scene, paths, acc.as_ref(), frame_seed);
        v.seconds += fv.seconds;
        v.walk_seconds += v.seconds - t0;
        if !cfg.accept || v.frames > 0 {
            v.stats.merge(&fv.stats);
        }
        v.paths += paths as u64;
        v.vpls += fv.vpls.len() as u64;
        let gathered: Vec<Gathered> = fv.vpls.iter().map(Gathered::from).collect();
        let mut tree = None;
        if let Gather::Tree { .. } = cfg.gather {
            v.seconds += busy_time(|| tree = Some(VplTree::build(&gathered)));
        }
        let (row_seconds, drawn): (f64, usize) = frame_img
            .par_chunks_mut(w)
            .enumerate()
            .map(|(py, row)| {
                let mut drawn = 0;
                let t = busy_time(|| {
                    for (px, out) in row.iter_mut().enumerate() {
                        let i = py * w + px;
                        *out = match (&setup.hits[i], cfg.gather, &tree) {
                            (None, _, _) => 0.0,
                            (Some(hit), Gather::All, _) => {
                                gather::gather_all(geometry, hit, &gathered, g_max)
                            }
                            (Some(hit), Gather::Tree { spp, sampling }, Some(t)) => {
                                let seed = frame_seed
                                    .wrapping_mul(0x9e37_79b9_7f4a_7c15)
                                    .wrapping_add(i as u64);
                                let (value, n) =
                                    t.gather(geometry, hit, spp, sampling, g_max, seed);
                                drawn += n;
                                value
                            }
                            (Some(_), Gather::Tree { .. }, None) => 0.0,
                        };
                    }
                });
                (t, drawn)
            })
            .reduce(|| (0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        v.tree_samples += drawn as u64;
        v.seconds += row_seconds;
        let lum: f64 = frame_img.iter().map(|&x| f64::from(x)).sum();
        v.frame_means.push(lum / npix as f64);
        if let Some(a) = &mut acc {
            a.update(lum).expect("frame luminances are finite");
        }
        for (i, &x) in frame_img.iter().enumerate() {
            let x = f64::from(x);
            sum[i] += x;
            sum2[i] += x * x;
        }
        sample = fv.sample;
        prev_paths = paths;
        v.frames += 1;
        progress.inc(1);
    }
    progress.finish_and_clear();
    let n = v.frames.max(1) as f64;
    v.image.mean = sum.iter().map(|&s| [(s / n) as f32; 3]).collect();
    v.image.var = sum
        .iter()
        .zip(&sum2)
        .map(|(&s, &s2)| {
            if v.frames > 1 {
                [(((s2 - s * s / n) / (n - 1.0)).max(0.0)) as f32; 3]
            } else {
                [0.0; 3]
            }
        })
        .collect();
    v.image.spp = v.frames;
    v.image.seconds = v.seconds;
    v.image.wall_seconds = start.elapsed().as_secs_f64();
    v
}

/// How the reference is made: plain VPLs, split-sampling tree gather.
#[derive(Clone, Copy, Debug)]
pub struct ReferenceConfig {
    /// Frames.
    pub frames: usize,
    /// VPLs per frame.
    pub vpls: usize,
    /// Clusters of the split-sampling cut per pixel and frame.
    pub spp: usize,
}

/// Where the reference of `setup` made as `rc` is cached.
pub fn reference_path(setup: &Setup, out: &std::path::Path, rc: &ReferenceConfig) -> PathBuf {
    out.join("reference").join(format!(
        "vpl-{}-{:016x}-g{}-{}x{}-{}x{}x{}-split.bin",
        setup.scene.scene.name,
        setup.scene.scene.fingerprint(),
        setup.scene.g_max,
        setup.width,
        setup.height,
        rc.frames,
        rc.vpls,
        rc.spp
    ))
}

/// The converged reference (plain VPLs, tree gather), from the cache or rendered and cached.
pub fn reference(
    setup: &Setup,
    out: &std::path::Path,
    rc: &ReferenceConfig,
    progress: bool,
) -> std::io::Result<Image> {
    let (path, frames) = (reference_path(setup, out, rc), rc.frames);
    if let Some(img) = read_raw(&path) {
        if img.width == setup.width && img.height == setup.height && img.spp == frames {
            eprintln!("reference: {} (cached)", path.display());
            return Ok(img);
        }
    }
    eprintln!("reference: {frames} frames -> {}", path.display());
    let v = run_variant(
        setup,
        "reference",
        &VariantConfig {
            accept: false,
            gather: Gather::Tree {
                spp: rc.spp,
                sampling: TreeSampling::Split,
            },
            budget: Budget::Frames(frames),
            vpls: rc.vpls,
            importons: 0,
            epsilon: 1.0,
            seed: 0x7e7e_7e7e_0000,
            progress,
        },
    );
    write_raw(&path, &v.image)?;
    Ok(v.image)
}

/// The RMS standard error of an image's pixels (from their variance across frames; the VPL
/// images are grey, so one channel).
pub fn rms_standard_error(img: &Image) -> f64 {
    let n = img.var.len().max(1) as f64;
    let s: f64 = img.var.iter().map(|&v| f64::from(v[0])).sum();
    (s / n / img.spp.max(1) as f64).sqrt()
}

/// The figures of a run.
#[derive(Clone, Debug)]
pub struct Report {
    /// Scene name.
    pub scene: String,
    /// `plain`, `accept`, `tree`.
    pub variants: Vec<Variant>,
    /// RMSE of each against the reference.
    pub rmse: Vec<f64>,
    /// The reference's own RMS standard error.
    pub reference_error: f64,
    /// Average of the reference image.
    pub reference_mean: f64,
}

impl Report {
    fn by(&self, name: &str) -> usize {
        self.variants
            .iter()
            .position(|v| v.name == name)
            .expect("every variant runs")
    }

    /// (rmse_b² · time_b) / (rmse_a² · time_a): how much more efficient `a` is than `b`.
    pub fn gain(&self, a: &str, b: &str) -> f64 {
        let (a, b) = (self.by(a), self.by(b));
        let e = |i: usize| self.rmse[i].powi(2) * self.variants[i].seconds;
        e(b) / e(a)
    }

    /// The JSON object of the keys.
    pub fn json(&self) -> serde_json::Value {
        let (p, a, t) = (self.by("plain"), self.by("accept"), self.by("tree"));
        let va = &self.variants[a];
        serde_json::json!({
            "scene": self.scene,
            "acceptance_rate": va.stats.acceptance_rate(),
            "mean_p": va.stats.mean_probability(),
            "energy_ratio": va.stats.energy_ratio().0,
            "energy_ratio_sd": va.stats.energy_ratio().1,
            "rmse_accept": self.rmse[a],
            "rmse_plain": self.rmse[p],
            "time_accept_s": va.seconds,
            "time_plain_s": self.variants[p].seconds,
            "efficiency_gain": self.gain("accept", "plain"),
            "rmse_tree": self.rmse[t],
            "time_tree_s": self.variants[t].seconds,
            "efficiency_gain_tree": self.gain("tree", "plain"),
            "frames": self.variants[p].frames,
            "frames_tree": self.variants[t].frames,
            "tree_samples_per_pixel_frame": self.variants[t].tree_samples as f64
                / (self.variants[t].frames.max(1) * self.variants[t].image.mean.len()) as f64,
            "vpls_per_frame_plain": self.variants[p].vpls as f64 / self.variants[p].frames as f64,
            "vpls_per_frame_accept": va.vpls as f64 / va.frames as f64,
            "rmse_reference": self.reference_error,
            "reference_mean": self.reference_mean,
        })
    }
}

fn fail(msg: impl std::fmt::Display) -> i32 {
    eprintln!("vpl: {msg}");
    2
}

/// `mlmeasure vpl`: returns the exit code.
pub fn run_cli(args: &VplArgs) -> i32 {
    let scene = match scenes::by_name(&args.scene) {
        Ok(s) => s,
        Err(e) => return fail(e),
    };
    let Some(sampling) = TreeSampling::from_name(&args.tree_sampling) else {
        return fail(format!("unknown --tree-sampling {:?}", args.tree_sampling));
    };
    let tree = Gather::Tree {
        spp: args.tree_spp.max(1),
        sampling,
    };
    let gather = match args.gather.as_str() {
        "all" => Gather::All,
        "tree" => tree,
        g => return fail(format!("unknown --gather {g:?} (all or tree)")),
    };
    if args.frames == 0 || args.vpls == 0 || args.width == 0 || args.height == 0 {
        return fail("--frames, --vpls, --width and --height must be positive");
    }
    if args.ref_frames == 0 || args.importons == 0 || args.tree_spp == 0 {
        return fail("--ref-frames, --importons and --tree-spp must be positive");
    }
    if let Err(e) = VplAcceptor::new(1, 1).and_then(|a| a.with_epsilon(args.epsilon)) {
        return fail(e);
    }
    let setup = Setup::new(scene, args.width, args.height);
    let rc = ReferenceConfig {
        frames: args.ref_frames,
        vpls: args.ref_vpls.max(1),
        spp: args.ref_spp.max(1),
    };
    let reference = match reference(&setup, &args.out, &rc, true) {
        Ok(r) => r,
        Err(e) => return fail(format!("reference: {e}")),
    };
    let base = VariantConfig {
        accept: false,
        gather,
        budget: Budget::Frames(args.frames),
        vpls: args.vpls,
        importons: args.importons,
        epsilon: args.epsilon,
        seed: args.seed,
        progress: true,
    };
    let plain = run_variant(&setup, "plain", &base);
    let accept = run_variant(
        &setup,
        "accept",
        &VariantConfig {
            accept: true,
            seed: args.seed ^ 0xacce,
            ..base
        },
    );
    let tree_v = run_variant(
        &setup,
        "tree",
        &VariantConfig {
            accept: true,
            gather: tree,
            budget: Budget::Seconds {
                seconds: plain.seconds,
                max: 1_000_000,
            },
            seed: args.seed ^ 0x7ee,
            ..base
        },
    );
    let variants = vec![plain, accept, tree_v];
    let rmse: Vec<f64> = variants.iter().map(|v| v.image.rmse(&reference)).collect();
    let report = Report {
        scene: setup.scene.scene.name.clone(),
        variants,
        rmse,
        reference_error: rms_standard_error(&reference),
        reference_mean: reference.average(),
    };
    if let Err(e) = write_images(&report, &reference, &args.out) {
        return fail(format!("images: {e}"));
    }
    print_table(&report, args);
    if args.json {
        println!("{}", report.json());
    }
    0
}

fn write_images(report: &Report, reference: &Image, out: &std::path::Path) -> std::io::Result<()> {
    let dir = out.join("vpl").join(&report.scene);
    // One exposure for all: the reference's average at 0.18.
    let k = 0.18 / reference.average().max(1e-30) as f32;
    let scaled = |img: &Image| Image {
        mean: img.mean.iter().map(|x| x.map(|c| c * k)).collect(),
        ..img.clone()
    };
    let mut panels = Vec::new();
    for v in &report.variants {
        let img = scaled(&v.image);
        write_png(
            &dir.join(format!("{}.png", v.name)),
            img.width,
            img.height,
            &img.mean,
        )?;
        panels.push((v.name.clone(), img));
    }
    let r = scaled(reference);
    write_png(&dir.join("reference.png"), r.width, r.height, &r.mean)?;
    panels.push(("reference".into(), r));
    let labelled: Vec<(&str, &Image)> = panels.iter().map(|(n, i)| (n.as_str(), i)).collect();
    let (w, h, values) = side_by_side_labelled(&labelled, 4);
    write_png(&dir.join("compare.png"), w, h, &values)?;
    eprintln!("images: {}", dir.display());
    Ok(())
}

fn print_table(r: &Report, args: &VplArgs) {
    println!(
        "{} {}x{}, N = {} VPLs/frame, gather {} (tree: {} x{}), reference mean {:.4e} (its RMS error {:.2e})",
        r.scene,
        args.width,
        args.height,
        args.vpls,
        args.gather,
        args.tree_sampling,
        args.tree_spp,
        r.reference_mean,
        r.reference_error
    );
    let a = &r.variants[r.by("accept")];
    let t = &r.variants[r.by("tree")];
    println!(
        "tree: {:.1} VPLs drawn per pixel and frame",
        t.tree_samples as f64 / (t.frames.max(1) * t.image.mean.len()) as f64
    );
    let (ratio, sd) = a.stats.energy_ratio();
    println!(
        "accept after the first frame: acceptance rate {:.4} (mean p {:.4}), energy ratio {:.4} ± {:.4}",
        a.stats.acceptance_rate(),
        a.stats.mean_probability(),
        ratio,
        sd
    );
    println!("| variant | frames | paths/frame | VPLs/frame | acceptance | time (s) | of which walks (s) | RMSE | own RMS std. error | efficiency vs plain |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (v, &e) in r.variants.iter().zip(&r.rmse) {
        let f = v.frames.max(1) as f64;
        println!(
            "| {} | {} | {:.0} | {:.0} | {:.3} | {:.2} | {:.2} | {:.4e} | {:.2e} | {:.2} |",
            v.name,
            v.frames,
            v.paths as f64 / f,
            v.vpls as f64 / f,
            v.stats.acceptance_rate(),
            v.seconds,
            v.walk_seconds,
            e,
            rms_standard_error(&v.image),
            r.gain(&v.name, "plain")
        );
    }
}
