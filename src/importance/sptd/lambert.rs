//! The exact cosine-weighted solid angle of a cap clipped by the horizon: the Lambert cap
//! integral of docs/formulas.md, section 7 (Snyder's horizon-clipped sphere form factor, "Area light
//! sources for real-time graphics", 1996), in a form that stays accurate for tiny caps.
//!
//! `I(ω, σ) = ∫_{C∩H} cos θ dω` for a cap of half-angle σ ≤ π/2 whose axis is at angle ω from
//! the normal. It is the area of the projection of `C ∩ H` on the tangent plane: the boundary
//! circle of the cap projects to an ellipse (semi-axes `sin σ |cos ω|` and `sin σ`), the horizon
//! to the unit circle, and the chord through their two contact points splits the region into a
//! segment of the ellipse and a segment of the unit disc:
//!
//! ```text
//! I = sin²σ cos ω · g(β) + g(τ),       g(x) = x − sin x cos x   (twice a disc segment)
//! τ = angle of (cos σ, Q),  β = angle of (−cos σ cos ω, Q),  Q = √(sin²σ − cos²ω)₊
//! ```
//!
//! Fully above the horizon (`Q = 0`, `β = π`, `τ = 0`) this is `π sin²σ cos ω`; fully below it
//! is 0; it agrees with Snyder's piecewise formula in between (tested), but `g` of a small
//! angle comes from its series instead of a difference of O(1) terms, so a cap of 1e-3 rad
//! grazing the horizon (`I ≈ 1e-9`) keeps its digits.

use super::trig::{atan2, atan2_4, atan2_first4, atan2_upper4};
use crate::lanes::{clamp4, gt_or, lt_or};
use crate::math;
use core::f32::consts::PI;
use wide::f32x4;

/// Series of `g(x) = x − sin x cos x` in `u = sin x` (for `cos x > 0`), used when `u² < 1/16`:
/// `g = u³ (2/3 + u² (1/5 + u² (3/28 + u² (5/72 + u² · 35/704))))`.
const G_SERIES: [f32; 5] = [2.0 / 3.0, 1.0 / 5.0, 3.0 / 28.0, 5.0 / 72.0, 35.0 / 704.0];

/// `g(θ) = θ − sin θ cos θ` for the angle θ ∈ [0, π] of `(x, y)`, `y ≥ 0`.
#[inline(always)]
#[cfg(any(test, feature = "internals"))]
fn seg(x: f32, y: f32) -> f32 {
    seg_angle(x, y, atan2(y, x))
}

/// [`seg`] with the angle `θ = atan2(y, x)` already known.
#[inline(always)]
fn seg_angle(x: f32, y: f32, theta: f32) -> f32 {
    let r2 = x * x + y * y;
    if r2 <= 0.0 {
        return 0.0;
    }
    let inv = 1.0 / r2;
    let u2 = y * y * inv;
    if x > 0.0 && u2 < 0.0625 {
        let u = math::sqrt(u2);
        let p = G_SERIES[3] + u2 * G_SERIES[4];
        let p = G_SERIES[2] + u2 * p;
        let p = G_SERIES[1] + u2 * p;
        let p = G_SERIES[0] + u2 * p;
        u * u2 * p
    } else {
        theta - x * y * inv
    }
}

#[inline(always)]
#[cfg(any(test, feature = "internals"))]
fn seg4(x: f32x4, y: f32x4) -> f32x4 {
    seg_angle4(x, y, atan2_4(y, x))
}

#[inline(always)]
fn seg_angle4(x: f32x4, y: f32x4, theta: f32x4) -> f32x4 {
    let zero = f32x4::ZERO;
    let r2 = x * x + y * y;
    let live = r2.simd_gt(zero);
    let inv = f32x4::ONE / live.select(r2, f32x4::ONE);
    let u2 = y * y * inv;
    let u = u2.sqrt();
    let p = f32x4::splat(G_SERIES[3]) + u2 * f32x4::splat(G_SERIES[4]);
    let p = f32x4::splat(G_SERIES[2]) + u2 * p;
    let p = f32x4::splat(G_SERIES[1]) + u2 * p;
    let p = f32x4::splat(G_SERIES[0]) + u2 * p;
    let series = u * u2 * p;
    let direct = theta - x * y * inv;
    let small = x.simd_gt(zero) & u2.simd_lt(f32x4::splat(0.0625));
    live.select(small.select(series, direct), zero)
}

/// `∫_{C∩H} cos θ dω` for a cap whose axis makes cosine `cos_omega` with the normal and whose
/// half-angle σ ∈ [0, π/2] has sine `sin_sigma`. `sin_sigma ≥ 1` means the shading point is
/// inside the bounding sphere: the whole upper hemisphere, π. Multiply by ρ/π for a Lambert
/// BRDF. NaN gives 0. Never negative.
#[inline]
#[must_use]
#[cfg(any(test, feature = "internals"))]
pub fn lambert_cap(cos_omega: f32, sin_sigma: f32) -> f32 {
    if sin_sigma >= 1.0 {
        return PI;
    }
    let s = if sin_sigma > 0.0 { sin_sigma } else { 0.0 };
    let c = if cos_omega > -1.0 { cos_omega } else { -1.0 };
    let c = if c < 1.0 { c } else { 1.0 };
    let z = math::sqrt((1.0 - s) * (1.0 + s));
    let q2 = (s - c) * (s + c);
    let q = math::sqrt(if q2 > 0.0 { q2 } else { 0.0 });
    let i = s * s * c * seg(-z * c, q) + seg(z, q);
    let i = if i >= 0.0 { i } else { 0.0 };
    if i > PI {
        PI
    } else {
        i
    }
}

/// The 4-wide twin of [`lambert_cap`].
#[inline]
#[must_use]
#[cfg(any(test, feature = "internals"))]
pub fn lambert_cap4(cos_omega: f32x4, sin_sigma: f32x4) -> f32x4 {
    let zero = f32x4::ZERO;
    let one = f32x4::ONE;
    let pi = f32x4::splat(PI);
    let inside = sin_sigma.simd_ge(one);
    let s = clamp4(sin_sigma, zero, one);
    let c = clamp4(cos_omega, -one, one);
    let z = ((one - s) * (one + s)).sqrt();
    let q2 = (s - c) * (s + c);
    let q = gt_or(q2, zero).sqrt();
    let i = s * s * c * seg4(-z * c, q) + seg4(z, q);
    let i = i.simd_ge(zero).select(i, zero);
    let i = lt_or(pi, i);
    inside.select(pi, i)
}

/// `(∫_{C∩H} cos θ dω, |C ∩ H|)`: the Lambert cap integral of [`lambert_cap`] together with the
/// solid angle of the part of the cap above the horizon, for the same arguments (and
/// `(π, 2π)` for `sin_sigma ≥ 1`). Their ratio is the mean cosine over the visible part.
///
/// `|C ∩ H|` is the two-cap lens of [`super::intersection_area`] specialised to a hemisphere:
/// its Gram determinant is the `Q²` above, the hemisphere's segment vanishes, and
/// `|C ∩ H| = 2 (a β − ψ)`, `a = 1 − cos σ`, `ψ = atan2(−a Q cos ω, cos σ cos²ω + Q²)`.
#[inline]
#[must_use]
pub fn lambert_visible(cos_omega: f32, sin_sigma: f32) -> (f32, f32) {
    if sin_sigma >= 1.0 {
        return (PI, 2.0 * PI);
    }
    let s = if sin_sigma > 0.0 { sin_sigma } else { 0.0 };
    let c = if cos_omega > -1.0 { cos_omega } else { -1.0 };
    let c = if c < 1.0 { c } else { 1.0 };
    let z = math::sqrt((1.0 - s) * (1.0 + s));
    let a = s * s / (1.0 + z);
    let q2 = (s - c) * (s + c);
    let q = math::sqrt(if q2 > 0.0 { q2 } else { 0.0 });
    let x = -z * c;
    let beta = atan2(q, x);
    let tau = atan2(q, z);
    let psi = atan2(-a * q * c, z * c * c + q * q);
    let l = s * s * c * seg_angle(x, q, beta) + seg_angle(z, q, tau);
    let v = 2.0 * (a * beta - psi);
    let l = if l >= 0.0 { l } else { 0.0 };
    let l = if l > PI { PI } else { l };
    let v = if v >= 0.0 { v } else { 0.0 };
    let vmax = 2.0 * PI * a;
    (l, if v > vmax { vmax } else { v })
}

/// The 4-wide twin of [`lambert_visible`].
// Always inlined: a call would save every vector register its callers (the BRDF-oriented
// evaluations) keep live across it: the System V x86-64 convention preserves none of them.
#[inline(always)]
#[must_use]
pub fn lambert_visible4(cos_omega: f32x4, sin_sigma: f32x4) -> (f32x4, f32x4) {
    let zero = f32x4::ZERO;
    let one = f32x4::ONE;
    let pi = f32x4::splat(PI);
    let two_pi = f32x4::splat(2.0 * PI);
    let inside = sin_sigma.simd_ge(one);
    let s = clamp4(sin_sigma, zero, one);
    let c = clamp4(cos_omega, -one, one);
    let z = ((one - s) * (one + s)).sqrt();
    let a = s * s / (one + z);
    let q2 = (s - c) * (s + c);
    let q = gt_or(q2, zero).sqrt();
    let x = -z * c;
    // q and z are +0 or positive (square roots of +0 or more).
    let beta = atan2_upper4(q, x);
    let tau = atan2_first4(q, z);
    let psi = atan2_4(-a * q * c, z * c * c + q * q);
    let l = s * s * c * seg_angle4(x, q, beta) + seg_angle4(z, q, tau);
    let v = f32x4::splat(2.0) * (a * beta - psi);
    let l = l.simd_ge(zero).select(l, zero);
    let l = lt_or(pi, l);
    let v = v.simd_ge(zero).select(v, zero);
    let vmax = two_pi * a;
    let v = lt_or(vmax, v);
    (inside.select(pi, l), inside.select(two_pi, v))
}
