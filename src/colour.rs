//! Linear RGB, for emission and albedo (no spectral upsampling), and its luminance: the scalar
//! energy the tree and every importance rank lights by (docs/formulas.md, section 15).
//!
//! The luminance is Rec. 709's Y = 0.2126 R + 0.7152 G + 0.0722 B, computed in f64 and rounded
//! once to f32. The three weights add up to 1 and the f64 error is far below half an f32 step,
//! so a grey colour (R = G = B = c) has luminance exactly c: grey inputs rank, sample and
//! weigh exactly as scalars did.

use core::ops::{Add, AddAssign, Div, Mul};

/// Rec. 709 luminance weights of R, G and B.
pub(crate) const LUMINANCE_WEIGHTS: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// A linear RGB triple (radiance, intensity, irradiance or albedo, per channel).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rgb {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
}

impl Rgb {
    /// Black.
    pub const ZERO: Rgb = Rgb::grey(0.0);
    /// White (1 in every channel).
    pub const ONE: Rgb = Rgb::grey(1.0);

    /// The colour of three channels.
    #[inline]
    #[must_use]
    pub const fn new(r: f32, g: f32, b: f32) -> Rgb {
        Rgb { r, g, b }
    }

    /// `v` in every channel.
    #[inline]
    #[must_use]
    pub const fn grey(v: f32) -> Rgb {
        Rgb { r: v, g: v, b: v }
    }

    /// The channels as an array.
    #[inline]
    #[must_use]
    pub const fn to_array(self) -> [f32; 3] {
        [self.r, self.g, self.b]
    }

    /// The colour of an array of channels.
    #[inline]
    #[must_use]
    pub const fn from_array(c: [f32; 3]) -> Rgb {
        Rgb::new(c[0], c[1], c[2])
    }

    /// Rec. 709 luminance, computed in f64 and rounded once (exactly `c` for a grey `c`).
    #[inline]
    #[must_use]
    pub fn luminance(self) -> f32 {
        let [wr, wg, wb] = LUMINANCE_WEIGHTS;
        (wr * f64::from(self.r) + wg * f64::from(self.g) + wb * f64::from(self.b)) as f32
    }

    /// `f` applied to each channel.
    #[inline]
    pub fn map(self, mut f: impl FnMut(f32) -> f32) -> Rgb {
        Rgb::new(f(self.r), f(self.g), f(self.b))
    }

    /// The largest channel.
    #[inline]
    #[must_use]
    pub fn max_channel(self) -> f32 {
        self.r.max(self.g).max(self.b)
    }

    /// Whether every channel is finite.
    #[inline]
    #[must_use]
    pub fn is_finite(self) -> bool {
        self.r.is_finite() && self.g.is_finite() && self.b.is_finite()
    }

    /// Whether every channel is 0 (or −0).
    #[inline]
    #[must_use]
    pub fn is_black(self) -> bool {
        self.r == 0.0 && self.g == 0.0 && self.b == 0.0
    }
}

impl From<f32> for Rgb {
    /// The grey colour of `v`.
    #[inline]
    fn from(v: f32) -> Rgb {
        Rgb::grey(v)
    }
}

impl From<[f32; 3]> for Rgb {
    #[inline]
    fn from(c: [f32; 3]) -> Rgb {
        Rgb::from_array(c)
    }
}

impl Mul<f32> for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, k: f32) -> Rgb {
        self.map(|c| c * k)
    }
}

impl Mul<Rgb> for Rgb {
    type Output = Rgb;
    #[inline]
    fn mul(self, o: Rgb) -> Rgb {
        Rgb::new(self.r * o.r, self.g * o.g, self.b * o.b)
    }
}

impl Div<f32> for Rgb {
    type Output = Rgb;
    #[inline]
    fn div(self, k: f32) -> Rgb {
        self.map(|c| c / k)
    }
}

impl Add for Rgb {
    type Output = Rgb;
    #[inline]
    fn add(self, o: Rgb) -> Rgb {
        Rgb::new(self.r + o.r, self.g + o.g, self.b + o.b)
    }
}

impl AddAssign for Rgb {
    #[inline]
    fn add_assign(&mut self, o: Rgb) {
        *self = *self + o;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grey colour's luminance is its value, bit for bit, over a sweep of f32s (normal,
    /// subnormal, tiny and huge).
    #[test]
    fn grey_luminance_is_exact() {
        let mut bits = 0u32;
        while bits < 0x7F80_0000 {
            let v = f32::from_bits(bits);
            assert_eq!(Rgb::grey(v).luminance().to_bits(), v.to_bits(), "{v:e}");
            bits += 0x3F1;
        }
        for v in [0.0, 1.0, 0.5, 0.1, 3.7, f32::MIN_POSITIVE, 1e-45, f32::MAX] {
            assert_eq!(Rgb::grey(v).luminance(), v);
        }
    }

    #[test]
    fn luminance_weights() {
        assert!((Rgb::new(1.0, 0.0, 0.0).luminance() - 0.2126).abs() < 1e-7);
        assert!((Rgb::new(0.0, 1.0, 0.0).luminance() - 0.7152).abs() < 1e-7);
        assert!((Rgb::new(0.0, 0.0, 1.0).luminance() - 0.0722).abs() < 1e-7);
        assert!((LUMINANCE_WEIGHTS.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }
}
