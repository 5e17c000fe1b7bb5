//! The tests' uniform numbers for the core's estimators: a [`SplitMix64`] stream behind the
//! core's [`Uniforms`] trait.

use crate::SplitMix64;
use manylights::Uniforms;

/// Uniform numbers from a [`SplitMix64`] stream: [`SplitMix64::f32`] (24 bits) and
/// [`SplitMix64::f64`] (53 bits), both in [0, 1), each one draw of the stream.
#[derive(Clone, Debug)]
pub struct TestUniforms(pub SplitMix64);

impl TestUniforms {
    /// The numbers of [`SplitMix64::new`]`(seed)`.
    #[must_use]
    pub fn new(seed: u64) -> TestUniforms {
        TestUniforms(SplitMix64::new(seed))
    }
}

impl Uniforms for TestUniforms {
    #[inline]
    fn next_f32(&mut self) -> f32 {
        self.0.f32()
    }

    #[inline]
    fn next_f64(&mut self) -> f64 {
        self.0.f64()
    }
}
