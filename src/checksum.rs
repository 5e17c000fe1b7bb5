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
pub(crate) struct Crc64 {
    state: u64,
}

impl Default for Crc64 {
    fn default() -> Self {
        Crc64::new()
    }
}

impl Crc64 {
    /// The CRC of no bytes yet.
    pub(crate) const fn new() -> Crc64 {
        Crc64 { state: !0 }
    }

    /// Adds `bytes`.
    pub(crate) fn update(&mut self, bytes: &[u8]) {
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
    pub(crate) fn finish(self) -> u64 {
        !self.state
    }
}

/// The CRC-64/XZ of `bytes`.
#[must_use]
pub fn crc64(bytes: &[u8]) -> u64 {
    let mut c = Crc64::new();
    c.update(bytes);
    c.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
