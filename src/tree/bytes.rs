//! The tree's byte form: the sealed header (magic, [`FORMAT_VERSION`], the payload's length
//! and CRC-64/XZ), the payload [`LightTree::as_bytes`] writes and [`LightTree::from_bytes`]
//! validates before it builds anything, and the lights' checksums a load with lights compares.

use super::{LightTree, Node4, MAX_DEPTH, MAX_LIGHTS};
use crate::checksum::{crc64, Crc64};
use crate::colour::Rgb;
use crate::error::{FormatError, ValidationError};
use crate::infinite_light::InfiniteLight;
use crate::light::Light;
use crate::limits::MAX_INFINITE_LIGHTS;
use crate::packed::{index_bits, path_bits, Packed};
use alloc::vec::Vec;

/// The byte format's version, the only one [`LightTree::from_bytes`] reads: a 24-byte header
/// (magic, version, payload length, CRC-64 of the payload) before the payload (counts, 64-byte
/// quantised nodes, variances, the leaf array and paths bit-packed into 64-bit words, the
/// lights' checksums, the section of the distant and environment lights), laid out on [`LightTree::as_bytes`].
pub const FORMAT_VERSION: u8 = 4;
const MAGIC: [u8; 7] = *b"MLTREE\x00";
/// Bytes of the header: magic (7), version (1), payload length (8), checksum (8).
pub const HEADER_BYTES: usize = 24;
/// Bytes of the payload's own header: three counts (8 each), the depth (4), the byte-order
/// mark (4).
const COUNTS: usize = 32;

/// The byte form of a payload: the header (magic, [`FORMAT_VERSION`], the payload's length, its
/// CRC-64/XZ) followed by `payload`, as [`LightTree::as_bytes`] writes it. For tools that
/// write payloads of their own (a fuzzer that reaches the parser behind the checksum, a
/// test of the structural checks); [`LightTree::from_bytes`] still validates the payload
/// fully.
#[must_use]
pub fn seal(payload: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER_BYTES + payload.len());
    out.extend_from_slice(&MAGIC);
    out.push(FORMAT_VERSION);
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc64(payload).to_le_bytes());
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
    let computed = crc64(payload);
    if computed != stored {
        return Err(FormatError::Checksum { stored, computed });
    }
    Ok(payload)
}

/// Lights per checksum of [`light_checks`]: the tree's bytes carry one CRC per block of this
/// many consecutive lights, so that a load with the wrong lights names the first block that
/// differs.
pub(crate) const LIGHT_BLOCK: usize = 64;

/// The canonical bytes of a light, as [`light_checks`] hashes them: a kind byte (0 point, 1
/// spot, 2 sphere, 3 disk, 4 triangle, 5 VPL, 6 distant, 7 environment), then every field in
/// declaration order (a colour as its red, green and blue), each `f32` as its little-endian bits (so `-0.0` and `0.0` differ), each `bool` as one byte.
/// Returns the number of bytes written to `out`.
fn light_bytes(light: &Light, out: &mut [u8; 64]) -> usize {
    let mut n = 0;
    let mut put = |bytes: &[u8]| {
        out[n..n + bytes.len()].copy_from_slice(bytes);
        n += bytes.len();
    };
    let f = |x: f32| x.to_bits().to_le_bytes();
    let rgb = |c: Rgb| {
        let mut b = [0u8; 12];
        for (k, x) in [c.r, c.g, c.b].into_iter().enumerate() {
            b[4 * k..4 * k + 4].copy_from_slice(&f(x));
        }
        b
    };
    match *light {
        Light::Point {
            position,
            intensity,
        } => {
            put(&[0]);
            for x in position.to_array() {
                put(&f(x));
            }
            put(&rgb(intensity));
        }
        Light::Spot {
            position,
            direction,
            intensity,
            half_angle,
            falloff_start,
        } => {
            put(&[1]);
            for x in position.to_array().into_iter().chain(direction.to_array()) {
                put(&f(x));
            }
            put(&rgb(intensity));
            for x in [half_angle, falloff_start] {
                put(&f(x));
            }
        }
        Light::Sphere {
            center,
            radius,
            radiance,
        } => {
            put(&[2]);
            for x in center.to_array() {
                put(&f(x));
            }
            put(&f(radius));
            put(&rgb(radiance));
        }
        Light::Disk {
            center,
            normal,
            radius,
            radiance,
            two_sided,
        } => {
            put(&[3]);
            for x in center.to_array().into_iter().chain(normal.to_array()) {
                put(&f(x));
            }
            put(&f(radius));
            put(&rgb(radiance));
            put(&[u8::from(two_sided)]);
        }
        Light::Triangle {
            vertices,
            radiance,
            two_sided,
        } => {
            put(&[4]);
            for v in vertices {
                for x in v.to_array() {
                    put(&f(x));
                }
            }
            put(&rgb(radiance));
            put(&[u8::from(two_sided)]);
        }
        Light::Vpl {
            position,
            normal,
            intensity,
        } => {
            put(&[5]);
            for x in position.to_array().into_iter().chain(normal.to_array()) {
                put(&f(x));
            }
            put(&rgb(intensity));
        }
        Light::Distant {
            direction,
            angular_radius,
            irradiance,
        } => {
            put(&[6]);
            for x in direction.to_array() {
                put(&f(x));
            }
            put(&f(angular_radius));
            put(&rgb(irradiance));
        }
        Light::Environment { irradiance } => {
            put(&[7]);
            for x in irradiance {
                put(&f(x));
            }
        }
    }
    n
}

/// The CRC-64/XZ of the canonical bytes of each block of [`LIGHT_BLOCK`] consecutive lights
/// (the last block may be shorter): what the tree's bytes store to tell whether the lights a
/// tree is loaded with are the ones it was built from. A light's canonical bytes: a kind byte
/// (0 point, 1 spot, 2 sphere, 3 disk, 4 triangle, 5 VPL, 6 distant, 7 environment), then
/// every field in declaration order (a colour as its red, green and blue), each `f32` as its little-endian bits (so `-0.0` and `0.0` differ), each `bool` as one
/// byte.
pub(crate) fn light_checks(lights: &[Light]) -> Vec<u64> {
    lights
        .chunks(LIGHT_BLOCK)
        .map(|block| {
            let mut c = Crc64::new();
            let mut buf = [0u8; 64];
            for l in block {
                let n = light_bytes(l, &mut buf);
                c.update(&buf[..n]);
            }
            c.finish()
        })
        .collect()
}

/// The number of light checksums of `n` lights.
pub(crate) fn light_check_count(n: usize) -> usize {
    n.div_ceil(LIGHT_BLOCK)
}

impl LightTree {
    /// The tree as bytes, for a host to cache or send to another process; read back with
    /// [`LightTree::from_bytes`] (or, with the lights, `LightSet::from_bytes`).
    ///
    /// Format version 4 ([`FORMAT_VERSION`]). A header of `HEADER_BYTES` bytes: the magic
    /// `MLTREE\0`, the version byte, then as little-endian u64 the payload's length and its
    /// CRC-64/XZ (`crc64`). The payload: as little-endian integers the node, light
    /// and leaf counts (u64 each) and the depth (u32), then a byte-order mark (the u32
    /// `0x01020304` in the host's byte order), followed in the host's byte order by the nodes,
    /// the node variances (u16 each), the leaf array, the paths and the lights' checksums
    /// (one u64 per block of `LIGHT_BLOCK` lights, `light_checks`), then the section
    /// of the distant and environment lights: their count as a little-endian u64, then the
    /// 64-byte [`InfiniteLight`] entries (in the host's byte order). The leaf
    /// array holds each light slot's light index in as many bits as the largest index needs
    /// (at least 1), the paths each light's path in `2·depth + 1` bits, each array packed back
    /// to back into 64-bit words (value `i` in bits `i·w` to `(i + 1)·w − 1` of the words read
    /// as one little-endian bit stream), with one word of padding after the last.
    #[must_use]
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
    /// mismatch), its entries of the lights at infinity included (else
    /// [`FormatError::Invalid`] with `ValidationError::BadInfinite` naming the first entry
    /// that differs from what `lights` give).
    pub fn from_bytes_with_lights(
        bytes: &[u8],
        lights: &[Light],
    ) -> Result<LightTree, FormatError> {
        let tree = LightTree::from_bytes(bytes)?;
        tree.check_lights(lights).map_err(FormatError::Lights)?;
        // The entries are outside the lights' checksums: compare them with the lights.
        tree.validate_infinite_lights(lights)
            .map_err(FormatError::Invalid)?;
        Ok(tree)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::Rgb;
    use glam::Vec3;

    #[test]
    fn light_checks_see_every_field() {
        let lights = [
            Light::Spot {
                position: Vec3::new(1.0, 2.0, 3.0),
                direction: Vec3::Z,
                intensity: Rgb::grey(1.0),
                half_angle: 0.5,
                falloff_start: 0.25,
            },
            Light::Disk {
                center: Vec3::ZERO,
                normal: Vec3::Z,
                radius: 1.0,
                radiance: Rgb::grey(1.0),
                two_sided: false,
            },
        ];
        let base = light_checks(&lights);
        assert_eq!(base.len(), 1);
        let mut other = lights;
        if let Light::Spot { falloff_start, .. } = &mut other[0] {
            *falloff_start = 0.2500001;
        }
        assert_ne!(light_checks(&other), base);
        let mut other = lights;
        if let Light::Disk { two_sided, .. } = &mut other[1] {
            *two_sided = true;
        }
        assert_ne!(light_checks(&other), base);
        assert_eq!(light_check_count(0), 0);
        assert_eq!(light_check_count(64), 1);
        assert_eq!(light_check_count(65), 2);
    }
}
