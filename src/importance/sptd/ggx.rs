//! The GGX BRDF as an SPTD (docs/formulas.md, section 8, "GGX fit"), with two corrections fitted along
//! with it. The cap integral `∫_{C∩H} f(ωi, ωo) cos θi dωi` (f: isotropic GGX with
//! height-correlated Smith masking-shadowing, no Fresnel term) is approximated by
//!
//! ```text
//! S(C) = ρ [ (1 − β) · |P(C) ∩ P(H)| / |P(H)| · M(c̄)/M(½)  +  β · L(C)/π ]
//! M(c) = min(1, G2(c)/G2(c_ref)),   G2(c) = 1/(1 + Λ(ωo) + Λ(θi = acos c))
//! c̄ = L(C) / |C ∩ H|,   L(C) = ∫_{C∩H} cos θi dωi   (exact: `lambert_visible`)
//! ```
//!
//! - The SPTD: a pivot `rp = R (sin Gθ, 0, cos Gθ)` in the frame where `n = +z` and
//!   `ωo = (sin θo, 0, cos θo)`, horizon-clipped exactly through `P(H)`; its amplitude
//!   `A = 4π ρ (1 − β) / (|P(H)| M(½))` is tied to the albedo.
//! - `β`, a share of a Lambert lobe of the same albedo: GGX's broad tails at large α, which a
//!   single SPTD (whose level sets are circles) cannot follow.
//! - `M`, the masking-shadowing of grazing `ωi`: f cos θi vanishes at the horizon like
//!   `G2 ∝ cos θi` while an SPTD does not, so caps that only graze the horizon would be
//!   overestimated a hundredfold. `M` is evaluated at the mean cosine `c̄` of the cap's visible
//!   part and is 1 above `c_ref`.
//!
//! A cap that does not cross the horizon costs no intersection at all: P is a bijection, so
//! `P(C)` then lies inside or outside `P(H)`, and `L`, `|C ∩ H|` are closed-form; the 4-wide
//! form takes the intersection path only for groups with a crossing cap (per-lane results are
//! the same either way). The whole hemisphere (and a shading point inside a cluster's bounding
//! sphere) gets exactly `ρ`. `R`, `Gθ`, `ρ`, `β` and `c_ref` come from the table `sptd/table.rs`, which
//! `mlrender sptd-fit` fits (see its docs for the objective), indexed by `u = √α` and
//! `v = 2θo/π` and filtered bilinearly.

use super::cap::{intersection_area, intersection_area4, Cap, Cap4};
use super::lambert::{lambert_visible, lambert_visible4};
use super::pivot::{Pivot, Pivot4};
use super::table;
use crate::material::MIN_ALPHA;
use crate::math;
use core::f32::consts::{FRAC_PI_2, PI};
use glam::Vec3;
use wide::f32x4;

/// The mask of all four lanes.
const ALL_LANES: f32x4 = f32x4::new([f32::from_bits(u32::MAX); 4]);

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
pub fn table_node(i: usize, j: usize) -> (f32, f32) {
    let n = (TABLE_SIZE - 1) as f32;
    let u = (i.min(TABLE_SIZE - 1)) as f32 / n;
    let v = (j.min(TABLE_SIZE - 1)) as f32 / n;
    ((u * u).max(MIN_ALPHA), (v * FRAC_PI_2).min(THETA_O_MAX))
}

/// The table's parameters at (α, |cos θo|), bilinearly interpolated in `(√α, 2θo/π)`.
/// α is clamped to `[MIN_ALPHA, 1]` (NaN to 1), θo to `[0, THETA_O_MAX]`.
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

/// One cap's integrals ([`SptdGgx::cap_integrals`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CapIntegrals {
    /// `≈ ∫_{C∩H} f cos θi dωi` for the GGX lobe.
    pub ggx: f32,
    /// `∫_{C∩H} cos θi dωi`, exact (π inside the sphere).
    pub lambert: f32,
    /// `|C ∩ H|`, exact (2π inside the sphere).
    pub visible: f32,
}

/// Four caps' integrals ([`SptdGgx::cap_integrals4`]).
#[derive(Clone, Copy, Debug)]
pub struct CapIntegrals4 {
    /// `≈ ∫_{C∩H} f cos θi dωi` for the GGX lobe.
    pub ggx: f32x4,
    /// `∫_{C∩H} cos θi dωi`, exact.
    pub lambert: f32x4,
    /// `|C ∩ H|`, exact.
    pub visible: f32x4,
}

/// GGX at one shading point as an SPTD: set up once (table lookup, pivot, `P(H)`, amplitude,
/// masking), then [`SptdGgx::integral`] / [`SptdGgx::integral4`] per cluster cap. No allocation.
#[derive(Clone, Copy, Debug)]
pub struct SptdGgx {
    normal: Vec3,
    pivot: Pivot,
    /// `P(H)`, the image of the upper hemisphere.
    horizon: Cap,
    /// `ρ (1 − β) / (|P(H)| M(½))`.
    scale_lobe: f32,
    /// `ρ β / π`.
    scale_lambert: f32,
    /// `½ + Λ(ωo)`.
    h0: f32,
    /// `α²`.
    alpha2: f32,
    /// `1/G2(c_ref)`.
    d_ref: f32,
    albedo: f32,
    params: GgxParams,
}

/// Smith's `Λ` at `cos θ = c > 0` for roughness² `a2`.
fn lambda(a2: f32, c: f32) -> f32 {
    let c2 = c * c;
    0.5 * (-1.0 + math::sqrt(1.0 + a2 * (1.0 - c2) / c2))
}

impl SptdGgx {
    /// In the local frame: `n = +z`, `ωo = (sin θo, 0, cos θo)` with `cos θo = |cos_theta_o|`
    /// (a view from below the surface is mirrored to above it). Cap axes given to the
    /// evaluators are then in this frame. NaN `cos_theta_o` gives a zero lobe.
    pub fn new(alpha: f32, cos_theta_o: f32) -> SptdGgx {
        if cos_theta_o.is_nan() {
            return SptdGgx::zero();
        }
        let params = ggx_params(alpha, cos_theta_o);
        SptdGgx::with_params(alpha, cos_theta_o, params, Vec3::Z, Vec3::X)
    }

    /// In world space: `normal` (flipped if `wo` is below it) and the direction towards the
    /// viewer `wo`; neither needs to be normalised. Cap axes given to the evaluators are then
    /// world directions, so no per-cluster frame change is needed. A zero or non-finite
    /// normal or `wo` gives a zero lobe; any other length is fine (a tiny or huge vector,
    /// whose f32 length would underflow or overflow, is normalised in f64).
    pub fn oriented(alpha: f32, normal: Vec3, wo: Vec3) -> SptdGgx {
        let unit = |v: Vec3| {
            let l2 = v.length_squared();
            if math::len2_is_safe(l2) {
                Some(v / math::sqrt(l2))
            } else {
                math::unit(v)
            }
        };
        let (Some(mut n), Some(wo)) = (unit(normal), unit(wo)) else {
            return SptdGgx::zero();
        };
        let mut cos_o = n.dot(wo);
        if cos_o < 0.0 {
            n = -n;
            cos_o = -cos_o;
        }
        let t = wo - n * cos_o;
        let tl = t.length();
        let t = if tl > 1e-6 {
            t / tl
        } else {
            n.any_orthonormal_vector()
        };
        SptdGgx::with_params(alpha, cos_o, ggx_params(alpha, cos_o), n, t)
    }

    /// From explicit parameters, for roughness `alpha` and view cosine `cos_theta_o` (used by
    /// the masking term), with the frame given by the unit `normal` and the unit `tangent`
    /// towards ωo. This is the form the fitting tool uses.
    pub fn with_params(
        alpha: f32,
        cos_theta_o: f32,
        params: GgxParams,
        normal: Vec3,
        tangent: Vec3,
    ) -> SptdGgx {
        let alpha = if alpha.is_nan() {
            1.0
        } else {
            alpha.clamp(MIN_ALPHA, 1.0)
        };
        let cos_max = math::cos(THETA_O_MAX);
        let c = cos_theta_o.abs();
        let c = if c >= cos_max { c.min(1.0) } else { cos_max };
        let alpha2 = alpha * alpha;
        let h0 = 0.5 + lambda(alpha2, c);
        let c_ref = params.masking_cos.clamp(1e-3, 1.0);
        let c_ref = if c_ref.is_nan() { 1.0 } else { c_ref };
        let d_ref = h0 + 0.5 * math::sqrt(c_ref * c_ref + alpha2 * (1.0 - c_ref * c_ref)) / c_ref;
        let (s, co) = math::sin_cos(params.pivot_elevation);
        let pivot = Pivot::from_direction(tangent * s + normal * co, params.pivot_norm);
        let horizon = pivot.map_cap(&Cap::hemisphere(normal));
        let area = horizon.area();
        let albedo = if params.albedo > 0.0 {
            params.albedo
        } else {
            0.0
        };
        let beta = params.lambert_weight.clamp(0.0, 1.0);
        let beta = if beta.is_nan() { 0.0 } else { beta };
        let mut g = SptdGgx {
            normal,
            pivot,
            horizon,
            scale_lobe: 0.0,
            scale_lambert: albedo * beta / PI,
            h0,
            alpha2,
            d_ref,
            albedo,
            params,
        };
        let norm = g.mask(0.5);
        let scale = albedo * (1.0 - beta) / (area * norm);
        g.scale_lobe = if area > 0.0 && scale.is_finite() {
            scale
        } else {
            0.0
        };
        if !(g.scale_lobe.is_finite() && g.scale_lambert.is_finite()) {
            return SptdGgx::zero();
        }
        g
    }

    /// The zero lobe (what a zero or non-finite direction gives).
    pub(crate) fn zero() -> SptdGgx {
        SptdGgx {
            normal: Vec3::Z,
            pivot: Pivot::new(Vec3::ZERO),
            horizon: Cap::EMPTY,
            scale_lobe: 0.0,
            scale_lambert: 0.0,
            h0: 0.5,
            alpha2: 1.0,
            d_ref: 1.0,
            albedo: 0.0,
            params: GgxParams {
                pivot_norm: 0.0,
                pivot_elevation: 0.0,
                albedo: 0.0,
                lambert_weight: 0.0,
                masking_cos: 1.0,
            },
        }
    }

    /// `M(c) = min(1, G2(c)/G2(c_ref))` for a mean cosine `c ∈ [0, 1]`.
    #[inline(always)]
    fn mask(&self, c: f32) -> f32 {
        let e = c * self.h0 + 0.5 * math::sqrt(c * c + self.alpha2 * (1.0 - c * c));
        let m = self.d_ref * c / e;
        if m < 1.0 {
            m
        } else {
            1.0
        }
    }

    /// The parameters looked up.
    pub fn params(&self) -> GgxParams {
        self.params
    }

    /// The pivot (in the frame of the constructor).
    pub fn pivot(&self) -> &Pivot {
        &self.pivot
    }

    /// `P(H)`, the image of the upper hemisphere.
    pub fn horizon_image(&self) -> &Cap {
        &self.horizon
    }

    /// The unit normal of the frame (flipped towards ωo).
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// The SPTD's amplitude `A = 4π ρ (1 − β) / (|P(H)| M(½))`.
    pub fn amplitude(&self) -> f32 {
        4.0 * PI * self.scale_lobe
    }

    /// The directional albedo `ρ`: the integral over the whole upper hemisphere, also the
    /// value for a shading point inside a cluster's bounding sphere.
    pub fn albedo(&self) -> f32 {
        self.albedo
    }

    /// The approximated `f cos θi` at the unit direction `w` (the density the model
    /// integrates, with `M` at `w`'s own cosine); 0 below the horizon.
    pub fn lobe(&self, w: Vec3) -> f32 {
        let c = w.dot(self.normal);
        if c >= 0.0 {
            self.amplitude() * self.pivot.density(w) * self.mask(c) + self.scale_lambert * c
        } else {
            0.0
        }
    }

    /// The model from the SPTD area and the Lambert pair, clamped into `[0, ρ]`: the integral
    /// over part of the hemisphere is at most the one over all of it, but the model's masking
    /// correction `M(c̄)/M(½)` can take a cap that nearly holds the hemisphere past `ρ` (by
    /// 1.25 % at α ≈ 0.9 with ωo near grazing, `fuzz/regressions/sptd/`); NaN gives 0.
    #[inline(always)]
    fn combine(&self, lens: f32, lambert: f32, visible: f32) -> f32 {
        let cbar = if visible > 0.0 {
            lambert / visible
        } else {
            0.0
        };
        let cbar = if cbar < 1.0 { cbar } else { 1.0 };
        let v = self.scale_lobe * lens * self.mask(cbar) + self.scale_lambert * lambert;
        if v >= self.albedo {
            self.albedo
        } else if v >= 0.0 {
            v
        } else {
            0.0
        }
    }

    /// `≈ ∫_{C∩H} f cos θi dωi` over the cap of unit `axis` and half-angle σ ∈ [0, π/2] given by
    /// its sine (for a bounding sphere of radius r at distance d, `sin σ = r/d`).
    /// `sin_sigma ≥ 1` (the shading point inside the sphere) gives the whole hemisphere, the
    /// albedo. NaN gives 0; never negative.
    #[inline]
    pub fn integral(&self, axis: Vec3, sin_sigma: f32) -> f32 {
        self.cap_integrals(axis, sin_sigma).ggx
    }

    /// [`SptdGgx::integral`] together with the two exact quantities it computes on the way:
    /// `∫_{C∩H} cos θi dωi` (a Lambert lobe's cap integral, as
    /// [`lambert_cap`](super::lambert_cap)) and `|C ∩ H|` (so callers need neither again).
    #[inline]
    pub fn cap_integrals(&self, axis: Vec3, sin_sigma: f32) -> CapIntegrals {
        if sin_sigma >= 1.0 {
            return CapIntegrals {
                ggx: self.albedo,
                lambert: PI,
                visible: 2.0 * PI,
            };
        }
        let cap = Cap::from_sin(axis, sin_sigma);
        let mapped = self.pivot.map_cap(&cap);
        let n = self.normal;
        let cos_omega = axis.x * n.x + axis.y * n.y + axis.z * n.z;
        // A cap that does not cross the horizon needs no intersection: P is a bijection, so
        // P(C) is then inside P(H) or outside it, and the Lambert pair is closed-form.
        let s = if sin_sigma > 0.0 { sin_sigma } else { 0.0 };
        let (lens, l, v) = if (s - cos_omega) * (s + cos_omega) <= 0.0 {
            if cos_omega > 0.0 {
                let a = cap.one_minus_cos;
                // cos ω ≤ 1 for a unit axis; the clamp keeps an infinite one from giving NaN.
                let c = if cos_omega < 1.0 { cos_omega } else { 1.0 };
                (
                    2.0 * PI * mapped.one_minus_cos,
                    s * s * c * PI,
                    2.0 * (a * PI),
                )
            } else {
                (0.0, 0.0, 0.0)
            }
        } else {
            let (l, v) = lambert_visible(cos_omega, sin_sigma);
            (intersection_area(&mapped, &self.horizon), l, v)
        };
        CapIntegrals {
            ggx: self.combine(lens, l, v),
            lambert: l,
            visible: v,
        }
    }

    /// `≈ ∫_{C∩H} f cos θi dωi` for any cap (half-angle up to π).
    #[inline]
    pub fn integral_cap(&self, cap: &Cap) -> f32 {
        let lens = intersection_area(&self.pivot.map_cap(cap), &self.horizon);
        let n = self.normal;
        let cos_omega = cap.axis.dot(n);
        let (l, v) = if cap.cos >= 0.0 {
            let sin = math::sqrt(cap.one_minus_cos * cap.one_plus_cos);
            lambert_visible(cos_omega, if sin < 1.0 { sin } else { 0.999_999_9 })
        } else {
            let sin = math::sqrt(cap.one_minus_cos * cap.one_plus_cos);
            let (l, v) = lambert_visible(-cos_omega, if sin < 1.0 { sin } else { 0.999_999_9 });
            (PI - l, 2.0 * PI - v)
        };
        self.combine(lens, l, v)
    }

    /// The 4-wide twin of [`SptdGgx::integral`]: four caps with unit axes `(ax, ay, az)` and
    /// sines of their half-angles.
    #[inline]
    pub fn integral4(&self, ax: f32x4, ay: f32x4, az: f32x4, sin_sigma: f32x4) -> f32x4 {
        self.cap_integrals4(ax, ay, az, sin_sigma).ggx
    }

    /// The 4-wide twin of [`SptdGgx::cap_integrals`].
    #[inline]
    pub fn cap_integrals4(
        &self,
        ax: f32x4,
        ay: f32x4,
        az: f32x4,
        sin_sigma: f32x4,
    ) -> CapIntegrals4 {
        SptdGgx4::new(self).cap_integrals(ax, ay, az, sin_sigma, ALL_LANES)
    }
}

/// An [`SptdGgx`]'s per-point constants in four lanes, for the 4-wide evaluators: set up once
/// per shading point ([`SptdGgx4::new`]), so that the evaluators load them instead of splatting
/// them at every call; the same operations on the same values as the [`SptdGgx`] methods.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SptdGgx4 {
    nx: f32x4,
    ny: f32x4,
    nz: f32x4,
    pivot: Pivot4,
    horizon: Cap4,
    scale_lobe: f32x4,
    scale_lambert: f32x4,
    amplitude: f32x4,
    h0: f32x4,
    alpha2: f32x4,
    d_ref: f32x4,
    albedo: f32x4,
}

impl SptdGgx4 {
    #[inline(always)]
    pub(crate) fn new(g: &SptdGgx) -> SptdGgx4 {
        SptdGgx4 {
            nx: f32x4::splat(g.normal.x),
            ny: f32x4::splat(g.normal.y),
            nz: f32x4::splat(g.normal.z),
            pivot: Pivot4::new(&g.pivot),
            horizon: Cap4::splat(&g.horizon),
            scale_lobe: f32x4::splat(g.scale_lobe),
            scale_lambert: f32x4::splat(g.scale_lambert),
            amplitude: f32x4::splat(g.amplitude()),
            h0: f32x4::splat(g.h0),
            alpha2: f32x4::splat(g.alpha2),
            d_ref: f32x4::splat(g.d_ref),
            albedo: f32x4::splat(g.albedo),
        }
    }

    /// The 4-wide twin of [`SptdGgx::mask`].
    #[inline(always)]
    fn mask(&self, c: f32x4) -> f32x4 {
        let half = f32x4::splat(0.5);
        let e = c * self.h0 + half * (c * c + self.alpha2 * (f32x4::ONE - c * c)).sqrt();
        let m = self.d_ref * c / e;
        m.simd_lt(f32x4::ONE).select(m, f32x4::ONE)
    }

    /// The 4-wide twin of [`SptdGgx::lobe`], lane by lane the same operations, for unit
    /// directions `(wx, wy, wz)`.
    #[inline(always)]
    pub(crate) fn lobe(&self, wx: f32x4, wy: f32x4, wz: f32x4) -> f32x4 {
        let c = wx * self.nx + wy * self.ny + wz * self.nz;
        let v =
            self.amplitude * self.pivot.density(wx, wy, wz) * self.mask(c) + self.scale_lambert * c;
        c.simd_ge(f32x4::ZERO).select(v, f32x4::ZERO)
    }

    /// [`SptdGgx::cap_integrals4`] in the lanes of the mask `lanes`: the others hold finite or
    /// non-finite values of no meaning (a cap across the horizon outside `lanes` gets the
    /// closed forms of a cap that does not cross it, so that a group whose crossing caps are
    /// all outside `lanes` pays for no intersection).
    #[inline(always)]
    pub(crate) fn cap_integrals(
        &self,
        ax: f32x4,
        ay: f32x4,
        az: f32x4,
        sin_sigma: f32x4,
        lanes: f32x4,
    ) -> CapIntegrals4 {
        let zero = f32x4::ZERO;
        let cap = Cap4::from_sin(ax, ay, az, sin_sigma);
        let mapped = self.pivot.map_cap(&cap);
        let cos_omega = ax * self.nx + ay * self.ny + az * self.nz;
        let pi = f32x4::splat(PI);
        let s = sin_sigma.simd_gt(zero).select(sin_sigma, zero);
        let crossing = ((s - cos_omega) * (s + cos_omega)).simd_gt(zero);
        let above = cos_omega.simd_gt(zero);
        let lens = above.select(f32x4::splat(2.0 * PI) * mapped.one_minus_cos, zero);
        let c = cos_omega.simd_lt(f32x4::ONE).select(cos_omega, f32x4::ONE);
        let l = above.select(s * s * c * pi, zero);
        let v = above.select(f32x4::splat(2.0) * (cap.one_minus_cos * pi), zero);
        // Only groups with a cap across the horizon pay for the intersections (same per-lane
        // choice as the scalar form, so the two agree lane by lane). The whole hemisphere
        // (`sin σ ≥ 1`) alone does not: its lens is not read (its result is ρ) and
        // `lambert_visible4` gives it `(π, 2π)`.
        let inside = sin_sigma.simd_ge(f32x4::ONE);
        let (lens, l, v) = if (crossing & !inside & lanes).any() {
            let (lc, vc) = lambert_visible4(cos_omega, sin_sigma);
            let lensc = intersection_area4(&mapped, &self.horizon);
            (
                crossing.select(lensc, lens),
                crossing.select(lc, l),
                crossing.select(vc, v),
            )
        } else {
            let whole = crossing & inside;
            (
                lens,
                whole.select(pi, l),
                whole.select(f32x4::splat(2.0 * PI), v),
            )
        };
        let live = v.simd_gt(zero);
        let cbar = l / live.select(v, f32x4::ONE);
        let cbar = live.select(cbar, zero);
        let cbar = cbar.simd_lt(f32x4::ONE).select(cbar, f32x4::ONE);
        let r = self.scale_lobe * lens * self.mask(cbar) + self.scale_lambert * l;
        let r = r.simd_ge(zero).select(r, zero);
        let rho = self.albedo;
        let r = r.simd_ge(rho).select(rho, r);
        CapIntegrals4 {
            ggx: inside.select(self.albedo, r),
            lambert: l,
            visible: v,
        }
    }
}
