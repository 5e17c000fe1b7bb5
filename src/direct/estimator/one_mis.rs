//! One-sample MIS: `tl-mis`, `bl-mis` and `tl-mis-pinf` take light samples from one sampler
//! (the TL tree, the BRDF-oriented cut, or the tree with pbrt-v4's fixed probability for the
//! lights at infinity) and one BSDF sample, weighed by the power heuristic with the counts
//! (Veach 1997, section 9.2).

use super::{next1, next2, BsdfDraw, Estimator, Phase, Role, Step, Weighted};
use crate::direct::sampler::LightSampler;
use crate::direct::{DirectError, Params, Technique, Uniforms, MAX_LIGHT_SAMPLES};
use crate::mis::Factors;
use crate::sample::ONE_MINUS_EPSILON;

/// The number of light samples of a `bl-mis` estimate (1 for every other technique with one
/// light sample and one BSDF sample).
#[inline]
pub(super) fn one_mis_light_samples(technique: Technique, params: &Params) -> u32 {
    if technique == Technique::BlMis {
        params.bl_light_samples.clamp(1, MAX_LIGHT_SAMPLES)
    } else {
        1
    }
}

impl Estimator<'_> {
    /// The next light sample: sample i of k takes its uniform number in [i/k, (i+1)/k), so the
    /// k samples stratify the light choice (k = 1: the number itself). `None` when it has no
    /// light or point.
    pub(super) fn one_mis_light(
        &mut self,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<Option<Step>, DirectError> {
        let k = one_mis_light_samples(self.technique, &self.params);
        let i = self.run.j;
        self.run.j += 1;
        if self.run.j >= k {
            self.run.phase = Phase::OneMisBsdf;
        }
        let v = next1(u)?;
        let uv = next2(u)?;
        let v = if k == 1 {
            v
        } else {
            ((i as f32 + v) / k as f32).min(ONE_MINUS_EPSILON)
        };
        let s = match self.technique {
            Technique::TlMis => self.tl.sample(v),
            Technique::TlMisPinf => self.pinf.as_ref().and_then(|p| p.sample(v)),
            _ => self.bl.as_ref().and_then(|b| b.sample(v)),
        };
        match s {
            Some(s) => self.draw(s.light, s.pmf, uv, Role::OneMis),
            None => Ok(None),
        }
    }

    /// The BSDF sample, the estimate's last.
    pub(super) fn one_mis_bsdf(
        &mut self,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<Step, DirectError> {
        self.run.phase = Phase::Done;
        Ok(Step::Bsdf(BsdfDraw {
            u: next2(u)?,
            p: None,
        }))
    }

    /// The weight of a light sample of density `pdf` (pmf · point pdf) whose direction the
    /// BSDF samples with density `pdf_tb`: k light samples each contribute 1/k of their
    /// estimate, weighed against the one BSDF sample with the counts (k, 1); their density
    /// together is k·pdf.
    pub(super) fn one_mis_weight(&self, pdf: f32, pdf_tb: f32) -> Weighted {
        let k = one_mis_light_samples(self.technique, &self.params) as f32;
        let a = pdf * k;
        if pdf_tb > 0.0 {
            let w = crate::mis::power(k, pdf, &[(1.0, pdf_tb)]);
            Weighted::checked(Factors {
                num: w,
                den: a,
                pdf: a,
            })
        } else {
            Weighted::plain(a)
        }
    }

    /// The weight of the BSDF sample (density `bsdf_pdf`) that reached `light` at a point of
    /// light-sampling density `point_pdf`.
    pub(super) fn one_mis_hit_weight(
        &mut self,
        light: u32,
        point_pdf: f32,
        bsdf_pdf: f32,
    ) -> Weighted {
        let pmf = match self.technique {
            Technique::BlMis => self.pmf_bl(light),
            Technique::TlMisPinf => self.pinf.as_ref().map_or(0.0, |s| s.pmf(light)),
            _ => self.tl.pmf(light),
        };
        let pdf_l = pmf * point_pdf;
        let k = one_mis_light_samples(self.technique, &self.params) as f32;
        let w = crate::mis::power(1.0, bsdf_pdf, &[(k, pdf_l)]);
        Weighted::checked(Factors {
            num: w,
            den: bsdf_pdf,
            pdf: bsdf_pdf,
        })
    }
}
