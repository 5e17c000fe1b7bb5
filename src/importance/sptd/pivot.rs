//! The spherical pivot transform and the closed-form image of a cap (docs/formulas.md, section 8; Dupuy,
//! Heitz & Belcour 2017, "A Spherical Cap Preserving Parameterization for Spherical
//! Distributions", the pivot transform and its cap-to-cap property).
//!
//! ```text
//! P(ω) = ω + t (rp − ω),   t = 2(1 − ω·rp)/|ω − rp|²        (P ∘ P = identity)
//! |dP/dω| = k²/|ω − rp|⁴,  k = 1 − |rp|²
//! Dp(ω) = (1/4π) k²/|ω − rp|⁴                              (SPTD of a uniform base)
//! C = {ω·c ≥ z}:  h = z − c·rp,  m = k c − 2h rp,  w = k (c·rp) − h (1 + |rp|²)
//! P(C) = {ω·c' ≥ z'},  c' = −m/|m|,  z' = −w/|m|
//! ```
//!
//! The pivot is kept as direction and norm so that `m` and `w` can be evaluated without the
//! O(k) cancellation of the textbook form near the pivot's direction ([`Pivot::map_cap`]).
//! Since `|m|² − w² = k² sin²σ`, the two ends of `z'` are taken from the factor that does not
//! cancel: `1 − z' = (|m| + w)/|m| = k² sin²σ / (|m|(|m| − w))` and
//! `1 + z' = (|m| − w)/|m| = k² sin²σ / (|m|(|m| + w))`, the first form when it adds numbers of
//! one sign, the second otherwise. So `P(C)` keeps full precision whether it is a speck or
//! nearly the whole sphere.

use super::cap::{Cap, Cap4};
use crate::lanes::{clamp4, gt_or};
use crate::math;
#[cfg(any(test, feature = "internals"))]
use core::f32::consts::PI;
use glam::Vec3;
use wide::f32x4;

/// Pivots are kept strictly inside the unit ball: `|rp| ≤ MAX_NORM`.
pub const MAX_NORM: f32 = 0.9999;

/// A pivot `rp = R p̂` inside the unit ball.
///
/// Stored as its direction `p̂` and norm `R` with `1 − R` kept exact, because every quantity
/// near the peak of a sharp lobe is a small multiple of `1 − R` (see [`Pivot::map_cap`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pivot {
    /// Unit direction `p̂` (+z for the centre).
    dir: Vec3,
    /// `R = |rp|`.
    norm: f32,
    /// `1 − R`.
    gap: f32,
    /// `k = 1 − R²`.
    k: f32,
    /// `1 + R²`.
    one_plus: f32,
}

impl Pivot {
    /// The pivot at `rp`, scaled back to [`MAX_NORM`] if longer; a non-finite `rp` gives the
    /// centre (the transform is then the antipodal map).
    #[inline]
    #[must_use]
    pub fn new(rp: Vec3) -> Pivot {
        let rp = if rp.is_finite() { rp } else { Vec3::ZERO };
        let r = math::sqrt(rp.x * rp.x + rp.y * rp.y + rp.z * rp.z);
        if r > 0.0 {
            Pivot::from_direction(rp * (1.0 / r), r)
        } else {
            Pivot::from_direction(Vec3::Z, 0.0)
        }
    }

    /// The pivot `norm · dir` for a unit `dir`; `norm` is clamped to `[0, MAX_NORM]` (NaN to
    /// 0), a non-finite `dir` gives the centre.
    #[inline]
    #[must_use]
    pub fn from_direction(dir: Vec3, norm: f32) -> Pivot {
        let (dir, norm) = if dir.is_finite() {
            (dir, norm)
        } else {
            (Vec3::Z, 0.0)
        };
        let r = if norm > 0.0 { norm } else { 0.0 };
        let r = if r < MAX_NORM { r } else { MAX_NORM };
        let gap = 1.0 - r;
        Pivot {
            dir,
            norm: r,
            gap,
            k: gap * (1.0 + r),
            one_plus: 1.0 + r * r,
        }
    }

    /// The pivot point `rp`.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn point(&self) -> Vec3 {
        self.dir * self.norm
    }

    /// The unit direction of the pivot.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn direction(&self) -> Vec3 {
        self.dir
    }

    /// The norm `R`.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn norm(&self) -> f32 {
        self.norm
    }

    /// `k = 1 − |rp|²`.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn k(&self) -> f32 {
        self.k
    }

    /// `|ω − rp|²` and `p̂ − ω`, as `(1 − R)² + R |ω − p̂|²` (no cancellation near p̂).
    #[inline(always)]
    fn dist2(&self, w: Vec3) -> (f32, Vec3) {
        let e = self.dir - w;
        let e2 = e.x * e.x + e.y * e.y + e.z * e.z;
        (self.gap * self.gap + self.norm * e2, e)
    }

    /// `P(ω)` for a unit `ω` (P is an involution).
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn transform(&self, w: Vec3) -> Vec3 {
        let (d2, e) = self.dist2(w);
        if d2 <= 0.0 {
            return w;
        }
        // 1 − ω·rp = (1 − R) + R |ω − p̂|²/2 and rp − ω = (p̂ − ω) − (1 − R) p̂.
        let one_minus_dot = self.gap + 0.5 * self.norm * (e.x * e.x + e.y * e.y + e.z * e.z);
        let t = 2.0 * one_minus_dot / d2;
        w + (e - self.dir * self.gap) * t
    }

    /// The Jacobian `|dP/dω| = k²/|ω − rp|⁴`.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn jacobian(&self, w: Vec3) -> f32 {
        let (d2, _) = self.dist2(w);
        self.k * self.k / (d2 * d2)
    }

    /// `|ω − rp|²` for a unit `ω`, as `(1 − R)² + R |ω − p̂|²` (no cancellation near `p̂`).
    #[inline]
    #[must_use]
    pub fn distance2(&self, w: Vec3) -> f32 {
        self.dist2(w).0
    }

    /// The SPTD density of a uniform base distribution, `Dp(ω) = k²/(4π |ω − rp|⁴)`;
    /// it integrates to 1 over the sphere.
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn density(&self, w: Vec3) -> f32 {
        self.jacobian(w) / (4.0 * PI)
    }

    /// The cap `P(C)` (closed form, stable at both ends; see the module docs).
    ///
    /// With `δ = 1 − c·p̂ = |c − p̂|²/2` and `a = 1 − z`, the map's `m` and `w` are evaluated as
    /// `m = ((1 − R)² + 2Ra − 2R²δ) p̂ + k (c − p̂)` and `w = (1 + R²) a − (1 − R)² − 2Rδ`,
    /// which equal the textbook forms but add no rounding error of order `k` to results of
    /// order `k²` near the pivot's direction.
    #[inline]
    #[must_use]
    pub fn map_cap(&self, cap: &Cap) -> Cap {
        let (p, r, g, k) = (self.dir, self.norm, self.gap, self.k);
        let c = cap.axis;
        let a = cap.one_minus_cos;
        let (ex, ey, ez) = (c.x - p.x, c.y - p.y, c.z - p.z);
        let delta = 0.5 * (ex * ex + ey * ey + ez * ez);
        let g2 = g * g;
        let along = (g2 + 2.0 * r * a) - 2.0 * r * r * delta;
        let mx = along * p.x + k * ex;
        let my = along * p.y + k * ey;
        let mz = along * p.z + k * ez;
        let w = self.one_plus * a - g2 - 2.0 * r * delta;
        let ml = math::sqrt(mx * mx + my * my + mz * mz);
        let ml = if ml > f32::MIN_POSITIVE {
            ml
        } else {
            f32::MIN_POSITIVE
        };
        let k2s2 = k * k * (a * cap.one_plus_cos);
        let (omc, opc) = if w <= 0.0 {
            let big = ml - w;
            (k2s2 / (ml * big), big / ml)
        } else {
            let big = ml + w;
            (big / ml, k2s2 / (ml * big))
        };
        let inv = 1.0 / ml;
        let cos = -w * inv;
        let cos = if cos > -1.0 { cos } else { -1.0 };
        let cos = if cos < 1.0 { cos } else { 1.0 };
        Cap {
            axis: Vec3::new(-mx * inv, -my * inv, -mz * inv),
            cos,
            one_minus_cos: omc,
            one_plus_cos: opc,
        }
    }

    /// The 4-wide twin of [`Pivot::map_cap`].
    #[inline]
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn map_cap4(&self, cap: &Cap4) -> Cap4 {
        Pivot4::new(self).map_cap(cap)
    }
}

/// Four unit directions relative to a pivot's direction `p̂`: `e = ω − p̂` and `|e|²`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Offset4 {
    ex: f32x4,
    ey: f32x4,
    ez: f32x4,
    e2: f32x4,
}

/// A [`Pivot`]'s constants in four lanes, for its 4-wide evaluators (set up once per shading
/// point so that the evaluators load them instead of splatting them at every call).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pivot4 {
    px: f32x4,
    py: f32x4,
    pz: f32x4,
    r: f32x4,
    k: f32x4,
    /// `(1 − R)²`.
    g2: f32x4,
    one_plus: f32x4,
    /// `k²`.
    k2: f32x4,
}

impl Pivot4 {
    #[inline(always)]
    pub(crate) fn new(p: &Pivot) -> Pivot4 {
        Pivot4 {
            px: f32x4::splat(p.dir.x),
            py: f32x4::splat(p.dir.y),
            pz: f32x4::splat(p.dir.z),
            r: f32x4::splat(p.norm),
            k: f32x4::splat(p.k),
            g2: f32x4::splat(p.gap * p.gap),
            one_plus: f32x4::splat(p.one_plus),
            k2: f32x4::splat(p.k * p.k),
        }
    }

    /// [`Pivot::map_cap4`].
    #[inline(always)]
    #[cfg(any(test, feature = "internals"))]
    pub(crate) fn map_cap(&self, cap: &Cap4) -> Cap4 {
        self.map_cap_at(cap, &self.offset(cap.ax, cap.ay, cap.az))
    }

    /// Where the unit directions `(wx, wy, wz)` lie relative to the pivot: what
    /// [`Pivot4::distance2`] and [`Pivot4::map_cap_at`] take.
    #[inline(always)]
    pub(crate) fn offset(&self, wx: f32x4, wy: f32x4, wz: f32x4) -> Offset4 {
        let (ex, ey, ez) = (wx - self.px, wy - self.py, wz - self.pz);
        Offset4 {
            ex,
            ey,
            ez,
            e2: ex * ex + ey * ey + ez * ez,
        }
    }

    /// The 4-wide twin of [`Pivot::distance2`], lane by lane the same operations.
    #[inline(always)]
    pub(crate) fn distance2(&self, off: &Offset4) -> f32x4 {
        self.g2 + self.r * off.e2
    }

    /// [`Pivot4::map_cap`] for caps whose axes have the offset `off` ([`Pivot4::offset`]).
    #[inline(always)]
    pub(crate) fn map_cap_at(&self, cap: &Cap4, off: &Offset4) -> Cap4 {
        let one = f32x4::ONE;
        let two = f32x4::splat(2.0);
        let (px, py, pz) = (self.px, self.py, self.pz);
        let (r, k, g2) = (self.r, self.k, self.g2);
        let a = cap.one_minus_cos;
        let (ex, ey, ez) = (off.ex, off.ey, off.ez);
        let delta = f32x4::splat(0.5) * off.e2;
        let along = (g2 + two * r * a) - two * r * r * delta;
        let mx = along * px + k * ex;
        let my = along * py + k * ey;
        let mz = along * pz + k * ez;
        let w = self.one_plus * a - g2 - two * r * delta;
        let ml = (mx * mx + my * my + mz * mz).sqrt();
        let tiny = f32x4::splat(f32::MIN_POSITIVE);
        let ml = gt_or(ml, tiny);
        let k2s2 = self.k2 * (a * cap.one_plus_cos);
        let neg = w.simd_le(f32x4::ZERO);
        let big = neg.select(ml - w, ml + w);
        let small = k2s2 / (ml * big);
        let ratio = big / ml;
        let inv = one / ml;
        let cos = -w * inv;
        let cos = clamp4(cos, -one, one);
        Cap4 {
            ax: -mx * inv,
            ay: -my * inv,
            az: -mz * inv,
            cos,
            one_minus_cos: neg.select(small, ratio),
            one_plus_cos: neg.select(ratio, small),
        }
    }
}
