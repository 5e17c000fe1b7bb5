//! Batches for wavefront hosts, which hold many path vertices at once: points on lights for
//! many (light, shading point, uniform numbers) triples, and the estimators' per-point set-up
//! with their one-call estimates for many shading points (the set's environment included,
//! as [`Estimator::estimate`] takes it). Each is bit for bit the single calls made one after
//! the other ([`sample_point`], [`Estimator::new`] and [`Estimator::estimate`]).

use crate::direct::{Estimator, Occluder, Params, Technique, Uniforms};
use crate::error::{DirectError, LengthMismatch};
use crate::light::point::{sample_point, LightPoint};
use crate::light::Light;
use crate::light_set::LightSet;
use crate::material::ShadingPoint;
use core::fmt;
use glam::Vec3;

/// Points on lights for many triples: `out[j] = sample_point(&lights[which[j]], xs[j],
/// us[j])`, `None` where `which[j]` is out of range (and where `sample_point` gives none).
///
/// Errors: [`LengthMismatch`] unless `xs`, `us` and `out` have the length of `which`
/// (nothing is written then).
pub fn sample_points(
    lights: &[Light],
    which: &[u32],
    xs: &[Vec3],
    us: &[[f32; 2]],
    out: &mut [Option<LightPoint>],
) -> Result<(), LengthMismatch> {
    let n = which.len();
    LengthMismatch::check("xs", n, xs.len())?;
    LengthMismatch::check("us", n, us.len())?;
    LengthMismatch::check("out", n, out.len())?;
    for (((o, &l), &x), &u) in out.iter_mut().zip(which).zip(xs).zip(us) {
        *o = lights
            .get(l as usize)
            .and_then(|light| sample_point(light, x, u));
    }
    Ok(())
}

/// Why [`estimate_each`] refused its input.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum BatchError {
    /// `out` does not hold `per_point` estimates for each shading point (or `per_point` is 0).
    Length(LengthMismatch),
    /// The estimator refused shading point `index` (or a uniform number drawn for it).
    Point {
        /// The shading point's index.
        index: usize,
        /// What was wrong.
        error: DirectError,
    },
}

impl fmt::Display for BatchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BatchError::Length(e) => e.fmt(f),
            BatchError::Point { index, error } => write!(f, "points[{index}]: {error}"),
        }
    }
}

impl core::error::Error for BatchError {}

impl From<LengthMismatch> for BatchError {
    fn from(e: LengthMismatch) -> Self {
        BatchError::Length(e)
    }
}

/// `per_point` estimates at each of `points` with `technique` and `params`: for each point in
/// order, [`Estimator::new`] there (the per-point set-up; made once and moved by
/// [`Estimator::reset`], which gives the same estimator) and `per_point` calls of
/// [`Estimator::estimate`] with `occluder` and the uniform numbers of `u` (RGB), written to
/// `out[j · per_point ..][..per_point]` — bit for bit, and drawing exactly the uniform
/// numbers, of those single calls made one after the other. Every shading point is checked
/// before the first estimate.
///
/// Errors: [`BatchError::Length`] unless `out.len() == points.len() · per_point` with
/// `per_point ≥ 1`; [`BatchError::Point`] naming the first invalid shading point (before any
/// estimate or uniform number), or the point whose estimate drew a bad uniform number (`out`
/// then holds the estimates of the points before it).
#[allow(clippy::too_many_arguments)] // the single calls' arguments, and the batch's
pub fn estimate_each<O: Occluder + ?Sized>(
    set: &LightSet,
    points: &[ShadingPoint],
    per_point: usize,
    technique: Technique,
    params: &Params,
    occluder: &O,
    u: &mut (impl Uniforms + ?Sized),
    out: &mut [[f64; 3]],
) -> Result<(), BatchError> {
    let want = points
        .len()
        .checked_mul(per_point)
        .filter(|_| per_point > 0);
    LengthMismatch::check("out", want.unwrap_or(usize::MAX), out.len())?;
    for (index, sp) in points.iter().enumerate() {
        sp.validate().map_err(|e| BatchError::Point {
            index,
            error: DirectError::Shading(e),
        })?;
    }
    // One estimator, moved from point to point ([`Estimator::reset`]: the same set-up as a
    // new one, without its copy).
    let mut est: Option<Estimator<'_>> = None;
    for (index, (sp, o)) in points
        .iter()
        .zip(out.chunks_exact_mut(per_point))
        .enumerate()
    {
        let at = |error| BatchError::Point { index, error };
        let e = Estimator::reuse(&mut est, set, sp, technique, params).map_err(at)?;
        for v in o {
            *v = e.estimate(occluder, u).map_err(at)?;
        }
    }
    Ok(())
}
