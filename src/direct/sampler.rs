//! Light samplers bound to one shading point, in the shape of pbrt-v4's `LightSampler`: a
//! light for a uniform number, with its probability, and the probability of any light.

use crate::cut::{BlCutOptions, LightCut};
use crate::importance::{BlImportance, TlImportance};
use crate::light_set::{AliasTable, LightSet};
use crate::material::{ShadingError, ShadingPoint};
use crate::sample::LightSample;
use crate::tree::LightTree;
use glam::Vec3;

/// Chooses one light at a shading point (the point the sampler was made for).
///
/// Contract: `sample(u)` returns a light with `pmf > 0` equal to `self.pmf(light)`, or `None`
/// when no light can contribute; the pmfs of all lights sum to 1 whenever `sample` can return
/// a light. `u` is uniform in [0, 1) (values outside are clamped into it, NaN counts as 0).
pub trait LightSampler {
    /// A light for the uniform number `u`, with its probability.
    fn sample(&self, u: f32) -> Option<LightSample>;
    /// The probability that [`LightSampler::sample`] returns `light` (0 for an index out of
    /// range).
    fn pmf(&self, light: u32) -> f32;
}

/// Tree descent with the Conty–Kulla importance ([`TlImportance`]): one light per sample, no
/// splitting (pbrt-v4's `BVHLightSampler`).
#[derive(Clone, Copy, Debug)]
pub struct TreeSampler<'a> {
    tree: &'a LightTree,
    importance: TlImportance,
}

impl<'a> TreeSampler<'a> {
    /// The sampler at a point of the given surface normal (a zero normal: an omnidirectional
    /// receiver, as in a participating medium).
    pub fn new(tree: &'a LightTree, position: Vec3, normal: Vec3) -> TreeSampler<'a> {
        TreeSampler::with_importance(tree, TlImportance::new(position, normal))
    }

    /// The sampler for an importance already set up.
    pub fn with_importance(tree: &'a LightTree, importance: TlImportance) -> TreeSampler<'a> {
        TreeSampler { tree, importance }
    }

    /// The tree.
    #[inline]
    pub fn tree(&self) -> &'a LightTree {
        self.tree
    }

    /// The importance.
    #[inline]
    pub fn importance(&self) -> &TlImportance {
        &self.importance
    }
}

impl LightSampler for TreeSampler<'_> {
    #[inline]
    fn sample(&self, u: f32) -> Option<LightSample> {
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

    /// The cut.
    #[inline]
    pub fn cut(&self) -> &LightCut {
        &self.cut
    }

    /// The importance.
    #[inline]
    pub fn importance(&self) -> &BlImportance {
        &self.importance
    }

    /// The tree.
    #[inline]
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
    fn sample(&self, u: f32) -> Option<LightSample> {
        self.cut.sample(self.tree, &self.importance, u)
    }

    #[inline]
    fn pmf(&self, light: u32) -> f32 {
        self.cut.pmf(self.tree, &self.importance, light)
    }
}

/// Every light with the same probability (pbrt-v4's `UniformLightSampler`).
#[derive(Clone, Copy, Debug)]
pub struct UniformSampler {
    n: u32,
}

impl UniformSampler {
    /// Over `n` lights.
    pub fn new(n: u32) -> UniformSampler {
        UniformSampler { n }
    }

    /// A light for the uniform number `u` in [0, 1) with 53 bits (for more lights than an
    /// f32 can tell apart); clamped, NaN counts as 0.
    #[inline]
    pub fn sample_f64(&self, u: f64) -> Option<LightSample> {
        if self.n == 0 {
            return None;
        }
        let u = if u > 0.0 { u } else { 0.0 };
        let light = ((u * f64::from(self.n)) as u32).min(self.n - 1);
        Some(LightSample {
            light,
            pmf: 1.0 / self.n as f32,
        })
    }
}

impl LightSampler for UniformSampler {
    #[inline]
    fn sample(&self, u: f32) -> Option<LightSample> {
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
pub struct PowerSampler<'a> {
    table: &'a AliasTable,
}

impl<'a> PowerSampler<'a> {
    /// The sampler of a light set.
    pub fn new(set: &'a LightSet) -> PowerSampler<'a> {
        PowerSampler { table: set.power() }
    }

    /// A light for the uniform number `u` in [0, 1) with 53 bits; clamped, NaN counts as 0.
    #[inline]
    pub fn sample_f64(&self, u: f64) -> Option<LightSample> {
        self.table
            .sample(u)
            .map(|(light, pmf)| LightSample { light, pmf })
    }
}

impl LightSampler for PowerSampler<'_> {
    #[inline]
    fn sample(&self, u: f32) -> Option<LightSample> {
        self.sample_f64(f64::from(u))
    }

    #[inline]
    fn pmf(&self, light: u32) -> f32 {
        self.table.pmf(light)
    }
}
