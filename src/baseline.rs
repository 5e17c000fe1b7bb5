//! A plain binary light tree sampled with the scalar TL importance: what pbrt-v4's light BVH
//! does, done carefully, over the same SAOH build as [`crate::LightTree`]. It is the readable
//! reference and the baseline the 4-wide tree is measured against; it is not the main API.
//!
//! Nodes are 48 bytes (pbrt-v4 quantises to 32 plus a hash map per light for pmf queries; here
//! each light's path is stored instead). A node's left child follows it in memory, the right
//! child's index is stored. Descent evaluates both children with [`TlImportance::eval`] and
//! never allocates; the same fallback and vanishing-light rules as the 4-wide descent apply.

use crate::build::saoh::children;
use crate::build::{binary, BuildOptions};
use crate::error::BuildError;
use crate::importance::TlImportance;
use crate::light::Light;
use crate::math;
use crate::sample::{admit, sanitize, SampledLight, MIN_PMF, ONE_MINUS_EPSILON};
use crate::tree::SlotBounds;

/// Bit set in a node's `child` when it is a leaf (the rest of the bits: the light).
const LEAF_BIT: u32 = 1 << 31;
use alloc::vec;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// One node of the binary tree: its cluster's bounds and its right child or light.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct BinaryNode {
    /// Bounding-sphere centre.
    pub center: [f32; 3],
    /// Bounding-sphere radius.
    pub radius: f32,
    /// Unit cone axis.
    pub axis: [f32; 3],
    /// cos θo.
    pub cos_o: f32,
    /// sin θo.
    pub sin_o: f32,
    /// cos θe.
    pub cos_e: f32,
    /// Energy.
    pub energy: f32,
    /// `LEAF_BIT | light` for a leaf, else the index of the right child.
    pub child: u32,
}

impl BinaryNode {
    #[inline(always)]
    fn bounds(&self) -> SlotBounds {
        SlotBounds {
            center: Vec3::from_array(self.center),
            radius: self.radius,
            axis: Vec3::from_array(self.axis),
            cos_o: self.cos_o,
            sin_o: self.sin_o,
            cos_e: self.cos_e,
            energy: self.energy,
        }
    }
}

/// The baseline binary light tree.
#[derive(Clone, Debug, PartialEq)]
pub struct BinaryLightTree {
    nodes: Vec<BinaryNode>,
    paths: Vec<u64>,
}

impl BinaryLightTree {
    /// Builds with default options (the same build as [`crate::LightTree::build`]).
    pub fn build(lights: &[Light]) -> Result<BinaryLightTree, BuildError> {
        BinaryLightTree::build_with(lights, &BuildOptions::default())
    }

    /// Builds with `opts`.
    pub fn build_with(
        lights: &[Light],
        opts: &BuildOptions,
    ) -> Result<BinaryLightTree, BuildError> {
        let bin = binary(lights, opts, &crate::build::Serial)?;
        let mut paths = vec![0u64; lights.len()];
        // The binary tree in depth-first order (a left child follows its parent; the right
        // child follows the left child's subtree of 2·count − 1 nodes).
        let mut nodes: Vec<BinaryNode> = Vec::with_capacity(bin.nodes.len());
        let mut stack = Vec::new();
        if !bin.nodes.is_empty() {
            stack.push(0usize);
        }
        while let Some(i) = stack.pop() {
            let b = &bin.nodes[i];
            let c = &b.bounds.cone;
            let (sin_o, cos_o) = math::sin_cos(c.theta_o);
            let child = match b.light() {
                Some(l) => LEAF_BIT | l,
                None => {
                    let (l, r) = children(&bin.nodes, i);
                    stack.push(r);
                    stack.push(l);
                    (nodes.len() + 2 * bin.nodes[l].count as usize) as u32
                }
            };
            nodes.push(BinaryNode {
                center: b.bounds.sphere.center.to_array(),
                radius: b.bounds.sphere.radius,
                axis: c.axis.to_array(),
                cos_o,
                sin_o: sin_o.max(0.0),
                cos_e: math::cos(c.theta_e),
                energy: b.bounds.energy,
                child,
            });
        }
        drop(bin);
        // Paths: 1 bit per level (0 = left), below a marker bit.
        let mut stack = vec![(0usize, 1u64)];
        while let Some((i, path)) = stack.pop() {
            let Some(n) = nodes.get(i) else { break };
            if n.child & LEAF_BIT != 0 {
                paths[(n.child & !LEAF_BIT) as usize] = path;
            } else {
                stack.push((i + 1, path << 1));
                stack.push((n.child as usize, (path << 1) | 1));
            }
        }
        Ok(BinaryLightTree { nodes, paths })
    }

    /// The nodes (node 0 is the root).
    #[must_use]
    pub fn nodes(&self) -> &[BinaryNode] {
        &self.nodes
    }

    /// Bytes of all arrays (nodes and paths).
    #[must_use]
    pub fn bytes(&self) -> usize {
        core::mem::size_of_val(self.nodes.as_slice())
            + core::mem::size_of_val(self.paths.as_slice())
    }

    /// Importances of the two children of inner node `i`, or their energies below the root
    /// when both are 0; a child whose path probability from a node reached with probability
    /// `reach` would fall below [`MIN_PMF`] gets weight 0 (as in the 4-wide descent).
    #[inline(always)]
    fn weights(
        &self,
        imp: &TlImportance,
        i: usize,
        root: bool,
        reach: f32,
    ) -> Option<(f32, f32, f32)> {
        let left = self.nodes.get(i + 1)?;
        let right = self.nodes.get(self.nodes[i].child as usize)?;
        let (mut wl, mut wr) = (imp.eval(&left.bounds()), imp.eval(&right.bounds()));
        let mut sum = wl + wr;
        if !(sum > 0.0 && sum < f32::INFINITY) {
            if root {
                return None;
            }
            (wl, wr) = (left.energy, right.energy);
            sum = wl + wr;
            if !(sum > 0.0 && sum < f32::INFINITY) {
                return None;
            }
        }
        let ([wl, wr, _, _], sum) = admit([wl, wr, 0.0, 0.0], sum, reach, MIN_PMF);
        Some((wl, wr, sum))
    }

    /// Samples a light by binary descent with one warped uniform number.
    #[must_use]
    pub fn sample(&self, imp: &TlImportance, u: f32) -> Option<SampledLight> {
        let mut u = sanitize(u);
        let mut i = 0usize;
        let root = self.nodes.first()?;
        if root.child & LEAF_BIT != 0 {
            return (imp.eval(&root.bounds()) > 0.0).then_some(SampledLight {
                light: root.child & !LEAF_BIT,
                pmf: 1.0,
            });
        }
        let mut pmf = 1.0f32;
        let mut first = true;
        loop {
            let (wl, wr, sum) = self.weights(imp, i, first, pmf)?;
            first = false;
            let t = u * sum;
            let go_left = wr <= 0.0 || (wl > 0.0 && t < wl);
            if go_left {
                pmf *= wl / sum;
                u = (t / wl).clamp(0.0, ONE_MINUS_EPSILON);
                i += 1;
            } else {
                pmf *= wr / sum;
                u = ((t - wl) / wr).clamp(0.0, ONE_MINUS_EPSILON);
                i = self.nodes[i].child as usize;
            }
            let child = self.nodes.get(i)?.child;
            if child & LEAF_BIT != 0 {
                return Some(SampledLight {
                    light: child & !LEAF_BIT,
                    pmf,
                });
            }
        }
    }

    /// The exact pmf of `light` (what [`BinaryLightTree::sample`] reports for it).
    #[must_use]
    pub fn pmf(&self, imp: &TlImportance, light: u32) -> f32 {
        let Some(&path) = self.paths.get(light as usize) else {
            return 0.0;
        };
        if path == 0 {
            return 0.0;
        }
        let levels = 63 - path.leading_zeros();
        if levels == 0 {
            return match self.nodes.first() {
                Some(root) if imp.eval(&root.bounds()) > 0.0 => 1.0,
                _ => 0.0,
            };
        }
        let mut i = 0usize;
        let mut pmf = 1.0f32;
        for level in 0..levels {
            let Some((wl, wr, sum)) = self.weights(imp, i, level == 0, pmf) else {
                return 0.0;
            };
            if (path >> (levels - 1 - level)) & 1 == 0 {
                pmf *= wl / sum;
                i += 1;
            } else {
                pmf *= wr / sum;
                i = self.nodes[i].child as usize;
            }
        }
        pmf
    }
}
