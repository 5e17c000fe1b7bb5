//! The tests' deterministic generator: SplitMix64 (Steele, Lea & Flood 2014), one stream per
//! seed, shared by the core's unit tests and its integration tests (`tests/common`).

use glam::{DVec3, Vec3};

/// One step of SplitMix64 on `state`.
#[inline]
pub fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A SplitMix64 stream. `SplitMix64(state)` starts at a raw state, [`SplitMix64::new`] from a
/// seed (mixed with a constant, so that small seeds do not start next to each other's
/// states).
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// The stream of `seed`.
    pub fn new(seed: u64) -> SplitMix64 {
        SplitMix64(seed ^ 0x5851_F42D_4C95_7F2D)
    }

    /// The next 64 bits.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        splitmix64(&mut self.0)
    }

    /// The next 32 bits (the high half of the next 64).
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        (self.next_u64() >> 32) as u32
    }

    /// Uniform in [0, 1) with 24 random bits (every value exactly representable).
    #[inline]
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
    }

    /// Uniform in [0, 1) with 53 random bits.
    #[inline]
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Two uniforms in [0, 1) (f32, 24 bits each), in that order.
    pub fn u2(&mut self) -> [f32; 2] {
        [self.f32(), self.f32()]
    }

    /// Uniform in [−h, h).
    pub fn signed(&mut self, h: f32) -> f32 {
        (self.f32() * 2.0 - 1.0) * h
    }

    /// Uniform integer in [0, n) (`n` > 0).
    pub fn below(&mut self, n: usize) -> usize {
        assert!(n > 0);
        (((self.next_u64() >> 32) * n as u64) >> 32) as usize
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.f64() < p
    }

    /// Uniform in [lo, hi) (f32, 24 bits).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    /// Uniform in [lo, hi) (f64, 53 bits).
    pub fn range64(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.f64()
    }

    /// Log-uniform in [lo, hi] (both > 0; f32).
    pub fn log_range(&mut self, lo: f32, hi: f32) -> f32 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.f32()).exp()
    }

    /// Log-uniform in [lo, hi] (both > 0; f64).
    pub fn log_range64(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.f64()).exp()
    }

    /// Uniform point in the cube [−half, half]³.
    pub fn in_cube(&mut self, half: f32) -> Vec3 {
        Vec3::new(
            self.range(-half, half),
            self.range(-half, half),
            self.range(-half, half),
        )
    }

    /// Uniform unit vector in f64.
    pub fn unit64(&mut self) -> DVec3 {
        let z = self.range64(-1.0, 1.0);
        let phi = self.range64(0.0, 2.0 * std::f64::consts::PI);
        let s = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    /// Uniform unit vector ([`SplitMix64::unit64`] rounded to f32 and normalised).
    pub fn unit(&mut self) -> Vec3 {
        self.unit64().as_vec3().normalize()
    }

    /// A direction that need not be unit length (the API normalises), sometimes axis-aligned.
    pub fn direction(&mut self) -> Vec3 {
        let d = match self.below(8) {
            0 => [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z][self.below(6)],
            _ => self.unit(),
        };
        d * self.log_range(1e-3, 1e3)
    }
}

#[cfg(test)]
mod tests {
    use super::SplitMix64;

    /// The stream from state 0 is the reference implementation's (Vigna's `splitmix64.c`):
    /// the tests' scenes and golden hashes rest on these bits.
    #[test]
    fn the_stream_is_the_reference_one() {
        let mut r = SplitMix64(0);
        let got = [r.next_u64(), r.next_u64(), r.next_u64()];
        assert_eq!(
            got,
            [
                0xe220_a839_7b1d_cdaf,
                0x6e78_9e6a_a1b9_65f4,
                0x06c4_5d18_8009_454f
            ]
        );
    }
}
