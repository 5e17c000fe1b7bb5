//! The Lambertian lobe `f = albedo / π`, cosine-sampled: a point of the unit disk by the
//! concentric map (Shirley & Chiu, "A Low Distortion Map Between Disk and Square", 1997) lifted
//! to the hemisphere (Malley's method), pdf = cos θi / π.

use super::{finite, unit_square, Brdf};
use crate::math;
use core::f32::consts::FRAC_1_PI;
use glam::Vec3;

/// A Lambertian (perfectly diffuse) reflector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert {
    albedo: f32,
}

impl Lambert {
    /// A diffuse lobe of the given albedo, clamped into [0, 1] (NaN becomes 0).
    #[must_use]
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
    #[must_use]
    pub fn albedo(&self) -> f32 {
        self.albedo
    }
}

/// Shirley–Chiu concentric map of [0, 1)² onto the unit disk (the disk lights' f64 map).
fn concentric(u: [f32; 2]) -> (f32, f32) {
    let (x, y) = crate::light::point::disk::concentric([f64::from(u[0]), f64::from(u[1])]);
    (x as f32, y as f32)
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
        let wi = math::normalize(Vec3::new(x, y, z));
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
