//! The light tree as flat, `bytemuck::Pod` arrays: [`Node4`] (four child slots in SoA lanes,
//! two cache lines), per-node statistics, and per-light paths; its self-check
//! ([`LightTree::validate`]) and its byte serialisation.

use crate::bounds::{Cone, Sphere};
use crate::error::{FormatError, ValidationError};
use crate::quantize;
use alloc::vec;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Deepest tree a 64-bit path can encode (2 bits per level plus a marker bit).
pub const MAX_DEPTH: u32 = 31;

/// `child` value of an empty slot.
pub const EMPTY_SLOT: u32 = u32::MAX;
/// Bit set in `child` when the slot is a single light (the rest of the bits: its index).
pub const LEAF_BIT: u32 = 1 << 31;

/// A tree node: four child clusters, each attribute stored as four lanes so one f32x4 load
/// gives it for all four children. 128 bytes, aligned to a cache line.
///
/// Empty slots have `energy = 0` and `child = EMPTY_SLOT`, and evaluate to importance 0.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Node4 {
    /// Bounding-sphere centres, x.
    pub center_x: [f32; 4],
    /// Bounding-sphere centres, y.
    pub center_y: [f32; 4],
    /// Bounding-sphere centres, z.
    pub center_z: [f32; 4],
    /// Bounding-sphere radii.
    pub radius: [f32; 4],
    /// Cluster energies (sum of the lights' energies).
    pub energy: [f32; 4],
    /// Cone axes, octahedral 16+16 bits (see `quantize`).
    pub axis: [u32; 4],
    /// Cone angles: `sin(θo/2)` in the low, `sin(θe/2)` in the high 16 bits, rounded up.
    pub angles: [u32; 4],
    /// [`EMPTY_SLOT`], `LEAF_BIT | light`, or the index of a child node.
    pub child: [u32; 4],
}

/// What a slot of a [`Node4`] holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// Nothing.
    Empty,
    /// A single light, by index in the build's input.
    Light(u32),
    /// An inner node, by index in [`LightTree::nodes`].
    Node(u32),
}

/// One slot's bounds, decoded to plain numbers (what the scalar importances read).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlotBounds {
    /// Bounding-sphere centre.
    pub center: Vec3,
    /// Bounding-sphere radius.
    pub radius: f32,
    /// Unit cone axis.
    pub axis: Vec3,
    /// cos θo.
    pub cos_o: f32,
    /// sin θo.
    pub sin_o: f32,
    /// cos θe.
    pub cos_e: f32,
    /// Energy.
    pub energy: f32,
}

impl Node4 {
    /// A node with four empty slots.
    pub const EMPTY: Node4 = Node4 {
        center_x: [0.0; 4],
        center_y: [0.0; 4],
        center_z: [0.0; 4],
        radius: [0.0; 4],
        energy: [0.0; 4],
        axis: [0; 4],
        angles: [0; 4],
        child: [EMPTY_SLOT; 4],
    };

    /// What slot `k` (0..4) holds.
    #[inline]
    pub fn slot(&self, k: usize) -> Slot {
        let c = self.child[k];
        if c == EMPTY_SLOT {
            Slot::Empty
        } else if c & LEAF_BIT != 0 {
            Slot::Light(c & !LEAF_BIT)
        } else {
            Slot::Node(c)
        }
    }

    /// Slot `k`'s bounds, decoded.
    pub fn bounds(&self, k: usize) -> SlotBounds {
        let (cos_o, sin_o) = quantize::decode_angle(self.angles[k]);
        let (cos_e, _) = quantize::decode_angle(self.angles[k] >> 16);
        SlotBounds {
            center: Vec3::new(self.center_x[k], self.center_y[k], self.center_z[k]),
            radius: self.radius[k],
            axis: quantize::decode_axis(self.axis[k]),
            cos_o,
            sin_o,
            cos_e,
            energy: self.energy[k],
        }
    }

    pub(crate) fn sphere(&self, k: usize) -> Sphere {
        Sphere {
            center: Vec3::new(self.center_x[k], self.center_y[k], self.center_z[k]),
            radius: self.radius[k],
        }
    }

    pub(crate) fn cone(&self, k: usize) -> Cone {
        Cone {
            axis: quantize::decode_axis(self.axis[k]),
            theta_o: quantize::angle_of(self.angles[k]),
            theta_e: quantize::angle_of(self.angles[k] >> 16),
        }
    }
}

/// Statistics of one node's whole cluster, for split sampling's variance heuristic
/// (Conty & Kulla, "Predicted variance"): the number of lights and the variance of their
/// energies relative to their squared mean (the mean is the cluster energy over the count;
/// the variance is `energy_rel_variance · mean²`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct NodeStats {
    /// Lights under the node.
    pub count: u32,
    /// Population variance of their energies over the squared mean energy.
    pub energy_rel_variance: f32,
}

/// Size and shape of a built tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeStats {
    /// Lights passed to the build.
    pub lights: u32,
    /// Lights in the tree (those with positive energy).
    pub sampled_lights: u32,
    /// Number of [`Node4`].
    pub nodes: u32,
    /// Levels of nodes (0 for an empty tree).
    pub depth: u32,
    /// Bytes of all the tree's arrays.
    pub bytes: usize,
    /// `bytes / lights`.
    pub bytes_per_light: f32,
    /// Mean number of filled slots per node.
    pub mean_fill: f32,
}

/// A light tree: immutable after build, `Send + Sync`, shared by all threads.
///
/// Built by [`LightTree::build`]; sampled with [`LightTree::sample`] and queried with
/// [`LightTree::pmf`].
#[derive(Clone, Debug, PartialEq)]
pub struct LightTree {
    pub(crate) nodes: Vec<Node4>,
    pub(crate) node_stats: Vec<NodeStats>,
    pub(crate) paths: Vec<u64>,
    pub(crate) depth: u32,
}

/// The number of levels a path encodes (0 for the "not in tree" path 0).
#[inline]
pub(crate) fn path_len(path: u64) -> u32 {
    if path == 0 {
        0
    } else {
        (63 - path.leading_zeros()) / 2
    }
}

const MAGIC: [u8; 8] = *b"MLTREE\x00\x01";
const HEADER: usize = 32;

impl LightTree {
    /// The nodes; node 0 is the root (absent for a tree that samples nothing).
    pub fn nodes(&self) -> &[Node4] {
        &self.nodes
    }

    /// Per-node statistics, parallel to [`LightTree::nodes`].
    pub fn node_stats(&self) -> &[NodeStats] {
        &self.node_stats
    }

    /// Per light: its 2-bit child choices, the root's choice in the highest pair, below a marker
    /// bit 1 (so a path of L levels is `1 << 2L | choices`); 0 for a light that is not in the
    /// tree (zero energy).
    pub fn paths(&self) -> &[u64] {
        &self.paths
    }

    /// Number of lights the tree was built from.
    pub fn light_count(&self) -> u32 {
        self.paths.len() as u32
    }

    /// Whether the tree samples nothing (no light has positive energy).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Total energy of the sampled lights.
    pub fn total_energy(&self) -> f32 {
        self.nodes
            .first()
            .map_or(0.0, |n| n.energy.iter().sum::<f32>())
    }

    /// Size and shape.
    pub fn stats(&self) -> TreeStats {
        let bytes = core::mem::size_of_val(self.nodes.as_slice())
            + core::mem::size_of_val(self.node_stats.as_slice())
            + core::mem::size_of_val(self.paths.as_slice());
        let lights = self.paths.len() as u32;
        let sampled = self.paths.iter().filter(|&&p| p != 0).count() as u32;
        let filled: usize = self
            .nodes
            .iter()
            .map(|n| n.child.iter().filter(|&&c| c != EMPTY_SLOT).count())
            .sum();
        TreeStats {
            lights,
            sampled_lights: sampled,
            nodes: self.nodes.len() as u32,
            depth: self.depth,
            bytes,
            bytes_per_light: if lights > 0 {
                bytes as f32 / lights as f32
            } else {
                0.0
            },
            mean_fill: if self.nodes.is_empty() {
                0.0
            } else {
                filled as f32 / self.nodes.len() as f32
            },
        }
    }

    /// Checks every invariant: each node reachable from the root exactly once and each light
    /// at most once, numbers finite and non-negative, each inner slot's energy the sum of its
    /// children's and its light count theirs, every slot's sphere and cone containing the
    /// sphere and cone of every light below it, each light's path leading to its leaf, the
    /// depth within [`MAX_DEPTH`]. Runs after every build in debug builds and in tests.
    pub fn validate(&self) -> Result<(), ValidationError> {
        let n_nodes = self.nodes.len();
        let n_lights = self.paths.len();
        if self.node_stats.len() != n_nodes || n_nodes >= LEAF_BIT as usize {
            return Err(ValidationError::BadStats);
        }
        if n_lights >= LEAF_BIT as usize {
            return Err(ValidationError::BadStats);
        }
        if self.depth > MAX_DEPTH {
            return Err(ValidationError::TooDeep);
        }
        if n_nodes == 0 {
            if self.depth != 0 || self.paths.iter().any(|&p| p != 0) {
                return Err(ValidationError::BadStats);
            }
            return Ok(());
        }
        let mut node_seen = vec![false; n_nodes];
        let mut light_seen = vec![false; n_lights];
        node_seen[0] = true;
        // Ancestor slots of the current position: (sphere, cone, node, slot).
        let mut ancestors: Vec<(Sphere, Cone)> = Vec::with_capacity(MAX_DEPTH as usize);
        let mut max_depth = 0;
        self.validate_node(
            0,
            0,
            1,
            &mut node_seen,
            &mut light_seen,
            &mut ancestors,
            &mut max_depth,
        )?;
        if let Some(i) = node_seen.iter().position(|s| !s) {
            return Err(ValidationError::UnreachableNode { node: i as u32 });
        }
        for (l, (&p, &seen)) in self.paths.iter().zip(&light_seen).enumerate() {
            if (p != 0) != seen {
                return Err(ValidationError::BadPath { light: l as u32 });
            }
        }
        if max_depth != self.depth {
            return Err(ValidationError::BadStats);
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)] // a recursive walk carrying its state
    fn validate_node(
        &self,
        index: u32,
        level: u32,
        path: u64,
        node_seen: &mut [bool],
        light_seen: &mut [bool],
        ancestors: &mut Vec<(Sphere, Cone)>,
        max_depth: &mut u32,
    ) -> Result<u32, ValidationError> {
        if level >= MAX_DEPTH {
            return Err(ValidationError::TooDeep);
        }
        *max_depth = (*max_depth).max(level + 1);
        let node = &self.nodes[index as usize];
        let mut count = 0u32;
        let mut filled = 0;
        for k in 0..4 {
            let bad_number = ValidationError::BadNumber {
                node: index,
                slot: k as u8,
            };
            let e = node.energy[k];
            let finite = node.center_x[k].is_finite()
                && node.center_y[k].is_finite()
                && node.center_z[k].is_finite()
                && node.radius[k].is_finite()
                && node.radius[k] >= 0.0
                && e.is_finite();
            if !finite {
                return Err(bad_number);
            }
            let slot_path = (path << 2) | k as u64;
            match node.slot(k) {
                Slot::Empty => {
                    if e != 0.0 {
                        return Err(bad_number);
                    }
                }
                Slot::Light(l) => {
                    filled += 1;
                    if e <= 0.0 {
                        return Err(bad_number);
                    }
                    let li = l as usize;
                    if li >= light_seen.len() || light_seen[li] {
                        return Err(ValidationError::BadLeaf {
                            node: index,
                            slot: k as u8,
                        });
                    }
                    light_seen[li] = true;
                    if self.paths[li] != slot_path {
                        return Err(ValidationError::BadPath { light: l });
                    }
                    let (sphere, cone) = (node.sphere(k), node.cone(k));
                    for (level, (s, c)) in ancestors.iter().enumerate() {
                        let tol = 1e-5 * (s.radius + s.center.abs().max_element()) + 1e-6;
                        if !s.contains(&sphere, tol) || !c.contains(&cone, 3e-4) {
                            return Err(ValidationError::BoundsViolation {
                                light: l,
                                level: level as u32,
                            });
                        }
                    }
                    count += 1;
                }
                Slot::Node(c) => {
                    filled += 1;
                    let ci = c as usize;
                    if ci >= node_seen.len() || node_seen[ci] {
                        return Err(ValidationError::BadChild {
                            node: index,
                            slot: k as u8,
                        });
                    }
                    if e <= 0.0 {
                        return Err(bad_number);
                    }
                    node_seen[ci] = true;
                    ancestors.push((node.sphere(k), node.cone(k)));
                    let sub = self.validate_node(
                        c,
                        level + 1,
                        slot_path,
                        node_seen,
                        light_seen,
                        ancestors,
                        max_depth,
                    )?;
                    ancestors.pop();
                    let child = &self.nodes[ci];
                    let sum: f64 = child.energy.iter().map(|&x| f64::from(x)).sum();
                    if (sum - f64::from(e)).abs() > 1e-4 * sum.max(f64::from(e)) {
                        return Err(ValidationError::EnergyMismatch {
                            node: index,
                            slot: k as u8,
                        });
                    }
                    count += sub;
                }
            }
        }
        if filled == 0 {
            return Err(ValidationError::BadStats);
        }
        let st = &self.node_stats[index as usize];
        if st.count != count || !st.energy_rel_variance.is_finite() || st.energy_rel_variance < 0.0
        {
            return Err(ValidationError::BadStats);
        }
        Ok(count)
    }

    /// The tree as bytes (little-endian header, then the nodes, node statistics and paths), for
    /// a host to cache or send to another process; read back with [`LightTree::from_bytes`].
    pub fn as_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(
            HEADER
                + core::mem::size_of_val(self.nodes.as_slice())
                + core::mem::size_of_val(self.node_stats.as_slice())
                + core::mem::size_of_val(self.paths.as_slice()),
        );
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&(self.nodes.len() as u64).to_le_bytes());
        out.extend_from_slice(&(self.paths.len() as u64).to_le_bytes());
        out.extend_from_slice(&self.depth.to_le_bytes());
        out.extend_from_slice(&0x0102_0304u32.to_ne_bytes());
        out.extend_from_slice(bytemuck::cast_slice(&self.nodes));
        out.extend_from_slice(bytemuck::cast_slice(&self.node_stats));
        out.extend_from_slice(bytemuck::cast_slice(&self.paths));
        out
    }

    /// Reads a tree written by [`LightTree::as_bytes`] on a machine of the same byte order,
    /// and validates it fully: corrupt bytes give an error, never a panic or a bad tree.
    pub fn from_bytes(bytes: &[u8]) -> Result<LightTree, FormatError> {
        if bytes.len() < HEADER {
            return Err(FormatError::Truncated);
        }
        let u64_at = |o: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&bytes[o..o + 8]);
            u64::from_le_bytes(b)
        };
        let u32_at = |o: usize| {
            let mut b = [0u8; 4];
            b.copy_from_slice(&bytes[o..o + 4]);
            b
        };
        if bytes[..8] != MAGIC || u32_at(28) != 0x0102_0304u32.to_ne_bytes() {
            return Err(FormatError::BadHeader);
        }
        let n_nodes = u64_at(8);
        let n_lights = u64_at(16);
        let depth = u32::from_le_bytes(u32_at(24));
        if n_nodes >= u64::from(LEAF_BIT) || n_lights >= u64::from(LEAF_BIT) {
            return Err(FormatError::Invalid(ValidationError::BadStats));
        }
        let (n_nodes, n_lights) = (n_nodes as usize, n_lights as usize);
        let node_bytes = n_nodes * core::mem::size_of::<Node4>();
        let stat_bytes = n_nodes * core::mem::size_of::<NodeStats>();
        let path_bytes = n_lights * 8;
        let need = HEADER + node_bytes + stat_bytes + path_bytes;
        if bytes.len() < need {
            return Err(FormatError::Truncated);
        }
        if bytes.len() > need {
            return Err(FormatError::TrailingBytes);
        }
        let mut o = HEADER;
        let nodes: Vec<Node4> = bytemuck::pod_collect_to_vec(&bytes[o..o + node_bytes]);
        o += node_bytes;
        let node_stats: Vec<NodeStats> = bytemuck::pod_collect_to_vec(&bytes[o..o + stat_bytes]);
        o += stat_bytes;
        let paths: Vec<u64> = bytemuck::pod_collect_to_vec(&bytes[o..o + path_bytes]);
        let tree = LightTree {
            nodes,
            node_stats,
            paths,
            depth,
        };
        tree.validate().map_err(FormatError::Invalid)?;
        Ok(tree)
    }

    /// The `(node, slot)` a path (encoded as in [`LightTree::paths`]) ends at; `None` when the
    /// path leaves the tree.
    pub fn slot_at(&self, path: u64) -> Option<(u32, usize)> {
        let levels = path_len(path);
        if levels == 0 || self.nodes.is_empty() {
            return None;
        }
        let mut node = 0u32;
        for level in 0..levels {
            let k = ((path >> (2 * (levels - 1 - level))) & 3) as usize;
            if level + 1 == levels {
                return Some((node, k));
            }
            match self.nodes.get(node as usize)?.slot(k) {
                Slot::Node(c) => node = c,
                _ => return None,
            }
        }
        None
    }
}

const _: () = assert!(core::mem::size_of::<Node4>() == 128);
const _: () = assert!(core::mem::align_of::<Node4>() == 64);
