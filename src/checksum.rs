//! The checksum of the tree's byte form: CRC-64/XZ (the CRC-64 of the xz file format, ECMA-182's
//! polynomial in reflected form), and the canonical bytes of a light it is taken over.
//!
//! CRC-64/XZ: polynomial `0x42F0E1EBA9EA3693` (reflected: `0xC96C5795D7870F42`), initial value
//! and final XOR `0xFFFFFFFFFFFFFFFF`, input and output reflected; its check value (the CRC of
//! the nine ASCII bytes `123456789`) is `0x995DC9BBDF1939FA`. As every CRC of 64 bits it
//! detects every change confined to 64 consecutive bits (a burst error), and any other change
//! escapes it with probability 2⁻⁶⁴. It detects corruption, not tampering: anyone can compute
//! it.
//!
//! Computed eight bytes at a time ("slicing by 8") from tables built at compile time.

use crate::colour::Rgb;
use crate::light::Light;

/// The reflected polynomial.
const POLY: u64 = 0xC96C_5795_D787_0F42;

/// `TABLES[0]` is the byte-at-a-time table; `TABLES[k][b]` is the CRC state after the byte `b`
/// followed by `k` zero bytes.
static TABLES: [[u64; 256]; 8] = tables();

const fn tables() -> [[u64; 256]; 8] {
    let mut t = [[0u64; 256]; 8];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u64;
        let mut bit = 0;
        while bit < 8 {
            c = if c & 1 != 0 { (c >> 1) ^ POLY } else { c >> 1 };
            bit += 1;
        }
        t[0][i] = c;
        i += 1;
    }
    let mut k = 1;
    while k < 8 {
        let mut i = 0;
        while i < 256 {
            let prev = t[k - 1][i];
            t[k][i] = (prev >> 8) ^ t[0][(prev & 0xFF) as usize];
            i += 1;
        }
        k += 1;
    }
    t
}

/// A running CRC-64/XZ: [`Crc64::update`] with the bytes in order, then [`Crc64::finish`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crc64 {
    state: u64,
}

impl Default for Crc64 {
    fn default() -> Self {
        Crc64::new()
    }
}

impl Crc64 {
    /// The CRC of no bytes yet.
    pub const fn new() -> Crc64 {
        Crc64 { state: !0 }
    }

    /// Adds `bytes`.
    pub fn update(&mut self, bytes: &[u8]) {
        let t = &TABLES;
        let mut c = self.state;
        let mut chunks = bytes.chunks_exact(8);
        for w in &mut chunks {
            let mut b = [0u8; 8];
            b.copy_from_slice(w);
            let v = (c ^ u64::from_le_bytes(b)).to_le_bytes();
            c = t[7][v[0] as usize]
                ^ t[6][v[1] as usize]
                ^ t[5][v[2] as usize]
                ^ t[4][v[3] as usize]
                ^ t[3][v[4] as usize]
                ^ t[2][v[5] as usize]
                ^ t[1][v[6] as usize]
                ^ t[0][v[7] as usize];
        }
        for &b in chunks.remainder() {
            c = (c >> 8) ^ t[0][((c ^ u64::from(b)) & 0xFF) as usize];
        }
        self.state = c;
    }

    /// The CRC of the bytes added.
    pub fn finish(self) -> u64 {
        !self.state
    }
}

/// The CRC-64/XZ of `bytes`.
pub fn crc64(bytes: &[u8]) -> u64 {
    let mut c = Crc64::new();
    c.update(bytes);
    c.finish()
}

/// Lights per checksum of [`light_checks`]: the tree's bytes carry one CRC per block of this
/// many consecutive lights, so that a load with the wrong lights names the first block that
/// differs.
pub const LIGHT_BLOCK: usize = 64;

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
pub fn light_checks(lights: &[Light]) -> alloc::vec::Vec<u64> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The bitwise reference: one bit at a time, straight from the definition.
    fn crc64_bitwise(bytes: &[u8]) -> u64 {
        let mut c = !0u64;
        for &b in bytes {
            c ^= u64::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 { (c >> 1) ^ POLY } else { c >> 1 };
            }
        }
        !c
    }

    #[test]
    fn check_value_of_crc64_xz() {
        assert_eq!(crc64(b"123456789"), 0x995D_C9BB_DF19_39FA);
        assert_eq!(crc64(b""), 0);
    }

    #[test]
    fn slicing_by_8_equals_the_bitwise_definition() {
        let mut x = 0x1234_5678_9ABC_DEF0u64;
        let bytes: alloc::vec::Vec<u8> = (0..1000)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x as u8
            })
            .collect();
        for len in (0..40).chain([63, 64, 65, 999, 1000]) {
            assert_eq!(crc64(&bytes[..len]), crc64_bitwise(&bytes[..len]), "{len}");
            // Split anywhere, the running CRC is the same.
            for cut in [0, 1, 7, 8, 9].into_iter().filter(|&c| c <= len) {
                let mut c = Crc64::new();
                c.update(&bytes[..cut]);
                c.update(&bytes[cut..len]);
                assert_eq!(c.finish(), crc64(&bytes[..len]));
            }
        }
    }

    #[test]
    fn every_burst_of_up_to_64_bits_changes_the_crc() {
        let bytes = [0x5Au8; 48];
        let base = crc64(&bytes);
        for start in 0..bytes.len() * 8 - 64 {
            for pattern in [1u64, 0xFFFF_FFFF_FFFF_FFFF, 0x8000_0000_0000_0001, 0xF0F0] {
                let mut b = bytes;
                for i in 0..64 {
                    if pattern >> i & 1 != 0 {
                        let bit = start + i;
                        b[bit / 8] ^= 1 << (bit % 8);
                    }
                }
                assert_ne!(crc64(&b), base, "burst at bit {start}");
            }
        }
    }

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
