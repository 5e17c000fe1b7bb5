//! The tree's self-check: [`LightTree::validate`] walks every node once and checks the
//! invariants the descents rely on; [`LightTree::validate_lights`] and
//! [`LightTree::check_lights`] compare the tree with the lights it was built from.

use super::{
    light_check_count, light_checks, path_len, Child, LightTree, LIGHT_BLOCK, MAX_DEPTH, MAX_LIGHTS,
};
use crate::bounds::{Cone, Sphere};
use crate::error::{LightMismatch, ValidationError};
use crate::light::Light;
use crate::packed::{index_bits, path_bits};
use alloc::vec;
use alloc::vec::Vec;

/// What [`LightTree::validate`] carries down the walk.
struct Walk<'a> {
    tree: &'a LightTree,
    /// The decoded bounds of the slots above the current node.
    ancestors: Vec<(Sphere, Cone)>,
    node_seen: Vec<bool>,
    leaf_seen: Vec<bool>,
    light_seen: Vec<bool>,
    max_depth: u32,
}

impl LightTree {
    /// Checks every invariant: each node reachable from the root exactly once, each leaf entry
    /// and each light at most once; codes in range and decoded numbers finite; every slot above
    /// a light containing the light's slot (up to that slot's own rounding) and each inner
    /// slot's energy the sum of its child's slots' (within their rounding, 0.2 %); each light's path leading
    /// to its leaf; the depth within [`MAX_DEPTH`] and the widths of the leaf entries and paths
    /// the ones the light count and depth need. Runs
    /// after every build in debug builds and in tests; [`LightTree::validate_lights`] also
    /// checks the leaves against the lights' own bounds.
    pub fn validate(&self) -> Result<(), ValidationError> {
        self.validate_nodes()?;
        self.validate_infinite()
    }

    /// [`LightTree::validate`] of the nodes, leaf array and paths.
    fn validate_nodes(&self) -> Result<(), ValidationError> {
        let n_nodes = self.nodes.len();
        let n_lights = self.paths.len();
        if n_nodes > MAX_LIGHTS as usize
            || self.variances.len() != n_nodes
            || n_lights > MAX_LIGHTS as usize
            || self.leaves.len() > n_lights
            || self.light_checks.len() != light_check_count(n_lights)
        {
            return Err(ValidationError::BadStats);
        }
        if self.depth > MAX_DEPTH {
            return Err(ValidationError::TooDeep);
        }
        if self.leaves.bits() != index_bits(n_lights) || self.paths.bits() != path_bits(self.depth)
        {
            return Err(ValidationError::BadStats);
        }
        if n_nodes == 0 {
            if self.depth != 0
                || !self.leaves.is_empty()
                || (0..n_lights).any(|l| self.paths.get(l) != Some(0))
            {
                return Err(ValidationError::BadStats);
            }
            return Ok(());
        }
        let mut walk = Walk {
            tree: self,
            ancestors: Vec::with_capacity(MAX_DEPTH as usize),
            node_seen: vec![false; n_nodes],
            leaf_seen: vec![false; self.leaves.len()],
            light_seen: vec![false; n_lights],
            max_depth: 0,
        };
        walk.node_seen[0] = true;
        walk.node(0, 0, 1)?;
        if let Some(i) = walk.node_seen.iter().position(|s| !s) {
            return Err(ValidationError::UnreachableNode { node: i as u32 });
        }
        if walk.leaf_seen.iter().any(|s| !s) {
            return Err(ValidationError::BadStats);
        }
        for (l, &seen) in walk.light_seen.iter().enumerate() {
            if (self.paths.get(l) != Some(0)) != seen {
                return Err(ValidationError::BadPath { light: l as u32 });
            }
        }
        if walk.max_depth != self.depth {
            return Err(ValidationError::BadStats);
        }
        Ok(())
    }

    /// [`LightTree::validate`], and every light's exact bounds inside its leaf slot's decoded
    /// bounds (so inside every ancestor's), its energy at most the slot's, and the lights in
    /// the tree exactly those of positive energy. `lights` is the slice the tree was built
    /// from.
    pub fn validate_lights(&self, lights: &[Light]) -> Result<(), ValidationError> {
        self.validate()?;
        if lights.len() != self.paths.len() {
            return Err(ValidationError::BadStats);
        }
        self.validate_infinite_lights(lights)?;
        for (l, light) in lights.iter().enumerate() {
            let b = light.bounds();
            let path = self.path(l as u32);
            if (path != 0) != (b.energy > 0.0) {
                return Err(ValidationError::BadPath { light: l as u32 });
            }
            if path == 0 {
                continue;
            }
            if !self.slot_holds(path, &b) {
                return Err(ValidationError::BoundsViolation {
                    light: l as u32,
                    level: path_len(path) - 1,
                });
            }
        }
        Ok(())
    }

    /// Whether the slot at `path` (a light's path) contains the bounds `b`: sphere, cone and
    /// energy.
    fn slot_holds(&self, path: u64, b: &crate::bounds::LightBounds) -> bool {
        let Some((node, k)) = self.slot_at(path) else {
            return false;
        };
        let n = &self.nodes[node as usize];
        let s = n.sphere(k);
        s.contains(&b.sphere, sphere_tolerance(&s))
            && n.cone(k).contains(&b.cone, CONE_TOLERANCE)
            && n.energy_of(k) >= b.energy
    }

    /// Checks that `lights` are the lights this tree was built from, block by block of
    /// `LIGHT_BLOCK` lights in index order: their number first; then in each block every
    /// light valid ([`Light::validate`]), in the tree exactly when its energy is positive, its
    /// exact bounds inside its leaf slot, and the block's CRC-64 the one the tree stores; and
    /// the total energy within [`crate::MAX_TOTAL_ENERGY`]. The error names the first
    /// mismatch: a light where its own checks fail, else the block whose checksum differs (a
    /// light changed within its slot's bounds, or lights swapped within them).
    pub fn check_lights(&self, lights: &[Light]) -> Result<(), LightMismatch> {
        if lights.len() != self.paths.len() {
            return Err(LightMismatch::Count {
                tree: self.paths.len() as u32,
                given: lights.len(),
            });
        }
        let checks = light_checks(lights);
        let mut total = 0.0f64;
        for (block, (chunk, (&want, &got))) in lights
            .chunks(LIGHT_BLOCK)
            .zip(self.light_checks.iter().zip(&checks))
            .enumerate()
        {
            let first = block * LIGHT_BLOCK;
            for (i, light) in chunk.iter().enumerate() {
                let l = first + i;
                let e = light.validated_energy(l).map_err(LightMismatch::Invalid)?;
                total += f64::from(e);
                let index = l as u32;
                let path = self.path(index);
                if (path != 0) != (e > 0.0) {
                    return Err(LightMismatch::Sampled {
                        light: index,
                        in_tree: path != 0,
                    });
                }
                if path != 0 && !self.slot_holds(path, &light.bounds_with_energy(e)) {
                    return Err(LightMismatch::Escapes { light: index });
                }
            }
            if want != got {
                return Err(LightMismatch::Changed {
                    first: first as u32,
                    end: (first + chunk.len()) as u32,
                });
            }
        }
        if total > f64::from(crate::MAX_TOTAL_ENERGY) {
            return Err(LightMismatch::Invalid(
                crate::BuildError::TotalEnergyTooLarge,
            ));
        }
        Ok(())
    }
}

/// Slack of the sphere containment checks: f32 rounding of the decoded centres.
fn sphere_tolerance(s: &Sphere) -> f32 {
    1e-5 * (s.radius + s.center.abs().max_element()) + 1e-6
}

/// Slack of the cone containment checks against the exact light bounds, in radians.
const CONE_TOLERANCE: f32 = 3e-4;

/// Slack of the cone checks of a leaf slot against its ancestors: the leaf's own rounding (its
/// axis error, at most 0.02, counted twice, and a step of θo and of θe) plus
/// [`CONE_TOLERANCE`].
const LEAF_CONE_SLACK: f32 = 0.07;

impl Walk<'_> {
    fn node(&mut self, index: u32, level: u32, path: u64) -> Result<(), ValidationError> {
        if level >= MAX_DEPTH {
            return Err(ValidationError::TooDeep);
        }
        self.max_depth = self.max_depth.max(level + 1);
        let tree = self.tree;
        let node = &tree.nodes[index as usize];
        let bad_stats = ValidationError::BadStats;
        let m = node.mask;
        if m == 0 || (m & (m >> 4) & 0xF) != 0 || !(1..=254).contains(&node.exponent) {
            return Err(bad_stats);
        }
        if !node.origin.iter().all(|x| x.is_finite()) {
            return Err(ValidationError::BadNumber {
                node: index,
                slot: 0,
            });
        }
        let v = tree.energy_rel_variance(index);
        if !v.is_finite() || v < 0.0 {
            return Err(bad_stats);
        }
        let n_inner = node.inner_count() as usize;
        if (node.child_base as usize).saturating_add(n_inner) > tree.nodes.len() {
            return Err(ValidationError::BadChild {
                node: index,
                slot: 0,
            });
        }
        if (node.leaf_base as usize).saturating_add(node.leaf_count() as usize) > tree.leaves.len()
        {
            return Err(ValidationError::BadLeaf {
                node: index,
                slot: 0,
            });
        }
        for k in 0..4 {
            let bad_number = ValidationError::BadNumber {
                node: index,
                slot: k as u8,
            };
            let code = node.energy_code(k);
            // Codes of +∞ and NaN (and negative numbers) are rejected.
            if code >= 0x7F800 {
                return Err(bad_number);
            }
            let e = node.energy_of(k);
            let s = node.sphere(k);
            if !(s.center.is_finite() && s.radius.is_finite()) {
                return Err(bad_number);
            }
            let slot_path = (path << 2) | k as u64;
            match node.child(k) {
                Child::Empty => {
                    if code != 0 {
                        return Err(bad_number);
                    }
                }
                Child::Leaf(i) => {
                    if e <= 0.0 {
                        return Err(bad_number);
                    }
                    let bad_leaf = ValidationError::BadLeaf {
                        node: index,
                        slot: k as u8,
                    };
                    let i = i as usize;
                    if self.leaf_seen[i] {
                        return Err(bad_leaf);
                    }
                    self.leaf_seen[i] = true;
                    let l = tree.leaves.get(i).map_or(usize::MAX, |l| l as usize);
                    if l >= self.light_seen.len() || self.light_seen[l] {
                        return Err(bad_leaf);
                    }
                    self.light_seen[l] = true;
                    if tree.paths.get(l) != Some(slot_path) {
                        return Err(ValidationError::BadPath { light: l as u32 });
                    }
                    // Every ancestor bounds the light. The exact light is only known to
                    // `validate_lights`; here its leaf slot, shrunk by what its own rounding
                    // may have added, must fit: the decoded sphere reaches at most
                    // 2·|c' − c| + 1.25 steps ≤ (√3 + 1.25) steps beyond the light's (and the
                    // cone the axis error and a step of each angle beyond the light's).
                    let (leaf, cone) = (node.sphere(k), node.cone(k));
                    let shrink = 3.1 * node.scale();
                    for (level, (a, c)) in self.ancestors.iter().enumerate() {
                        let tol = sphere_tolerance(a) + shrink;
                        if !a.contains(&leaf, tol) || !c.contains(&cone, LEAF_CONE_SLACK) {
                            return Err(ValidationError::BoundsViolation {
                                light: l as u32,
                                level: level as u32,
                            });
                        }
                    }
                }
                Child::Node(c) => {
                    let ci = c as usize;
                    if self.node_seen[ci] {
                        return Err(ValidationError::BadChild {
                            node: index,
                            slot: k as u8,
                        });
                    }
                    if e <= 0.0 {
                        return Err(bad_number);
                    }
                    self.node_seen[ci] = true;
                    self.ancestors.push((s, node.cone(k)));
                    self.node(c, level + 1, slot_path)?;
                    self.ancestors.pop();
                    // The slot's energy is its lights', as the child's slots' are (each rounded
                    // up by at most 2⁻¹¹).
                    let child = &tree.nodes[ci];
                    let sum: f64 = child.energies().iter().map(|&x| f64::from(x)).sum();
                    let e = f64::from(e);
                    if (e - sum).abs() > 2e-3 * e.max(sum) + 1e-37 {
                        return Err(ValidationError::EnergyMismatch {
                            node: index,
                            slot: k as u8,
                        });
                    }
                }
            }
        }
        Ok(())
    }
}
