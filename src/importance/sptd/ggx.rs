//! The GGX cap integral (docs/formulas.md, section 8, "GGX fit" and "As built"):
//! `∫_{C∩H} f(ωi, ωo) cos θi dωi` over a cap C clipped by the upper hemisphere H, for f the
//! isotropic GGX BRDF with height-correlated Smith masking-shadowing and no Fresnel term. A cap
//! small against its distance from the SPTD's pivot takes the *lateral rule*, any other the
//! *SPTD part*:
//!
//! ```text
//! S(C) = S_lat(C)    if 2(1 − cos σ) < 0.49 · min(|c − rp|², 1)     (c: the cap's axis)
//!        S_sptd(C)   otherwise (and for caps of a hemisphere or more)
//! ```
//!
//! clamped into `[0, ρ]`. Both use the exact `L(C) = ∫_{C∩H} cos θi dωi`, `V = |C ∩ H|`
//! (`lambert_visible`; closed forms for a cap that does not cross the horizon) and the mean
//! cosine `c̄ = L/V` of the visible part.
//!
//! **The SPTD part**, fitted by `sptd-fit` (tools/sptd-fit) ([`SptdGgx::sptd_integral_cap`]):
//!
//! ```text
//! S_sptd(C) = ρ [ (1 − β) · |P(C) ∩ P(H)| / |P(H)| · M(c̄)/M(½)  +  β · L(C)/π ]
//! M(c) = min(1, G2(c)/G2(c_ref)),   G2(c) = 1/(1 + Λ(ωo) + Λ(θi = acos c))
//! ```
//!
//! - The SPTD: a pivot `rp = R (sin Gθ, 0, cos Gθ)` in the frame where `n = +z` and
//!   `ωo = (sin θo, 0, cos θo)`, horizon-clipped exactly through `P(H)`; its amplitude
//!   `A = 4π ρ (1 − β) / (|P(H)| M(½))` is tied to the albedo.
//! - `β`, a share of a Lambert lobe of the same albedo: GGX's broad tails at large α, which a
//!   single SPTD (whose level sets are circles) cannot follow.
//! - `M`, the masking-shadowing of grazing `ωi`: f cos θi vanishes at the horizon like
//!   `G2 ∝ cos θi` while an SPTD does not, so caps that only graze the horizon would be
//!   overestimated a hundredfold. `M` is evaluated at `c̄` and is 1 above `c_ref`.
//!
//! `R`, `Gθ`, `ρ`, `β` and `c_ref` come from the table `sptd/table.rs`, indexed by `u = √α`
//! and `v = 2θo/π` and filtered bilinearly. A cap that does not cross the horizon costs no
//! intersection: P is a bijection, so `P(C)` then lies inside or outside `P(H)`.
//!
//! **The lateral rule.** An SPTD's level sets are circles, but at oblique views GGX's lobe is a
//! ridge along the plane of incidence, narrower across it by `cos θd` (`θd` the angle of ωo to
//! the half vector): away from the ridge the SPTD overestimates small caps up to a
//! thousandfold. A small cap instead gets the exact `f cos` averaged across the ridge: with
//! `h = ωo + ω` (unnormalised; `D` only depends on its direction), `hn = h·n` and `ht` its part
//! along the surface, `D(h) = α² r²/π` with `r = |h|²/(α² hn² + |ht|²)`, and
//!
//! ```text
//! S_lat(C) = V · G2(c̄) · α²/(4π cos θo) · ⟨r²⟩
//! ```
//!
//! where `⟨r²⟩` is the mean of `r²` over the cap's chord through its axis across the plane of
//! incidence (half-length `R = sin σ`), weighted as a disc's chords are (`√(R² − t²)`), with
//! `hn` and the in-plane part `x` of `ht` held at the axis. Writing `u` for the distance from
//! the plane (`y` at the axis), `C² = x² + α² hn²` and `K = (1 − α²) hn²`, `r = 1 + K/(C² + u²)`,
//! and the mean has the closed form
//!
//! ```text
//! ⟨r²⟩ = 1 + 2K (4N + K w(1 + w)) / (m (1 + w) N)
//! Q = y² + C² − R²,  N = √(Q² + 4R²C²),  m = N + Q,  w = √(1 + 2R²/m)
//! ```
//!
//! with `m = 4R²C²/(N − Q)` and `2R²/m = (N − Q)/(2C²)` for `Q < 0`, so that nothing cancels.
//! For a cap across the horizon the axis is lifted to the mean cosine (`hn = cos θo + c̄`) and
//! `R` is the half-chord there, `√(sin²σ − (c̄ − cos ω)²)`. As σ → 0, `S_lat(C)/V` tends to the
//! exact `f cos θi` at the axis ([`SptdGgx::lobe`]); it is positive wherever the visible part
//! is.
//!
//! The whole hemisphere (and a shading point inside a cluster's bounding sphere) gets exactly
//! `ρ`. The 4-wide form computes each part only for groups with a lane that takes it, and the
//! intersection only for groups with a crossing cap that takes the SPTD part (per-lane results
//! are the same either way).

use super::cap::{intersection_area, intersection_area4, Cap, Cap4};
use super::ggx_table::{ggx_params, GgxParams, THETA_O_MAX};
use super::lambert::{lambert_visible, lambert_visible4};
use super::pivot::{Pivot, Pivot4};
use crate::lanes::{gt_or, lt_or};
use crate::material::MIN_ALPHA;
use crate::math;
use core::f32::consts::PI;
use glam::Vec3;
use wide::f32x4;

/// The mask of all four lanes.
#[cfg(any(test, feature = "internals"))]
const ALL_LANES: f32x4 = f32x4::new([f32::from_bits(u32::MAX); 4]);

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

/// GGX's cap integral at one shading point (module docs): set up once (table lookup, pivot,
/// `P(H)`, amplitude, masking, the view's frame), then [`SptdGgx::integral`] /
/// [`SptdGgx::integral4`] per cluster cap. No allocation.
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
    /// `G2(c_ref)`.
    g2_ref: f32,
    albedo: f32,
    // Read by the fit and the tests (`params()`), not by the importance.
    #[cfg_attr(not(any(test, feature = "internals")), allow(dead_code))]
    params: GgxParams,
    /// `cos θo` (θo clamped to [`THETA_O_MAX`]).
    cos_o: f32,
    /// The unit tangent `t` towards ωo (`ωo = sin θo t + cos θo n`).
    tangent: Vec3,
    /// `sin θo`.
    sin_o: f32,
    /// The unit normal of the plane of incidence, `n × t`.
    lateral: Vec3,
    /// `α² / (4π cos θo)`: `f cos θi = point_scale · r² G2` with `r = |h|²/(α² hn² + |ht|²)`.
    point_scale: f32,
    /// `1 − α²`.
    one_minus_alpha2: f32,
}

/// Caps with `2(1 − cos σ) < SMALL_CAP · min(|c − rp|², 1)` (σ below about 0.7 of the
/// distance of the axis `c` from the pivot `rp`, and below 0.7 rad) take the lateral rule, the
/// others the SPTD part (see the module docs).
const SMALL_CAP: f32 = 0.49;

/// Smith's `Λ` at `cos θ = c > 0` for roughness² `a2`.
fn lambda(a2: f32, c: f32) -> f32 {
    let c2 = c * c;
    0.5 * (-1.0 + math::sqrt(1.0 + a2 * (1.0 - c2) / c2))
}

impl SptdGgx {
    /// In the local frame: `n = +z`, `ωo = (sin θo, 0, cos θo)` with `cos θo = |cos_theta_o|`
    /// (a view from below the surface is mirrored to above it). Cap axes given to the
    /// evaluators are then in this frame. NaN `cos_theta_o` gives a zero lobe.
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
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
    #[must_use]
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
        let tl = math::length(t);
        let t = if tl > 1e-6 {
            t / tl
        } else {
            n.any_orthonormal_vector()
        };
        let params = ggx_params(alpha, cos_o);
        SptdGgx::build(
            alpha,
            cos_o,
            Some(if tl > 1e-6 { tl } else { 0.0 }),
            params,
            n,
            t,
        )
    }

    /// From explicit parameters, for roughness `alpha` and view cosine `cos_theta_o` (used by
    /// the masking term), with the frame given by the unit `normal` and the unit `tangent`
    /// towards ωo. This is the form the fitting tool uses.
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn with_params(
        alpha: f32,
        cos_theta_o: f32,
        params: GgxParams,
        normal: Vec3,
        tangent: Vec3,
    ) -> SptdGgx {
        SptdGgx::build(alpha, cos_theta_o, None, params, normal, tangent)
    }

    /// [`SptdGgx::with_params`], with `sin θo` given where it is known more accurately than
    /// `√(1 − cos²θo)` (a view near the normal); used unless θo is clamped.
    fn build(
        alpha: f32,
        cos_theta_o: f32,
        sin_theta_o: Option<f32>,
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
        let sin_o = match sin_theta_o {
            Some(s) if c == cos_theta_o.abs() && (0.0..=1.0).contains(&s) => s,
            _ => math::sqrt((1.0 - c) * (1.0 + c)),
        };
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
            g2_ref: 1.0 / d_ref,
            albedo,
            params,
            cos_o: c,
            tangent,
            sin_o,
            lateral: normal.cross(tangent),
            point_scale: if albedo > 0.0 {
                alpha2 / (4.0 * PI * c)
            } else {
                0.0
            },
            one_minus_alpha2: 1.0 - alpha2,
        };
        let norm = g.mask(0.5);
        let scale = albedo * (1.0 - beta) / (area * norm);
        g.scale_lobe = if area > 0.0 && scale.is_finite() {
            scale
        } else {
            0.0
        };
        if !(g.scale_lobe.is_finite()
            && g.scale_lambert.is_finite()
            && g.tangent.is_finite()
            && g.lateral.is_finite())
        {
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
            g2_ref: 1.0,
            albedo: 0.0,
            params: GgxParams {
                pivot_norm: 0.0,
                pivot_elevation: 0.0,
                albedo: 0.0,
                lambert_weight: 0.0,
                masking_cos: 1.0,
            },
            cos_o: 1.0,
            tangent: Vec3::X,
            sin_o: 0.0,
            lateral: Vec3::Y,
            point_scale: 0.0,
            one_minus_alpha2: 0.0,
        }
    }

    /// `G2(c)/G2(c_ref)` for `cos θi = c ∈ [0, 1]`, with `G2(c) = c/e(c)`,
    /// `e(c) = c (½ + Λ(ωo)) + ½ √(c² + α²(1 − c²)) = c (1 + Λ(ωo) + Λ(θi))`.
    #[inline(always)]
    fn mask_raw(&self, c: f32) -> f32 {
        let e = c * self.h0 + 0.5 * math::sqrt(c * c + self.alpha2 * (1.0 - c * c));
        self.d_ref * c / e
    }

    /// `M = min(1, G2(c)/G2(c_ref))` from [`SptdGgx::mask_raw`]'s value.
    #[inline(always)]
    fn clamp_mask(m: f32) -> f32 {
        if m < 1.0 {
            m
        } else {
            1.0
        }
    }

    /// `M(c) = min(1, G2(c)/G2(c_ref))` for a mean cosine `c ∈ [0, 1]`.
    #[inline(always)]
    fn mask(&self, c: f32) -> f32 {
        Self::clamp_mask(self.mask_raw(c))
    }

    /// `r = |h|²/(α² hn² + |ht|²)` for the half vector `h = ωo + ω` of a direction `ω` with
    /// `hn = h·n` and `|ht|² = |h − hn n|²`, so that `D(h) = α² r²/π`; `r ∈ [1, 1/α²]`.
    #[inline(always)]
    fn half_ratio(&self, hn2: f32, ht2: f32) -> f32 {
        (hn2 + ht2) / (self.alpha2 * hn2 + ht2)
    }

    /// The lateral rule `S_lat(C)` for a cap of unit `axis` (cosine `cos_omega` with the normal),
    /// `sin σ = s`, whose visible part has the solid angle `v` and the mean cosine `cbar`,
    /// with `G2(cbar)` given: `v · G2(c̄)/(4 cos θo)` times the mean of `D(h)` over the
    /// visible part's chord across the plane of incidence (module docs); 0 for `v = 0`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn lateral_rule(
        &self,
        axis: Vec3,
        cos_omega: f32,
        s: f32,
        crossing: bool,
        cbar: f32,
        g2: f32,
        v: f32,
    ) -> f32 {
        let (t, b) = (self.tangent, self.lateral);
        // `ωo + axis` along the surface: `x` in the plane of incidence, `y` across it.
        let x = (axis.x * t.x + axis.y * t.y + axis.z * t.z) + self.sin_o;
        let y = axis.x * b.x + axis.y * b.y + axis.z * b.z;
        let (hn, r2) = if crossing {
            let lift = cbar - cos_omega;
            let w2 = (s - lift) * (s + lift);
            (self.cos_o + cbar, if w2 > 0.0 { w2 } else { 0.0 })
        } else {
            (self.cos_o + cos_omega, s * s)
        };
        let mean = self.chord_mean(hn * hn, x * x, y, r2);
        let p = v * self.point_scale * g2 * mean;
        if v > 0.0 {
            p
        } else {
            0.0
        }
    }

    /// The mean of `r²` (`D = α² r²/π`) along a chord across the plane of incidence, weighted
    /// as a disc's chords are (`√(R² − t²)`, `|t| ≤ R`): `hn² = hn2`, the in-plane part
    /// `x2` of `|ht|²`, the chord's centre at `y` from the plane, `R² = r2`: the closed form
    /// `1 + 2K (4N + K w(1 + w)) / (m (1 + w) N)` of the module docs.
    #[inline(always)]
    fn chord_mean(&self, hn2: f32, x2: f32, y: f32, r2: f32) -> f32 {
        let c2 = x2 + self.alpha2 * hn2;
        let k = self.one_minus_alpha2 * hn2;
        let q = (y * y + c2) - r2;
        let rc4 = 4.0 * r2 * c2;
        let big_n = math::sqrt(q * q + rc4);
        // |Q| + N: no cancellation for either sign of Q.
        let sum = big_n + q.abs();
        let (xn, xd) = if q >= 0.0 {
            (2.0 * r2, sum)
        } else {
            (sum, 2.0 * c2)
        };
        let w = math::sqrt(1.0 + xn / xd);
        let w1 = 1.0 + w;
        let num = 2.0 * k * (4.0 * big_n + k * w * w1);
        let den = w1 * big_n;
        let (num, den) = if q >= 0.0 {
            (num, sum * den)
        } else {
            (num * sum, rc4 * den)
        };
        1.0 + num / den
    }

    /// Whether a cap with `1 − cos σ = a` whose axis lies at `|c − rp|² = dist2` from the
    /// pivot takes the lateral rule: `2a < SMALL_CAP · min(dist2, 1)` (false for NaN).
    #[inline(always)]
    fn is_small(a: f32, dist2: f32) -> bool {
        let d = if dist2 < 1.0 { dist2 } else { 1.0 };
        2.0 * a < SMALL_CAP * d
    }

    /// `r` clamped into `[0, ρ]` (NaN to 0).
    #[inline(always)]
    fn clamp_albedo(&self, r: f32) -> f32 {
        if r >= self.albedo {
            self.albedo
        } else if r >= 0.0 {
            r
        } else {
            0.0
        }
    }

    /// The parameters looked up.
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn params(&self) -> GgxParams {
        self.params
    }

    /// The pivot (in the frame of the constructor).
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn pivot(&self) -> &Pivot {
        &self.pivot
    }

    /// `P(H)`, the image of the upper hemisphere.
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn horizon_image(&self) -> &Cap {
        &self.horizon
    }

    /// The unit normal of the frame (flipped towards ωo).
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// The SPTD's amplitude `A = 4π ρ (1 − β) / (|P(H)| M(½))`.
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn amplitude(&self) -> f32 {
        4.0 * PI * self.scale_lobe
    }

    /// The directional albedo `ρ`: the integral over the whole upper hemisphere, also the
    /// value for a shading point inside a cluster's bounding sphere.
    #[must_use]
    pub fn albedo(&self) -> f32 {
        self.albedo
    }

    /// `f cos θi` of the GGX lobe at the unit direction `w`, exact (`D(h) G2/(4 cos θo)`): the
    /// limit of the model's cap average `S(C)/|C ∩ H|` for a vanishing cap about `w`; 0 below
    /// the horizon.
    #[must_use]
    pub fn lobe(&self, w: Vec3) -> f32 {
        let n = self.normal;
        let c = w.x * n.x + w.y * n.y + w.z * n.z;
        if c > 0.0 {
            let (t, b) = (self.tangent, self.lateral);
            let x = (w.x * t.x + w.y * t.y + w.z * t.z) + self.sin_o;
            let y = w.x * b.x + w.y * b.y + w.z * b.z;
            let ht2 = x * x + y * y;
            let hn = self.cos_o + c;
            let r = self.half_ratio(hn * hn, ht2);
            self.point_scale * (r * r) * (self.mask_raw(c) * self.g2_ref)
        } else {
            0.0
        }
    }

    /// The mean cosine `c̄ = L/V ∈ [0, 1]` of a cap's visible part (0 for `V = 0`).
    #[inline(always)]
    fn mean_cos(lambert: f32, visible: f32) -> f32 {
        let cbar = if visible > 0.0 {
            lambert / visible
        } else {
            0.0
        };
        if cbar < 1.0 {
            cbar
        } else {
            1.0
        }
    }

    /// The SPTD part from the lens area, the Lambert integral and `G2(c̄)/G2(c_ref)`
    /// ([`SptdGgx::mask_raw`]), unclamped.
    #[inline(always)]
    fn sptd_value(&self, lens: f32, lambert: f32, mask_raw: f32) -> f32 {
        self.scale_lobe * lens * Self::clamp_mask(mask_raw) + self.scale_lambert * lambert
    }

    /// The SPTD part alone, clamped into `[0, ρ]`: the integral over part of the hemisphere
    /// is at most the one over all of it, but the masking correction `M(c̄)/M(½)` can take a
    /// cap that nearly holds the hemisphere past `ρ` (by 1.25 % at α ≈ 0.9 with ωo near
    /// grazing, `fuzz/regressions/sptd/`); NaN gives 0.
    #[inline(always)]
    #[cfg(any(test, feature = "internals"))]
    fn combine(&self, lens: f32, lambert: f32, visible: f32) -> f32 {
        let v = self.sptd_value(
            lens,
            lambert,
            self.mask_raw(Self::mean_cos(lambert, visible)),
        );
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
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn integral(&self, axis: Vec3, sin_sigma: f32) -> f32 {
        self.cap_integrals(axis, sin_sigma).ggx
    }

    /// [`SptdGgx::integral`] together with the two exact quantities it computes on the way:
    /// `∫_{C∩H} cos θi dωi` (a Lambert lobe's cap integral, as
    /// [`lambert_cap`](super::lambert_cap)) and `|C ∩ H|` (so callers need neither again).
    #[inline]
    #[must_use]
    pub fn cap_integrals(&self, axis: Vec3, sin_sigma: f32) -> CapIntegrals {
        if sin_sigma >= 1.0 {
            return CapIntegrals {
                ggx: self.albedo,
                lambert: PI,
                visible: 2.0 * PI,
            };
        }
        let cap = Cap::from_sin(axis, sin_sigma);
        let n = self.normal;
        let cos_omega = axis.x * n.x + axis.y * n.y + axis.z * n.z;
        // A cap that does not cross the horizon needs no intersection: P is a bijection, so
        // P(C) is then inside P(H) or outside it, and the Lambert pair is closed-form.
        let s = if sin_sigma > 0.0 { sin_sigma } else { 0.0 };
        let crossing = (s - cos_omega) * (s + cos_omega) > 0.0;
        let above = cos_omega > 0.0;
        let (l, v) = if crossing {
            lambert_visible(cos_omega, sin_sigma)
        } else if above {
            // cos ω ≤ 1 for a unit axis; the clamp keeps an infinite one from giving NaN.
            let c = if cos_omega < 1.0 { cos_omega } else { 1.0 };
            (s * s * c * PI, 2.0 * (cap.one_minus_cos * PI))
        } else {
            (0.0, 0.0)
        };
        // The mean cosine of the visible part: `c (1 + cos σ)/2` for a cap above the horizon.
        let cbar = if crossing {
            Self::mean_cos(l, v)
        } else if above {
            let c = if cos_omega < 1.0 { cos_omega } else { 1.0 };
            0.5 * c * cap.one_plus_cos
        } else {
            0.0
        };
        let m = self.mask_raw(cbar);
        let ggx = if Self::is_small(cap.one_minus_cos, self.pivot.distance2(axis)) {
            self.lateral_rule(axis, cos_omega, s, crossing, cbar, m * self.g2_ref, v)
        } else {
            let mapped = self.pivot.map_cap(&cap);
            let lens = if crossing {
                intersection_area(&mapped, &self.horizon)
            } else if above {
                2.0 * PI * mapped.one_minus_cos
            } else {
                0.0
            };
            self.sptd_value(lens, l, m)
        };
        CapIntegrals {
            ggx: self.clamp_albedo(ggx),
            lambert: l,
            visible: v,
        }
    }

    /// The lens `|P(C) ∩ P(H)|` and the Lambert pair `(∫_{C∩H} cos, |C ∩ H|)` of any cap.
    #[inline]
    #[cfg(any(test, feature = "internals"))]
    fn cap_parts(&self, cap: &Cap) -> (f32, f32, f32) {
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
        (lens, l, v)
    }

    /// `≈ ∫_{C∩H} f cos θi dωi` for any cap (half-angle up to π); caps of a hemisphere or
    /// more take the SPTD part.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn integral_cap(&self, cap: &Cap) -> f32 {
        let (lens, l, v) = self.cap_parts(cap);
        let m = self.mask_raw(Self::mean_cos(l, v));
        let axis = cap.axis;
        if cap.cos > 0.0 && Self::is_small(cap.one_minus_cos, self.pivot.distance2(axis)) {
            let cos_omega = axis.dot(self.normal);
            let s = math::sqrt(cap.one_minus_cos * cap.one_plus_cos);
            let crossing = (s - cos_omega) * (s + cos_omega) > 0.0;
            let cbar = Self::mean_cos(l, v);
            self.clamp_albedo(self.lateral_rule(
                axis,
                cos_omega,
                s,
                crossing,
                cbar,
                m * self.g2_ref,
                v,
            ))
        } else {
            self.clamp_albedo(self.sptd_value(lens, l, m))
        }
    }

    /// The SPTD part of the model alone,
    /// `S_sptd(C) = ρ[(1 − β)·|P(C) ∩ P(H)|/|P(H)|·M(c̄)/M(½) + β·L(C)/π]` clamped into
    /// `[0, ρ]`, for any cap (half-angle up to π): the part `sptd-fit` (tools/sptd-fit) fits.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn sptd_integral_cap(&self, cap: &Cap) -> f32 {
        let (lens, l, v) = self.cap_parts(cap);
        self.combine(lens, l, v)
    }

    /// The 4-wide twin of [`SptdGgx::integral`]: four caps with unit axes `(ax, ay, az)` and
    /// sines of their half-angles.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn integral4(&self, ax: f32x4, ay: f32x4, az: f32x4, sin_sigma: f32x4) -> f32x4 {
        self.cap_integrals4(ax, ay, az, sin_sigma).ggx
    }

    /// The 4-wide twin of [`SptdGgx::cap_integrals`].
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
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
    h0: f32x4,
    alpha2: f32x4,
    d_ref: f32x4,
    g2_ref: f32x4,
    albedo: f32x4,
    cos_o: f32x4,
    sin_o: f32x4,
    tx: f32x4,
    ty: f32x4,
    tz: f32x4,
    bx: f32x4,
    by: f32x4,
    bz: f32x4,
    point_scale: f32x4,
    one_minus_alpha2: f32x4,
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
            h0: f32x4::splat(g.h0),
            alpha2: f32x4::splat(g.alpha2),
            d_ref: f32x4::splat(g.d_ref),
            g2_ref: f32x4::splat(g.g2_ref),
            albedo: f32x4::splat(g.albedo),
            cos_o: f32x4::splat(g.cos_o),
            sin_o: f32x4::splat(g.sin_o),
            tx: f32x4::splat(g.tangent.x),
            ty: f32x4::splat(g.tangent.y),
            tz: f32x4::splat(g.tangent.z),
            bx: f32x4::splat(g.lateral.x),
            by: f32x4::splat(g.lateral.y),
            bz: f32x4::splat(g.lateral.z),
            point_scale: f32x4::splat(g.point_scale),
            one_minus_alpha2: f32x4::splat(g.one_minus_alpha2),
        }
    }

    /// The 4-wide twin of [`SptdGgx::mask_raw`].
    #[inline(always)]
    fn mask_raw(&self, c: f32x4) -> f32x4 {
        let half = f32x4::splat(0.5);
        let e = c * self.h0 + half * (c * c + self.alpha2 * (f32x4::ONE - c * c)).sqrt();
        self.d_ref * c / e
    }

    /// The 4-wide twin of [`SptdGgx::half_ratio`].
    #[inline(always)]
    fn half_ratio(&self, hn2: f32x4, ht2: f32x4) -> f32x4 {
        (hn2 + ht2) / (self.alpha2 * hn2 + ht2)
    }

    /// The 4-wide twin of [`SptdGgx::chord_mean`].
    #[inline(always)]
    fn chord_mean(&self, hn2: f32x4, x2: f32x4, y: f32x4, r2: f32x4) -> f32x4 {
        let one = f32x4::ONE;
        let two = f32x4::splat(2.0);
        let four = f32x4::splat(4.0);
        let c2 = x2 + self.alpha2 * hn2;
        let k = self.one_minus_alpha2 * hn2;
        let q = (y * y + c2) - r2;
        let rc4 = four * r2 * c2;
        let big_n = (q * q + rc4).sqrt();
        // |Q| + N: no cancellation for either sign of Q.
        let sum = big_n + q.abs();
        let pos = q.simd_ge(f32x4::ZERO);
        let xn = pos.select(two * r2, sum);
        let xd = pos.select(sum, two * c2);
        let w = (one + xn / xd).sqrt();
        let w1 = one + w;
        let num = two * k * (four * big_n + k * w * w1);
        let den = w1 * big_n;
        let num = pos.select(num, num * sum);
        let den = pos.select(sum * den, rc4 * den);
        one + num / den
    }

    /// `ωo + ω` along the surface for the unit directions `(wx, wy, wz)`: `(x, y)`, `x` in
    /// the plane of incidence, `y` across it.
    #[inline(always)]
    fn along_surface(&self, wx: f32x4, wy: f32x4, wz: f32x4) -> (f32x4, f32x4) {
        let x = (wx * self.tx + wy * self.ty + wz * self.tz) + self.sin_o;
        let y = wx * self.bx + wy * self.by + wz * self.bz;
        (x, y)
    }

    /// The 4-wide twin of [`SptdGgx::lobe`], lane by lane the same operations, for unit
    /// directions `(wx, wy, wz)`.
    #[inline(always)]
    pub(crate) fn lobe(&self, wx: f32x4, wy: f32x4, wz: f32x4) -> f32x4 {
        let c = wx * self.nx + wy * self.ny + wz * self.nz;
        let (x, y) = self.along_surface(wx, wy, wz);
        let ht2 = x * x + y * y;
        let hn = self.cos_o + c;
        let r = self.half_ratio(hn * hn, ht2);
        let v = self.point_scale * (r * r) * (self.mask_raw(c) * self.g2_ref);
        c.simd_gt(f32x4::ZERO).select(v, f32x4::ZERO)
    }

    /// [`SptdGgx::cap_integrals4`] in the lanes of the mask `lanes`: the others hold finite or
    /// non-finite values of no meaning (work that no lane of `lanes` needs is skipped: the
    /// lens of a cap across the horizon, the SPTD part where every lane takes the lateral rule,
    /// the lateral rule where every lane takes the SPTD part).
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
        let one = f32x4::ONE;
        let two = f32x4::splat(2.0);
        let cap = Cap4::from_sin(ax, ay, az, sin_sigma);
        let cos_omega = ax * self.nx + ay * self.ny + az * self.nz;
        let pi = f32x4::splat(PI);
        let s = gt_or(sin_sigma, zero);
        let crossing = ((s - cos_omega) * (s + cos_omega)).simd_gt(zero);
        let above = cos_omega.simd_gt(zero);
        let c = lt_or(cos_omega, one);
        let l = above.select(s * s * c * pi, zero);
        let v = above.select(two * (cap.one_minus_cos * pi), zero);
        // Only groups with a cap across the horizon pay for the exact Lambert pair (same
        // per-lane choice as the scalar form, so the two agree lane by lane). The whole
        // hemisphere (`sin σ ≥ 1`) alone does not: `lambert_visible4` gives it `(π, 2π)`, and
        // neither its lens nor its lateral rule is read (its result is ρ).
        let inside = sin_sigma.simd_ge(one);
        let any_crossing = (crossing & !inside & lanes).any();
        let (l, v) = if any_crossing {
            let (lc, vc) = lambert_visible4(cos_omega, sin_sigma);
            (crossing.select(lc, l), crossing.select(vc, v))
        } else {
            let whole = crossing & inside;
            (whole.select(pi, l), whole.select(two * pi, v))
        };
        let off = self.pivot.offset(ax, ay, az);
        let dist2 = self.pivot.distance2(&off);
        let d = lt_or(dist2, one);
        let small = (two * cap.one_minus_cos).simd_lt(f32x4::splat(SMALL_CAP) * d);
        // The mean cosine of the visible part: `c (1 + cos σ)/2` for a cap above the horizon.
        let half = f32x4::splat(0.5);
        let cbar = above.select(half * c * cap.one_plus_cos, zero);
        let live = v.simd_gt(zero);
        let cbar = if any_crossing {
            let cc = l / live.select(v, one);
            let cc = live.select(cc, zero);
            crossing.select(lt_or(cc, one), cbar)
        } else {
            cbar
        };
        let m = self.mask_raw(cbar);
        // Each part only where a lane of `lanes` takes it.
        let lateral = if (lanes & small).any() {
            let (x, y) = self.along_surface(ax, ay, az);
            let (hn, r2) = if any_crossing {
                let lift = cbar - cos_omega;
                let w2 = (s - lift) * (s + lift);
                (
                    crossing.select(self.cos_o + cbar, self.cos_o + cos_omega),
                    crossing.select(gt_or(w2, zero), s * s),
                )
            } else {
                (self.cos_o + cos_omega, s * s)
            };
            let mean = self.chord_mean(hn * hn, x * x, y, r2);
            let p = v * self.point_scale * (m * self.g2_ref) * mean;
            live.select(p, zero)
        } else {
            zero
        };
        let need_sptd = lanes & !small;
        let r = if need_sptd.any() {
            let mapped = self.pivot.map_cap_at(&cap, &off);
            let lens = above.select(f32x4::splat(2.0 * PI) * mapped.one_minus_cos, zero);
            let lens = if (crossing & !inside & need_sptd).any() {
                crossing.select(intersection_area4(&mapped, &self.horizon), lens)
            } else {
                lens
            };
            let mc = lt_or(m, one);
            let sptd = self.scale_lobe * lens * mc + self.scale_lambert * l;
            small.select(lateral, sptd)
        } else {
            lateral
        };
        let r = r.simd_ge(zero).select(r, zero);
        let rho = self.albedo;
        // (`r ≥ ρ ? ρ : r` is `r < ρ ? r : ρ` for the r that is not NaN.)
        let r = lt_or(r, rho);
        CapIntegrals4 {
            ggx: inside.select(self.albedo, r),
            lambert: l,
            visible: v,
        }
    }
}
