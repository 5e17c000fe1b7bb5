//! Spatial and orientation bounds of lights and clusters: boxes, bounding spheres and
//! orientation cones (Conty & Kulla, "Orientation bounds"), with the cone union and the
//! orientation measure M_Ω used by the SAOH build.

use crate::math::{self, Exact, Fast, Trig};
use bytemuck::Zeroable;
use core::f32::consts::{FRAC_PI_2, PI};
use glam::{Vec3, Vec3A};

/// Axis-aligned bounding box, held in 16-byte lanes so unions are one SIMD min and max. An
/// empty box has `min > max`.
#[derive(Clone, Copy, Debug, PartialEq, Zeroable)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3A,
    /// Upper corner.
    pub max: Vec3A,
}

impl Aabb {
    /// The empty box (the identity of [`Aabb::union`]).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3A::splat(f32::INFINITY),
        max: Vec3A::splat(f32::NEG_INFINITY),
    };

    /// The box with corners `min` and `max`.
    #[must_use]
    pub fn new(min: Vec3, max: Vec3) -> Aabb {
        Aabb {
            min: min.into(),
            max: max.into(),
        }
    }

    /// The box of one point.
    #[must_use]
    pub fn point(p: Vec3) -> Aabb {
        Aabb::new(p, p)
    }

    /// Smallest box holding both.
    #[inline(always)]
    #[must_use]
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Smallest box holding `self` and `p`.
    #[inline(always)]
    #[must_use]
    pub fn grow(self, p: Vec3) -> Aabb {
        let p = Vec3A::from(p);
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// [`Aabb::grow`] by a point in a 16-byte lane.
    #[inline(always)]
    pub(crate) fn grow_a(self, p: Vec3A) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// [`Aabb::center`] in a 16-byte lane.
    #[inline(always)]
    pub(crate) fn center_a(&self) -> Vec3A {
        (self.min + self.max) * 0.5
    }

    /// True when the box holds no point.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// `max - min` (zero for an empty box).
    #[inline]
    #[must_use]
    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3A::ZERO).into()
    }

    /// Centre of the box.
    #[inline]
    #[must_use]
    pub fn center(&self) -> Vec3 {
        ((self.min + self.max) * 0.5).into()
    }

    /// The spatial measure M_A of the SAOH: surface area, or the diagonal length for a box of
    /// zero area (points on a line or a single point), so that such clusters still compare.
    #[inline]
    #[must_use]
    pub fn measure(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        let area = 2.0 * (e.x * e.y + e.y * e.z + e.z * e.x);
        if area > 0.0 {
            area
        } else {
            math::length(e)
        }
    }
}

/// An orientation cone: every emitting normal lies within `theta_o` of `axis`, and each point
/// emits within `theta_e` of its normal. Angles in radians, `theta_o` in [0, π],
/// `theta_e` in [0, π/2].
#[derive(Clone, Copy, Debug, PartialEq, Zeroable)]
pub struct Cone {
    /// Unit axis.
    pub axis: Vec3,
    /// Normal spread θo.
    pub theta_o: f32,
    /// Emission spread θe.
    pub theta_e: f32,
}

/// The angle between two unit vectors, accurate also when they are nearly (anti)parallel,
/// where `acos` of the dot product loses half the digits.
pub(crate) fn angle_between(a: Vec3, b: Vec3) -> f32 {
    angle_with::<Exact>(a, b)
}

#[inline]
fn angle_with<T: Trig>(a: Vec3, b: Vec3) -> f32 {
    T::atan2(math::length(a.cross(b)), a.dot(b))
}

/// Angle added to a union's θo to absorb the rounding of the rotated axis (radians).
const UNION_SLACK: f32 = 2e-6;

impl Cone {
    /// The cone of an omnidirectional emitter (θo = π, θe = π/2).
    pub const SPHERE: Cone = Cone {
        axis: Vec3::Z,
        theta_o: PI,
        theta_e: FRAC_PI_2,
    };

    /// True when the normals may point anywhere.
    #[inline]
    #[must_use]
    pub fn is_sphere(&self) -> bool {
        self.theta_o >= PI
    }

    /// Smallest cone (by the construction of docs/formulas.md, section 2) holding both.
    #[must_use]
    pub fn union(self, b: Cone) -> Cone {
        self.union_with::<Exact>(b)
    }

    /// [`Cone::union`] with polynomial trigonometry: for the SAOH's bucket estimates only.
    #[inline]
    pub(crate) fn union_fast(self, b: Cone) -> Cone {
        self.union_with::<Fast>(b)
    }

    #[inline]
    fn union_with<T: Trig>(self, b: Cone) -> Cone {
        let theta_e = self.theta_e.max(b.theta_e);
        if self.is_sphere() || b.is_sphere() {
            return Cone {
                axis: Vec3::Z,
                theta_o: PI,
                theta_e,
            };
        }
        let (big, small) = if self.theta_o >= b.theta_o {
            (self, b)
        } else {
            (b, self)
        };
        let cos_d = big.axis.dot(small.axis);
        let d = angle_with::<T>(big.axis, small.axis);
        if (d + small.theta_o).min(PI) <= big.theta_o {
            return Cone { theta_e, ..big };
        }
        let theta_o = (big.theta_o + small.theta_o + d) * 0.5;
        if theta_o >= PI {
            return Cone {
                axis: Vec3::Z,
                theta_o: PI,
                theta_e,
            };
        }
        // Rotate big.axis towards small.axis by theta_o - big.theta_o.
        let phi = theta_o - big.theta_o;
        let perp = small.axis - big.axis * cos_d;
        let perp = if perp.length_squared() > 1e-12 {
            math::normalize(perp)
        } else {
            big.axis.any_orthonormal_vector()
        };
        let (s, c) = T::sin_cos(phi);
        let axis = math::normalize(big.axis * c + perp * s);
        // Nearly opposite axes leave `perp` to f32 cancellation and the rotated axis off the
        // great circle through both: widen θo to what the axis really needs where the slack
        // does not cover it, so the union always contains both cones.
        let need = (angle_with::<T>(axis, big.axis) + big.theta_o)
            .max(angle_with::<T>(axis, small.axis) + small.theta_o);
        let theta_o = if need > theta_o + UNION_SLACK {
            need
        } else {
            theta_o
        };
        Cone {
            axis,
            theta_o: (theta_o + UNION_SLACK).min(PI),
            theta_e,
        }
    }

    /// Whether `self` contains `inner` within `tol` radians.
    #[must_use]
    pub fn contains(&self, inner: &Cone, tol: f32) -> bool {
        if inner.theta_e > self.theta_e + tol {
            return false;
        }
        if self.theta_o + tol >= PI {
            return true;
        }
        angle_between(self.axis, inner.axis) + inner.theta_o <= self.theta_o + tol
    }

    /// The orientation measure M_Ω of the SAOH (Conty & Kulla):
    /// `2π(1 − cos θo) + π/2 · (2 θw sin θo − cos(θo − 2θw) − 2 θo sin θo + cos θo)`,
    /// `θw = min(θo + θe, π)`.
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn measure(&self) -> f32 {
        self.measure_with::<Exact>()
    }

    /// [`Cone::measure`] with polynomial trigonometry: for the SAOH's bucket estimates only.
    #[inline]
    pub(crate) fn measure_fast(&self) -> f32 {
        self.measure_with::<Fast>()
    }

    #[inline]
    fn measure_with<T: Trig>(&self) -> f32 {
        if self.is_sphere() {
            // θw = π, sin θo = 0, cos(θo − 2θw) = cos(−π) = −1: the whole sphere.
            return 4.0 * PI;
        }
        let theta_o = self.theta_o;
        let theta_w = (theta_o + self.theta_e).min(PI);
        let (sin_o, cos_o) = T::sin_cos(theta_o);
        let cos_ow = T::sin_cos(theta_o - 2.0 * theta_w).1;
        2.0 * PI * (1.0 - cos_o)
            + FRAC_PI_2 * (2.0 * theta_w * sin_o - cos_ow - 2.0 * theta_o * sin_o + cos_o)
    }
}

/// A bounding sphere.
#[derive(Clone, Copy, Debug, PartialEq, Zeroable)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (≥ 0).
    pub radius: f32,
}

impl Sphere {
    /// Whether `self` contains `inner`, with absolute slack `tol`.
    #[must_use]
    pub fn contains(&self, inner: &Sphere, tol: f32) -> bool {
        let d = math::sq(f64::from(self.center.x - inner.center.x))
            + math::sq(f64::from(self.center.y - inner.center.y))
            + math::sq(f64::from(self.center.z - inner.center.z));
        math::sqrt64(d) + f64::from(inner.radius) <= f64::from(self.radius) + f64::from(tol)
    }

    /// A sphere containing every sphere of `spheres` (finite): centred on the middle of their
    /// bounding box, with the radius computed in f64 and rounded outwards. The zero sphere for
    /// an empty slice.
    #[must_use]
    pub fn enclosing(spheres: &[Sphere]) -> Sphere {
        let Some(first) = spheres.first() else {
            return Sphere {
                center: Vec3::ZERO,
                radius: 0.0,
            };
        };
        let (mut lo, mut hi) = (first.center, first.center);
        for s in spheres {
            lo = lo.min(s.center - Vec3::splat(s.radius));
            hi = hi.max(s.center + Vec3::splat(s.radius));
        }
        let center = lo * 0.5 + hi * 0.5;
        let mut r = 0.0f64;
        for s in spheres {
            let d = math::sq(f64::from(s.center.x) - f64::from(center.x))
                + math::sq(f64::from(s.center.y) - f64::from(center.y))
                + math::sq(f64::from(s.center.z) - f64::from(center.z));
            r = r.max(math::sqrt64(d) + f64::from(s.radius));
        }
        Sphere {
            center,
            radius: crate::math::outward(r),
        }
    }
}

/// Everything the tree keeps about one light or one cluster of lights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    /// Box of the emitting geometry.
    pub aabb: Aabb,
    /// A sphere holding the emitting geometry (tight for single lights).
    pub sphere: Sphere,
    /// Orientation cone.
    pub cone: Cone,
    /// Energy (an upper bound of, and proportional to, the emitted power).
    pub energy: f32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measure_of_hemisphere_emitter() {
        // A one-sided planar emitter (θo = 0, θe = π/2): θw = π/2,
        // M = 0 + π/2 (0 − cos(−π) − 0 + 1) = π.
        let c = Cone {
            axis: Vec3::Z,
            theta_o: 0.0,
            theta_e: FRAC_PI_2,
        };
        assert!((c.measure() - PI).abs() < 1e-5, "{}", c.measure());
        assert_eq!(Cone::SPHERE.measure(), 4.0 * PI);
    }

    #[test]
    fn measure_is_monotone_in_theta_o() {
        let mut prev = 0.0;
        for i in 0..=100 {
            let c = Cone {
                axis: Vec3::Z,
                theta_o: PI * i as f32 / 100.0,
                theta_e: 0.3,
            };
            let m = c.measure();
            assert!(m + 1e-4 >= prev, "i={i}: {m} < {prev}");
            prev = m;
        }
    }

    #[test]
    fn union_contains_both() {
        let mut seed = 1u32;
        let mut rnd = || {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            (seed >> 8) as f32 / (1u32 << 24) as f32
        };
        for _ in 0..10_000 {
            let mut cone = || {
                let z = 2.0 * rnd() - 1.0;
                let phi = 2.0 * PI * rnd();
                let s = math::sin_from_cos(z);
                Cone {
                    axis: Vec3::new(s * math::cos(phi), s * math::sin(phi), z).normalize(),
                    theta_o: if rnd() < 0.3 { 0.0 } else { PI * rnd() * rnd() },
                    theta_e: FRAC_PI_2 * rnd(),
                }
            };
            let (a, b) = (cone(), cone());
            let u = a.union(b);
            assert!(u.contains(&a, 1e-5), "{a:?} ∪ {b:?} = {u:?}");
            assert!(u.contains(&b, 1e-5), "{a:?} ∪ {b:?} = {u:?}");
            let w = u.theta_o.max(a.theta_o).max(b.theta_o);
            assert!(u.theta_o <= w + 1e-5);
        }
    }

    #[test]
    fn antiparallel_cones() {
        let a = Cone {
            axis: Vec3::Z,
            theta_o: 0.2,
            theta_e: 0.1,
        };
        let b = Cone {
            axis: -Vec3::Z,
            theta_o: 0.2,
            theta_e: 0.3,
        };
        let u = a.union(b);
        assert!(u.contains(&a, 1e-5) && u.contains(&b, 1e-5), "{u:?}");
        assert_eq!(u.theta_e, 0.3);
    }
}
