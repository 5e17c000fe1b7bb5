//! The Lambertian lobe `f = albedo / π`, cosine-sampled: a point of the unit disk by the
//! concentric map (Shirley & Chiu, "A Low Distortion Map Between Disk and Square", 1997) lifted
//! to the hemisphere (Malley's method), pdf = cos θi / π.

use super::{finite, unit_square, Brdf};
use crate::math;
use core::f32::consts::{FRAC_1_PI, FRAC_PI_4};
use glam::Vec3;

/// A Lambertian (perfectly diffuse) reflector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert {
    albedo: f32,
}

impl Lambert {
    /// A diffuse lobe of the given albedo, clamped into [0, 1] (NaN becomes 0).
    pub fn new(albedo: f32) -> Lambert {
        Lambert {
            albedo: if albedo.is_nan() {
                0.0
            } else {
                albedo.clamp(0.0, 1.0)
            },
        }
    }

    /// The albedo.
    pub fn albedo(&self) -> f32 {
        self.albedo
    }
}

/// Shirley–Chiu concentric map of [0, 1)² onto the unit disk.
fn concentric(u: [f32; 2]) -> (f32, f32) {
    let (a, b) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, FRAC_PI_4 * (b / a))
    } else {
        (b, 2.0 * FRAC_PI_4 - FRAC_PI_4 * (a / b))
    };
    let (s, c) = math::sin_cos(phi);
    (r * c, r * s)
}

impl Brdf for Lambert {
    fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        if finite(wo) && finite(wi) && wo.z > 0.0 && wi.z > 0.0 {
            self.albedo * FRAC_1_PI
        } else {
            0.0
        }
    }

    fn sample(&self, wo: Vec3, u: [f32; 2]) -> Option<(Vec3, f32)> {
        let u = unit_square(u)?;
        if !(finite(wo) && wo.z > 0.0) {
            return None;
        }
        let (x, y) = concentric(u);
        let z = math::sqrt((1.0 - x * x - y * y).max(0.0));
        let wi = Vec3::new(x, y, z).normalize();
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0).then_some((wi, pdf))
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if finite(wo) && finite(wi) && wo.z > 0.0 && wi.z > 0.0 {
            wi.z * FRAC_1_PI
        } else {
            0.0
        }
    }
}
