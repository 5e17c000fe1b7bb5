//! `mlrender compare`: every technique on one scene at equal samples per pixel and at equal
//! time, against a cached reference.
//!
//! - **Reference**: the `full` technique at `ref_spp` estimates per pixel (default 64 × the
//!   compared spp), with its own seed, cached as raw f32 under
//!   `out/reference/<scene>-<lights>-<W>x<H>-<ref_spp>.bin` (delete the file to recompute it).
//! - **Equal spp**: each technique at `spp`; RMSE against the reference.
//! - **Equal time**: the time budget is what `full` took at `spp`; each technique then renders
//!   again with `spp_t = max(1, round(budget / its ms per spp))` (fresh seed) and its RMSE is
//!   reported as `rmse_equal_time`.
//! - `mean_rel_diff`: |average of the equal-spp image − average of the reference| / average of
//!   the reference.
//!
//! Outputs under `out/compare/<scene>-<lights>/`: one PNG per technique (equal spp,
//! `<technique>.png`), `reference.png`, `side_by_side.png` (techniques in report order, then
//! the reference, separated by 4 black columns; below, each one's lower middle quarter
//! magnified 2×), `convergence.svg` (unless `--no-plot`: RMSE against time, log-log, from
//! renders at 1, 2, 4, … 4 × spp), `table.md` (the Markdown table, also printed).
//! With `--json` the last line of stdout is
//! `{scene, lights, resolution, spp, ref_spp, techniques: [{name, rmse_equal_spp,
//! rmse_equal_time, spp_equal_time, ms_per_spp, mean_rel_diff}]}`.

use crate::estimator::techniques::Technique;
use crate::render::{
    convergence_svg, read_raw, render, side_by_side_with_crops, write_png, write_raw, Image,
    RenderConfig,
};
use crate::scene::RenderScene;
use serde_json::json;
use std::path::PathBuf;

/// What to compare.
#[derive(Clone, Debug)]
pub struct CompareConfig {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Estimates per pixel at equal spp.
    pub spp: usize,
    /// Estimates per pixel of the reference.
    pub ref_spp: usize,
    /// Seed.
    pub seed: u64,
    /// Root output folder (`out`).
    pub out: PathBuf,
    /// Progress bars.
    pub progress: bool,
    /// Also render every technique at 1, 2, 4, … 4 × spp and plot RMSE against time
    /// (`convergence.svg`).
    pub plot: bool,
}

/// One technique's numbers.
#[derive(Clone, Debug)]
pub struct TechReport {
    /// The technique.
    pub technique: Technique,
    /// RMSE at equal spp.
    pub rmse_equal_spp: f64,
    /// RMSE at equal time.
    pub rmse_equal_time: f64,
    /// spp of the equal-time render.
    pub spp_equal_time: usize,
    /// Milliseconds per spp (whole image, all threads).
    pub ms_per_spp: f64,
    /// Relative difference of the image averages at equal spp.
    pub mean_rel_diff: f64,
}

/// The comparison.
#[derive(Clone, Debug)]
pub struct Report {
    /// Scene name.
    pub scene: String,
    /// Light count.
    pub lights: usize,
    /// Width, height.
    pub resolution: (usize, usize),
    /// Equal spp.
    pub spp: usize,
    /// Reference spp.
    pub ref_spp: usize,
    /// Per technique, in [`Technique::ALL`] order.
    pub techniques: Vec<TechReport>,
}

impl Report {
    /// The JSON object of the last line.
    pub fn json(&self) -> serde_json::Value {
        json!({
            "scene": self.scene,
            "lights": self.lights,
            "resolution": [self.resolution.0, self.resolution.1],
            "spp": self.spp,
            "ref_spp": self.ref_spp,
            "techniques": self.techniques.iter().map(|t| json!({
                "name": t.technique.name(),
                "rmse_equal_spp": t.rmse_equal_spp,
                "rmse_equal_time": t.rmse_equal_time,
                "spp_equal_time": t.spp_equal_time,
                "ms_per_spp": t.ms_per_spp,
                "mean_rel_diff": t.mean_rel_diff,
            })).collect::<Vec<_>>(),
        })
    }

    /// The Markdown table.
    pub fn table(&self) -> String {
        let base = self
            .techniques
            .iter()
            .find(|t| t.technique == Technique::TlSplit)
            .map(|t| (t.rmse_equal_spp, t.rmse_equal_time));
        let mut s = format!(
            "{} ({} lights, {}x{}, {} spp; reference: full at {} spp)\n\n",
            self.scene, self.lights, self.resolution.0, self.resolution.1, self.spp, self.ref_spp
        );
        s.push_str("| technique | RMSE equal spp | ×tl-split | RMSE equal time | ×tl-split | spp at equal time | ms/spp | mean rel. diff |\n");
        s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|\n");
        for t in &self.techniques {
            let (r1, r2) = base.map_or((f64::NAN, f64::NAN), |(a, b)| {
                (t.rmse_equal_spp / a, t.rmse_equal_time / b)
            });
            s.push_str(&format!(
                "| {} | {:.5} | {:.3} | {:.5} | {:.3} | {} | {:.1} | {:.2} % |\n",
                t.technique.name(),
                t.rmse_equal_spp,
                r1,
                t.rmse_equal_time,
                r2,
                t.spp_equal_time,
                t.ms_per_spp,
                100.0 * t.mean_rel_diff
            ));
        }
        s
    }
}

/// The cached reference of `scene` (computed and stored if missing).
pub fn reference(scene: &RenderScene, cfg: &CompareConfig) -> std::io::Result<Image> {
    let path = cfg.out.join("reference").join(format!(
        "{}-{}-{}x{}-{}.bin",
        scene.name,
        scene.lights.lights.len(),
        cfg.width,
        cfg.height,
        cfg.ref_spp
    ));
    if let Some(img) = read_raw(&path) {
        if img.width == cfg.width && img.height == cfg.height && img.spp == cfg.ref_spp {
            eprintln!("reference: {} (cached)", path.display());
            return Ok(img);
        }
    }
    eprintln!(
        "reference: full at {} spp -> {}",
        cfg.ref_spp,
        path.display()
    );
    let img = render(
        scene,
        &RenderConfig {
            width: cfg.width,
            height: cfg.height,
            spp: cfg.ref_spp,
            technique: Technique::Full,
            seed: cfg.seed ^ 0x7e7e_7e7e_0000,
            progress: cfg.progress,
        },
    );
    write_raw(&path, &img)?;
    Ok(img)
}

/// `mlrender reference`: the cached reference (computed if missing) and a check that a second
/// technique (`tl-split`, at a quarter of the reference's spp, its own seed) converges to the
/// same image: returns the reference, the relative difference of the two image averages,
/// the standard error of that difference (relative), and their RMSE.
pub fn check_reference(
    scene: &RenderScene,
    cfg: &CompareConfig,
) -> std::io::Result<(Image, f64, f64, f64)> {
    let reference = reference(scene, cfg)?;
    let other = render(
        scene,
        &RenderConfig {
            width: cfg.width,
            height: cfg.height,
            spp: (cfg.ref_spp / 4).max(1),
            technique: Technique::TlSplit,
            seed: cfg.seed ^ 0x0123_4567,
            progress: cfg.progress,
        },
    );
    let a = reference.average();
    let rel = (other.average() - a).abs() / a;
    let se = (other.average_se().powi(2) + reference.average_se().powi(2)).sqrt() / a;
    let rmse = other.rmse(&reference);
    Ok((reference, rel, se, rmse))
}

/// Runs the comparison and writes its images and table.
pub fn run(scene: &RenderScene, cfg: &CompareConfig) -> std::io::Result<Report> {
    let reference = reference(scene, cfg)?;
    let ref_avg = reference.average();
    let dir = cfg
        .out
        .join("compare")
        .join(format!("{}-{}", scene.name, scene.lights.lights.len()));
    let rc = |technique, spp, seed| RenderConfig {
        width: cfg.width,
        height: cfg.height,
        spp,
        technique,
        seed,
        progress: cfg.progress,
    };
    let images: Vec<Image> = Technique::ALL
        .iter()
        .map(|&t| render(scene, &rc(t, cfg.spp, cfg.seed)))
        .collect();
    let full_idx = Technique::ALL
        .iter()
        .position(|&t| t == Technique::Full)
        .expect("full is a technique");
    let budget = images[full_idx].seconds;
    let mut techniques = Vec::new();
    for (&t, img) in Technique::ALL.iter().zip(&images) {
        write_png(
            &dir.join(format!("{}.png", t.name())),
            img.width,
            img.height,
            &img.mean,
        )?;
        let per_spp = img.seconds / cfg.spp as f64;
        let spp_t = ((budget / per_spp).round() as usize).max(1);
        let eq = render(scene, &rc(t, spp_t, cfg.seed.wrapping_add(0x5eed)));
        techniques.push(TechReport {
            technique: t,
            rmse_equal_spp: img.rmse(&reference),
            rmse_equal_time: eq.rmse(&reference),
            spp_equal_time: spp_t,
            ms_per_spp: per_spp * 1e3,
            mean_rel_diff: (img.average() - ref_avg).abs() / ref_avg,
        });
    }
    write_png(
        &dir.join("reference.png"),
        reference.width,
        reference.height,
        &reference.mean,
    )?;
    let mut all: Vec<&Image> = images.iter().collect();
    all.push(&reference);
    let (w, h, sbs) = side_by_side_with_crops(&all, 4);
    write_png(&dir.join("side_by_side.png"), w, h, &sbs)?;
    if cfg.plot {
        let mut series = Vec::new();
        for &t in &Technique::ALL {
            let mut points = Vec::new();
            let mut spp = 1;
            while spp <= 4 * cfg.spp {
                let img = render(scene, &rc(t, spp, cfg.seed.wrapping_add(0xc0 + spp as u64)));
                points.push((img.seconds, img.rmse(&reference)));
                spp *= 2;
            }
            series.push((t.name(), points));
        }
        let title = format!(
            "{} ({} lights, {}x{}): RMSE against time",
            scene.name,
            scene.lights.lights.len(),
            cfg.width,
            cfg.height
        );
        std::fs::write(
            dir.join("convergence.svg"),
            convergence_svg(&title, &series),
        )?;
    }
    let report = Report {
        scene: scene.name.clone(),
        lights: scene.lights.lights.len(),
        resolution: (cfg.width, cfg.height),
        spp: cfg.spp,
        ref_spp: cfg.ref_spp,
        techniques,
    };
    std::fs::write(dir.join("table.md"), report.table())?;
    eprintln!("images and table.md in {}", dir.display());
    Ok(report)
}
