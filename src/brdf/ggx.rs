//! The GGX (Trowbridge–Reitz) microfacet reflection lobe, isotropic, without Fresnel:
//!
//! ```text
//! D(h)       = 1 / (π α² ((h.x² + h.y²)/α² + h.z²)²)                  (Walter et al. 2007)
//! Λ(w)       = (sqrt(1 + α² tan²θ) − 1) / 2
//! G2(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi))       height-correlated Smith (Heitz 2014, eq. 99)
//! f(wo, wi)  = D(h) G2 / (4 cos θo cos θi) = D(h) / (2 (cos θi·Lo + cos θo·Li)),
//!              L(w) = sqrt(w.z² + α²(w.x² + w.y²))
//! ```
//!
//! Sampling follows Heitz 2018, "Sampling the GGX Distribution of Visible Normals": the view
//! direction is stretched to the α = 1 configuration, a visible normal of the hemisphere is
//! drawn with the disk warp of that paper, unstretched, and wo reflected about it. The pdf of
//! the reflected direction is `G1(wo) D(h) / (4 cos θo) = D(h) / (2 (cos θo + Lo))`; directions
//! that reflect below the horizon are returned as `None` (so the pdf integrates to 1 minus
//! their probability over the upper hemisphere). Writing f and the pdf with L(w) instead of
//! tan θ keeps them finite at grazing angles.

use super::{finite, unit_square, Brdf};
use crate::material::MIN_ALPHA;
use crate::math;
use core::f32::consts::{FRAC_1_PI, TAU};
use glam::Vec3;

/// An isotropic GGX lobe of roughness α.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    alpha: f32,
}

impl Ggx {
    /// A lobe of roughness `alpha` (GGX α, i.e. perceptual roughness squared), clamped into
    /// [[`MIN_ALPHA`], 1]; NaN becomes 1.
    #[must_use]
    pub fn new(alpha: f32) -> Ggx {
        Ggx {
            alpha: if alpha.is_nan() {
                1.0
            } else {
                alpha.clamp(MIN_ALPHA, 1.0)
            },
        }
    }

    /// The (clamped) roughness α.
    #[must_use]
    pub fn alpha(&self) -> f32 {
        self.alpha
    }

    /// The normal distribution D(h) for a unit half vector h (0 below the horizon).
    #[must_use]
    pub fn d(&self, h: Vec3) -> f32 {
        if !(finite(h) && h.z > 0.0) {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let t = (h.x * h.x + h.y * h.y) / a2 + h.z * h.z;
        FRAC_1_PI / (a2 * t * t)
    }

    /// `L(w) = cos θ · sqrt(1 + α² tan² θ)`, so that `1 + Λ(w) = (cos θ + L(w)) / (2 cos θ)`.
    #[inline]
    fn l(&self, w: Vec3) -> f32 {
        math::sqrt(w.z * w.z + self.alpha * self.alpha * (w.x * w.x + w.y * w.y))
    }

    /// Smith's masking term G1(w) = 1 / (1 + Λ(w)) (0 at or below the horizon).
    #[must_use]
    pub fn g1(&self, w: Vec3) -> f32 {
        if !(finite(w) && w.z > 0.0) {
            return 0.0;
        }
        2.0 * w.z / (w.z + self.l(w))
    }

    /// The height-correlated masking-shadowing term G2(wo, wi) = 1 / (1 + Λ(wo) + Λ(wi)).
    #[must_use]
    pub fn g2(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !(finite(wo) && finite(wi) && wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        2.0 * wo.z * wi.z / (wi.z * self.l(wo) + wo.z * self.l(wi))
    }

    /// The unit half vector of two directions above the horizon.
    #[inline]
    fn half(wo: Vec3, wi: Vec3) -> Option<Vec3> {
        if finite(wo) && finite(wi) && wo.z > 0.0 && wi.z > 0.0 {
            math::try_normalize(wo + wi)
        } else {
            None
        }
    }
}

impl Brdf for Ggx {
    fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        let f = self.d(h) / (2.0 * (wi.z * self.l(wo) + wo.z * self.l(wi)));
        if f.is_finite() {
            f
        } else {
            0.0
        }
    }

    fn sample(&self, wo: Vec3, u: [f32; 2]) -> Option<(Vec3, f32)> {
        let u = unit_square(u)?;
        if !(finite(wo) && wo.z > 0.0) {
            return None;
        }
        let a = self.alpha;
        // Stretch the view direction to the hemisphere configuration (α = 1).
        let vh = math::try_normalize(Vec3::new(a * wo.x, a * wo.y, wo.z))?;
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / math::sqrt(len2)
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        // A point of the projected visible hemisphere: a disk whose lower half is squashed.
        let r = math::sqrt(u[0]);
        let (sp, cp) = math::sin_cos(TAU * u[1]);
        let p1 = r * cp;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * math::sqrt((1.0 - p1 * p1).max(0.0)) + s * (r * sp);
        let nh = t1 * p1 + t2 * p2 + vh * math::sqrt((1.0 - p1 * p1 - p2 * p2).max(0.0));
        // Unstretch to the microfacet normal, and reflect.
        let m = math::try_normalize(Vec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)))?;
        let wi = math::normalize(m * (2.0 * wo.dot(m)) - wo);
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0 && pdf < f32::INFINITY).then_some((wi, pdf))
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = Self::half(wo, wi) else {
            return 0.0;
        };
        let p = self.d(h) / (2.0 * (wo.z + self.l(wo)));
        if p.is_finite() {
            p
        } else {
            0.0
        }
    }
}
