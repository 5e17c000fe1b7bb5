//! The single-sample techniques: `uniform`, `power`, `tl` and `bl` take one light sample and
//! weigh it alone (weight 1, density pmf · point pdf).

use super::{next1, next2, next64, Estimator, Role, Step};
use crate::direct::sampler::{EnergySampler, LightSampler, UniformSampler};
use crate::direct::{DirectError, Technique, Uniforms};

impl Estimator<'_> {
    /// The one light sample of `uniform`, `power`, `tl` or `bl` (`None`: no light can
    /// contribute, or the technique is of another family).
    pub(super) fn single_sample(
        &mut self,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<Option<Step>, DirectError> {
        let s = match self.technique {
            Technique::Uniform => {
                let v = next64(u)?;
                UniformSampler::new(self.set.len() as u32).sample_f64(v)
            }
            Technique::Energy => {
                let v = next64(u)?;
                EnergySampler::new(self.set).sample_f64(v)
            }
            Technique::Tl => self.tl.sample(next1(u)?),
            Technique::Bl => {
                let v = next1(u)?;
                self.bl.as_ref().and_then(|b| b.sample(v))
            }
            _ => None,
        };
        match s {
            // The only light sample, if it has a point.
            Some(s) => {
                let uv = next2(u)?;
                Ok(Some(
                    self.draw(s.light, s.pmf, uv, Role::Plain)?
                        .unwrap_or(Step::Done),
                ))
            }
            None => Ok(None),
        }
    }
}
