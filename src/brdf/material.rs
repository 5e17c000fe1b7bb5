//! [`Brdf`] for [`Material`]: `f = albedo/π + specular · GGX(α)`, sampled by picking the GGX
//! lobe with probability `specular / (albedo + specular)` (else the cosine lobe) with the first
//! uniform number warped back into [0, 1), and the pdf of the whole mixture. The scalar
//! [`Brdf::eval`], the sampling and the pdf use the albedo's luminance;
//! [`Material::eval_rgb`] is f in colour.

use super::{finite, Brdf, Ggx, Lambert};
use crate::colour::Rgb;
use crate::material::Material;
use glam::Vec3;

/// `(albedo, specular, GGX)` with the weights clamped into [0, 1] (NaN → 0).
fn lobes(m: &Material) -> (f32, f32, Ggx) {
    let (albedo, specular, alpha) = m.lobes();
    let w = |v: f32| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (w(albedo), w(specular), Ggx::new(alpha))
}

/// Probability of sampling the GGX lobe; `None` when the material reflects nothing.
fn p_specular(albedo: f32, specular: f32) -> Option<f32> {
    let total = albedo + specular;
    (total > 0.0).then(|| specular / total)
}

/// A weight clamped into [0, 1] (NaN → 0).
#[inline]
fn unit_weight(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

impl Material {
    /// f(ωo, ωi) per channel (local frame, as [`Brdf::eval`]): channel c is what
    /// [`Brdf::eval`] gives for a material of albedo channel c, operation for operation (so a
    /// grey material gives [`Brdf::eval`] in every channel).
    #[must_use]
    pub fn eval_rgb(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let (albedo, specular, alpha) = self.colour_lobes();
        let specular = unit_weight(specular);
        let glossy = (specular > 0.0).then(|| specular * Ggx::new(alpha).eval(wo, wi));
        albedo.map(|a| {
            let a = unit_weight(a);
            let mut f = 0.0;
            if a > 0.0 {
                f += Lambert::new(a).eval(wo, wi);
            }
            if let Some(g) = glossy {
                f += g;
            }
            f
        })
    }
}

impl Brdf for Material {
    /// f with the albedo's luminance in place of the albedo: one scalar, what the importances
    /// and the lobe choice use (for a grey albedo, f in every channel). f in colour, what the
    /// estimators multiply by, is [`Material::eval_rgb`].
    fn eval(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (albedo, specular, ggx) = lobes(self);
        let mut f = 0.0;
        if albedo > 0.0 {
            f += Lambert::new(albedo).eval(wo, wi);
        }
        if specular > 0.0 {
            f += specular * ggx.eval(wo, wi);
        }
        f
    }

    fn sample(&self, wo: Vec3, u: [f32; 2]) -> Option<(Vec3, f32)> {
        let (albedo, specular, ggx) = lobes(self);
        let ps = p_specular(albedo, specular)?;
        if u[0].is_nan() || !finite(wo) {
            return None;
        }
        let wi = if u[0] < ps {
            ggx.sample(wo, [u[0] / ps, u[1]])?.0
        } else {
            Lambert::new(1.0)
                .sample(wo, [(u[0] - ps) / (1.0 - ps), u[1]])?
                .0
        };
        let pdf = self.pdf(wo, wi);
        (pdf > 0.0 && pdf < f32::INFINITY).then_some((wi, pdf))
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (albedo, specular, ggx) = lobes(self);
        let Some(ps) = p_specular(albedo, specular) else {
            return 0.0;
        };
        let mut p = 0.0;
        if ps > 0.0 {
            p += ps * ggx.pdf(wo, wi);
        }
        if ps < 1.0 {
            p += (1.0 - ps) * Lambert::new(1.0).pdf(wo, wi);
        }
        p
    }
}
