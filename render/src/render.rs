//! Direct illumination of a [`RenderScene`] with any technique of
//! [`crate::estimator::techniques`], plus image output.
//!
//! One shading point per pixel (the first surface hit by the ray through the pixel centre: no
//! pixel jitter, so that an image's error is the light-sampling error alone). At each shading
//! point the technique's set-up ([`Setup`]) is built once with the scene's geometry as
//! [`Occluder`](crate::estimator::techniques::Occluder), then `spp` independent estimates are
//! averaged: light samples cast shadow rays, BRDF (TB) rays reach only the lights in front of
//! the first surface. The lights themselves are not drawn (direct illumination of surfaces
//! only). Rows run in parallel with rayon; a progress bar (indicatif, on a terminal) counts
//! rows.
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
//! Output: [`write_png`] (8-bit sRGB, clamped), [`write_exr`] (linear f32 OpenEXR) and
//! [`write_image`] (either, from the file extension).

use crate::estimator::techniques::{Params, Setup, Technique};
use crate::font;
use crate::scene::RenderScene;
use indicatif::{ProgressBar, ProgressStyle};
use manylights::ShadingPoint;
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use std::io::{BufWriter, Write};
use std::path::Path;
use std::time::Instant;

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
}

/// A rendered grey-level image: per-pixel mean and per-estimate variance.
#[derive(Clone, Debug)]
pub struct Image {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Mean of the estimates, row-major.
    pub mean: Vec<f32>,
    /// Per-estimate sample variance of each pixel (0 with one estimate).
    pub var: Vec<f32>,
    /// Estimates per pixel.
    pub spp: usize,
    /// Busy seconds of the render: the CPU time spent on its rows, summed over the threads
    /// that rendered them (see the module documentation). 0 for an image read from disk.
    pub seconds: f64,
    /// Wall-clock seconds of the render. 0 for an image read from disk.
    pub wall_seconds: f64,
}

impl Image {
    /// The average of the pixel means.
    pub fn average(&self) -> f64 {
        self.mean.iter().map(|&v| f64::from(v)).sum::<f64>() / self.mean.len() as f64
    }

    /// Standard error of [`Image::average`] from the per-pixel variances.
    pub fn average_se(&self) -> f64 {
        let n = self.mean.len() as f64;
        let s: f64 = self.var.iter().map(|&v| f64::from(v)).sum();
        (s / self.spp.max(1) as f64).sqrt() / n
    }

    /// Root mean square difference to `other` (same size).
    pub fn rmse(&self, other: &Image) -> f64 {
        let s: f64 = self
            .mean
            .iter()
            .zip(&other.mean)
            .map(|(&a, &b)| (f64::from(a) - f64::from(b)).powi(2))
            .sum();
        (s / self.mean.len() as f64).sqrt()
    }
}

/// CPU time of the calling thread, in seconds.
#[cfg(any(target_os = "linux", target_os = "macos"))]
fn thread_cpu_seconds() -> Option<f64> {
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
fn thread_cpu_seconds() -> Option<f64> {
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

/// The shading point seen through pixel (`px`, `py`), if any.
pub fn primary(
    scene: &RenderScene,
    px: usize,
    py: usize,
    w: usize,
    h: usize,
) -> Option<ShadingPoint> {
    let cam = &scene.camera;
    let d = cam.direction(
        (px as f32 + 0.5) / w as f32,
        (py as f32 + 0.5) / h as f32,
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

/// Renders `scene` with `cfg`.
pub fn render(scene: &RenderScene, cfg: &RenderConfig) -> Image {
    let (w, h) = (cfg.width, cfg.height);
    let params = Params::default();
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
    let mut mean = vec![0f32; w * h];
    let mut var = vec![0f32; w * h];
    // Busy time: each row timed on its own thread, summed (see the module documentation).
    let busy: f64 = mean
        .par_chunks_mut(w.max(1))
        .zip(var.par_chunks_mut(w.max(1)))
        .enumerate()
        .map(|(py, (row_m, row_v))| {
            let t = busy_time(|| {
                for px in 0..w {
                    let Some(sp) = primary(scene, px, py, w, h) else {
                        continue;
                    };
                    let seed = cfg
                        .seed
                        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
                        .wrapping_add(((py * w + px) as u64) << 8)
                        .wrapping_add(tech_index);
                    let mut rng = Pcg64Mcg::seed_from_u64(seed);
                    let setup = Setup::new(&scene.lights, &sp, cfg.technique, &params)
                        .with_occluder(&scene.geometry);
                    let (mut m, mut m2) = (0f64, 0f64);
                    for k in 0..cfg.spp {
                        let x = setup.estimate(cfg.technique, &mut rng);
                        let d = x - m;
                        m += d / (k + 1) as f64;
                        m2 += d * (x - m);
                    }
                    row_m[px] = m as f32;
                    row_v[px] = if cfg.spp > 1 {
                        (m2 / (cfg.spp - 1) as f64) as f32
                    } else {
                        0.0
                    };
                }
            });
            bar.inc(1);
            t
        })
        .sum();
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
    }
}

/// Clamp to [0, 1] and encode as 8-bit sRGB.
pub fn tone_map(v: f32) -> u8 {
    let c = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// `e` with `path` in front of its message (same kind).
fn with_path(path: &Path, e: impl std::fmt::Display, kind: std::io::ErrorKind) -> std::io::Error {
    std::io::Error::new(kind, format!("{}: {e}", path.display()))
}

/// Creates the parent folder of `path` (an error names the folder).
fn create_parent(path: &Path) -> std::io::Result<()> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => std::fs::create_dir_all(dir).map_err(|e| {
            std::io::Error::new(
                e.kind(),
                format!("cannot create folder {}: {e}", dir.display()),
            )
        }),
        _ => Ok(()),
    }
}

/// Checks that `values` holds `width × height` values.
fn check_size(path: &Path, width: usize, height: usize, values: &[f32]) -> std::io::Result<()> {
    if width == 0 || height == 0 || width.checked_mul(height) != Some(values.len()) {
        return Err(with_path(
            path,
            format!("{} values for a {width}x{height} image", values.len()),
            std::io::ErrorKind::InvalidInput,
        ));
    }
    Ok(())
}

/// Writes grey-level values (`width × height`, row-major, linear) as an 8-bit sRGB PNG
/// (creating the folder if needed; errors name the file).
pub fn write_png(path: &Path, width: usize, height: usize, values: &[f32]) -> std::io::Result<()> {
    check_size(path, width, height, values)?;
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(with_path(
            path,
            "image too large for PNG",
            std::io::ErrorKind::InvalidInput,
        ));
    };
    create_parent(path)?;
    let file = std::fs::File::create(path).map_err(|e| with_path(path, &e, e.kind()))?;
    let mut enc = png::Encoder::new(BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(png::BitDepth::Eight);
    let other = |e| with_path(path, e, std::io::ErrorKind::Other);
    let mut writer = enc.write_header().map_err(other)?;
    let data: Vec<u8> = values.iter().map(|&v| tone_map(v)).collect();
    writer.write_image_data(&data).map_err(other)?;
    writer.finish().map_err(other)?;
    Ok(())
}

/// Writes grey-level values (`width × height`, row-major, linear) as a linear OpenEXR file:
/// 32-bit float R, G and B channels, all three equal to the value (what every viewer opens;
/// no tone mapping, no clamping), scan lines with lossless ZIP compression (the most widely
/// read layout). Creates the folder if needed; errors name the file.
pub fn write_exr(path: &Path, width: usize, height: usize, values: &[f32]) -> std::io::Result<()> {
    use exr::prelude::{Encoding, SpecificChannels, Vec2, WritableImage};
    check_size(path, width, height, values)?;
    create_parent(path)?;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let v = values[y * width + x];
        (v, v, v)
    });
    exr::prelude::Image::from_encoded_channels((width, height), Encoding::SMALL_LOSSLESS, channels)
        .write()
        .to_file(path)
        .map_err(|e| match e {
            exr::error::Error::Io(io) => with_path(path, &io, io.kind()),
            e => with_path(path, e, std::io::ErrorKind::Other),
        })
}

/// Writes `values` with [`write_exr`] if `path` ends in `.exr` (any case), with [`write_png`]
/// otherwise.
pub fn write_image(
    path: &Path,
    width: usize,
    height: usize,
    values: &[f32],
) -> std::io::Result<()> {
    if is_exr(path) {
        write_exr(path, width, height, values)
    } else {
        write_png(path, width, height, values)
    }
}

/// Whether `path` ends in `.exr` (any case).
pub fn is_exr(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// Images side by side (same height), separated by `gap` black columns.
pub fn side_by_side(images: &[&Image], gap: usize) -> (usize, usize, Vec<f32>) {
    let h = images.first().map_or(0, |i| i.height);
    let w: usize =
        images.iter().map(|i| i.width).sum::<usize>() + gap * images.len().saturating_sub(1);
    let mut out = vec![0f32; w * h];
    let mut x0 = 0;
    for img in images {
        for y in 0..h.min(img.height) {
            out[y * w + x0..y * w + x0 + img.width]
                .copy_from_slice(&img.mean[y * img.width..(y + 1) * img.width]);
        }
        x0 += img.width + gap;
    }
    (w, h, out)
}

/// The part of a `width × height` image that the crops row of [`side_by_side_with_crops`]
/// magnifies 2×: its lower middle quarter, as inclusive pixel bounds `(x0, y0, x1, y1)`
/// (columns w/4 to w/4 + (w − 1)/2, rows h/2 to the last).
pub fn crop_region(width: usize, height: usize) -> (usize, usize, usize, usize) {
    let (x0, y0) = (width / 4, height / 2);
    let x1 = (x0 + width.saturating_sub(1) / 2).min(width.saturating_sub(1));
    let y1 = (y0 + height.saturating_sub(1) / 2).min(height.saturating_sub(1));
    (x0, y0, x1, y1)
}

/// The crops row: each image's [`crop_region`] magnified 2× (nearest neighbour), `w` wide
/// and `h` high, placed as in [`side_by_side`].
fn crops_row(images: &[&Image], gap: usize, w: usize, h: usize) -> Vec<f32> {
    let mut row = vec![0f32; w * h];
    let mut x0 = 0;
    for img in images {
        let (iw, ih) = (img.width, img.height);
        let (cx, cy, _, _) = crop_region(iw, ih);
        for y in 0..h.min(ih) {
            for x in 0..iw {
                let sx = (cx + x / 2).min(iw - 1);
                let sy = (cy + y / 2).min(ih - 1);
                row[y * w + x0 + x] = img.mean[sy * iw + sx];
            }
        }
        x0 += iw + gap;
    }
    row
}

/// [`side_by_side`] with a second row: each image's crop of its lower middle quarter
/// ([`crop_region`]), magnified 2× (nearest neighbour), below it, `gap` black rows between.
pub fn side_by_side_with_crops(images: &[&Image], gap: usize) -> (usize, usize, Vec<f32>) {
    let (w, h, top) = side_by_side(images, gap);
    let mut out = top;
    out.extend(std::iter::repeat_n(0.0, w * gap));
    out.extend(crops_row(images, gap, w, h));
    (w, 2 * h + gap, out)
}

/// Outlines each image's [`crop_region`] on the side-by-side row `top` (`w` wide): a 1-pixel
/// line inside the region's border, in dashes of two white (1.0) and two black pixels so that
/// it shows on bright and dark areas alike.
fn outline_crop_regions(top: &mut [f32], w: usize, images: &[&Image], gap: usize) {
    let h = top.len().checked_div(w).unwrap_or(0);
    let mut x0 = 0;
    for img in images {
        let (ax, ay, bx, by) = crop_region(img.width, img.height);
        let mut set = |x: usize, y: usize| {
            if y < h {
                top[y * w + x0 + x] = if (x + y) / 2 % 2 == 0 { 1.0 } else { 0.0 };
            }
        };
        if img.width > 0 && img.height > 0 {
            for x in ax..=bx {
                set(x, ay);
                set(x, by);
            }
            for y in ay..=by {
                set(ax, y);
                set(bx, y);
            }
        }
        x0 += img.width + gap;
    }
}

/// Height in pixels of the caption strip of [`side_by_side_labelled`] at font scale `scale`:
/// the glyph height and a black margin of `scale` pixels above and below.
pub fn caption_height(scale: usize) -> usize {
    (font::GLYPH_H + 2) * scale
}

/// The font scale of the captions of [`side_by_side_labelled`]: 2 if every label fits above
/// its image at ×2 (with a margin of 2 pixels on the left), 1 otherwise.
pub fn caption_scale(panels: &[(&str, &Image)]) -> usize {
    let fits = |label: &str, img: &Image| 2 + font::text_width(label, 2) <= img.width;
    if panels.iter().all(|&(label, img)| fits(label, img)) {
        2
    } else {
        1
    }
}

/// The labelled comparison image: [`side_by_side_with_crops`] of the images, with a caption
/// strip on top — each panel's label in white (1.0) on black, centred above it, in the
/// built-in [`font`] at [`caption_scale`] (a label too long for its panel even at ×1 is cut
/// short) — and each image's [`crop_region`] outlined on the top row (1 pixel, dashed white
/// and black), so that the crops row needs no labels of its own. Returns width, height
/// ([`caption_height`] + 2 × image height + `gap`) and the values.
pub fn side_by_side_labelled(panels: &[(&str, &Image)], gap: usize) -> (usize, usize, Vec<f32>) {
    if panels.is_empty() {
        return (0, 0, Vec::new());
    }
    let images: Vec<&Image> = panels.iter().map(|&(_, img)| img).collect();
    let (w, h, mut top) = side_by_side(&images, gap);
    outline_crop_regions(&mut top, w, &images, gap);
    let scale = caption_scale(panels);
    let strip = caption_height(scale);
    let mut out = vec![0f32; w * strip];
    let mut x0 = 0;
    for &(label, img) in panels {
        let text = font::truncate(label, scale, img.width.saturating_sub(scale));
        let dx = (img.width.saturating_sub(font::text_width(text, scale)) / 2).max(scale);
        font::draw_text(&mut out, w, x0 + dx, scale, text, scale, 1.0);
        x0 += img.width + gap;
    }
    out.extend(top);
    out.extend(std::iter::repeat_n(0.0, w * gap));
    out.extend(crops_row(&images, gap, w, h));
    (w, strip + 2 * h + gap, out)
}

/// A log-log SVG plot of RMSE against busy seconds ([`Image::seconds`]), one polyline per
/// named series of `(seconds, rmse)` points.
pub fn convergence_svg(title: &str, series: &[(&str, Vec<(f64, f64)>)]) -> String {
    const COLORS: [&str; 7] = [
        "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
    ];
    let (pw, ph, ml, mr, mt, mb) = (640.0, 420.0, 70.0, 130.0, 30.0, 50.0);
    let pts = series
        .iter()
        .flat_map(|s| s.1.iter())
        .filter(|p| p.0 > 0.0 && p.1 > 0.0);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        x0 = x0.min(x.log10());
        x1 = x1.max(x.log10());
        y0 = y0.min(y.log10());
        y1 = y1.max(y.log10());
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let (x0, x1, y0, y1) = (
        x0.floor(),
        x1.ceil().max(x0.floor() + 1.0),
        y0.floor(),
        y1.ceil().max(y0.floor() + 1.0),
    );
    let fx = |x: f64| ml + (x.log10() - x0) / (x1 - x0) * (pw - ml - mr);
    let fy = |y: f64| mt + (y1 - y.log10()) / (y1 - y0) * (ph - mt - mb);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{pw}\" height=\"{ph}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"{}\" y=\"18\" text-anchor=\"middle\">{title}</text>\n",
        pw / 2.0
    );
    let (l, r, t, b) = (ml, pw - mr, mt, ph - mb);
    s.push_str(&format!(
        "<rect x=\"{l}\" y=\"{t}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n",
        r - l,
        b - t
    ));
    for e in (x0 as i32)..=(x1 as i32) {
        let x = fx(10f64.powi(e));
        s.push_str(&format!(
            "<line x1=\"{x}\" y1=\"{t}\" x2=\"{x}\" y2=\"{b}\" stroke=\"#ddd\"/><text x=\"{x}\" y=\"{}\" text-anchor=\"middle\">1e{e}</text>\n",
            b + 16.0
        ));
    }
    for e in (y0 as i32)..=(y1 as i32) {
        let y = fy(10f64.powi(e));
        s.push_str(&format!(
            "<line x1=\"{l}\" y1=\"{y}\" x2=\"{r}\" y2=\"{y}\" stroke=\"#ddd\"/><text x=\"{}\" y=\"{}\" text-anchor=\"end\">1e{e}</text>\n",
            l - 6.0,
            y + 4.0
        ));
    }
    s.push_str(&format!(
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">busy CPU time (s, summed over threads)</text>\n<text x=\"16\" y=\"{}\" transform=\"rotate(-90 16 {})\" text-anchor=\"middle\">RMSE</text>\n",
        (l + r) / 2.0,
        ph - 10.0,
        (t + b) / 2.0,
        (t + b) / 2.0
    ));
    for (i, (name, points)) in series.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        let poly: Vec<String> = points
            .iter()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0)
            .map(|&(x, y)| format!("{:.1},{:.1}", fx(x), fy(y)))
            .collect();
        s.push_str(&format!(
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{c}\" stroke-width=\"2\"/>\n",
            poly.join(" ")
        ));
        let ly = t + 10.0 + 18.0 * i as f64;
        s.push_str(&format!(
            "<line x1=\"{}\" y1=\"{ly}\" x2=\"{}\" y2=\"{ly}\" stroke=\"{c}\" stroke-width=\"2\"/><text x=\"{}\" y=\"{}\">{name}</text>\n",
            r + 10.0,
            r + 30.0,
            r + 36.0,
            ly + 4.0
        ));
    }
    s.push_str("</svg>\n");
    s
}

/// Writes an image's means as raw little-endian f32 (header: width, height, spp as u64).
/// Creates the folder if needed; errors name the file.
pub fn write_raw(path: &Path, img: &Image) -> std::io::Result<()> {
    create_parent(path)?;
    let write = || -> std::io::Result<()> {
        let mut f = BufWriter::new(std::fs::File::create(path)?);
        for v in [img.width as u64, img.height as u64, img.spp as u64] {
            f.write_all(&v.to_le_bytes())?;
        }
        for &v in img.mean.iter().chain(&img.var) {
            f.write_all(&v.to_le_bytes())?;
        }
        f.flush()
    };
    write().map_err(|e| with_path(path, &e, e.kind()))
}

/// Reads what [`write_raw`] wrote (None if missing or malformed).
pub fn read_raw(path: &Path) -> Option<Image> {
    let bytes = std::fs::read(path).ok()?;
    let u = |i: usize| -> Option<usize> {
        Some(u64::from_le_bytes(bytes.get(i * 8..i * 8 + 8)?.try_into().ok()?) as usize)
    };
    let (width, height, spp) = (u(0)?, u(1)?, u(2)?);
    let n = width * height;
    let floats: Vec<f32> = bytes
        .get(24..)?
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if floats.len() != 2 * n {
        return None;
    }
    Some(Image {
        width,
        height,
        mean: floats[..n].to_vec(),
        var: floats[n..].to_vec(),
        spp,
        seconds: 0.0,
        wall_seconds: 0.0,
    })
}
