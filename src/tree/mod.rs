//! The light tree as flat, `bytemuck::Pod` arrays: [`Node4`] (four child clusters quantised
//! into one 64-byte cache line), the lights of the leaf slots in tree order, and per-light
//! paths, both bit-packed, and beside the nodes the distant and environment lights
//! ([`InfiniteLight`], weighed against the nodes at the root: [`crate::light_set`]); its
//! self-check ([`LightTree::validate`]) and its byte serialisation.
//!
//! This file holds the [`LightTree`] type and the part of its API that reads the finished
//! tree: the accessors ([`LightTree::nodes`], [`LightTree::slot`], [`LightTree::path`],
//! [`LightTree::stats`], …), the checks ([`LightTree::validate`],
//! [`LightTree::validate_lights`]) and the byte form ([`LightTree::as_bytes`],
//! [`LightTree::from_bytes`]). The rest of its API is spread over `crate::build` (building),
//! `crate::sample` (sampling and pmfs), [`crate::cut`] (sampling inside one cluster,
//! [`LightTree::sample_cluster`]) and `crate::trace` (the lights a ray reaches).

pub(crate) mod bytes;
mod validate;

pub(crate) use bytes::light_check_count;
pub use bytes::FORMAT_VERSION;
pub(crate) use bytes::{light_checks, LIGHT_BLOCK};

use crate::bounds::{Cone, Sphere};
use crate::infinite_light::InfiniteLight;
use crate::packed::{path_bits, Packed};
use crate::quantize;
use alloc::vec;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use wide::{f32x4, i32x4, u16x8};

/// Deepest tree a 64-bit path can encode (2 bits per level plus a marker bit).
pub const MAX_DEPTH: u32 = 31;

/// Largest number of lights (and of nodes) a tree holds.
pub const MAX_LIGHTS: u32 = (1 << 31) - 2;

/// A tree node: four child clusters in one 64-byte cache line (`repr(C)`, little-endian in
/// the byte format). Each slot is empty, a single light, or an inner node.
///
/// | offset | field | contents |
/// |---:|---|---|
/// | 0 | `sphere: [u32; 4]` | per slot: bytes 0–2 the centre's x, y, z codes, byte 3 the radius code |
/// | 16 | `cone: [u32; 4]` | per slot: bits 0–15 the axis (8+8-bit octahedral), 16–23 `sin(θo/2)`, 24–31 `sin(θe/2)`, 8 bits each |
/// | 32 | `origin: [f32; 3]` | the frame of the sphere codes |
/// | 44 | `child_base: u32` | index of the first inner child in [`LightTree::nodes`] |
/// | 48 | `energy: [u16; 4]` | per slot: the upper 16 bits of the cluster energy's 20-bit code (0: empty) |
/// | 56 | `leaf_base: u32` | index of the first light slot in the leaf array ([`LightTree::leaf_light`]) |
/// | 60 | `energy_low: u16` | bits 4k..4k+4: the low 4 bits of slot k's energy code |
/// | 62 | `exponent: u8` | the frame's scale `2^(exponent − 127)` |
/// | 63 | `mask: u8` | bit k: slot k is an inner node; bit 4 + k: slot k is a light |
///
/// A slot's centre is `origin + code · scale` per axis and its radius `code · scale`; its
/// cone and energy decode as in the crate's `quantize` module (an energy code is the upper 20
/// bits of the f32, rounded up). Every code is rounded outwards
/// from what it bounds (see docs/formulas.md, section 14), so the decoded bounds contain the
/// lights below the slot and importances stay conservative. The inner children of a node are
/// consecutive nodes, `child_base`, `child_base + 1`, … in slot order, and its light slots
/// consecutive entries of the leaf array from `leaf_base`.
///
/// Empty slots have energy 0 and evaluate to importance 0.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Node4 {
    /// Sphere codes, one word per slot.
    pub(crate) sphere: [u32; 4],
    /// Cone codes, one word per slot.
    pub(crate) cone: [u32; 4],
    /// Origin of the sphere codes.
    pub(crate) origin: [f32; 3],
    /// Index of the first inner child node.
    pub(crate) child_base: u32,
    /// Slot energies: the upper 16 bits of their 20-bit codes.
    pub(crate) energy: [u16; 4],
    /// Index of the first light slot in the leaf array.
    pub(crate) leaf_base: u32,
    /// Slot energies: the low 4 bits of their codes, slot k in bits 4k..4k+4.
    pub(crate) energy_low: u16,
    /// Scale exponent of the sphere codes (biased by 127).
    pub(crate) exponent: u8,
    /// Inner-node slots in bits 0–3, light slots in bits 4–7.
    pub(crate) mask: u8,
}

/// What a slot of a [`Node4`] holds, as the node alone knows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Child {
    /// Nothing.
    Empty,
    /// A single light, by its index in the leaf array ([`LightTree::leaf_light`]).
    Leaf(u32),
    /// An inner node, by index in [`LightTree::nodes`].
    Node(u32),
}

/// What a slot of a [`Node4`] holds, resolved by its tree.
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

/// Decoded sphere lanes of a node: centre x, y, z and radius of its four slots.
#[derive(Clone, Copy, Debug)]
pub struct Spheres4 {
    /// Centres, x.
    pub x: f32x4,
    /// Centres, y.
    pub y: f32x4,
    /// Centres, z.
    pub z: f32x4,
    /// Radii.
    pub r: f32x4,
}

/// The number of set bits among the low four of `x`, read from the sixteen counts packed in one
/// constant: three operations on a descent's chain of dependences, where `count_ones` of a
/// `u32` is two multiplications on baseline x86-64 (no popcount instruction).
#[inline(always)]
pub(crate) fn count4(x: u32) -> u32 {
    ((0x4332_3221_3221_2110u64 >> (4 * (x & 0xF))) & 0xF) as u32
}

impl Node4 {
    /// A node with four empty slots.
    pub const EMPTY: Node4 = Node4 {
        sphere: [0; 4],
        cone: [0; 4],
        origin: [0.0; 3],
        child_base: 0,
        energy: [0; 4],
        leaf_base: 0,
        energy_low: 0,
        exponent: 127,
        mask: 0,
    };

    /// What slot `k` (0..4) holds.
    #[inline(always)]
    #[must_use]
    pub fn child(&self, k: usize) -> Child {
        let bit = 1u32 << (k & 3);
        let below = bit - 1;
        let m = u32::from(self.mask);
        if m & bit != 0 {
            Child::Node(self.child_base.wrapping_add(count4(m & below)))
        } else if (m >> 4) & bit != 0 {
            Child::Leaf(self.leaf_base.wrapping_add(count4((m >> 4) & below)))
        } else {
            Child::Empty
        }
    }

    /// Number of inner-node slots.
    #[inline]
    #[must_use]
    pub fn inner_count(&self) -> u32 {
        count4(u32::from(self.mask))
    }

    /// Number of light slots.
    #[inline]
    #[must_use]
    pub fn leaf_count(&self) -> u32 {
        count4(u32::from(self.mask) >> 4)
    }

    /// The scale of the sphere codes.
    #[inline(always)]
    #[must_use]
    pub fn scale(&self) -> f32 {
        quantize::scale_of(self.exponent)
    }

    /// The four slots' spheres, decoded lane by lane (the twin of [`Node4::bounds`]).
    #[inline(always)]
    #[must_use]
    pub fn spheres4(&self) -> Spheres4 {
        let q = i32x4::new(bytemuck::cast(self.sphere));
        let s = f32x4::splat(self.scale());
        Spheres4 {
            x: quantize::byte_lanes(q, 0) * s + f32x4::splat(self.origin[0]),
            y: quantize::byte_lanes(q, 8) * s + f32x4::splat(self.origin[1]),
            z: quantize::byte_lanes(q, 16) * s + f32x4::splat(self.origin[2]),
            r: quantize::byte_lanes(q, 24) * s,
        }
    }

    /// Slot `k`'s 20-bit energy code.
    #[inline(always)]
    #[must_use]
    pub fn energy_code(&self, k: usize) -> u32 {
        let k = k & 3;
        (u32::from(self.energy[k]) << 4) | ((u32::from(self.energy_low) >> (4 * k)) & 0xF)
    }

    /// Sets slot `k`'s energy code (the upper 20 bits of an f32, see `quantize`).
    pub(crate) fn set_energy_code(&mut self, k: usize, code: u32) {
        let k = k & 3;
        self.energy[k] = (code >> 4) as u16;
        let shift = 4 * k as u32;
        self.energy_low = (self.energy_low & !(0xF << shift)) | (((code & 0xF) as u16) << shift);
    }

    /// The four slots' energies: [`Node4::energy_of`] of each slot, decoded in 16-bit lanes.
    /// The f32 of slot k is its code shifted up by 12 bits: `energy[k]` as the upper half,
    /// and bits 4k..4k+4 of `energy_low` at bits 12..16 of the lower half, moved there by a
    /// product with 2^(12 − 4k) (the bits it pushes beyond 16 fall off).
    #[inline(always)]
    #[must_use]
    pub fn energy4(&self) -> f32x4 {
        let e = self.energy;
        let upper = u16x8::new([0, e[0], 0, e[1], 0, e[2], 0, e[3]]);
        let lower = (u16x8::splat(self.energy_low) * u16x8::new([4096, 0, 256, 0, 16, 0, 1, 0]))
            & u16x8::splat(0xF000);
        bytemuck::cast(upper | lower)
    }

    /// The four slots' energies, as numbers.
    #[inline]
    #[must_use]
    pub fn energies(&self) -> [f32; 4] {
        [0, 1, 2, 3].map(|k| self.energy_of(k))
    }

    /// Slot `k`'s energy.
    #[inline]
    #[must_use]
    pub fn energy_of(&self, k: usize) -> f32 {
        quantize::decode_energy(self.energy_code(k))
    }

    /// Slot `k`'s bounds, decoded.
    #[must_use]
    pub fn bounds(&self, k: usize) -> SlotBounds {
        let k = k & 3;
        let s = self.sphere(k);
        let w = self.cone[k];
        let (cos_o, sin_o) = quantize::decode_angle(w >> 16);
        let cos_e = quantize::decode_emission(w >> 24);
        SlotBounds {
            center: s.center,
            radius: s.radius,
            axis: quantize::decode_axis(w),
            cos_o,
            sin_o,
            cos_e,
            energy: self.energy_of(k),
        }
    }

    /// Slot `k`'s sphere, decoded.
    #[inline]
    pub(crate) fn sphere(&self, k: usize) -> Sphere {
        quantize::decode_sphere(self.sphere[k & 3], self.origin, self.scale())
    }

    /// Slot `k`'s cone, decoded.
    pub(crate) fn cone(&self, k: usize) -> Cone {
        quantize::decode_cone(self.cone[k & 3])
    }
}

/// Size and shape of a built tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TreeStats {
    /// Lights passed to the build.
    pub lights: u32,
    /// Lights that can be sampled: those in the node tree (of positive energy), and the
    /// distant and environment lights of positive irradiance (for the environment, a positive
    /// bound), which [`LightTree::sample`] chooses at the root.
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
    /// Per node, the relative variance of its lights' energies (bfloat16), for split sampling.
    pub(crate) variances: Vec<u16>,
    /// Per light slot in tree order, its light's index, in [`index_bits`] of the light count.
    pub(crate) leaves: Packed,
    /// Per light, its path (see [`LightTree::path`]), in [`path_bits`] of the depth.
    pub(crate) paths: Packed,
    pub(crate) depth: u32,
    /// Per block of [`LIGHT_BLOCK`] lights, the CRC-64 of their descriptors
    /// (`light_checks`): what a load with lights checks them against.
    pub(crate) light_checks: Vec<u64>,
    /// The distant and environment lights, in input order (not in the nodes; their paths are
    /// 0).
    pub(crate) infinite: Vec<InfiniteLight>,
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

impl LightTree {
    /// A tree of finished nodes, node variances and leaf array over `n_lights` lights, `depth`
    /// levels deep, with the paths written by one pass over the nodes, parents before their
    /// children as the build lays them out (so that they are packed in the width the depth
    /// needs, and nothing is kept for them while the nodes are made).
    pub(crate) fn with_paths(
        nodes: Vec<Node4>,
        variances: Vec<u16>,
        leaves: Packed,
        n_lights: usize,
        depth: u32,
    ) -> LightTree {
        let mut paths = Packed::zeros(n_lights, path_bits(depth));
        // One pass over the nodes in order: a node's children come after it, so its path
        // (0 for a node no path reaches) is known when it is read.
        let mut node_paths: Vec<u64> = vec![0; nodes.len()];
        if let Some(root) = node_paths.first_mut() {
            *root = 1;
        }
        for (index, node) in nodes.iter().enumerate() {
            let path = node_paths[index];
            if path == 0 {
                continue;
            }
            for k in 0..4 {
                let slot_path = (path << 2) | k as u64;
                match node.child(k) {
                    Child::Node(c) => {
                        if let Some(p) = node_paths
                            .get_mut(c as usize)
                            .filter(|_| c as usize > index)
                        {
                            *p = slot_path;
                        }
                    }
                    Child::Leaf(i) => match leaves.get(i as usize) {
                        Some(l) if (l as usize) < n_lights => paths.set(l as usize, slot_path),
                        _ => {}
                    },
                    Child::Empty => {}
                }
            }
        }
        LightTree {
            nodes,
            variances,
            leaves,
            paths,
            depth,
            light_checks: vec![0; light_check_count(n_lights)],
            infinite: Vec::new(),
        }
    }

    /// The nodes; node 0 is the root (absent for a tree that samples nothing).
    #[must_use]
    pub fn nodes(&self) -> &[Node4] {
        &self.nodes
    }

    /// The variance of the energies of the lights under node `node`, over their squared mean
    /// (0 for a node out of range): what split sampling's variance heuristic reads.
    #[inline]
    #[must_use]
    pub fn energy_rel_variance(&self, node: u32) -> f32 {
        self.variances
            .get(node as usize)
            .map_or(0.0, |&v| quantize::decode_bf16(v))
    }

    /// The light of light slot `i` in tree order (a slot [`Child::Leaf`]`(i)` holds it); `None`
    /// past the last light slot.
    #[inline(always)]
    #[must_use]
    pub fn leaf_light(&self, i: u32) -> Option<u32> {
        self.leaves.get(i as usize).map(|l| l as u32)
    }

    /// Number of light slots (the lights of positive energy).
    #[must_use]
    pub fn leaf_count(&self) -> u32 {
        self.leaves.len() as u32
    }

    /// The path of `light`: its 2-bit slot choices from the root, the root's choice in the
    /// highest pair, below a marker bit 1 (so a path of L levels is `1 << 2L | choices`); 0 for
    /// a light that is not in the tree (zero energy) or out of range.
    #[inline]
    #[must_use]
    pub fn path(&self, light: u32) -> u64 {
        self.paths.get(light as usize).unwrap_or(0)
    }

    /// Number of lights the tree was built from.
    #[must_use]
    pub fn light_count(&self) -> u32 {
        self.paths.len() as u32
    }

    /// Levels of nodes (0 for an empty tree).
    #[must_use]
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// Whether the tree samples nothing: no light of the node tree has positive energy and
    /// there is no distant or environment light.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty() && self.infinite.is_empty()
    }

    /// Total energy of the sampled lights (as the root's slots store it, rounded up).
    #[must_use]
    pub fn total_energy(&self) -> f32 {
        self.nodes
            .first()
            .map_or(0.0, |n| n.energies().iter().sum::<f32>())
    }

    /// What slot `k` of `node` (a node of this tree) holds.
    #[inline(always)]
    #[must_use]
    pub fn slot(&self, node: &Node4, k: usize) -> Slot {
        match node.child(k) {
            Child::Empty => Slot::Empty,
            Child::Node(c) => Slot::Node(c),
            Child::Leaf(i) => match self.leaf_light(i) {
                Some(l) => Slot::Light(l),
                None => Slot::Empty,
            },
        }
    }

    /// The lights at infinity that can be sampled somewhere: of a positive irradiance (a
    /// distant light's luminance, an environment's largest bound).
    fn sampled_infinite(&self) -> usize {
        self.infinite
            .iter()
            .filter(|e| e.irradiance.iter().any(|&x| x > 0.0))
            .count()
    }

    /// Bytes of the nodes, the node variances, the leaf array, the paths, the lights'
    /// checksums and the entries of the lights at infinity.
    fn array_bytes(&self) -> usize {
        core::mem::size_of_val(self.nodes.as_slice())
            + core::mem::size_of_val(self.variances.as_slice())
            + self.leaves.byte_len()
            + self.paths.byte_len()
            + core::mem::size_of_val(self.light_checks.as_slice())
            + core::mem::size_of_val(self.infinite.as_slice())
    }

    /// Size and shape.
    #[must_use]
    pub fn stats(&self) -> TreeStats {
        let bytes = self.array_bytes();
        let lights = self.paths.len() as u32;
        let filled: u32 = self
            .nodes
            .iter()
            .map(|n| n.inner_count() + n.leaf_count())
            .sum();
        TreeStats {
            lights,
            sampled_lights: (self.leaves.len() + self.sampled_infinite()) as u32,
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

    /// The `(node, slot)` a path (encoded as in [`LightTree::path`]) ends at; `None` when the
    /// path leaves the tree.
    #[must_use]
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
            match self.nodes.get(node as usize)?.child(k) {
                Child::Node(c) => node = c,
                _ => return None,
            }
        }
        None
    }
}

const _: () = assert!(core::mem::size_of::<Node4>() == 64);
const _: () = assert!(core::mem::align_of::<Node4>() == 64);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn count4_counts_the_low_four_bits() {
        for x in 0..256u32 {
            assert_eq!(count4(x), (x & 0xF).count_ones(), "{x:#x}");
        }
    }

    #[test]
    fn energy4_decodes_each_slot_as_energy_of() {
        let mut node = Node4::EMPTY;
        // Every 20-bit code in each slot, the other slots holding other codes.
        for code in 0..1u32 << 20 {
            for k in 0..4 {
                node.set_energy_code(k, (code ^ (0x5A5A5 * k as u32)) & 0xF_FFFF);
            }
            let lanes = node.energy4().to_array();
            for (k, lane) in lanes.iter().enumerate() {
                assert_eq!(
                    lane.to_bits(),
                    node.energy_of(k).to_bits(),
                    "code {code:#x}"
                );
            }
        }
    }
}
