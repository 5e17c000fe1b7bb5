//! Unsigned integers of one fixed width, packed back to back into 64-bit words: the tree's
//! leaf array (light indices, as many bits as the largest index needs) and its per-light
//! paths (two bits per level and a marker bit).

use alloc::vec;
use alloc::vec::Vec;

/// `len` unsigned integers of `bits` bits each (1 to 64): value `i` is bits `i·bits` to
/// `(i + 1)·bits − 1` of the words read as one little-endian bit stream. One word more than
/// the values need is kept (zero when built), so that every read loads the same two
/// consecutive words whatever the value's position.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Packed {
    bits: u32,
    len: usize,
    words: Vec<u64>,
}

impl Packed {
    /// The number of words `len` values of `bits` bits take (the padding word included).
    pub(crate) fn word_count(len: usize, bits: u32) -> usize {
        (len as u64 * u64::from(bits)).div_ceil(64) as usize + 1
    }

    /// `len` zeros of `bits` bits (clamped into 1 to 64).
    pub(crate) fn zeros(len: usize, bits: u32) -> Packed {
        let bits = bits.clamp(1, 64);
        Packed {
            bits,
            len,
            words: vec![0; Packed::word_count(len, bits)],
        }
    }

    /// `len` values of `bits` bits read from `words` (as [`Packed::words`] gives them);
    /// `None` unless there are exactly [`Packed::word_count`] of them.
    pub(crate) fn from_words(len: usize, bits: u32, words: Vec<u64>) -> Option<Packed> {
        ((1..=64).contains(&bits) && words.len() == Packed::word_count(len, bits))
            .then_some(Packed { bits, len, words })
    }

    /// The values, each cut to `bits` bits.
    #[cfg(test)]
    pub(crate) fn from_values(bits: u32, values: &[u64]) -> Packed {
        let mut p = Packed::zeros(values.len(), bits);
        for (i, &v) in values.iter().enumerate() {
            p.set(i, v);
        }
        p
    }

    /// Value `i`; `None` past the end.
    #[inline(always)]
    pub(crate) fn get(&self, i: usize) -> Option<u64> {
        if i >= self.len {
            return None;
        }
        let bit = i as u64 * u64::from(self.bits);
        let w = (bit >> 6) as usize;
        let (lo, hi) = (*self.words.get(w)?, *self.words.get(w + 1)?);
        let both = (u128::from(hi) << 64) | u128::from(lo);
        Some((both >> (bit & 63)) as u64 & (u64::MAX >> (64 - self.bits)))
    }

    /// Hints that value `i` will soon be read ([`crate::prefetch`]): the cache line of its
    /// first word. Nothing past the end.
    #[inline(always)]
    pub(crate) fn prefetch(&self, i: usize) {
        let w = ((i as u64 * u64::from(self.bits)) >> 6) as usize;
        if let Some(word) = self.words.get(w) {
            crate::prefetch::prefetch(word);
        }
    }

    /// Sets value `i` (< `len`) to `value` cut to `bits` bits.
    pub(crate) fn set(&mut self, i: usize, value: u64) {
        debug_assert!(i < self.len);
        let bit = i as u64 * u64::from(self.bits);
        let (w, shift) = ((bit >> 6) as usize, (bit & 63) as u32);
        let mask = u128::from(u64::MAX >> (64 - self.bits)) << shift;
        let mut both = (u128::from(self.words[w + 1]) << 64) | u128::from(self.words[w]);
        both = (both & !mask) | ((u128::from(value) << shift) & mask);
        self.words[w] = both as u64;
        self.words[w + 1] = (both >> 64) as u64;
    }

    /// Sets values `at..at + src.len()`, all zero before, to the values of `src` (of the same
    /// width), a word at a time.
    pub(crate) fn fill_from(&mut self, at: usize, src: &Packed) {
        debug_assert!(src.bits == self.bits && at + src.len <= self.len);
        let bits = u64::from(self.bits);
        let (start, total) = (at as u64 * bits, src.len as u64 * bits);
        let (first, shift) = ((start >> 6) as usize, (start & 63) as u32);
        let words = total.div_ceil(64) as usize;
        let rest = (total & 63) as u32;
        for (i, &word) in src.words[..words].iter().enumerate() {
            let v = if i + 1 == words && rest != 0 {
                word & (u64::MAX >> (64 - rest))
            } else {
                word
            };
            self.words[first + i] |= v << shift;
            if shift != 0 {
                self.words[first + i + 1] |= v >> (64 - shift);
            }
        }
    }

    /// Number of values.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Whether there are no values.
    pub(crate) fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bits per value.
    pub(crate) fn bits(&self) -> u32 {
        self.bits
    }

    /// The words, padding word included.
    pub(crate) fn words(&self) -> &[u64] {
        &self.words
    }

    /// Bytes of the words.
    pub(crate) fn byte_len(&self) -> usize {
        self.words.len() * 8
    }
}

/// Bits a light index below `n` needs (at least 1).
pub(crate) fn index_bits(n: usize) -> u32 {
    (usize::BITS - n.saturating_sub(1).leading_zeros()).max(1)
}

/// Bits a path of a tree of `depth` levels needs: two per level and the marker bit.
pub(crate) fn path_bits(depth: u32) -> u32 {
    2 * depth + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_of_every_width_read_back() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for bits in 1..=64u32 {
            let mask = u64::MAX >> (64 - bits);
            let values: Vec<u64> = (0..131)
                .map(|_| {
                    state = state
                        .wrapping_mul(6_364_136_223_846_793_005)
                        .wrapping_add(1_442_695_040_888_963_407);
                    state & mask
                })
                .collect();
            let mut p = Packed::from_values(bits, &values);
            for (i, &v) in values.iter().enumerate() {
                assert_eq!(p.get(i), Some(v), "bits {bits}, value {i}");
            }
            assert_eq!(p.get(values.len()), None);
            // Overwriting one value leaves its neighbours alone.
            p.set(7, mask);
            p.set(8, 0);
            assert_eq!(
                (p.get(6), p.get(7), p.get(8), p.get(9)),
                (Some(values[6]), Some(mask), Some(0), Some(values[9]))
            );
            assert_eq!(*p.words().last().unwrap(), 0, "the padding word stays 0");
            let q = Packed::from_words(p.len(), bits, p.words().to_vec()).unwrap();
            assert_eq!(p, q);
            assert!(Packed::from_words(p.len(), bits, p.words()[1..].to_vec()).is_none());
        }
    }

    #[test]
    fn fill_from_writes_what_set_writes() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for bits in 1..=64u32 {
            let mask = u64::MAX >> (64 - bits);
            for (len, parts) in [(0, &[0usize][..]), (1, &[1]), (130, &[3, 0, 64, 63])] {
                let values: Vec<u64> = (0..len).map(|_| next() & mask).collect();
                let want = Packed::from_values(bits, &values);
                let mut got = Packed::zeros(len, bits);
                let mut at = 0;
                for &m in parts.iter().chain([&(len - parts.iter().sum::<usize>())]) {
                    got.fill_from(at, &Packed::from_values(bits, &values[at..at + m]));
                    at += m;
                }
                assert_eq!(got, want, "bits {bits}, {len} values");
            }
        }
    }

    #[test]
    fn widths() {
        assert_eq!(
            [0, 1, 2, 3, 4, 5, 100_000, 1_000_000].map(index_bits),
            [1, 1, 1, 2, 2, 3, 17, 20]
        );
        assert_eq!(index_bits(1 << 31), 31);
        assert_eq!([0, 1, 13, 31].map(path_bits), [1, 3, 27, 63]);
    }
}
