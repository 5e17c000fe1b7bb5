//! Where an image's error against a reference comes from, and how much of it is the
//! reference's own: the figures `compare` reports beside each RMSE.
//!
//! - **Reference variance removed** (docs/formulas.md, section 15): the reference `R` is
//!   itself an estimate, independent of the image `X`, so a pixel's expected squared
//!   difference is `E[(X − R)²] = E[(X − μ)²] + Var(R)` (μ the pixel's exact value).
//!   [`corrected_rmse`] subtracts the mean over the pixels of the reference's estimated
//!   variance of its pixel means ([`Image::mean_variances`]) from the MSE:
//!   `sqrt(max(0, MSE − V))`.
//! - **Splits** ([`Classes`], [`split`]): the pixels are partitioned into classes (by the
//!   material or the view angle of the primary hit at the pixel's centre,
//!   [`crate::render::centre_hits`]); a class's part of the image's MSE is its pixels' sum of
//!   squared errors over the image's pixel count, so the parts add up to the MSE, and with
//!   each class's share of `V` removed they add up to `MSE − V`.
//!
//! Every figure is computed from the per-pixel squared errors ([`Image::squared_errors`]) and
//! reference variances ([`Image::mean_variances`]) alone, one scalar per pixel each.

use crate::image::Image;
use crate::scene::RenderScene;
use manylights::ShadingPoint;

/// The RMSE with the reference's variance removed: `sqrt(max(0, mse − ref_var))`, `mse` the
/// mean squared difference to the reference and `ref_var` the mean over the same pixels of
/// the variance of the reference's pixel means. NaN if either is NaN.
pub fn corrected_rmse(mse: f64, ref_var: f64) -> f64 {
    let d = mse - ref_var;
    if d.is_nan() {
        f64::NAN
    } else {
        d.max(0.0).sqrt()
    }
}

/// A partition of an image's pixels into named classes.
#[derive(Clone, Debug, PartialEq)]
pub struct Classes {
    /// What the classes are of (`material`, `angle`, `material_angle`).
    pub what: &'static str,
    /// Per class: its name and, for a material class, its kind (`lambert`, `ggx`, `plastic`;
    /// `none` for pixels without a primary hit).
    pub names: Vec<(String, &'static str)>,
    /// The class of each pixel, row-major (an index into `names`).
    pub of_pixel: Vec<usize>,
}

/// The number of view-angle classes of [`Classes::by_angle`]: bins of cos θo of width
/// `1 / ANGLE_BINS`.
pub const ANGLE_BINS: usize = 10;

/// The name of pixels without a primary hit (background, or a centre ray grazing its
/// surface).
pub const NO_HIT: &str = "no hit";

/// The view-angle bin of `cos θo`: `floor(cos θo · ANGLE_BINS)`, clamped to the bins.
pub fn angle_bin(cos_theta_o: f32) -> usize {
    ((cos_theta_o.clamp(0.0, 1.0) * ANGLE_BINS as f32) as usize).min(ANGLE_BINS - 1)
}

/// The name of view-angle bin `b`: its cos θo range and the matching θo range in degrees
/// (`cos 0.0-0.1 (84-90°)`).
pub fn angle_name(b: usize) -> String {
    let (lo, hi) = (
        b as f64 / ANGLE_BINS as f64,
        (b + 1) as f64 / ANGLE_BINS as f64,
    );
    format!(
        "cos {lo:.1}-{hi:.1} ({:.0}-{:.0}°)",
        hi.acos().to_degrees(),
        lo.acos().to_degrees()
    )
}

/// `cos θo` of a primary hit: the view direction against the normal (which faces it).
fn cos_theta_o(sp: &ShadingPoint) -> f32 {
    sp.normal.normalize().dot(sp.wo.normalize())
}

impl Classes {
    /// Classes from a label per pixel, in decreasing order of pixel count (ties in order of
    /// first appearance), [`NO_HIT`] last; classes without pixels do not appear.
    fn from_labels(what: &'static str, labels: Vec<(String, &'static str)>) -> Classes {
        let mut names: Vec<(String, &'static str)> = Vec::new();
        let mut counts: Vec<usize> = Vec::new();
        let mut raw = Vec::with_capacity(labels.len());
        for label in labels {
            let i = match names.iter().position(|n| *n == label) {
                Some(i) => i,
                None => {
                    names.push(label);
                    counts.push(0);
                    names.len() - 1
                }
            };
            counts[i] += 1;
            raw.push(i);
        }
        let mut order: Vec<usize> = (0..names.len()).collect();
        order.sort_by_key(|&i| (names[i].1 == "none", std::cmp::Reverse(counts[i]), i));
        let mut rank = vec![0; names.len()];
        for (r, &i) in order.iter().enumerate() {
            rank[i] = r;
        }
        Classes {
            what,
            names: order.iter().map(|&i| names[i].clone()).collect(),
            of_pixel: raw.iter().map(|&i| rank[i]).collect(),
        }
    }

    /// The pixels by the material class ([`RenderScene::material_class`]) of their centre's
    /// primary hit (`hits` from [`crate::render::centre_hits`]).
    pub fn by_material(scene: &RenderScene, hits: &[Option<ShadingPoint>]) -> Classes {
        let labels = hits
            .iter()
            .map(|h| match h {
                Some(sp) => {
                    let c = scene.material_class(&sp.material);
                    (c.name, c.kind)
                }
                None => (NO_HIT.to_string(), "none"),
            })
            .collect();
        Classes::from_labels("material", labels)
    }

    /// The pixels by the cos θo bin ([`angle_bin`]) of their centre's primary hit, grazing
    /// views first.
    pub fn by_angle(hits: &[Option<ShadingPoint>]) -> Classes {
        let mut c = Classes::from_labels(
            "angle",
            hits.iter()
                .map(|h| match h {
                    Some(sp) => (angle_name(angle_bin(cos_theta_o(sp))), ""),
                    None => (NO_HIT.to_string(), "none"),
                })
                .collect(),
        );
        // Bins in order of the angle rather than of their pixel counts (the names sort so).
        let mut order: Vec<usize> = (0..c.names.len()).collect();
        order.sort_by(|&a, &b| {
            let (na, nb) = (&c.names[a], &c.names[b]);
            (na.1 == "none", &na.0).cmp(&(nb.1 == "none", &nb.0))
        });
        let mut rank = vec![0; order.len()];
        for (r, &i) in order.iter().enumerate() {
            rank[i] = r;
        }
        c.names = order.iter().map(|&i| c.names[i].clone()).collect();
        for p in &mut c.of_pixel {
            *p = rank[*p];
        }
        c
    }

    /// The pixels by material class and view-angle bin together (`wet street (…) · cos
    /// 0.0-0.1 (84-90°)`), in decreasing order of pixel count.
    pub fn by_material_and_angle(scene: &RenderScene, hits: &[Option<ShadingPoint>]) -> Classes {
        let labels = hits
            .iter()
            .map(|h| match h {
                Some(sp) => {
                    let c = scene.material_class(&sp.material);
                    let a = angle_name(angle_bin(cos_theta_o(sp)));
                    (format!("{} · {a}", c.name), c.kind)
                }
                None => (NO_HIT.to_string(), "none"),
            })
            .collect();
        Classes::from_labels("material_angle", labels)
    }

    /// The number of pixels of each class.
    pub fn pixels(&self) -> Vec<usize> {
        let mut n = vec![0; self.names.len()];
        for &c in &self.of_pixel {
            n[c] += 1;
        }
        n
    }
}

/// One class's sums over its pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ClassError {
    /// Its pixels.
    pub pixels: usize,
    /// The sum of their squared errors.
    pub squared_error: f64,
    /// The sum of the squares of their squared errors (for [`ClassError::mse_part_se`]).
    pub squared_error_sq: f64,
    /// The sum of their reference variances (of the reference's pixel means).
    pub ref_variance: f64,
}

impl ClassError {
    /// The class's part of the MSE of an image of `total` pixels.
    pub fn mse_part(&self, total: usize) -> f64 {
        self.squared_error / total as f64
    }

    /// The standard error of [`ClassError::mse_part`] from the spread of the class's squared
    /// errors: `sqrt(n · s²) / total`, `s²` their sample variance over the class's `n`
    /// pixels (the pixels' errors are independent; their spread also holds that of their
    /// expectations, so this errs on the large side). NaN below 2 pixels.
    pub fn mse_part_se(&self, total: usize) -> f64 {
        let n = self.pixels as f64;
        if self.pixels < 2 {
            return f64::NAN;
        }
        let mean = self.squared_error / n;
        let s2 = ((self.squared_error_sq - n * mean * mean) / (n - 1.0)).max(0.0);
        (n * s2).sqrt() / total as f64
    }

    /// The class's part of the MSE with its reference variance removed (may be negative: the
    /// parts add up to `MSE − V`).
    pub fn mse_part_corrected(&self, total: usize) -> f64 {
        (self.squared_error - self.ref_variance) / total as f64
    }

    /// The RMSE over the class's own pixels (NaN without pixels).
    pub fn rmse(&self) -> f64 {
        (self.squared_error / self.pixels as f64).sqrt()
    }

    /// [`ClassError::rmse`] with the reference variance removed ([`corrected_rmse`]).
    pub fn rmse_corrected(&self) -> f64 {
        let n = self.pixels as f64;
        corrected_rmse(self.squared_error / n, self.ref_variance / n)
    }
}

/// The per-class sums of the per-pixel squared errors `squared` and reference variances
/// `ref_variance` (both row-major, one per pixel of `classes`).
pub fn split(squared: &[f64], ref_variance: &[f64], classes: &Classes) -> Vec<ClassError> {
    let mut out = vec![ClassError::default(); classes.names.len()];
    for ((&c, &e), &v) in classes.of_pixel.iter().zip(squared).zip(ref_variance) {
        out[c].pixels += 1;
        out[c].squared_error += e;
        out[c].squared_error_sq += e * e;
        out[c].ref_variance += v;
    }
    out
}

/// An image's error against the reference: totals and every split.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorSummary {
    /// Mean squared difference to the reference.
    pub mse: f64,
    /// Mean over the pixels of the variance of the reference's pixel means.
    pub ref_variance: f64,
    /// The standard error of `mse` from the spread of the per-pixel squared errors (see
    /// [`ClassError::mse_part_se`]).
    pub mse_se: f64,
    /// Per split (in the order of the `Classes` given), per class.
    pub splits: Vec<Vec<ClassError>>,
}

impl ErrorSummary {
    /// The summary of the per-pixel `squared` errors with the reference's per-pixel
    /// `ref_variance`, split by each of `classes`.
    pub fn new(squared: &[f64], ref_variance: &[f64], classes: &[Classes]) -> ErrorSummary {
        let n = squared.len() as f64;
        let whole = split(
            squared,
            ref_variance,
            &Classes {
                what: "all",
                names: vec![("all".into(), "")],
                of_pixel: vec![0; squared.len()],
            },
        );
        ErrorSummary {
            mse: squared.iter().sum::<f64>() / n,
            mse_se: whole[0].mse_part_se(squared.len()),
            ref_variance: ref_variance.iter().sum::<f64>() / n,
            splits: classes
                .iter()
                .map(|c| split(squared, ref_variance, c))
                .collect(),
        }
    }

    /// The root of [`ErrorSummary::mse`].
    pub fn rmse(&self) -> f64 {
        self.mse.sqrt()
    }

    /// The RMSE with the reference variance removed ([`corrected_rmse`]).
    pub fn rmse_corrected(&self) -> f64 {
        corrected_rmse(self.mse, self.ref_variance)
    }
}

/// The grey-level error map of the per-pixel `squared` errors: `sqrt(squared) / scale` (the
/// absolute error in units of `scale`; a PNG clamps it to [0, 1]).
pub fn error_map(squared: &[f64], scale: f64) -> Vec<f32> {
    squared.iter().map(|&e| (e.sqrt() / scale) as f32).collect()
}

/// `values` as an [`Image`] of the size of `like` (for the side-by-side panels).
pub fn map_image(like: &Image, values: Vec<f32>) -> Image {
    Image {
        width: like.width,
        height: like.height,
        var: vec![[0.0; 3]; values.len()],
        mean: values.into_iter().map(crate::image::grey).collect(),
        spp: 1,
        seconds: 0.0,
        wall_seconds: 0.0,
        failed: 0,
    }
}
