//! `mlrender compare`: every technique on one scene at equal samples per pixel and at equal
//! time, against a cached reference.
//!
//! - **Reference**: the `full` technique at `ref_spp` estimates per pixel (default 64 × the
//!   compared spp), with its own seed (a progress bar with the time left on stderr while it
//!   renders, when stderr is a terminal), cached as raw f32 (per pixel the mean and the
//!   per-estimate sample variance of its estimates) under
//!   `out/reference/<scene>-<lights>-<fingerprint>-<W>x<H>-<ref_spp>-<seed>.bin`, the fingerprint
//!   being [`RenderScene::fingerprint`] (a changed scene never reuses a stale reference; delete
//!   the folder to reclaim the space).
//! - **Time** is busy time summed over the render threads ([`Image::seconds`]: each image row
//!   timed by the CPU clock of the thread that renders it, the row times added up),
//!   everywhere: budget, ms per spp, the equal-time renders' own times and the convergence
//!   plot. It is about wall time × threads on idle cores; it counts neither idle threads nor
//!   the time other processes take the cores, and does not depend on the thread count, so
//!   that equal time stays equal on a shared, loaded machine, where wall time does not.
//! - **Equal spp**: each technique at `spp`; RMSE against the reference.
//! - **Cost model**: a render's time is affine in spp, `fixed + spp × per_spp`: `fixed` (primary
//!   rays and the techniques' set-up at every pixel) is measured by a render at 0 spp, and
//!   `per_spp = (time of the equal-spp render − fixed) / spp` (see [`Cost::from_times`]). Taking
//!   `time / spp` instead would charge the fixed part to every sample and give the cheap
//!   techniques, which then render many more spp than `spp`, up to a quarter less than their
//!   budget at the `--quick` settings. The equal-spp render is the calibration: it is the
//!   same scene, size and technique, and it is rendered anyway.
//! - **Equal time**: the budget is `--time SECONDS` (busy seconds per technique) if given,
//!   otherwise what `full` took at `spp`. Each technique renders again (fresh seed) with
//!   `spp_t = max(1, round((budget − fixed) / per_spp))` ([`equal_time_spp`]; `full` gets `spp`
//!   back when the budget is its own time) and its RMSE is `rmse_equal_time`; the render's
//!   actual busy time is reported beside it (`seconds_equal_time`), so a budget missed because
//!   of a noisy timing is visible. A render rarely takes its budget exactly (the cost model
//!   is fitted on a loaded machine), and one that overshoots has had more time: beside each
//!   equal-time RMSE is the RMSE scaled to the budget, `RMSE × √(t / budget)`
//!   (`rmse_equal_time_at_budget`; the MSE of an unbiased estimate falls as 1/time), and every
//!   equal-time ratio to another technique (×tl-split, ×tl-mis, in every table and JSON key
//!   `*_equal_time_*vs_tl_mis`) is taken between the scaled RMSEs, so that an overshoot cannot
//!   favour one technique.
//! - `mean_rel_diff`: |average of the image − average of the reference| / average of the
//!   reference, for the technique's image with the most spp among its equal-spp, equal-time and
//!   convergence renders (`mean_rel_diff_spp`); `mean_rel_diff_signed` is the same without the
//!   absolute value (negative where the image is darker than the reference: what a heavy upper
//!   tail usually gives); `mean_rel_diff_se` is the standard error of that difference
//!   (relative; from both images' per-pixel variances, `null` below 2 spp), so that noise can
//!   be told from bias; `mean_rel_diff_sigma` is the ratio of the first to it. The table
//!   shows the signed difference.
//! - **Reference variance removed** ([`error_split`]; docs/formulas.md,
//!   section 15): beside each RMSE, `RMSE' = sqrt(max(0, MSE − V))` with `V` the mean over the
//!   pixels of the reference's own variance of its pixel means (its per-estimate sample
//!   variance over `ref_spp`), the part of the MSE that is the reference's noise; and the
//!   ratios of both to tl-mis's (the peer strategy).
//! - **Error splits**: each pixel is classed by the primary hit at its centre (under the
//!   jittered protocol its estimates hit anywhere in the pixel; the centre's hit classes it):
//!   by material class ([`RenderScene::material_class`]: kind and glossy lobe, named by the
//!   scene where it names them), by view angle (bins of cos θo 0.1 wide) and by both. Per
//!   technique and class: the class's part of the MSE (the parts add up to the MSE; with
//!   their share of `V` removed, to `MSE − V`) and the RMSE over the class's pixels, both also
//!   with `V` removed, and that RMSE over tl-mis's in the same class; `mse_se` is the
//!   standard error of a part (and `mse_*_se` of a whole MSE) from the spread of the
//!   per-pixel squared errors, so that a class's ratio can be told from noise.
//!
//! Outputs under `out/compare/<scene>-<lights>/`: per technique `<technique>.png` and
//! `<technique>.exr` (equal spp) and `<technique>-equal-time.png` / `.exr`, `reference.png` /
//! `.exr` (PNG: 8-bit sRGB clamped to [0, 1]; EXR: linear f32, R = G = B), `side_by_side.png`
//! (equal-spp images in report order, then the reference, separated by 4 black columns; above
//! each, a caption strip with its name and, for a technique, its RMSE against the reference;
//! below, each one's lower middle quarter, outlined on the image above, magnified 2×: see
//! [`side_by_side_labelled`]), `side_by_side_equal_time.png` (the same with the equal-time
//! images and their RMSE), `convergence.svg` (unless `--no-plot`: RMSE against busy time,
//! log-log, from renders at 1, 2, 4, … 4 × spp), `table.md` (the Markdown tables of
//! [`Report::table`]: the main one, the RMSEs with the reference's variance removed, the splits by
//! material and view angle at equal spp and equal time, and the [`JOINT_ROWS`] classes of
//! material and view angle that hold most of the default technique's error; `mlrender compare`
//! prints them with `--full`, and otherwise the short [`Report::summary`], one line per
//! technique, ending with where `table.md` and the images are). Error maps: per technique
//! `<technique>-error.png` / `.exr` and `<technique>-equal-time-error.png` / `.exr`,
//! `reference-error.png` / `.exr` (the reference's own variance of its pixel means): the EXR
//! holds the per-pixel squared error against the reference (linear), the PNG the absolute
//! error with white at [`ERROR_MAP_SCALE`] × tl-mis's RMSE at equal spp (clamped; the same
//! scale in every map); `side_by_side_error.png` and `side_by_side_equal_time_error.png` put
//! them side by side as the images are.
//! With `--json` the last line of stdout is
//! `{scene, lights, resolution, spp, ref_spp, time_budget_s, time_budget_from, dir,
//! techniques: [{name, rmse_equal_spp, rmse_equal_time, spp_equal_time, seconds_equal_time,
//! ms_per_spp, ms_fixed, seconds_equal_spp, mean_rel_diff, mean_rel_diff_signed,
//! mean_rel_diff_spp, mean_rel_diff_se, mean_rel_diff_sigma, failed_estimates,
//! mse_equal_spp_se, mse_equal_time_se, rmse_equal_spp_corrected, rmse_equal_time_corrected,
//! rmse_equal_spp_vs_tl_mis, rmse_equal_time_vs_tl_mis, rmse_equal_spp_corrected_vs_tl_mis,
//! rmse_equal_time_corrected_vs_tl_mis, errors: {material, angle, material_angle: {equal_spp,
//! equal_time: [{class, mse, mse_corrected, mse_se, rmse, rmse_corrected,
//! rmse_corrected_vs_tl_mis}]}}}], reference_mean_variance, reference_rmse_floor,
//! error_class_pixel, error_map_scale, error_classes: {material, angle, material_angle:
//! [{name, pixels, reference_mean, kind (not for angle)}]}}`, techniques in
//! [`Technique::ALL`] order, each split's classes in the order of `error_classes`;
//! `ms_per_spp` and `ms_fixed` are the cost model's (busy milliseconds), `mse` a class's part
//! of the image's MSE.

pub mod error_split;

use crate::image::{
    convergence_svg, read_raw, side_by_side_labelled, warn_failed, write_exr, write_png, write_raw,
    Image,
};
use crate::render::{centre_hits, render, render_with, Protocol, RenderConfig};
use crate::scene::RenderScene;
use error_split::{error_map, map_image, Classes, ErrorSummary};
use indicatif::{ProgressBar, ProgressStyle};
use manylights::{Params, Technique};
use serde_json::json;
use std::io::{Error, ErrorKind};
use std::path::{Path, PathBuf};

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
    /// Equal-time budget per technique in busy seconds (`--time`); `None`: what `full` took
    /// at `spp`.
    pub time: Option<f64>,
    /// Where the estimates are taken (the reference follows it).
    pub protocol: Protocol,
    /// The estimators' parameters (the reference's are the defaults).
    pub params: Params,
    /// Learned visibility for the techniques it applies to (not the reference's).
    pub learn: Option<crate::render::Learn>,
    /// The techniques to render, reported in [`Technique::ALL`] order (empty: all of them).
    /// They must include `tl-mis` (every ratio's denominator), `bl` and the default, and
    /// `full` unless `time` gives the budget.
    pub techniques: Vec<Technique>,
}

impl CompareConfig {
    /// The techniques rendered, in [`Technique::ALL`] order.
    pub fn chosen(&self) -> Vec<Technique> {
        Technique::ALL
            .into_iter()
            .filter(|t| self.techniques.is_empty() || self.techniques.contains(t))
            .collect()
    }
}

/// A technique's render time as `fixed + spp × per_spp` (busy seconds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cost {
    /// Seconds of a render at 0 spp: primary rays and set-up at every pixel.
    pub fixed: f64,
    /// Seconds per estimate per pixel (whole image).
    pub per_spp: f64,
}

impl Cost {
    /// The cost model from the time of a render at 0 spp (`fixed`) and of one at `spp`
    /// (`total`). When the timings are inconsistent (the 0-spp render took as long as the
    /// other, e.g. through a scheduling hiccup, or a time is not finite) it falls back to
    /// `fixed = 0`, `per_spp = total / spp`.
    pub fn from_times(fixed: f64, total: f64, spp: usize) -> Cost {
        let spp = spp.max(1) as f64;
        if fixed.is_finite() && total.is_finite() && fixed >= 0.0 && total > fixed {
            Cost {
                fixed,
                per_spp: (total - fixed) / spp,
            }
        } else {
            Cost {
                fixed: 0.0,
                per_spp: total / spp,
            }
        }
    }
}

/// The spp of an equal-time render: `max(1, round((budget − cost.fixed) / cost.per_spp))`
/// (1 when the budget does not cover the fixed part, or the time per spp is not positive and
/// finite).
pub fn equal_time_spp(budget: f64, cost: Cost) -> usize {
    let q = (budget - cost.fixed) / cost.per_spp;
    if cost.per_spp > 0.0 && q.is_finite() && q > 1.0 {
        // `as` saturates at usize::MAX.
        q.round() as usize
    } else {
        1
    }
}

/// Checks a `--time` value: positive and finite.
pub fn check_time(seconds: f64) -> Result<f64, String> {
    if seconds.is_finite() && seconds > 0.0 {
        Ok(seconds)
    } else {
        Err(format!(
            "the time budget must be a positive, finite number of seconds (got {seconds})"
        ))
    }
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
    /// Busy seconds of the equal-time render (compare with the budget).
    pub seconds_equal_time: f64,
    /// Busy seconds of the equal-spp render.
    pub seconds_equal_spp: f64,
    /// The cost model (from the 0-spp and equal-spp renders).
    pub cost: Cost,
    /// Busy milliseconds per spp (whole image) of the cost model.
    pub ms_per_spp: f64,
    /// Relative difference of the image averages, (image average − reference average) /
    /// reference average, at [`TechReport::mean_rel_diff_spp`]; its size is
    /// [`TechReport::mean_rel_diff`].
    pub mean_rel_diff_signed: f64,
    /// The highest spp the technique was rendered at (of its equal-spp, equal-time and
    /// convergence renders): the image of `mean_rel_diff_signed`.
    pub mean_rel_diff_spp: usize,
    /// Standard error of `mean_rel_diff` (relative to the reference average); NaN below 2 spp.
    pub mean_rel_diff_se: f64,
    /// The equal-spp image's error against the reference: totals, the reference's variance,
    /// and the splits by [`Report::classes`].
    pub errors_equal_spp: ErrorSummary,
    /// The same of the equal-time image.
    pub errors_equal_time: ErrorSummary,
    /// Estimates of its equal-spp and equal-time renders that the core refused with an error,
    /// each counted as black (0 in a sound run; `compare` warns otherwise).
    pub failed_estimates: u64,
}

impl TechReport {
    /// |image average − reference average| / reference average: the size of
    /// [`TechReport::mean_rel_diff_signed`] (the reference average is not negative).
    pub fn mean_rel_diff(&self) -> f64 {
        self.mean_rel_diff_signed.abs()
    }

    /// RMSE at equal spp with the reference's variance removed.
    pub fn rmse_equal_spp_corrected(&self) -> f64 {
        self.errors_equal_spp.rmse_corrected()
    }

    /// RMSE at equal time with the reference's variance removed.
    pub fn rmse_equal_time_corrected(&self) -> f64 {
        self.errors_equal_time.rmse_corrected()
    }

    /// `√(t / budget)` of the equal-time render, `t` its busy seconds: what its errors are
    /// multiplied by to be those of a render of exactly `budget` seconds (NaN unless both are
    /// positive and finite).
    pub fn budget_scale(&self, budget: f64) -> f64 {
        let t = self.seconds_equal_time;
        if t > 0.0 && t.is_finite() && budget > 0.0 && budget.is_finite() {
            (t / budget).sqrt()
        } else {
            f64::NAN
        }
    }

    /// The equal-time RMSE scaled to `budget` seconds: `RMSE × √(t / budget)`.
    pub fn rmse_equal_time_at(&self, budget: f64) -> f64 {
        self.rmse_equal_time * self.budget_scale(budget)
    }

    /// [`TechReport::rmse_equal_time_corrected`] scaled to `budget` seconds.
    pub fn rmse_equal_time_corrected_at(&self, budget: f64) -> f64 {
        self.rmse_equal_time_corrected() * self.budget_scale(budget)
    }
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
    /// Equal-time budget per technique, busy seconds.
    pub time_budget: f64,
    /// Whether the budget came from `--time` (otherwise: `full` at `spp`).
    pub time_given: bool,
    /// The folder of the images and table.
    pub dir: PathBuf,
    /// Per technique rendered, in [`Technique::ALL`] order.
    pub techniques: Vec<TechReport>,
    /// Where the estimates were taken.
    pub protocol: Protocol,
    /// Mean over the pixels of the variance of the reference's pixel means (its own
    /// estimate, from its samples).
    pub reference_variance: f64,
    /// The pixel classes of the error splits: by material, by view angle, by both.
    pub classes: Vec<Classes>,
    /// Per split, per class: the reference's average over the class's pixels.
    pub class_reference_means: Vec<Vec<f64>>,
    /// The absolute error shown as white in the error maps' PNG files.
    pub error_map_scale: f64,
}

/// The index of `t` in `chosen` (a technique every report holds: see [`CompareConfig`]).
fn index_of(chosen: &[Technique], t: Technique) -> usize {
    chosen
        .iter()
        .position(|&x| x == t)
        .expect("the report holds tl-mis, bl and the default")
}

/// `a / b`, NaN unless both are finite and `b` is positive.
fn ratio(a: f64, b: f64) -> f64 {
    if a.is_finite() && b.is_finite() && b > 0.0 {
        a / b
    } else {
        f64::NAN
    }
}

/// A ratio for a table: 3 decimals, `–` when not finite.
fn fmt_ratio(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.3}")
    } else {
        "–".into()
    }
}

/// A number for JSON: `null` when not finite.
fn num(x: f64) -> serde_json::Value {
    if x.is_finite() {
        json!(x)
    } else {
        serde_json::Value::Null
    }
}

impl Report {
    /// The JSON object of the last line.
    pub fn json(&self) -> serde_json::Value {
        let mis = self.tl_mis();
        json!({
            "scene": self.scene,
            "lights": self.lights,
            "resolution": [self.resolution.0, self.resolution.1],
            "spp": self.spp,
            "ref_spp": self.ref_spp,
            "time_budget_s": num(self.time_budget),
            "time_budget_from": if self.time_given { "--time" } else { "full" },
            "protocol": self.protocol.name(),
            "default_technique": Technique::DEFAULT.name(),
            "dir": self.dir.display().to_string(),
            "techniques": self.techniques.iter().map(|t| json!({
                "name": t.technique.name(),
                "rmse_equal_spp": num(t.rmse_equal_spp),
                "rmse_equal_time": num(t.rmse_equal_time),
                "rmse_equal_time_at_budget": num(t.rmse_equal_time_at(self.time_budget)),
                "rmse_equal_time_corrected_at_budget": num(t.rmse_equal_time_corrected_at(self.time_budget)),
                "budget_scale": num(t.budget_scale(self.time_budget)),
                "spp_equal_time": t.spp_equal_time,
                "seconds_equal_time": num(t.seconds_equal_time),
                "ms_per_spp": num(t.ms_per_spp),
                "ms_fixed": num(t.cost.fixed * 1e3),
                "seconds_equal_spp": num(t.seconds_equal_spp),
                "mean_rel_diff": num(t.mean_rel_diff()),
                "mean_rel_diff_signed": num(t.mean_rel_diff_signed),
                "mean_rel_diff_spp": t.mean_rel_diff_spp,
                "mean_rel_diff_se": num(t.mean_rel_diff_se),
                "mean_rel_diff_sigma": num(ratio(t.mean_rel_diff(), t.mean_rel_diff_se)),
                "failed_estimates": t.failed_estimates,
                "mse_equal_spp_se": num(t.errors_equal_spp.mse_se),
                "mse_equal_time_se": num(t.errors_equal_time.mse_se),
                "rmse_equal_spp_corrected": num(t.rmse_equal_spp_corrected()),
                "rmse_equal_time_corrected": num(t.rmse_equal_time_corrected()),
                "rmse_equal_spp_vs_tl_mis": num(ratio(t.rmse_equal_spp, mis.rmse_equal_spp)),
                "rmse_equal_time_vs_tl_mis": num(ratio(
                    t.rmse_equal_time_at(self.time_budget),
                    mis.rmse_equal_time_at(self.time_budget)
                )),
                "rmse_equal_spp_corrected_vs_tl_mis": num(ratio(
                    t.rmse_equal_spp_corrected(),
                    mis.rmse_equal_spp_corrected()
                )),
                "rmse_equal_time_corrected_vs_tl_mis": num(ratio(
                    t.rmse_equal_time_corrected_at(self.time_budget),
                    mis.rmse_equal_time_corrected_at(self.time_budget)
                )),
                "errors": self.classes.iter().enumerate().map(|(k, c)| {
                    let n = self.resolution.0 * self.resolution.1;
                    // `scale`: the technique's budget scale over tl-mis's (1 at equal spp).
                    let per = |e: &ErrorSummary, m: &ErrorSummary, scale: f64| {
                        c.names.iter().enumerate().map(|(i, (name, _))| {
                            let (x, y) = (e.splits[k][i], m.splits[k][i]);
                            json!({
                                "class": name,
                                "mse": num(x.mse_part(n)),
                                "mse_corrected": num(x.mse_part_corrected(n)),
                                "mse_se": num(x.mse_part_se(n)),
                                "rmse": num(x.rmse()),
                                "rmse_corrected": num(x.rmse_corrected()),
                                "rmse_corrected_vs_tl_mis": num(scale * ratio(x.rmse_corrected(), y.rmse_corrected())),
                            })
                        }).collect::<Vec<_>>()
                    };
                    (c.what.to_string(), json!({
                        "equal_spp": per(&t.errors_equal_spp, &mis.errors_equal_spp, 1.0),
                        "equal_time": per(&t.errors_equal_time, &mis.errors_equal_time, self.scale_over_mis(t)),
                    }))
                }).collect::<serde_json::Map<_, _>>(),
            })).collect::<Vec<_>>(),
            "reference_mean_variance": num(self.reference_variance),
            "reference_rmse_floor": num(self.reference_variance.sqrt()),
            "error_class_pixel": "the primary hit at the pixel centre",
            "error_map_scale": num(self.error_map_scale),
            "error_classes": self.classes.iter().zip(&self.class_reference_means).map(|(c, means)| {
                let pixels = c.pixels();
                (c.what.to_string(), c.names.iter().enumerate().map(|(i, (name, kind))| {
                    let mut o = json!({
                        "name": name,
                        "pixels": pixels[i],
                        "reference_mean": num(means[i]),
                    });
                    if c.what != "angle" {
                        o["kind"] = json!(kind);
                    }
                    o
                }).collect::<Vec<_>>().into())
            }).collect::<serde_json::Map<_, _>>(),
        })
    }

    /// The report of `t`, one every report holds (tl-mis, bl, the default: see
    /// [`CompareConfig`]).
    fn of(&self, t: Technique) -> &TechReport {
        self.techniques
            .iter()
            .find(|r| r.technique == t)
            .expect("the report holds tl-mis, bl and the default")
    }

    /// The report of tl-mis, the peer strategy every ratio is taken against.
    fn tl_mis(&self) -> &TechReport {
        self.of(Technique::TlMis)
    }

    /// `t`'s budget scale over tl-mis's: what a ratio of their equal-time errors is
    /// multiplied by to be the ratio of the errors scaled to the budget.
    fn scale_over_mis(&self, t: &TechReport) -> f64 {
        ratio(
            t.budget_scale(self.time_budget),
            self.tl_mis().budget_scale(self.time_budget),
        )
    }

    /// The file [`run`] writes the full tables to ([`Report::table`]): `table.md` in
    /// [`Report::dir`].
    #[must_use]
    pub fn table_path(&self) -> PathBuf {
        self.dir.join(TABLE_FILE)
    }

    /// The short summary `mlrender compare` prints: a line naming the scene and the budget,
    /// a header, one line per technique (its RMSE at equal spp, at equal time scaled to the
    /// budget, that over tl-mis's, and the image mean's signed relative difference to the
    /// reference with its standard error), and a line saying where the full tables and the
    /// images are. `2 + techniques + 1` lines.
    #[must_use]
    pub fn summary(&self) -> String {
        let mis = self.tl_mis().rmse_equal_time_at(self.time_budget);
        let budget = if self.time_given {
            "--time".to_string()
        } else {
            format!("full at {} spp", self.spp)
        };
        let mut s = format!(
            "{}, {} lights, {}x{}, {} spp (reference {} spp); equal time {:.3} busy s ({budget})\n",
            self.scene,
            self.lights,
            self.resolution.0,
            self.resolution.1,
            self.spp,
            self.ref_spp,
            self.time_budget,
        );
        s.push_str(&format!(
            "{:<12}{:>16}{:>17}{:>9}{:>21}\n",
            "technique", "RMSE equal spp", "RMSE equal time", "×tl-mis", "mean vs reference"
        ));
        for t in &self.techniques {
            let at_budget = t.rmse_equal_time_at(self.time_budget);
            let se = if t.mean_rel_diff_se.is_finite() {
                format!("± {:.2} %", 100.0 * t.mean_rel_diff_se)
            } else {
                String::new()
            };
            s.push_str(&format!(
                "{:<12}{:>16.5}{:>17.5}{:>9}{:>21}\n",
                t.technique.name(),
                t.rmse_equal_spp,
                at_budget,
                fmt_ratio(ratio(at_budget, mis)),
                format!("{:+.2} % {se}", 100.0 * t.mean_rel_diff_signed).trim_end(),
            ));
        }
        s.push_str(&format!(
            "full tables: {}; images: {}/*.png, *.exr\n",
            self.table_path().display(),
            self.dir.display()
        ));
        s
    }

    /// The Markdown table.
    pub fn table(&self) -> String {
        let rmse_of = |t: Technique| {
            self.techniques
                .iter()
                .find(|r| r.technique == t)
                .map_or((f64::NAN, f64::NAN), |r| {
                    (r.rmse_equal_spp, r.rmse_equal_time_at(self.time_budget))
                })
        };
        let (split, mis) = (rmse_of(Technique::TlSplit), rmse_of(Technique::TlMis));
        let budget = if self.time_given {
            format!("{:.3} s per technique (--time)", self.time_budget)
        } else {
            format!(
                "what full took at {} spp, {:.3} s",
                self.spp, self.time_budget
            )
        };
        let mut s = format!(
            "{} ({} lights, {}x{}, {} spp, {} protocol; reference: full at {} spp)\n\
             equal time: {budget}; times are busy time summed over threads; the equal-time ratios \
             are of the RMSEs scaled to the budget, RMSE × √(t / budget)\n\n",
            self.scene,
            self.lights,
            self.resolution.0,
            self.resolution.1,
            self.spp,
            self.protocol.name(),
            self.ref_spp
        );
        s.push_str("| technique | RMSE equal spp | ×tl-split | ×tl-mis | RMSE equal time | at budget | ×tl-split | ×tl-mis | spp at equal time | s at equal time | ms/spp | mean rel. diff | ± (1 se) | at spp |\n");
        s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
        for t in &self.techniques {
            let at_budget = t.rmse_equal_time_at(self.time_budget);
            s.push_str(&format!(
                "| {} | {:.5} | {:.3} | {:.3} | {:.5} | {:.5} | {:.3} | {:.3} | {} | {:.3} | {:.2} | {:+.2} % | {:.2} % | {} |\n",
                t.technique.name(),
                t.rmse_equal_spp,
                t.rmse_equal_spp / split.0,
                t.rmse_equal_spp / mis.0,
                t.rmse_equal_time,
                at_budget,
                at_budget / split.1,
                at_budget / mis.1,
                t.spp_equal_time,
                t.seconds_equal_time,
                t.ms_per_spp,
                100.0 * t.mean_rel_diff_signed,
                100.0 * t.mean_rel_diff_se,
                t.mean_rel_diff_spp,
            ));
        }
        s.push_str(&self.corrected_table());
        for (k, c) in self.classes.iter().enumerate() {
            if c.what == "material_angle" {
                s.push_str(&self.joint_table(k, JOINT_ROWS));
                continue;
            }
            for equal_time in [false, true] {
                s.push_str(&self.split_table(k, equal_time));
            }
        }
        s
    }

    /// The `rows` classes of split `k` with the largest parts of the default technique's
    /// MSE at equal time: for tl-mis, bl and the default, at equal spp and equal time, the
    /// class's share of the technique's MSE − V and its RMSE' over tl-mis's in the class.
    fn joint_table(&self, k: usize, rows: usize) -> String {
        let c = &self.classes[k];
        let n = self.resolution.0 * self.resolution.1;
        let mut shown = vec![Technique::TlMis, Technique::Bl];
        if !shown.contains(&Technique::DEFAULT) {
            shown.push(Technique::DEFAULT);
        }
        let mis = self.tl_mis();
        let default = self.of(Technique::DEFAULT);
        let mut order: Vec<usize> = (0..c.names.len()).collect();
        let part = |i: usize| default.errors_equal_time.splits[k][i].mse_part_corrected(n);
        order.sort_by(|&a, &b| part(b).total_cmp(&part(a)));
        let mut s = format!(
            "\nthe {rows} classes of material and view angle with the largest parts of {}'s MSE − V at equal time: \
             per technique, the class's share of its MSE − V and its RMSE' over tl-mis's in the class\n\n",
            Technique::DEFAULT.name()
        );
        s.push_str("| class | pixels |");
        for t in &shown {
            s.push_str(&format!(
                " {0} share, equal spp | {0} ×tl-mis | {0} share, equal time | {0} ×tl-mis |",
                t.name()
            ));
        }
        s.push_str("\n|---|---:|");
        s.push_str(&"---:|".repeat(4 * shown.len()));
        s.push('\n');
        let pixels = c.pixels();
        for &i in order.iter().take(rows) {
            s.push_str(&format!("| {} | {} |", c.names[i].0, pixels[i]));
            for &t in &shown {
                let r = self.of(t);
                for (e, m, scale) in [
                    (&r.errors_equal_spp, &mis.errors_equal_spp, 1.0),
                    (
                        &r.errors_equal_time,
                        &mis.errors_equal_time,
                        self.scale_over_mis(r),
                    ),
                ] {
                    let x = e.splits[k][i];
                    s.push_str(&format!(
                        " {:.1} % | {} |",
                        100.0 * ratio(x.mse_part_corrected(n), e.mse - e.ref_variance),
                        fmt_ratio(
                            scale * ratio(x.rmse_corrected(), m.splits[k][i].rmse_corrected())
                        )
                    ));
                }
            }
            s.push('\n');
        }
        s
    }

    /// The table of RMSEs with the reference's variance removed and their ratios to tl-mis's.
    fn corrected_table(&self) -> String {
        let mis = self.tl_mis();
        let v = self.reference_variance;
        let mut s = format!(
            "\nreference variance removed: RMSE' = sqrt(max(0, MSE − V)), V = {v:.3e} the mean \
             over the pixels of the variance of the reference's pixel means (RMSE floor √V = {:.5})\n\n",
            v.sqrt()
        );
        s.push_str("MSE ±: the standard error of the MSE, relative (from the spread of the per-pixel squared errors)\n\n");
        s.push_str("| technique | RMSE equal spp | MSE ± | RMSE' | ×tl-mis | RMSE' ×tl-mis | RMSE equal time | MSE ± | RMSE' | ×tl-mis | RMSE' ×tl-mis |\n");
        s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
        let rel = |e: &ErrorSummary| 100.0 * ratio(e.mse_se, e.mse);
        for t in &self.techniques {
            s.push_str(&format!(
                "| {} | {:.5} | {:.1} % | {:.5} | {} | {} | {:.5} | {:.1} % | {:.5} | {} | {} |\n",
                t.technique.name(),
                t.rmse_equal_spp,
                rel(&t.errors_equal_spp),
                t.rmse_equal_spp_corrected(),
                fmt_ratio(ratio(t.rmse_equal_spp, mis.rmse_equal_spp)),
                fmt_ratio(ratio(
                    t.rmse_equal_spp_corrected(),
                    mis.rmse_equal_spp_corrected()
                )),
                t.rmse_equal_time,
                rel(&t.errors_equal_time),
                t.rmse_equal_time_corrected(),
                fmt_ratio(ratio(
                    t.rmse_equal_time_at(self.time_budget),
                    mis.rmse_equal_time_at(self.time_budget)
                )),
                fmt_ratio(ratio(
                    t.rmse_equal_time_corrected_at(self.time_budget),
                    mis.rmse_equal_time_corrected_at(self.time_budget)
                )),
            ));
        }
        s
    }

    /// The table of split `k` at equal spp or equal time: per class its pixels, the
    /// reference's average there, and per technique its class RMSE over tl-mis's in the same
    /// class and (in parentheses) the class's share of the technique's MSE, both with the
    /// reference's variance removed.
    fn split_table(&self, k: usize, equal_time: bool) -> String {
        let c = &self.classes[k];
        let n = self.resolution.0 * self.resolution.1;
        fn errors(t: &TechReport, equal_time: bool) -> &ErrorSummary {
            if equal_time {
                &t.errors_equal_time
            } else {
                &t.errors_equal_spp
            }
        }
        let mis = errors(self.tl_mis(), equal_time);
        let mut s = format!(
            "\nerror by {} at {} (each pixel classed by its centre's primary hit): per technique, \
             the class's RMSE' over tl-mis's in the class (the class's share of the technique's MSE − V)\n\n",
            if c.what == "angle" { "view angle" } else { c.what },
            if equal_time { "equal time" } else { "equal spp" }
        );
        s.push_str("| class | pixels | reference mean |");
        for t in &self.techniques {
            s.push_str(&format!(" {} |", t.technique.name()));
        }
        s.push_str("\n|---|---:|---:|");
        s.push_str(&"---:|".repeat(self.techniques.len()));
        s.push('\n');
        let pixels = c.pixels();
        for (i, (name, _)) in c.names.iter().enumerate() {
            s.push_str(&format!(
                "| {name} | {:.1} % | {:.4} |",
                100.0 * pixels[i] as f64 / n as f64,
                self.class_reference_means[k][i]
            ));
            for t in &self.techniques {
                let e = errors(t, equal_time);
                let x = e.splits[k][i];
                let total = e.mse - e.ref_variance;
                let scale = if equal_time {
                    self.scale_over_mis(t)
                } else {
                    1.0
                };
                s.push_str(&format!(
                    " {} ({:.0} %) |",
                    fmt_ratio(scale * ratio(x.rmse_corrected(), mis.splits[k][i].rmse_corrected())),
                    100.0 * ratio(x.mse_part_corrected(n), total)
                ));
            }
            s.push('\n');
        }
        s
    }
}

/// Rejects a configuration `run`, `reference` or `check_reference` cannot use.
fn validate(cfg: &CompareConfig) -> std::io::Result<()> {
    let bad = |m: String| Error::new(ErrorKind::InvalidInput, m);
    if cfg.width == 0 || cfg.height == 0 {
        return Err(bad(format!("empty image {}x{}", cfg.width, cfg.height)));
    }
    if cfg.spp == 0 || cfg.ref_spp == 0 {
        return Err(bad("spp and ref_spp must be at least 1".into()));
    }
    if let Some(t) = cfg.time {
        check_time(t).map_err(bad)?;
    }
    let chosen = cfg.chosen();
    let mut needed = vec![Technique::TlMis, Technique::Bl, Technique::DEFAULT];
    if cfg.time.is_none() {
        needed.push(Technique::Full);
    }
    for t in needed {
        if !chosen.contains(&t) {
            return Err(bad(format!(
                "the techniques must include {} (tl-mis, bl and the default always, full \
                 unless --time gives the budget)",
                t.name()
            )));
        }
    }
    Ok(())
}

/// Creates `dir` and checks that a file can be written in it, so that a bad output folder
/// fails before the renders rather than after.
fn ensure_writable(dir: &Path) -> std::io::Result<()> {
    let ctx = |e: Error| {
        Error::new(
            e.kind(),
            format!("cannot write in folder {}: {e}", dir.display()),
        )
    };
    std::fs::create_dir_all(dir).map_err(ctx)?;
    let probe = dir.join(format!(".mlrender-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"").map_err(ctx)?;
    std::fs::remove_file(&probe).map_err(ctx)
}

/// Where [`reference()`] caches the reference of `scene` under `cfg`.
pub fn reference_path(scene: &RenderScene, cfg: &CompareConfig) -> PathBuf {
    cfg.out.join("reference").join(format!(
        "{}-{}-{:016x}-{}x{}-{}-{}-{}.bin",
        scene.name,
        scene.lights.len(),
        scene.fingerprint(),
        cfg.width,
        cfg.height,
        cfg.ref_spp,
        cfg.seed,
        cfg.protocol.name()
    ))
}

/// The folder [`run`] writes its images and table to.
pub fn output_dir(scene: &RenderScene, cfg: &CompareConfig) -> PathBuf {
    cfg.out
        .join("compare")
        .join(format!("{}-{}", scene.name, scene.lights.len()))
}

/// A long render's progress bar on stderr, with the time left: `rows` rows, drawn only when
/// `shown` and stderr is a terminal (indicatif hides it otherwise), so that logs stay clean.
fn long_bar(label: &str, rows: usize, shown: bool) -> ProgressBar {
    if !shown {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(rows as u64);
    b.set_style(
        ProgressStyle::with_template(
            "{msg} [{bar:30}] {pos}/{len} rows, {elapsed} elapsed, {eta} left",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    b.set_message(label.to_string());
    b
}

/// Renders `rc` with [`long_bar`] in place of the render's own bar.
fn render_long(scene: &RenderScene, rc: &RenderConfig, label: &str) -> Image {
    let bar = long_bar(label, rc.height, rc.progress);
    let img = render_with(
        scene,
        &RenderConfig {
            progress: false,
            ..*rc
        },
        Some(&|| bar.inc(1)),
    );
    bar.finish_and_clear();
    img
}

/// The cached reference of `scene` (computed and stored if missing), with a progress bar
/// and the time left when `cfg.progress` and stderr is a terminal.
pub fn reference(scene: &RenderScene, cfg: &CompareConfig) -> std::io::Result<Image> {
    validate(cfg)?;
    let path = reference_path(scene, cfg);
    if let Some(img) = read_raw(&path) {
        if img.width == cfg.width && img.height == cfg.height && img.spp == cfg.ref_spp {
            eprintln!("reference: {} (cached)", path.display());
            return Ok(img);
        }
    }
    if let Some(dir) = path.parent() {
        ensure_writable(dir)?;
    }
    eprintln!(
        "reference: full at {} spp -> {}",
        cfg.ref_spp,
        path.display()
    );
    let img = render_long(
        scene,
        &RenderConfig {
            width: cfg.width,
            height: cfg.height,
            spp: cfg.ref_spp,
            technique: Technique::Full,
            seed: cfg.seed ^ 0x7e7e_7e7e_0000,
            progress: cfg.progress,
            protocol: cfg.protocol,
            params: Params::default(),
            learn: None,
        },
        "reference",
    );
    warn_failed("the reference", img.failed);
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
    let other = render_long(
        scene,
        &RenderConfig {
            width: cfg.width,
            height: cfg.height,
            spp: (cfg.ref_spp / 4).max(1),
            technique: Technique::TlSplit,
            seed: cfg.seed ^ 0x0123_4567,
            progress: cfg.progress,
            protocol: cfg.protocol,
            params: cfg.params,
            learn: None,
        },
        "tl-split check",
    );
    let a = reference.average();
    let rel = (other.average() - a).abs() / a;
    let se = (other.average_se().powi(2) + reference.average_se().powi(2)).sqrt() / a;
    let rmse = other.rmse(&reference);
    Ok((reference, rel, se, rmse))
}

/// The image average of a technique's render with the most spp so far.
#[derive(Clone, Copy, Debug)]
struct Highest {
    spp: usize,
    average: f64,
    se: f64,
}

impl Highest {
    fn of(img: &Image) -> Highest {
        Highest {
            spp: img.spp,
            average: img.average(),
            se: if img.spp >= 2 {
                img.average_se()
            } else {
                f64::NAN
            },
        }
    }

    /// Keeps `img` if it has more spp.
    fn update(&mut self, img: &Image) {
        if img.spp > self.spp {
            *self = Highest::of(img);
        }
    }
}

/// The caption of a technique's panel in the side-by-side images: its name and its RMSE
/// against the reference, with 4 decimals (`full 0.1003`), or 2 significant digits in
/// scientific notation below 0.001 (`full 4.2e-5`) so that small errors keep their digits.
fn caption(name: &str, rmse: f64) -> String {
    if rmse.is_finite() && rmse > 0.0 && rmse < 1e-3 {
        format!("{name} {rmse:.1e}")
    } else {
        format!("{name} {rmse:.4}")
    }
}

/// Writes `img` as `<dir>/<stem>.png` and `<dir>/<stem>.exr`.
fn write_both(dir: &Path, stem: &str, img: &Image) -> std::io::Result<()> {
    write_png(
        &dir.join(format!("{stem}.png")),
        img.width,
        img.height,
        &img.mean,
    )?;
    write_exr(
        &dir.join(format!("{stem}.exr")),
        img.width,
        img.height,
        &img.mean,
    )
}

/// The name of the full tables' file in the output folder.
pub const TABLE_FILE: &str = "table.md";

/// The number of classes of material and view angle in the table of the largest parts.
pub const JOINT_ROWS: usize = 10;

/// The absolute error shown as white in the error maps' PNG files, in units of tl-mis's RMSE
/// at equal spp.
pub const ERROR_MAP_SCALE: f64 = 4.0;

/// Writes an error map: `<dir>/<stem>.png` (the grey levels of `map`) and `<dir>/<stem>.exr`
/// (the per-pixel `squared` errors, linear).
fn write_error_map(dir: &Path, stem: &str, map: &Image, squared: &[f64]) -> std::io::Result<()> {
    write_png(
        &dir.join(format!("{stem}.png")),
        map.width,
        map.height,
        &map.mean,
    )?;
    let sq: Vec<[f32; 3]> = squared
        .iter()
        .map(|&e| crate::image::grey(e as f32))
        .collect();
    write_exr(&dir.join(format!("{stem}.exr")), map.width, map.height, &sq)
}

/// Runs the comparison and writes its images and table (see the module documentation).
/// Errors: an invalid configuration (`InvalidInput`) or an output folder or file that cannot
/// be written (checked before the renders; the message names the path).
pub fn run(scene: &RenderScene, cfg: &CompareConfig) -> std::io::Result<Report> {
    validate(cfg)?;
    let dir = output_dir(scene, cfg);
    ensure_writable(&dir)?;
    let reference = reference(scene, cfg)?;
    let ref_avg = reference.average();
    let ref_se = reference.average_se();
    let rc = |technique, spp, seed| RenderConfig {
        width: cfg.width,
        height: cfg.height,
        spp,
        technique,
        seed,
        progress: cfg.progress,
        protocol: cfg.protocol,
        params: cfg.params,
        learn: cfg.learn,
    };
    // Equal spp, and the cost model of each technique.
    let chosen = cfg.chosen();
    let mut images = Vec::new();
    let mut costs = Vec::new();
    for &t in &chosen {
        let fixed = render(scene, &rc(t, 0, cfg.seed)).seconds;
        let img = render(scene, &rc(t, cfg.spp, cfg.seed));
        costs.push(Cost::from_times(fixed, img.seconds, cfg.spp));
        write_both(&dir, t.name(), &img)?;
        images.push(img);
    }
    let budget = cfg
        .time
        .unwrap_or_else(|| images[index_of(&chosen, Technique::Full)].seconds);
    eprintln!(
        "equal time: {budget:.3} busy s per technique ({})",
        if cfg.time.is_some() {
            "--time".to_string()
        } else {
            format!("full at {} spp", cfg.spp)
        }
    );
    // Equal time.
    let mut highest: Vec<Highest> = images.iter().map(Highest::of).collect();
    let mut eq_images = Vec::new();
    for (i, &t) in chosen.iter().enumerate() {
        let spp_t = equal_time_spp(budget, costs[i]);
        let eq = render(scene, &rc(t, spp_t, cfg.seed.wrapping_add(0x5eed)));
        write_both(&dir, &format!("{}-equal-time", t.name()), &eq)?;
        highest[i].update(&eq);
        eq_images.push(eq);
    }
    write_both(&dir, "reference", &reference)?;

    // Errors: the per-pixel squared errors and the reference's variances, split by the
    // classes of the pixels' centre hits; error maps on one scale for every technique.
    let hits = centre_hits(scene, cfg.width, cfg.height);
    let classes = vec![
        Classes::by_material(scene, &hits),
        Classes::by_angle(&hits),
        Classes::by_material_and_angle(scene, &hits),
    ];
    let ref_var = reference.mean_variances();
    let class_reference_means: Vec<Vec<f64>> = classes
        .iter()
        .map(|c| {
            let mut sums = vec![0f64; c.names.len()];
            for (&k, &v) in c.of_pixel.iter().zip(&reference.mean) {
                sums[k] += crate::image::channel_mean(v);
            }
            sums.iter()
                .zip(c.pixels())
                .map(|(&s, n)| s / n as f64)
                .collect()
        })
        .collect();
    let squared: Vec<Vec<f64>> = images
        .iter()
        .map(|i| i.squared_errors(&reference))
        .collect();
    let eq_squared: Vec<Vec<f64>> = eq_images
        .iter()
        .map(|i| i.squared_errors(&reference))
        .collect();
    let summaries: Vec<ErrorSummary> = squared
        .iter()
        .map(|sq| ErrorSummary::new(sq, &ref_var, &classes))
        .collect();
    let eq_summaries: Vec<ErrorSummary> = eq_squared
        .iter()
        .map(|sq| ErrorSummary::new(sq, &ref_var, &classes))
        .collect();
    let mis_rmse = summaries[index_of(&chosen, Technique::TlMis)].rmse();
    let error_map_scale = if mis_rmse.is_finite() && mis_rmse > 0.0 {
        ERROR_MAP_SCALE * mis_rmse
    } else {
        1.0
    };
    let ref_error = map_image(&reference, error_map(&ref_var, error_map_scale));
    write_error_map(&dir, "reference-error", &ref_error, &ref_var)?;
    for (stem, sqs, suffix) in [
        ("side_by_side_error.png", &squared, ""),
        (
            "side_by_side_equal_time_error.png",
            &eq_squared,
            "-equal-time",
        ),
    ] {
        let maps: Vec<Image> = sqs
            .iter()
            .map(|sq| map_image(&reference, error_map(sq, error_map_scale)))
            .collect();
        for ((t, map), sq) in chosen.iter().zip(&maps).zip(sqs.iter()) {
            write_error_map(&dir, &format!("{}{suffix}-error", t.name()), map, sq)?;
        }
        let captions: Vec<String> = chosen
            .iter()
            .zip(sqs.iter())
            .map(|(t, sq)| caption(t.name(), (sq.iter().sum::<f64>() / sq.len() as f64).sqrt()))
            .collect();
        let mut panels: Vec<(&str, &Image)> = captions
            .iter()
            .map(String::as_str)
            .zip(maps.iter())
            .collect();
        panels.push(("reference", &ref_error));
        let (w, h, sbs) = side_by_side_labelled(&panels, 4);
        write_png(&dir.join(stem), w, h, &sbs)?;
    }

    for (name, imgs) in [
        ("side_by_side.png", &images),
        ("side_by_side_equal_time.png", &eq_images),
    ] {
        let captions: Vec<String> = chosen
            .iter()
            .zip(imgs.iter())
            .map(|(t, img)| caption(t.name(), img.rmse(&reference)))
            .collect();
        let mut panels: Vec<(&str, &Image)> = captions
            .iter()
            .map(String::as_str)
            .zip(imgs.iter())
            .collect();
        panels.push(("reference", &reference));
        let (w, h, sbs) = side_by_side_labelled(&panels, 4);
        write_png(&dir.join(name), w, h, &sbs)?;
    }
    if cfg.plot {
        let mut series = Vec::new();
        for (i, &t) in chosen.iter().enumerate() {
            let mut points = Vec::new();
            let mut spp = 1;
            while spp <= 4 * cfg.spp {
                let img = render(scene, &rc(t, spp, cfg.seed.wrapping_add(0xc0 + spp as u64)));
                points.push((img.seconds, img.rmse(&reference)));
                highest[i].update(&img);
                spp *= 2;
            }
            series.push((t.name(), points));
        }
        let title = format!(
            "{} ({} lights, {}x{}): RMSE against busy time",
            scene.name,
            scene.lights.len(),
            cfg.width,
            cfg.height
        );
        let path = dir.join("convergence.svg");
        std::fs::write(&path, convergence_svg(&title, &series))
            .map_err(|e| Error::new(e.kind(), format!("{}: {e}", path.display())))?;
    }
    let techniques = chosen
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            let hi = highest[i];
            TechReport {
                technique: t,
                rmse_equal_spp: images[i].rmse(&reference),
                rmse_equal_time: eq_images[i].rmse(&reference),
                spp_equal_time: eq_images[i].spp,
                seconds_equal_time: eq_images[i].seconds,
                seconds_equal_spp: images[i].seconds,
                cost: costs[i],
                ms_per_spp: costs[i].per_spp * 1e3,
                mean_rel_diff_signed: (hi.average - ref_avg) / ref_avg,
                mean_rel_diff_spp: hi.spp,
                mean_rel_diff_se: (hi.se.powi(2) + ref_se.powi(2)).sqrt() / ref_avg,
                errors_equal_spp: summaries[i].clone(),
                errors_equal_time: eq_summaries[i].clone(),
                failed_estimates: images[i].failed + eq_images[i].failed,
            }
        })
        .collect::<Vec<TechReport>>();
    for t in &techniques {
        warn_failed(t.technique.name(), t.failed_estimates);
    }
    let report = Report {
        scene: scene.name.clone(),
        lights: scene.lights.len(),
        resolution: (cfg.width, cfg.height),
        spp: cfg.spp,
        ref_spp: cfg.ref_spp,
        time_budget: budget,
        time_given: cfg.time.is_some(),
        dir: dir.clone(),
        techniques,
        protocol: cfg.protocol,
        reference_variance: summaries.first().map_or(f64::NAN, |e| e.ref_variance),
        classes,
        class_reference_means,
        error_map_scale,
    };
    let path = report.table_path();
    std::fs::write(&path, report.table())
        .map_err(|e| Error::new(e.kind(), format!("{}: {e}", path.display())))?;
    Ok(report)
}
