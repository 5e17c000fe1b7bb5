//! An orthonormal shading frame built from a normal (Duff et al. 2017, "Building an
//! Orthonormal Basis, Revisited").

use crate::math;
use glam::Vec3;

/// A right-handed orthonormal frame; local coordinates have the normal along +z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Local +x.
    pub tangent: Vec3,
    /// Local +y.
    pub bitangent: Vec3,
    /// Local +z.
    pub normal: Vec3,
}

impl Frame {
    /// The frame around `normal` (need not be unit length; normalised in f64 so that tiny and
    /// huge vectors work). `None` for a zero or non-finite normal.
    pub fn from_normal(normal: Vec3) -> Option<Frame> {
        let v = [normal.x, normal.y, normal.z].map(f64::from);
        let l = math::sqrt64(math::sq(v[0]) + math::sq(v[1]) + math::sq(v[2]));
        if !(l > 0.0 && l < f64::INFINITY) {
            return None;
        }
        let n = math::normalize(Vec3::new(
            (v[0] / l) as f32,
            (v[1] / l) as f32,
            (v[2] / l) as f32,
        ));
        let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Some(Frame {
            tangent: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            bitangent: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            normal: n,
        })
    }

    /// World → local coordinates.
    #[inline]
    #[must_use]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(
            v.dot(self.tangent),
            v.dot(self.bitangent),
            v.dot(self.normal),
        )
    }

    /// Local → world coordinates.
    #[inline]
    #[must_use]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.tangent * v.x + self.bitangent * v.y + self.normal * v.z
    }
}
