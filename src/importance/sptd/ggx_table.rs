//! The fitted SPTD parameters of GGX ([`table`]) as the importance reads them: the nodes'
//! (α, θo), the bilinear lookup at any (α, θo), and the table interleaved per node.

use super::table;
use crate::material::MIN_ALPHA;
use crate::math;
#[cfg(any(test, feature = "internals"))]
use core::f32::consts::FRAC_PI_2;
use core::f32::consts::PI;

/// View angles beyond this (radians from the normal, 89°) are clamped to it.
pub const THETA_O_MAX: f32 = 89.0 * PI / 180.0;
/// Number of table nodes along each axis.
pub const TABLE_SIZE: usize = table::SIZE;

/// The SPTD parameters of GGX at one (α, θo).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GgxParams {
    /// Pivot norm `R` in `[0, 1)`.
    pub pivot_norm: f32,
    /// Pivot elevation `Gθ` (radians from the normal; negative leans towards the mirror
    /// direction, away from ωo).
    pub pivot_elevation: f32,
    /// Directional albedo `ρ = ∫_H f cos θi dωi`, which the whole hemisphere reproduces.
    pub albedo: f32,
    /// Share `β` of the Lambert lobe, in `[0, 1]`.
    pub lambert_weight: f32,
    /// `c_ref`: below this mean cosine of a cap's visible part, the masking correction applies.
    pub masking_cos: f32,
}

/// The (α, θo) that table node `(i, j)` was fitted at: `u = i/(SIZE − 1)`, `α = max(u², MIN_ALPHA)`,
/// `θo = min(j/(SIZE − 1) · π/2, THETA_O_MAX)`. Returns `(α, θo)`.
#[must_use]
#[cfg(any(test, feature = "internals"))]
pub fn table_node(i: usize, j: usize) -> (f32, f32) {
    let n = (TABLE_SIZE - 1) as f32;
    let u = (i.min(TABLE_SIZE - 1)) as f32 / n;
    let v = (j.min(TABLE_SIZE - 1)) as f32 / n;
    ((u * u).max(MIN_ALPHA), (v * FRAC_PI_2).min(THETA_O_MAX))
}

/// The table's parameters at (α, |cos θo|), bilinearly interpolated in `(√α, 2θo/π)`.
/// α is clamped to `[MIN_ALPHA, 1]` (NaN to 1), θo to `[0, THETA_O_MAX]`.
#[must_use]
pub fn ggx_params(alpha: f32, cos_theta_o: f32) -> GgxParams {
    let alpha = if alpha.is_nan() {
        1.0
    } else {
        alpha.clamp(MIN_ALPHA, 1.0)
    };
    let c = cos_theta_o.abs();
    let c = if c <= 1.0 { c } else { 1.0 };
    let theta = math::acos(c).min(THETA_O_MAX);
    let n = (TABLE_SIZE - 1) as f32;
    let x = math::sqrt(alpha) * n;
    let y = theta * (2.0 / PI) * n;
    // The cell and the weights, once for the five parameters.
    let i = (x as usize).min(TABLE_SIZE - 2);
    let j = (y as usize).min(TABLE_SIZE - 2);
    let fx = (x - i as f32).clamp(0.0, 1.0);
    let fy = (y - j as f32).clamp(0.0, 1.0);
    let (t00, t01) = (&PARAMS[i][j], &PARAMS[i][j + 1]);
    let (t10, t11) = (&PARAMS[i + 1][j], &PARAMS[i + 1][j + 1]);
    let lerp2 = |k: usize| {
        let a = t00[k] + (t01[k] - t00[k]) * fy;
        let b = t10[k] + (t11[k] - t10[k]) * fy;
        a + (b - a) * fx
    };
    GgxParams {
        pivot_norm: lerp2(0),
        pivot_elevation: lerp2(1),
        albedo: lerp2(2),
        lambert_weight: lerp2(3),
        masking_cos: lerp2(4),
    }
}

/// The table's five parameters interleaved per node, `[R, Gθ, ρ, β, c_ref]`, so that a lookup
/// reads each of its four nodes' parameters from adjacent words: a copy of [`table`] made at
/// compile time.
static PARAMS: [[[f32; 5]; TABLE_SIZE]; TABLE_SIZE] = interleave();

/// [`PARAMS`] from the table.
const fn interleave() -> [[[f32; 5]; TABLE_SIZE]; TABLE_SIZE] {
    let mut out = [[[0.0; 5]; TABLE_SIZE]; TABLE_SIZE];
    let mut i = 0;
    while i < TABLE_SIZE {
        let mut j = 0;
        while j < TABLE_SIZE {
            out[i][j] = [
                table::PIVOT_NORM[i][j],
                table::PIVOT_ELEVATION[i][j],
                table::ALBEDO[i][j],
                table::LAMBERT_WEIGHT[i][j],
                table::MASKING_COS[i][j],
            ];
            j += 1;
        }
        i += 1;
    }
    out
}
