//! Split sampling and the BRDF-aware mixtures of Liu et al. 2019: `tl-split` takes one TL
//! sample in each cluster of a split cut (and one of each light at infinity); `mis-equal` adds
//! N BRDF-aware samples, half BL and half BSDF (TB), weighed with fixed weights (their
//! section 5); `full` allocates its N samples between BL and TB adaptively (Algorithm 1) with
//! sequential weights. Per-light pmfs are remembered at the shading point ([`PmfCache`]).

use super::{next1, next2, BsdfDraw, Estimator, Phase, Role, Step, Weighted};
use crate::cut::CUT_CAPACITY;
use crate::direct::sampler::LightSampler;
use crate::direct::{DirectError, Technique, Uniforms};
use crate::importance::Importance;
use crate::mis::{CombinedWeights, Factors, Mixture, SequentialWeights};
use crate::sample::ONE_MINUS_EPSILON;

/// Per-light pmfs remembered at one shading point (direct-mapped): an estimate queries the
/// same few lights again and again, and the pmfs are fixed functions of the light there.
/// (It caches whole pmfs of lights; [`crate::Memo`] caches node importances of a descent.)
/// A slot holds a pmf only where its bit is set in the table's mask, so that forgetting them
/// all at a new point is clearing two words.
#[derive(Clone, Debug)]
pub(super) struct PmfCache {
    tl: PmfTable,
    bl: PmfTable,
}

/// One table of a [`PmfCache`]: the slots, and the mask of those that hold a pmf.
#[derive(Clone, Debug)]
struct PmfTable {
    slots: [(u32, f32); CACHE_SLOTS],
    filled: u64,
}

/// Slots of each cache table (at most 64: one bit each in [`PmfTable::filled`]).
const CACHE_SLOTS: usize = 64;

impl PmfCache {
    pub(super) const EMPTY: PmfCache = PmfCache {
        tl: PmfTable {
            slots: [(u32::MAX, 0.0); CACHE_SLOTS],
            filled: 0,
        },
        bl: PmfTable {
            slots: [(u32::MAX, 0.0); CACHE_SLOTS],
            filled: 0,
        },
    };

    /// Forgets every pmf (what [`PmfCache::EMPTY`] holds).
    #[inline]
    pub(super) fn clear(&mut self) {
        self.tl.filled = 0;
        self.bl.filled = 0;
    }

    #[inline]
    fn get(table: &mut PmfTable, light: u32, f: impl FnOnce() -> f32) -> f32 {
        let i = light as usize % CACHE_SLOTS;
        let bit = 1u64 << i;
        let slot = &mut table.slots[i];
        if table.filled & bit == 0 || slot.0 != light {
            *slot = (light, f());
            table.filled |= bit;
        }
        slot.1
    }
}

impl Estimator<'_> {
    /// Draws the split samples and moves to the first phase that yields them: the split
    /// samples first (`tl-split`, `mis-equal`, and `full` without BRDF-aware samples), or the
    /// mixture first (`full`).
    pub(super) fn begin_split(
        &mut self,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<(), DirectError> {
        self.draw_split(u)?;
        self.run.phase = if self.technique == Technique::Full && self.n_mix > 0 {
            Phase::Mixture
        } else {
            Phase::TlFirst
        };
        Ok(())
    }

    /// The next split sample before the mixture; then the mixture (`mis-equal` with BRDF-aware
    /// samples) or the end.
    pub(super) fn tl_first(&mut self) -> Result<Option<Step>, DirectError> {
        if let Some(d) = self.next_split()? {
            return Ok(Some(d));
        }
        let mixture = self.technique == Technique::MisEqual && self.n_mix > 0 && self.bl.is_some();
        self.run.phase = if mixture { Phase::Mixture } else { Phase::Done };
        Ok(None)
    }

    /// The next split sample after the mixture (`full`); then the end.
    pub(super) fn tl_last(&mut self) -> Result<Option<Step>, DirectError> {
        if let Some(d) = self.next_split()? {
            return Ok(Some(d));
        }
        self.run.phase = Phase::Done;
        Ok(None)
    }

    /// The next BRDF-aware sample, or the phase after the last (the split samples for `full`,
    /// the end for `mis-equal`).
    pub(super) fn mixture(
        &mut self,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<Option<Step>, DirectError> {
        if self.run.j >= self.n_mix {
            self.run.phase = if self.technique == Technique::Full {
                Phase::TlLast
            } else {
                Phase::Done
            };
            return Ok(None);
        }
        self.mixture_step(u)
    }

    /// The weight of a split sample of `light` of density `pdf` (its point's density
    /// `point_pdf`), whose direction the BSDF samples with density `pdf_tb`.
    pub(super) fn split_weight(
        &mut self,
        light: u32,
        pdf: f32,
        point_pdf: f32,
        pdf_tb: f32,
    ) -> Weighted {
        match self.technique {
            Technique::MisEqual => {
                let pdf_bl = if self.n_mix > 0 && self.bl_on() {
                    self.pmf_bl(light) * point_pdf
                } else {
                    0.0
                };
                let (w_tl, _) = self.combined().weights(pdf, pdf_bl, pdf_tb);
                Weighted::checked(Factors {
                    num: w_tl,
                    den: pdf,
                    pdf,
                })
            }
            Technique::Full if self.n_mix > 0 => {
                let pdf_bl = if self.bl_on() {
                    self.pmf_bl(light) * point_pdf
                } else {
                    0.0
                };
                let w = self.run.sw.tl_weight(pdf, pdf_bl, pdf_tb);
                Weighted::checked(Factors {
                    num: w,
                    den: pdf,
                    pdf,
                })
            }
            _ => Weighted::plain(pdf),
        }
    }

    /// The weight of a BL sample of the mixture, drawn with BL probability `p` and of BL pmf
    /// `pmf_bl`, its point's density `point_pdf`.
    pub(super) fn mixture_bl_weight(
        &mut self,
        light: u32,
        p: f32,
        pmf_bl: f32,
        point_pdf: f32,
        pdf_tb: f32,
    ) -> Weighted {
        let pdf_bl = pmf_bl * point_pdf;
        let pdf_tl = self.pmf_tl(light) * point_pdf;
        self.mixture_weight(p, pdf_tl, pdf_bl, pdf_tb)
    }

    /// The weight of a BSDF sample of the mixture (BL probability `p`, BSDF density
    /// `bsdf_pdf`) that reached `light` at a point of light-sampling density `point_pdf`.
    pub(super) fn mixture_hit_weight(
        &mut self,
        p: f32,
        light: u32,
        point_pdf: f32,
        bsdf_pdf: f32,
    ) -> Weighted {
        let pdf_tl = self.pmf_tl(light) * point_pdf;
        let pdf_bl = if self.uses_bl(p) {
            self.pmf_bl(light) * point_pdf
        } else {
            0.0
        };
        self.mixture_weight(p, pdf_tl, pdf_bl, bsdf_pdf)
    }

    /// Whether BL takes part in the BRDF-aware mixture.
    #[inline]
    pub(super) fn bl_on(&self) -> bool {
        self.bl.is_some() && (self.technique != Technique::Full || self.bl_in_full)
    }

    /// The fixed weights of `mis-equal`.
    #[inline]
    pub(super) fn combined(&self) -> CombinedWeights {
        CombinedWeights {
            n_tl: 1.0,
            n_mixture: self.n_mix as f32,
            p_ref: if self.bl.is_some() { 0.5 } else { 0.0 },
            heuristic: self.params.heuristic,
        }
    }

    /// The pmf of `light` within its cluster of the split cut (0 if in none), remembered; a
    /// light at infinity is a cluster of its own (1 where its TL importance is positive).
    #[inline]
    pub(super) fn pmf_tl(&mut self, light: u32) -> f32 {
        let (split, tl) = (&self.split, &self.tl);
        PmfCache::get(&mut self.pmfs.tl, light, || {
            let tree = tl.tree();
            if let Some(i) = tree.infinite_entry(light) {
                let e = &tree.infinite_lights()[i];
                return if tl.importance().eval_infinite(e) > 0.0 {
                    1.0
                } else {
                    0.0
                };
            }
            split
                .pmf_in(tree, tl.importance(), light)
                .map_or(0.0, |(_, p)| p)
        })
    }

    /// The pmf of `light` through the BRDF-oriented cut (0 without one), remembered.
    #[inline]
    pub(super) fn pmf_bl(&mut self, light: u32) -> f32 {
        let Some(bl) = &self.bl else {
            return 0.0;
        };
        PmfCache::get(&mut self.pmfs.bl, light, || bl.pmf(light))
    }

    /// Draws the split samples' lights: all uniform numbers first, then the descents together.
    pub(super) fn draw_split(
        &mut self,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<(), DirectError> {
        // The node tree's clusters here; the lights at infinity below.
        let m = self.split.tree_clusters().len();
        let mut us = [0f32; CUT_CAPACITY];
        let mut uvs = [[0f32; 2]; CUT_CAPACITY];
        for i in 0..m {
            us[i] = next1(u)?;
            uvs[i] = next2(u)?;
        }
        let mut chosen = [None; CUT_CAPACITY];
        self.split.sample_each(
            self.tl.tree(),
            self.tl.importance(),
            &us[..m],
            &mut chosen[..m],
        );
        let mut n = 0;
        for i in 0..m {
            if let Some(s) = chosen[i] {
                self.run.tl[n] = (s.light, s.pmf, uvs[i]);
                n += 1;
            }
        }
        // Each light at infinity is a cluster of its own, sampled where it may contribute.
        let tree = self.tl.tree();
        for e in tree.infinite_lights() {
            if self.tl.importance().eval_infinite(e) > 0.0 {
                self.run.tl[n] = (e.light, 1.0, next2(u)?);
                n += 1;
            }
        }
        self.run.tl_len = n;
        self.run.tl_next = 0;
        Ok(())
    }

    /// The next split sample with a point, if any is left.
    pub(super) fn next_split(&mut self) -> Result<Option<Step>, DirectError> {
        while self.run.tl_next < self.run.tl_len {
            let (light, pmf, uv) = self.run.tl[self.run.tl_next];
            self.run.tl_next += 1;
            if let Some(d) = self.draw(light, pmf, uv, Role::Split)? {
                return Ok(Some(d));
            }
        }
        Ok(None)
    }

    /// Settles a BSDF sample of the mixture that was never reported: its ray reached nothing.
    #[inline]
    pub(super) fn settle_pending(&mut self) {
        if let Some(p) = self.run.pending_tb.take() {
            self.run.alloc.record_tb(false);
            self.run.sw.record(p);
        }
    }

    /// The j-th BRDF-aware sample: a BL light sample, a BSDF sample, or nothing (a BL sample
    /// without a light or point).
    pub(super) fn mixture_step(
        &mut self,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<Option<Step>, DirectError> {
        let j = self.run.j;
        self.run.j += 1;
        let (technique, warped, p) = if self.technique == Technique::Full {
            let (t, w, p) = self.run.alloc.choose(next1(u)?);
            (t, w, p)
        } else {
            // ⌊N/2⌋ BL, ⌊N/2⌋ TB, and for an odd N one more, BL or TB with probability 1/2.
            let half = self.n_mix / 2;
            let v = next1(u)?;
            if j < half {
                (Mixture::Bl, v, 0.5)
            } else if j < 2 * half {
                (Mixture::Tb, v, 0.5)
            } else if v < 0.5 {
                (Mixture::Bl, 2.0 * v, 0.5)
            } else {
                (Mixture::Tb, (2.0 * v - 1.0).min(ONE_MINUS_EPSILON), 0.5)
            }
        };
        match technique {
            Mixture::Bl => {
                let uv = next2(u)?;
                if self.technique == Technique::Full {
                    self.run.sw.record(p);
                }
                let Some(s) = self.bl.as_ref().and_then(|b| b.sample(warped)) else {
                    return Ok(None);
                };
                let role = Role::MixtureBl { p, pmf_bl: s.pmf };
                self.draw(s.light, s.pmf, uv, role)
            }
            Mixture::Tb => {
                let v = next1(u)?;
                if self.technique == Technique::Full {
                    self.run.pending_tb = Some(p);
                }
                Ok(Some(Step::Bsdf(BsdfDraw {
                    u: [warped, v],
                    p: Some(p),
                })))
            }
        }
    }

    /// The weight of a point reached by a BRDF-aware sample of BL probability `p`.
    #[inline]
    pub(super) fn mixture_weight(&self, p: f32, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> Weighted {
        if self.technique == Technique::Full {
            // The term depends on the budget and the sample's own p only.
            let terms = SequentialWeights::new(self.n_mix, 1.0, self.params.heuristic);
            match terms.mixture_factors(p, pdf_tl, pdf_bl, pdf_tb) {
                Some(f) => Weighted::checked(f),
                None => Weighted::ZERO,
            }
        } else {
            let (_, w_m) = self.combined().weights(pdf_tl, pdf_bl, pdf_tb);
            let half = 0.5 * self.n_mix as f32;
            let den = half * pdf_bl + half * pdf_tb;
            Weighted::checked(Factors {
                num: w_m,
                den,
                pdf: den,
            })
        }
    }

    /// Whether a BRDF-aware sample of BL probability `p` is weighted with BL's density.
    #[inline]
    pub(super) fn uses_bl(&self, p: f32) -> bool {
        if self.technique == Technique::Full {
            p > 0.0
        } else {
            self.bl.is_some() || self.n_mix > 0
        }
    }
}
