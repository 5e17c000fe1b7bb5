//! Lights at infinity — distant lights (a cone of directions: a sun) and the host's
//! environment — kept beside the node tree and weighed against it at the root, at every
//! shading point, with the importance of the descent (docs/formulas.md, section 16).
//!
//! pbrt-v4's `BVHLightSampler` picks its infinite lights with a fixed probability (their count
//! over their count plus one) whatever the shading point; Cycles (since 3.5) keeps distant
//! lights and the background in a subtree of their own, weighed against the local lights'
//! subtree by orientation bounds. Here every distant and environment light is one entry of a
//! short list ([`InfiniteLight`], at most [`MAX_INFINITE_LIGHTS`]), and a sample first chooses
//! among {the node tree, each entry} in proportion to their importances at the point — the
//! tree's is the sum of its root's four slot importances, an entry's the same importance
//! ([`Importance::eval_infinite`]) in the same units — then descends the tree if it was
//! chosen. So `pmf = P(root choice) · P(descent)`, and [`LightTree::pmf`] recomputes both
//! factors from the same numbers: exactly what [`LightTree::sample`] reported.
//!
//! **The root choice** ([`RootChoice`]) is computed in f64 from the f32 importances: weights
//! that are NaN, negative or infinite count as 0; a choice whose probability would be below
//! [`MIN_PMF`] is dropped and the others renormalise (as the descent drops vanishing slots);
//! the uniform number is rescaled into the chosen interval. Below the root the descent runs
//! with the floor `MIN_PMF / P(tree)` (rounded up), so the product stays at least
//! [`MIN_PMF`] and the pmfs of all lights still sum to 1.
//!
//! **Storage and byte format.** The entries follow the paths in the byte format (version 4) as
//! a section of their own: a little-endian u64 count, then the 64-byte entries (fields in the
//! host's byte order, as the nodes). The lights they name have the path 0 (not in the node
//! tree). An empty section is 8 bytes of zeros; a tree without lights at infinity samples and
//! answers exactly as the node tree alone.

use crate::error::ValidationError;
use crate::importance::Importance;
use crate::light::Light;
use crate::sample::{tree_floor, SampledLight, WalkStart, MIN_PMF};
use crate::tree::LightTree;

pub(crate) use crate::infinite_light::{InfiniteKind, InfiniteLight};
pub(crate) use crate::limits::MAX_INFINITE_LIGHTS;
pub use crate::sample::RootChoice;

impl LightTree {
    /// The distant and environment lights, in the order of the build's input.
    #[inline]
    #[must_use]
    pub fn infinite_lights(&self) -> &[InfiniteLight] {
        &self.infinite
    }

    /// The entry of `light` among the lights at infinity, if it is one.
    #[inline]
    #[must_use]
    pub fn infinite_entry(&self, light: u32) -> Option<usize> {
        self.infinite.iter().position(|e| e.light == light)
    }

    /// The environment light's index, if the tree has one.
    #[inline]
    #[must_use]
    pub fn environment(&self) -> Option<u32> {
        self.infinite
            .iter()
            .find(|e| e.kind() == Some(InfiniteKind::Environment))
            .map(|e| e.light)
    }

    /// The node tree's weight at the root for `imp`: the sum of its root's four slot
    /// importances as the descent adds them (0 without nodes, or when the sum is not positive
    /// and finite).
    #[inline]
    pub fn root_weight<I: Importance + ?Sized>(&self, imp: &I) -> f64 {
        let Some(root) = self.nodes.first() else {
            return 0.0;
        };
        let a = imp.eval4(root).to_array();
        let sum = a[0] + a[1] + a[2] + a[3];
        if sum > 0.0 && sum < f32::INFINITY {
            f64::from(sum)
        } else {
            0.0
        }
    }

    /// The root choice for `imp` with the node tree weighing `tree` (see the module
    /// documentation).
    #[inline]
    pub fn root_choice<I: Importance + ?Sized>(&self, imp: &I, tree: f64) -> RootChoice {
        RootChoice::new(tree, self.infinite.iter().map(|e| imp.eval_infinite(e)))
    }

    /// [`LightTree::sample`] of a tree with lights at infinity.
    pub(crate) fn sample_with_infinite<I: Importance + ?Sized>(
        &self,
        imp: &I,
        u: f32,
    ) -> Option<SampledLight> {
        let choice = self.root_choice(imp, self.root_weight(imp));
        let (k, p, rest) = choice.pick(u)?;
        if k == 0 {
            let s = self.descend_from(imp, 0, true, rest, tree_floor(p))?;
            Some(SampledLight {
                light: s.light,
                pmf: p * s.pmf,
            })
        } else {
            Some(SampledLight {
                light: self.infinite[k - 1].light,
                pmf: p,
            })
        }
    }

    /// [`LightTree::pmf`] of a tree with lights at infinity.
    pub(crate) fn pmf_with_infinite<I: Importance + ?Sized>(&self, imp: &I, light: u32) -> f32 {
        let choice = self.root_choice(imp, self.root_weight(imp));
        if let Some(i) = self.infinite_entry(light) {
            return choice.probability(1 + i);
        }
        let p = choice.probability(0);
        if p <= 0.0 {
            return 0.0;
        }
        let walk = WalkStart {
            node: 0,
            root: true,
            path: self.path(light),
            from_level: 0,
            light,
            floor: tree_floor(p),
        };
        p * self.pmf_from(imp, &walk)
    }

    /// A light of the node tree alone, ignoring the lights at infinity: what
    /// [`LightTree::sample`] gives for a tree without them (pbrt-v4's descent of its BVH).
    #[inline]
    pub fn sample_local<I: Importance + ?Sized>(&self, imp: &I, u: f32) -> Option<SampledLight> {
        self.descend_from(imp, 0, true, u, MIN_PMF)
    }

    /// The pmf of [`LightTree::sample_local`] (0 for a light at infinity).
    #[inline]
    pub fn pmf_local<I: Importance + ?Sized>(&self, imp: &I, light: u32) -> f32 {
        let walk = WalkStart {
            node: 0,
            root: true,
            path: self.path(light),
            from_level: 0,
            light,
            floor: MIN_PMF,
        };
        self.pmf_from(imp, &walk)
    }

    /// Checks the entries of the lights at infinity (see [`ValidationError::BadInfinite`]).
    pub(crate) fn validate_infinite(&self) -> Result<(), ValidationError> {
        if self.infinite.len() > MAX_INFINITE_LIGHTS {
            return Err(ValidationError::BadStats);
        }
        let mut environments = 0;
        for (i, e) in self.infinite.iter().enumerate() {
            let bad = ValidationError::BadInfinite { entry: i as u32 };
            let finite = e.direction.iter().all(|x| x.is_finite())
                && e.cos_radius.is_finite()
                && e.sin_radius.is_finite()
                && e.irradiance.iter().all(|x| x.is_finite() && *x >= 0.0);
            if !finite
                || e.reserved != [0; 3]
                || e.light as usize >= self.paths.len()
                || self.path(e.light) != 0
                || self.infinite[..i].iter().any(|f| f.light == e.light)
            {
                return Err(bad);
            }
            match e.kind() {
                Some(InfiniteKind::Distant) => {
                    let l2 = e.direction().length_squared();
                    let r2 = e.cos_radius * e.cos_radius + e.sin_radius * e.sin_radius;
                    if (l2 - 1.0).abs() > 1e-5
                        || (r2 - 1.0).abs() > 1e-5
                        || e.cos_radius < -1e-6
                        || e.sin_radius < 0.0
                        || e.irradiance[1..].iter().any(|&x| x != 0.0)
                    {
                        return Err(bad);
                    }
                }
                Some(InfiniteKind::Environment) => {
                    environments += 1;
                    if environments > 1
                        || e.direction != [0.0; 3]
                        || e.cos_radius != -1.0
                        || e.sin_radius != 0.0
                    {
                        return Err(bad);
                    }
                }
                None => return Err(bad),
            }
        }
        Ok(())
    }

    /// Checks the entries against the lights the tree was built from: exactly the distant and
    /// environment lights, each entry what [`InfiniteLight::of`] makes of its light.
    pub(crate) fn validate_infinite_lights(&self, lights: &[Light]) -> Result<(), ValidationError> {
        let mut n = 0;
        for (i, l) in lights.iter().enumerate() {
            let Some(want) = InfiniteLight::of(i as u32, l) else {
                continue;
            };
            let entry = self.infinite.get(n).copied();
            if entry != Some(want) {
                return Err(ValidationError::BadInfinite { entry: n as u32 });
            }
            n += 1;
        }
        if n != self.infinite.len() {
            return Err(ValidationError::BadInfinite { entry: n as u32 });
        }
        Ok(())
    }
}
