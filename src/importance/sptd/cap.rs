//! Spherical caps and the exact area of the intersection of two caps (docs/formulas.md, section 8,
//! "Horizon"; the two-cap area of Dupuy, Heitz & Belcour 2017, SPTD paper, appendix).
//!
//! A cap `{ω : ω·axis ≥ cos σ}` carries `1 − cos σ` and `1 + cos σ` beside `cos σ`, each to full
//! relative precision: the caps a pivot transform produces range from 1e-12 sr to nearly the
//! whole sphere, and `cos σ` alone rounds both ends away in f32.
//!
//! # The intersection area, without cancellation
//!
//! The textbook form `2[π − γ − z1 φ1 − z2 φ2]` (docs/formulas.md) subtracts O(1) angles to get a result
//! that, for a cap of radius 1e-3, is 1e-6: in f32 that is noise. Here, after replacing a cap
//! larger than a hemisphere by its complement (so both caps have `z = cos σ ≥ 0`), the lens
//! `C1 ∩ C2` is split by the great circle through its two corners `p, q` into two *segments*,
//! one of each cap. With `φi` the half-angle at cap i's axis between its corners,
//!
//! ```text
//! Segᵢ = 2 [ aᵢ φᵢ − ψᵢ ],   aᵢ = 1 − zᵢ,   ψᵢ = atan2(aᵢ sin φᵢ cos φᵢ, cos² φᵢ + zᵢ sin² φᵢ)
//! ```
//!
//! (`2aᵢφᵢ` is the sector, `2ψᵢ` the spherical triangle (axis, p, q), signed, from the
//! Van Oosterom–Strackee formula simplified with `tan(r/2)² = a/(1 + z)`). `cos φᵢ` and
//! `sin φᵢ` come, unnormalised, from `Xᵢ = zⱼ − zᵢ cos d` and the Gram determinant
//! `Δ² = sᵢ² sin² d − Xᵢ²` of (axis1, axis2, p), each evaluated in whichever of the direct and
//! the `1 − z` forms is exact for the case at hand. Containment and disjointness need no
//! branch: `Δ = 0` and `φᵢ ∈ {0, π}`. Every term scales with the smaller cap, so the relative
//! error stays near f32 rounding for caps down to ~1e-5 rad; the sum of the four cases of
//! docs/formulas.md (including one cap containing the other and unions that cover the sphere) follows
//! from complements.

use super::trig::{atan2, atan2_4, atan2_upper4};
use crate::lanes::{clamp4, lt_or};
use crate::math;
use core::f32::consts::PI;
use glam::Vec3;
use wide::f32x4;

/// Caps closer to a hemisphere than this (in `cos σ`) are shrunk to it: the two-segment
/// formula is 0/0 for two exact hemispheres. The boundary moves by 1e-12 rad.
const Z_MIN: f32 = 1e-12;

/// A spherical cap `{ω : ω·axis ≥ cos}`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cap {
    /// Unit axis.
    pub axis: Vec3,
    /// Cosine of the half-angle σ, in `[-1, 1]`.
    pub cos: f32,
    /// `1 − cos σ`, accurate for tiny caps.
    pub one_minus_cos: f32,
    /// `1 + cos σ`, accurate for caps that are nearly the whole sphere.
    pub one_plus_cos: f32,
}

impl Cap {
    /// The whole sphere.
    #[cfg(any(test, feature = "internals"))]
    pub const SPHERE: Cap = Cap {
        axis: Vec3::Z,
        cos: -1.0,
        one_minus_cos: 2.0,
        one_plus_cos: 0.0,
    };

    /// The empty cap.
    pub const EMPTY: Cap = Cap {
        axis: Vec3::Z,
        cos: 1.0,
        one_minus_cos: 0.0,
        one_plus_cos: 2.0,
    };

    /// A cap from the cosine of its half-angle (clamped to `[-1, 1]`). Loses tiny caps: prefer
    /// [`Cap::from_sin`] when σ may be below ~1e-3.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn new(axis: Vec3, cos: f32) -> Cap {
        let cos = if cos > -1.0 { cos } else { -1.0 };
        let cos = if cos < 1.0 { cos } else { 1.0 };
        Cap {
            axis,
            cos,
            one_minus_cos: 1.0 - cos,
            one_plus_cos: 1.0 + cos,
        }
    }

    /// A cap of half-angle σ ∈ [0, π/2] from `sin σ` (clamped to `[0, 1]`; NaN gives the
    /// empty cap): exact for tiny caps.
    #[inline]
    #[must_use]
    pub fn from_sin(axis: Vec3, sin: f32) -> Cap {
        let s = if sin > 0.0 { sin } else { 0.0 };
        let s = if s < 1.0 { s } else { 1.0 };
        let cos = math::sqrt((1.0 - s) * (1.0 + s));
        Cap {
            axis,
            cos,
            one_minus_cos: s * s / (1.0 + cos),
            one_plus_cos: 1.0 + cos,
        }
    }

    /// The hemisphere around `axis`.
    #[inline]
    #[must_use]
    pub fn hemisphere(axis: Vec3) -> Cap {
        Cap {
            axis,
            cos: 0.0,
            one_minus_cos: 1.0,
            one_plus_cos: 1.0,
        }
    }

    /// The solid angle, `2π (1 − cos σ)`.
    #[inline]
    #[must_use]
    pub fn area(&self) -> f32 {
        2.0 * PI * self.one_minus_cos
    }

    /// The closure of the rest of the sphere.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn complement(&self) -> Cap {
        Cap {
            axis: -self.axis,
            cos: -self.cos,
            one_minus_cos: self.one_plus_cos,
            one_plus_cos: self.one_minus_cos,
        }
    }

    /// Whether the unit vector `w` lies in the cap (tested through `|w − axis|²/2 ≤ 1 − cos`
    /// for small caps, which keeps the test exact to f32 rounding for tiny ones).
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn contains(&self, w: Vec3) -> bool {
        if self.cos > 0.5 {
            let d = w - self.axis;
            0.5 * d.length_squared() <= self.one_minus_cos
        } else {
            w.dot(self.axis) >= self.cos
        }
    }
}

/// Four caps in SoA lanes.
#[derive(Clone, Copy, Debug)]
pub struct Cap4 {
    /// Axis x.
    pub ax: f32x4,
    /// Axis y.
    pub ay: f32x4,
    /// Axis z.
    pub az: f32x4,
    /// `cos σ`.
    pub cos: f32x4,
    /// `1 − cos σ`.
    pub one_minus_cos: f32x4,
    /// `1 + cos σ`.
    pub one_plus_cos: f32x4,
}

impl Cap4 {
    /// The same cap in all four lanes.
    #[inline]
    #[must_use]
    pub fn splat(c: &Cap) -> Cap4 {
        Cap4 {
            ax: f32x4::splat(c.axis.x),
            ay: f32x4::splat(c.axis.y),
            az: f32x4::splat(c.axis.z),
            cos: f32x4::splat(c.cos),
            one_minus_cos: f32x4::splat(c.one_minus_cos),
            one_plus_cos: f32x4::splat(c.one_plus_cos),
        }
    }

    /// Four caps of half-angles in [0, π/2] from their sines: the twin of [`Cap::from_sin`].
    #[inline]
    #[must_use]
    pub fn from_sin(ax: f32x4, ay: f32x4, az: f32x4, sin: f32x4) -> Cap4 {
        let zero = f32x4::ZERO;
        let one = f32x4::ONE;
        let s = clamp4(sin, zero, one);
        let cos = ((one - s) * (one + s)).sqrt();
        Cap4 {
            ax,
            ay,
            az,
            cos,
            one_minus_cos: s * s / (one + cos),
            one_plus_cos: one + cos,
        }
    }

    /// Lane `i` as a scalar cap.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn lane(&self, i: usize) -> Cap {
        let i = i & 3;
        Cap {
            axis: Vec3::new(
                self.ax.to_array()[i],
                self.ay.to_array()[i],
                self.az.to_array()[i],
            ),
            cos: self.cos.to_array()[i],
            one_minus_cos: self.one_minus_cos.to_array()[i],
            one_plus_cos: self.one_plus_cos.to_array()[i],
        }
    }
}

/// Area of the lens of two caps that are at most hemispheres (`z ≥ 0`): `(axis, z, 1 − z)`.
#[inline]
fn lens(c1: Vec3, z1: f32, a1: f32, c2: Vec3, z2: f32, a2: f32) -> f32 {
    let (z1, a1) = if z1 < Z_MIN {
        (Z_MIN, 1.0 - Z_MIN)
    } else {
        (z1, a1)
    };
    let (z2, a2) = if z2 < Z_MIN {
        (Z_MIN, 1.0 - Z_MIN)
    } else {
        (z2, a2)
    };
    let cd = c1.x * c2.x + c1.y * c2.y + c1.z * c2.z;
    let (dx, dy, dz) = (c1.x - c2.x, c1.y - c2.y, c1.z - c2.z);
    let e = 0.5 * (dx * dx + dy * dy + dz * dz);
    let (kx, ky, kz) = (
        c1.y * c2.z - c1.z * c2.y,
        c1.z * c2.x - c1.x * c2.z,
        c1.x * c2.y - c1.y * c2.x,
    );
    let sd2 = kx * kx + ky * ky + kz * kz;
    let acd = cd.abs();
    // Xi = zj − zi cos d = (e − aj) + ai cos d: whichever form has the smaller rounding bound.
    let x1 = if z2 + z1 * acd <= e + a2 + a1 * acd {
        z2 - z1 * cd
    } else {
        (e - a2) + a1 * cd
    };
    let x2 = if z1 + z2 * acd <= e + a1 + a2 * acd {
        z1 - z2 * cd
    } else {
        (e - a1) + a2 * cd
    };
    // Gram determinant from the smaller cap, where it does not cancel.
    let gram = if a1 <= a2 {
        a1 * (1.0 + z1) * sd2 - x1 * x1
    } else {
        a2 * (1.0 + z2) * sd2 - x2 * x2
    };
    let delta = math::sqrt(if gram > 0.0 { gram } else { 0.0 });
    let d2 = delta * delta;
    let phi1 = atan2(delta, x1);
    let phi2 = atan2(delta, x2);
    let n1 = x1 * x1 + d2;
    let n2 = x2 * x2 + d2;
    let psi1 = atan2(a1 * delta * x1 / n1, (x1 * x1 + z1 * d2) / n1);
    let psi2 = atan2(a2 * delta * x2 / n2, (x2 * x2 + z2 * d2) / n2);
    let area = 2.0 * ((a1 * phi1 - psi1) + (a2 * phi2 - psi2));
    // No crossing: one cap inside the other, or disjoint. Decided by the distance of the axes
    // against r1 + r2 (`e < 1 − cos(r1 + r2)`), not by the signs of X, which rounding decides
    // for (nearly) identical caps.
    if gram <= 0.0 {
        let u = (a1 + a2 - a1 * a2) + math::sqrt(a1 * (1.0 + z1)) * math::sqrt(a2 * (1.0 + z2));
        let small = if a1 < a2 { a1 } else { a2 };
        if e < u {
            2.0 * PI * small
        } else {
            0.0
        }
    } else {
        area
    }
}

/// The exact solid angle of `p ∩ q`, for caps of any size (0 for NaN input, never NaN).
#[inline]
#[must_use]
pub fn intersection_area(p: &Cap, q: &Cap) -> f32 {
    let fp = p.cos < 0.0;
    let fq = q.cos < 0.0;
    let (c1, z1, a1) = if fp {
        (-p.axis, -p.cos, p.one_plus_cos)
    } else {
        (p.axis, p.cos, p.one_minus_cos)
    };
    let (c2, z2, a2) = if fq {
        (-q.axis, -q.cos, q.one_plus_cos)
    } else {
        (q.axis, q.cos, q.one_minus_cos)
    };
    let l = lens(c1, z1, a1, c2, z2, a2);
    let (s1, s2) = (2.0 * PI * a1, 2.0 * PI * a2);
    let r = match (fp, fq) {
        (false, false) => l,
        (true, false) => s2 - l,
        (false, true) => s1 - l,
        (true, true) => (4.0 * PI - s1 - s2) + l,
    };
    // min() as the 4-wide `minps` does it (the second operand when unordered).
    let lo_omc = if p.one_minus_cos < q.one_minus_cos {
        p.one_minus_cos
    } else {
        q.one_minus_cos
    };
    let hi = 2.0 * PI * lo_omc;
    let r = if r >= 0.0 { r } else { 0.0 };
    if r > hi {
        hi
    } else {
        r
    }
}

/// The 4-wide twin of the private lens function.
#[inline]
#[allow(clippy::too_many_arguments)] // Two caps in SoA form: six lanes each, no struct to pass.
fn lens4(
    c1x: f32x4,
    c1y: f32x4,
    c1z: f32x4,
    z1: f32x4,
    a1: f32x4,
    c2x: f32x4,
    c2y: f32x4,
    c2z: f32x4,
    z2: f32x4,
    a2: f32x4,
) -> f32x4 {
    let zero = f32x4::ZERO;
    let one = f32x4::ONE;
    let zmin = f32x4::splat(Z_MIN);
    let amax = f32x4::splat(1.0 - Z_MIN);
    let small1 = z1.simd_lt(zmin);
    let (z1, a1) = (small1.select(zmin, z1), small1.select(amax, a1));
    let small2 = z2.simd_lt(zmin);
    let (z2, a2) = (small2.select(zmin, z2), small2.select(amax, a2));
    let cd = c1x * c2x + c1y * c2y + c1z * c2z;
    let (dx, dy, dz) = (c1x - c2x, c1y - c2y, c1z - c2z);
    let e = f32x4::splat(0.5) * (dx * dx + dy * dy + dz * dz);
    let (kx, ky, kz) = (
        c1y * c2z - c1z * c2y,
        c1z * c2x - c1x * c2z,
        c1x * c2y - c1y * c2x,
    );
    let sd2 = kx * kx + ky * ky + kz * kz;
    let acd = cd.abs();
    let x1 = (z2 + z1 * acd)
        .simd_le(e + a2 + a1 * acd)
        .select(z2 - z1 * cd, (e - a2) + a1 * cd);
    let x2 = (z1 + z2 * acd)
        .simd_le(e + a1 + a2 * acd)
        .select(z1 - z2 * cd, (e - a1) + a2 * cd);
    let gram = a1.simd_le(a2).select(
        a1 * (one + z1) * sd2 - x1 * x1,
        a2 * (one + z2) * sd2 - x2 * x2,
    );
    let live = gram.simd_gt(zero);
    let delta = live.select(gram, zero).sqrt();
    let d2 = delta * delta;
    // δ is +0 or positive (a square root of +0 or more).
    let phi1 = atan2_upper4(delta, x1);
    let phi2 = atan2_upper4(delta, x2);
    let n1 = x1 * x1 + d2;
    let n2 = x2 * x2 + d2;
    let psi1 = atan2_4(a1 * delta * x1 / n1, (x1 * x1 + z1 * d2) / n1);
    let psi2 = atan2_4(a2 * delta * x2 / n2, (x2 * x2 + z2 * d2) / n2);
    let area = f32x4::splat(2.0) * ((a1 * phi1 - psi1) + (a2 * phi2 - psi2));
    let u = (a1 + a2 - a1 * a2) + (a1 * (one + z1)).sqrt() * (a2 * (one + z2)).sqrt();
    let small = lt_or(a1, a2);
    let inner = e.simd_lt(u).select(f32x4::splat(2.0 * PI) * small, zero);
    live.select(area, inner)
}

/// The 4-wide twin of [`intersection_area`], lane by lane.
// Always inlined: a call would save every vector register its callers (the BRDF-oriented
// evaluations) keep live across it: the System V x86-64 convention preserves none of them.
#[inline(always)]
#[must_use]
pub fn intersection_area4(p: &Cap4, q: &Cap4) -> f32x4 {
    let zero = f32x4::ZERO;
    let two_pi = f32x4::splat(2.0 * PI);
    let fp = p.cos.simd_lt(zero);
    let fq = q.cos.simd_lt(zero);
    let l = lens4(
        fp.select(-p.ax, p.ax),
        fp.select(-p.ay, p.ay),
        fp.select(-p.az, p.az),
        fp.select(-p.cos, p.cos),
        fp.select(p.one_plus_cos, p.one_minus_cos),
        fq.select(-q.ax, q.ax),
        fq.select(-q.ay, q.ay),
        fq.select(-q.az, q.az),
        fq.select(-q.cos, q.cos),
        fq.select(q.one_plus_cos, q.one_minus_cos),
    );
    let s1 = two_pi * fp.select(p.one_plus_cos, p.one_minus_cos);
    let s2 = two_pi * fq.select(q.one_plus_cos, q.one_minus_cos);
    let r = fp.select(
        fq.select((f32x4::splat(4.0 * PI) - s1 - s2) + l, s2 - l),
        fq.select(s1 - l, l),
    );
    let lo_omc = lt_or(p.one_minus_cos, q.one_minus_cos);
    let hi = two_pi * lo_omc;
    let r = r.simd_ge(zero).select(r, zero);
    lt_or(hi, r)
}
