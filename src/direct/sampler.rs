//! Light samplers bound to one shading point, in the shape of pbrt-v4's `LightSampler`: a
//! light for a uniform number, with its probability, and the probability of any light.

use crate::cut::{BlCutOptions, LightCut};
use crate::importance::{BlImportance, TlImportance};
use crate::infinite::RootChoice;
use crate::light_set::{AliasTable, LightSet};
use crate::material::{ShadingError, ShadingPoint};
use crate::sample::{root_product, SampledLight, ONE_MINUS_EPSILON};
use crate::tree::LightTree;
use glam::Vec3;

/// Chooses one light at a shading point (the point the sampler was made for).
///
/// Contract: `sample(u)` returns a light with `pmf > 0` equal to `self.pmf(light)`, or `None`
/// when no light can contribute; the pmfs of all lights sum to 1 whenever `sample` can return
/// a light. `u` is uniform in [0, 1) (values outside are clamped into it, NaN counts as 0).
pub trait LightSampler {
    /// A light for the uniform number `u`, with its probability.
    fn sample(&self, u: f32) -> Option<SampledLight>;
    /// The probability that [`LightSampler::sample`] returns `light` (0 for an index out of
    /// range).
    fn pmf(&self, light: u32) -> f32;
}

/// Tree descent with the Conty–Kulla importance ([`TlImportance`]): one light per sample, no
/// splitting (pbrt-v4's `BVHLightSampler`), with the tree's distant and environment lights
/// weighed against its nodes at the root by the same importance ([`crate::light_set`]).
#[derive(Clone, Copy, Debug)]
pub struct TreeSampler<'a> {
    tree: &'a LightTree,
    importance: TlImportance,
}

impl<'a> TreeSampler<'a> {
    /// The sampler at a point of the given surface normal (a zero normal: an omnidirectional
    /// receiver, as in a participating medium).
    #[must_use]
    pub fn new(tree: &'a LightTree, position: Vec3, normal: Vec3) -> TreeSampler<'a> {
        TreeSampler::with_importance(tree, TlImportance::new(position, normal))
    }

    /// The sampler for an importance already set up.
    #[must_use]
    pub fn with_importance(tree: &'a LightTree, importance: TlImportance) -> TreeSampler<'a> {
        TreeSampler { tree, importance }
    }

    /// The tree.
    #[inline]
    #[must_use]
    pub fn tree(&self) -> &'a LightTree {
        self.tree
    }

    /// The importance.
    #[inline]
    #[must_use]
    pub fn importance(&self) -> &TlImportance {
        &self.importance
    }
}

impl LightSampler for TreeSampler<'_> {
    #[inline]
    fn sample(&self, u: f32) -> Option<SampledLight> {
        self.tree.sample(&self.importance, u)
    }

    #[inline]
    fn pmf(&self, light: u32) -> f32 {
        self.tree.pmf(&self.importance, light)
    }
}

/// The BRDF-oriented light cut of Liu et al. 2019 (section 4.1): a cluster of the cut by its
/// BRDF-oriented importance, then a descent in it. The sampler owns its tree, importance and
/// cut, so the cut is always queried with the importance it was built with.
///
/// With distant and environment lights, a sample first chooses at the root among the node
/// tree's clusters of the cut (of weight the sum of their weights) and each light at infinity
/// (of its BL importance, [`BlImportance::eval_infinite_with_integral`]), as
/// [`crate::infinite::RootChoice`] does, then samples the node tree's clusters if they were
/// chosen: `pmf = P(tree) · pmf in the clusters`, exact. A product below [`MIN_PMF`](crate::MIN_PMF) counts as
/// no light (sample gives `None`, pmf 0). This is [`LightCut::sample`] and [`LightCut::pmf`]
/// of its cut, which holds the lights at infinity as clusters of their own.
#[derive(Clone, Debug)]
pub struct CutSampler<'a> {
    tree: &'a LightTree,
    importance: BlImportance,
    cut: LightCut,
}

impl<'a> CutSampler<'a> {
    /// Builds the cut at `sp` (an error names the shading point's field that is wrong).
    pub fn new(
        tree: &'a LightTree,
        sp: &ShadingPoint,
        options: &BlCutOptions,
    ) -> Result<CutSampler<'a>, ShadingError> {
        let importance = BlImportance::new(sp)?;
        Ok(CutSampler::with_importance(tree, importance, options))
    }

    /// Builds the cut for an importance already set up.
    #[must_use]
    pub fn with_importance(
        tree: &'a LightTree,
        importance: BlImportance,
        options: &BlCutOptions,
    ) -> CutSampler<'a> {
        let cut = LightCut::build_bl(tree, &importance, options);
        CutSampler {
            tree,
            importance,
            cut,
        }
    }

    /// Moves the sampler to another shading point in place: it becomes what
    /// [`CutSampler::with_importance`] gives for `importance` on the same tree, without a
    /// copy of its cut.
    pub fn reset(&mut self, importance: BlImportance, options: &BlCutOptions) {
        self.cut.rebuild_bl(self.tree, &importance, options);
        self.importance = importance;
    }

    /// Scales the cut's cluster weights ([`LightCut::scale_weights`]): sampling and pmfs
    /// follow the scaled weights, exactly.
    pub(crate) fn scale_weights(&mut self, factor: impl FnMut(&crate::cut::Cluster) -> f32) {
        self.cut.scale_weights(self.tree, factor);
    }

    /// [`CutSampler::reset`] to the importance of [`BlImportance::with_directions`], set up in
    /// place.
    #[inline]
    pub(crate) fn reset_with_directions(
        &mut self,
        sp: &ShadingPoint,
        n: Vec3,
        wo: Vec3,
        options: &BlCutOptions,
    ) {
        self.importance = BlImportance::with_directions(sp, n, wo);
        self.cut.rebuild_bl(self.tree, &self.importance, options);
    }

    /// The root choice between the node tree's clusters of the cut and the lights at
    /// infinity (`None` without any): [`LightCut::root_choice`].
    #[inline]
    #[must_use]
    pub fn root_choice(&self) -> Option<&RootChoice> {
        self.cut.root_choice()
    }

    /// The cut.
    #[inline]
    #[must_use]
    pub fn cut(&self) -> &LightCut {
        &self.cut
    }

    /// The importance.
    #[inline]
    #[must_use]
    pub fn importance(&self) -> &BlImportance {
        &self.importance
    }

    /// The tree.
    #[inline]
    #[must_use]
    pub fn tree(&self) -> &'a LightTree {
        self.tree
    }

    /// The pmfs of many lights at once (`out[i]` for `lights[i]`, as [`LightSampler::pmf`]
    /// gives them; the tree walks interleaved).
    #[inline]
    pub fn pmf_each(&self, lights: &[u32], out: &mut [f32]) {
        self.cut.pmf_each(self.tree, &self.importance, lights, out);
    }
}

impl LightSampler for CutSampler<'_> {
    #[inline]
    fn sample(&self, u: f32) -> Option<SampledLight> {
        self.cut.sample(self.tree, &self.importance, u)
    }

    #[inline]
    fn pmf(&self, light: u32) -> f32 {
        self.cut.pmf(self.tree, &self.importance, light)
    }
}

/// pbrt-v4's handling of lights at infinity (`BVHLightSampler`): each distant or environment
/// light with the fixed probability `1 / (n + 1)` (n of them; `1 / n` without local lights),
/// whatever the shading point, and the node tree by TL descent otherwise. The yardstick of the
/// root choice per shading point (technique `tl-mis-pinf`). A product below [`MIN_PMF`](crate::MIN_PMF)
/// counts as no light. As pbrt-v4's, it returns no light when the tree is chosen at a point
/// where its root importance is 0, so there (only) the pmfs sum to `pInfinite` rather than 1:
/// still unbiased, as no light that contributes has pmf 0.
#[derive(Clone, Copy, Debug)]
pub struct PinfSampler<'a> {
    tree: &'a LightTree,
    importance: TlImportance,
    /// pInfinite = n / (n + 1), or 1 without local lights, or 0 without lights at infinity.
    p_infinite: f32,
}

impl<'a> PinfSampler<'a> {
    /// The sampler for an importance already set up.
    #[must_use]
    pub fn with_importance(tree: &'a LightTree, importance: TlImportance) -> PinfSampler<'a> {
        let n = tree.infinite_lights().len();
        let local = usize::from(!tree.nodes().is_empty());
        let p_infinite = if n == 0 {
            0.0
        } else {
            n as f32 / (n + local) as f32
        };
        PinfSampler {
            tree,
            importance,
            p_infinite,
        }
    }

    /// pInfinite: the probability of choosing a light at infinity.
    #[inline]
    #[must_use]
    pub fn p_infinite(&self) -> f32 {
        self.p_infinite
    }
}

impl LightSampler for PinfSampler<'_> {
    fn sample(&self, u: f32) -> Option<SampledLight> {
        let u = if u >= 0.0 {
            u.min(ONE_MINUS_EPSILON)
        } else {
            0.0
        };
        let inf = self.tree.infinite_lights();
        if u < self.p_infinite {
            let k = ((u / self.p_infinite * inf.len() as f32) as usize).min(inf.len() - 1);
            return Some(SampledLight {
                light: inf[k].light,
                pmf: self.p_infinite / inf.len() as f32,
            });
        }
        let rest = ((u - self.p_infinite) / (1.0 - self.p_infinite)).min(ONE_MINUS_EPSILON);
        let s = self.tree.sample_local(&self.importance, rest)?;
        let pmf = root_product(1.0 - self.p_infinite, s.pmf);
        (pmf > 0.0).then_some(SampledLight {
            light: s.light,
            pmf,
        })
    }

    fn pmf(&self, light: u32) -> f32 {
        let inf = self.tree.infinite_lights();
        if self.tree.infinite_entry(light).is_some() {
            return self.p_infinite / inf.len() as f32;
        }
        if self.p_infinite >= 1.0 {
            return 0.0;
        }
        root_product(
            1.0 - self.p_infinite,
            self.tree.pmf_local(&self.importance, light),
        )
    }
}

/// Every light with the same probability (pbrt-v4's `UniformLightSampler`).
#[derive(Clone, Copy, Debug)]
pub struct UniformSampler {
    n: u32,
}

impl UniformSampler {
    /// Over `n` lights.
    #[must_use]
    pub fn new(n: u32) -> UniformSampler {
        UniformSampler { n }
    }

    /// A light for the uniform number `u` in [0, 1) with 53 bits (for more lights than an
    /// f32 can tell apart); clamped, NaN counts as 0.
    #[inline]
    #[must_use]
    pub fn sample_f64(&self, u: f64) -> Option<SampledLight> {
        if self.n == 0 {
            return None;
        }
        let u = if u > 0.0 { u } else { 0.0 };
        let light = ((u * f64::from(self.n)) as u32).min(self.n - 1);
        Some(SampledLight {
            light,
            pmf: 1.0 / self.n as f32,
        })
    }
}

impl LightSampler for UniformSampler {
    #[inline]
    fn sample(&self, u: f32) -> Option<SampledLight> {
        self.sample_f64(f64::from(u))
    }

    #[inline]
    fn pmf(&self, light: u32) -> f32 {
        if light < self.n {
            1.0 / self.n as f32
        } else {
            0.0
        }
    }
}

/// Every light with probability ∝ its energy, through the light set's alias table: O(1) per
/// sample (pbrt-v4's `PowerLightSampler`). The same at every shading point.
#[derive(Clone, Copy, Debug)]
pub struct EnergySampler<'a> {
    table: &'a AliasTable,
}

impl<'a> EnergySampler<'a> {
    /// The sampler of a light set.
    #[must_use]
    pub fn new(set: &'a LightSet) -> EnergySampler<'a> {
        EnergySampler {
            table: set.energies(),
        }
    }

    /// A light for the uniform number `u` in [0, 1) with 53 bits; clamped, NaN counts as 0.
    #[inline]
    #[must_use]
    pub fn sample_f64(&self, u: f64) -> Option<SampledLight> {
        self.table
            .sample(u)
            .map(|(light, pmf)| SampledLight { light, pmf })
    }
}

impl LightSampler for EnergySampler<'_> {
    #[inline]
    fn sample(&self, u: f32) -> Option<SampledLight> {
        self.sample_f64(f64::from(u))
    }

    #[inline]
    fn pmf(&self, light: u32) -> f32 {
        self.table.pmf(light)
    }
}
