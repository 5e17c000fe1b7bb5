//! A minimal f64 3-vector for the geometry of light sampling.
//!
//! Solid angles of small caps and spherical triangles, and the points on them, are computed in
//! f64 so that the pdfs stay exact for lights that are tiny or far away as seen from the shading
//! point; results are rounded to f32 once at the end. (glam's `DVec3` needs a cargo feature the
//! core does not enable.)

use crate::math;
use core::ops::{Add, Mul, Neg, Sub};
use glam::Vec3;

/// A 3-vector of f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct V64 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

impl V64 {
    #[inline]
    pub(super) fn new(x: f64, y: f64, z: f64) -> V64 {
        V64 { x, y, z }
    }

    #[inline]
    pub(super) fn from_f32(v: Vec3) -> V64 {
        V64::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
    }

    /// Rounded to f32 (saturating to ±∞).
    #[inline]
    pub(super) fn to_f32(self) -> Vec3 {
        Vec3::new(self.x as f32, self.y as f32, self.z as f32)
    }

    #[inline]
    pub(super) fn dot(self, o: V64) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline]
    pub(super) fn cross(self, o: V64) -> V64 {
        V64::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    #[inline]
    pub(super) fn length_squared(self) -> f64 {
        self.dot(self)
    }

    #[inline]
    pub(super) fn length(self) -> f64 {
        math::sqrt64(self.length_squared())
    }

    /// The unit vector, or `None` for a zero or non-finite vector.
    #[inline]
    pub(super) fn normalize(self) -> Option<V64> {
        let l = self.length();
        if l > 0.0 && l < f64::INFINITY {
            Some(self * (1.0 / l))
        } else {
            None
        }
    }

    /// Two unit vectors completing the unit `n` to a right-handed orthonormal basis (Duff et
    /// al. 2017, "Building an Orthonormal Basis, Revisited").
    #[inline]
    pub(super) fn basis(self) -> (V64, V64) {
        let n = self;
        let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        (
            V64::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            V64::new(b, sign + n.y * n.y * a, -n.y),
        )
    }
}

impl Add for V64 {
    type Output = V64;
    #[inline]
    fn add(self, o: V64) -> V64 {
        V64::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for V64 {
    type Output = V64;
    #[inline]
    fn sub(self, o: V64) -> V64 {
        V64::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Mul<f64> for V64 {
    type Output = V64;
    #[inline]
    fn mul(self, s: f64) -> V64 {
        V64::new(self.x * s, self.y * s, self.z * s)
    }
}

impl Neg for V64 {
    type Output = V64;
    #[inline]
    fn neg(self) -> V64 {
        V64::new(-self.x, -self.y, -self.z)
    }
}
