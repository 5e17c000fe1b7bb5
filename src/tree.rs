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

use crate::bounds::{Cone, Sphere};
use crate::checksum::{self, light_check_count, LIGHT_BLOCK};
use crate::error::{FormatError, LightMismatch, ValidationError};
use crate::infinite::{InfiniteLight, MAX_INFINITE_LIGHTS};
use crate::light::Light;
use crate::packed::{index_bits, path_bits, Packed};
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
    pub fn inner_count(&self) -> u32 {
        count4(u32::from(self.mask))
    }

    /// Number of light slots.
    #[inline]
    pub fn leaf_count(&self) -> u32 {
        count4(u32::from(self.mask) >> 4)
    }

    /// The scale of the sphere codes.
    #[inline(always)]
    pub fn scale(&self) -> f32 {
        quantize::scale_of(self.exponent)
    }

    /// The four slots' spheres, decoded lane by lane (the twin of [`Node4::bounds`]).
    #[inline(always)]
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
    pub fn energy4(&self) -> f32x4 {
        let e = self.energy;
        let upper = u16x8::new([0, e[0], 0, e[1], 0, e[2], 0, e[3]]);
        let lower = (u16x8::splat(self.energy_low) * u16x8::new([4096, 0, 256, 0, 16, 0, 1, 0]))
            & u16x8::splat(0xF000);
        bytemuck::cast(upper | lower)
    }

    /// The four slots' energies, as numbers.
    #[inline]
    pub fn energies(&self) -> [f32; 4] {
        [0, 1, 2, 3].map(|k| self.energy_of(k))
    }

    /// Slot `k`'s energy.
    #[inline]
    pub fn energy_of(&self, k: usize) -> f32 {
        quantize::decode_energy(self.energy_code(k))
    }

    /// Slot `k`'s bounds, decoded.
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
    /// Per node, the relative variance of its lights' energies (bfloat16), for split sampling.
    pub(crate) variances: Vec<u16>,
    /// Per light slot in tree order, its light's index, in [`index_bits`] of the light count.
    pub(crate) leaves: Packed,
    /// Per light, its path (see [`LightTree::path`]), in [`path_bits`] of the depth.
    pub(crate) paths: Packed,
    pub(crate) depth: u32,
    /// Per block of [`LIGHT_BLOCK`] lights, the CRC-64 of their descriptors
    /// ([`checksum::light_checks`]): what a load with lights checks them against.
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

/// The byte format's version, the only one [`LightTree::from_bytes`] reads: a 24-byte header
/// (magic, version, payload length, CRC-64 of the payload) before the payload (counts, 64-byte
/// quantised nodes, variances, the leaf array and paths bit-packed into 64-bit words, the
/// lights' checksums, the section of the distant and environment lights), laid out on [`LightTree::as_bytes`].
pub const FORMAT_VERSION: u8 = 4;
const MAGIC: [u8; 7] = *b"MLTREE\x00";
/// Bytes of the header: magic (7), version (1), payload length (8), checksum (8).
pub(crate) const HEADER_BYTES: usize = 24;
/// Bytes of the payload's own header: three counts (8 each), the depth (4), the byte-order
/// mark (4).
const COUNTS: usize = 32;

/// The byte form of a payload: the header (magic, [`FORMAT_VERSION`], the payload's length, its
/// CRC-64/XZ) followed by `payload`, as [`LightTree::as_bytes`] writes it. For tools that
/// write payloads of their own (a fuzzer that reaches the parser behind the checksum, a
/// test of the structural checks); [`LightTree::from_bytes`] still validates the payload
/// fully.
pub(crate) fn seal(payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_BYTES + payload.len());
    out.extend_from_slice(&MAGIC);
    out.push(FORMAT_VERSION);
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&checksum::crc64(payload).to_le_bytes());
    out.extend_from_slice(payload);
    out
}

/// The payload of sealed bytes, once the header says they are a tree of this format version
/// whose payload is exactly the bytes after it and carries its checksum; nothing of the
/// payload is read before.
fn unseal(bytes: &[u8]) -> Result<&[u8], FormatError> {
    if bytes.len() >= 8 && bytes[..7] == MAGIC && bytes[7] != FORMAT_VERSION {
        return Err(FormatError::UnsupportedVersion {
            found: bytes[7],
            supported: FORMAT_VERSION,
        });
    }
    if bytes.len() < HEADER_BYTES {
        return Err(FormatError::Truncated);
    }
    if bytes[..7] != MAGIC {
        return Err(FormatError::BadHeader);
    }
    let u64_at = |o: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&bytes[o..o + 8]);
        u64::from_le_bytes(b)
    };
    let (declared, stored) = (u64_at(8), u64_at(16));
    let payload = &bytes[HEADER_BYTES..];
    let len = payload.len() as u64;
    if len < declared {
        return Err(FormatError::Truncated);
    }
    if len > declared {
        return Err(FormatError::TrailingBytes);
    }
    let computed = checksum::crc64(payload);
    if computed != stored {
        return Err(FormatError::Checksum { stored, computed });
    }
    Ok(payload)
}

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
    pub fn nodes(&self) -> &[Node4] {
        &self.nodes
    }

    /// The variance of the energies of the lights under node `node`, over their squared mean
    /// (0 for a node out of range): what split sampling's variance heuristic reads.
    #[inline]
    pub fn energy_rel_variance(&self, node: u32) -> f32 {
        self.variances
            .get(node as usize)
            .map_or(0.0, |&v| quantize::decode_bf16(v))
    }

    /// The light of light slot `i` in tree order (a slot [`Child::Leaf`]`(i)` holds it); `None`
    /// past the last light slot.
    #[inline(always)]
    pub fn leaf_light(&self, i: u32) -> Option<u32> {
        self.leaves.get(i as usize).map(|l| l as u32)
    }

    /// Number of light slots (the lights of positive energy).
    pub fn leaf_count(&self) -> u32 {
        self.leaves.len() as u32
    }

    /// The path of `light`: its 2-bit slot choices from the root, the root's choice in the
    /// highest pair, below a marker bit 1 (so a path of L levels is `1 << 2L | choices`); 0 for
    /// a light that is not in the tree (zero energy) or out of range.
    #[inline]
    pub fn path(&self, light: u32) -> u64 {
        self.paths.get(light as usize).unwrap_or(0)
    }

    /// Number of lights the tree was built from.
    pub fn light_count(&self) -> u32 {
        self.paths.len() as u32
    }

    /// Levels of nodes (0 for an empty tree).
    pub fn depth(&self) -> u32 {
        self.depth
    }

    /// Whether the tree samples nothing: no light of the node tree has positive energy and
    /// there is no distant or environment light.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty() && self.infinite.is_empty()
    }

    /// Total energy of the sampled lights (as the root's slots store it, rounded up).
    pub fn total_energy(&self) -> f32 {
        self.nodes
            .first()
            .map_or(0.0, |n| n.energies().iter().sum::<f32>())
    }

    /// What slot `k` of `node` (a node of this tree) holds.
    #[inline(always)]
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
            sampled_lights: self.leaves.len() as u32,
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
        let checks = checksum::light_checks(lights);
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

    /// The tree as bytes, for a host to cache or send to another process; read back with
    /// [`LightTree::from_bytes`] (or, with the lights, `LightSet::from_bytes`).
    ///
    /// Format version 4 ([`FORMAT_VERSION`]). A header of `HEADER_BYTES` bytes: the magic
    /// `MLTREE\0`, the version byte, then as little-endian u64 the payload's length and its
    /// CRC-64/XZ (`checksum::crc64`). The payload: as little-endian integers the node, light
    /// and leaf counts (u64 each) and the depth (u32), then a byte-order mark (the u32
    /// `0x01020304` in the host's byte order), followed in the host's byte order by the nodes,
    /// the node variances (u16 each), the leaf array, the paths and the lights' checksums
    /// (one u64 per block of `LIGHT_BLOCK` lights, `checksum::light_checks`), then the section
    /// of the distant and environment lights: their count as a little-endian u64, then the
    /// 64-byte [`InfiniteLight`] entries (in the host's byte order). The leaf
    /// array holds each light slot's light index in as many bits as the largest index needs
    /// (at least 1), the paths each light's path in `2·depth + 1` bits, each array packed back
    /// to back into 64-bit words (value `i` in bits `i·w` to `(i + 1)·w − 1` of the words read
    /// as one little-endian bit stream), with one word of padding after the last.
    pub fn as_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(COUNTS + self.array_bytes());
        out.extend_from_slice(&(self.nodes.len() as u64).to_le_bytes());
        out.extend_from_slice(&(self.paths.len() as u64).to_le_bytes());
        out.extend_from_slice(&(self.leaves.len() as u64).to_le_bytes());
        out.extend_from_slice(&self.depth.to_le_bytes());
        out.extend_from_slice(&0x0102_0304u32.to_ne_bytes());
        out.extend_from_slice(bytemuck::cast_slice(&self.nodes));
        out.extend_from_slice(bytemuck::cast_slice(&self.variances));
        out.extend_from_slice(bytemuck::cast_slice(self.leaves.words()));
        out.extend_from_slice(bytemuck::cast_slice(self.paths.words()));
        out.extend_from_slice(bytemuck::cast_slice(&self.light_checks));
        out.extend_from_slice(&(self.infinite.len() as u64).to_le_bytes());
        out.extend_from_slice(bytemuck::cast_slice(&self.infinite));
        seal(&out)
    }

    /// Reads a tree written by [`LightTree::as_bytes`] on a machine of the same byte order.
    /// The header is checked first (magic, version, the payload's length and its CRC-64), and
    /// nothing of the payload is read unless its checksum matches; then the tree is validated
    /// fully ([`LightTree::validate`]). Corrupt bytes give an error, never a panic or a bad
    /// tree: a change confined to 64 consecutive bits of the payload always fails the
    /// checksum, any other change does with probability 1 − 2⁻⁶⁴, and a change to the header
    /// fails its own checks. Bytes of another format version give
    /// [`FormatError::UnsupportedVersion`].
    pub fn from_bytes(bytes: &[u8]) -> Result<LightTree, FormatError> {
        let payload = unseal(bytes)?;
        if payload.len() < COUNTS {
            return Err(FormatError::Truncated);
        }
        let u64_at = |o: usize| {
            let mut b = [0u8; 8];
            b.copy_from_slice(&payload[o..o + 8]);
            u64::from_le_bytes(b)
        };
        let u32_at = |o: usize| {
            let mut b = [0u8; 4];
            b.copy_from_slice(&payload[o..o + 4]);
            b
        };
        if u32_at(28) != 0x0102_0304u32.to_ne_bytes() {
            return Err(FormatError::BadHeader);
        }
        let n_nodes = u64_at(0);
        let n_lights = u64_at(8);
        let n_leaves = u64_at(16);
        let depth = u32::from_le_bytes(u32_at(24));
        let max = u64::from(MAX_LIGHTS);
        if n_nodes > max || n_lights > max || n_leaves > n_lights || depth > MAX_DEPTH {
            return Err(FormatError::Invalid(ValidationError::BadStats));
        }
        let (n_nodes, n_lights, n_leaves) =
            (n_nodes as usize, n_lights as usize, n_leaves as usize);
        let (leaf_bits, path_bits) = (index_bits(n_lights), path_bits(depth));
        let node_bytes = n_nodes * core::mem::size_of::<Node4>();
        let variance_bytes = n_nodes * 2;
        let leaf_bytes = Packed::word_count(n_leaves, leaf_bits) * 8;
        let path_bytes = Packed::word_count(n_lights, path_bits) * 8;
        let check_bytes = light_check_count(n_lights) * 8;
        let arrays = COUNTS + node_bytes + variance_bytes + leaf_bytes + path_bytes + check_bytes;
        if payload.len() < arrays + 8 {
            return Err(FormatError::Truncated);
        }
        let n_infinite = u64_at(arrays);
        if n_infinite > MAX_INFINITE_LIGHTS as u64 {
            return Err(FormatError::Invalid(ValidationError::BadStats));
        }
        let infinite_bytes = n_infinite as usize * core::mem::size_of::<InfiniteLight>();
        let need = arrays + 8 + infinite_bytes;
        if payload.len() < need {
            return Err(FormatError::Truncated);
        }
        if payload.len() > need {
            return Err(FormatError::TrailingBytes);
        }
        let mut o = COUNTS;
        let nodes: Vec<Node4> = bytemuck::pod_collect_to_vec(&payload[o..o + node_bytes]);
        o += node_bytes;
        let variances: Vec<u16> = bytemuck::pod_collect_to_vec(&payload[o..o + variance_bytes]);
        o += variance_bytes;
        let words = |raw: &[u8]| bytemuck::pod_collect_to_vec::<u8, u64>(raw);
        let leaves = Packed::from_words(n_leaves, leaf_bits, words(&payload[o..o + leaf_bytes]));
        o += leaf_bytes;
        let paths = Packed::from_words(n_lights, path_bits, words(&payload[o..o + path_bytes]));
        o += path_bytes;
        let light_checks = words(&payload[o..o + check_bytes]);
        let (Some(leaves), Some(paths)) = (leaves, paths) else {
            return Err(FormatError::Truncated);
        };
        o = arrays + 8;
        let infinite: Vec<InfiniteLight> =
            bytemuck::pod_collect_to_vec(&payload[o..o + infinite_bytes]);
        let tree = LightTree {
            nodes,
            variances,
            leaves,
            paths,
            depth,
            light_checks,
            infinite,
        };
        tree.validate().map_err(FormatError::Invalid)?;
        Ok(tree)
    }

    /// [`LightTree::from_bytes`], then [`LightTree::check_lights`]: the tree of `bytes` if
    /// `lights` are the ones it was built from (else [`FormatError::Lights`] naming the first
    /// mismatch).
    pub fn from_bytes_with_lights(
        bytes: &[u8],
        lights: &[Light],
    ) -> Result<LightTree, FormatError> {
        let tree = LightTree::from_bytes(bytes)?;
        tree.check_lights(lights).map_err(FormatError::Lights)?;
        Ok(tree)
    }

    /// The `(node, slot)` a path (encoded as in [`LightTree::path`]) ends at; `None` when the
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
            match self.nodes.get(node as usize)?.child(k) {
                Child::Node(c) => node = c,
                _ => return None,
            }
        }
        None
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
