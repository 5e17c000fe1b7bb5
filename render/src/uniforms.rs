//! The renderer's uniform numbers for the core's estimators: a `rand` generator behind the
//! core's [`Uniforms`] trait.

use manylights::Uniforms;
use rand::Rng;

/// Uniform numbers from a `rand` generator (`random::<f32>()`, `random::<f64>()`: both in
/// [0, 1)).
#[derive(Debug)]
pub struct RngUniforms<'r, R: Rng>(pub &'r mut R);

impl<R: Rng> Uniforms for RngUniforms<'_, R> {
    #[inline]
    fn next_f32(&mut self) -> f32 {
        self.0.random::<f32>()
    }

    #[inline]
    fn next_f64(&mut self) -> f64 {
        self.0.random::<f64>()
    }
}
