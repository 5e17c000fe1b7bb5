//! Polynomial inverse trigonometry for the 4-wide SPTD path, with scalar twins.
//!
//! Everything is built on one arc tangent: `atan(t) ≈ t · P(t²)` on `[0, 1]`, `P` of degree 8
//! fitted for minimax *relative* error (1.7e-8 in exact arithmetic, so f32 rounding dominates),
//! and the usual octant reduction for [`atan2`]. [`asin`] and [`acos`] go through `atan2` with
//! `√((1 − x)(1 + x))`, which keeps them accurate near ±1 where the textbook polynomial forms
//! of acos lose digits. Relative accuracy near 0 matters here: the cap-intersection formula
//! subtracts angles of tiny caps. The measured maximum errors are checked by tests in this
//! module. Scalar and 4-wide versions perform the same operations in the same order (no fused
//! multiply-add), so they agree bit for bit on IEEE hardware.
//!
//! Never NaN out: `atan2(0, 0)` is 0, a NaN coordinate gives a value in `[-π, π]`, and [`asin`]
//! and [`acos`] treat a NaN argument as −1.

#[cfg(any(test, feature = "internals"))]
use crate::lanes::clamp4;
use crate::lanes::{gt_or, lt_or};
#[cfg(any(test, feature = "internals"))]
use crate::math;
use core::f32::consts::{FRAC_PI_2, PI};
use wide::f32x4;

/// Coefficients of `P` in `atan(t) ≈ t · P(t²)`, lowest degree first.
const ATAN: [f32; 9] = [
    1.0,
    -0.333_331_53,
    0.199_937_75,
    -0.142_110_7,
    0.106_660_63,
    -0.075_523_43,
    0.043_213_41,
    -0.016_368_895,
    0.002_920_936_5,
];

/// `atan(t)` for `t` in `[0, 1]`.
#[inline(always)]
fn atan_unit(t: f32) -> f32 {
    let s = t * t;
    let mut p = ATAN[8];
    p = p * s + ATAN[7];
    p = p * s + ATAN[6];
    p = p * s + ATAN[5];
    p = p * s + ATAN[4];
    p = p * s + ATAN[3];
    p = p * s + ATAN[2];
    p = p * s + ATAN[1];
    p = p * s + ATAN[0];
    t * p
}

#[inline(always)]
fn atan_unit4(t: f32x4) -> f32x4 {
    let s = t * t;
    let mut p = f32x4::splat(ATAN[8]);
    p = p * s + f32x4::splat(ATAN[7]);
    p = p * s + f32x4::splat(ATAN[6]);
    p = p * s + f32x4::splat(ATAN[5]);
    p = p * s + f32x4::splat(ATAN[4]);
    p = p * s + f32x4::splat(ATAN[3]);
    p = p * s + f32x4::splat(ATAN[2]);
    p = p * s + f32x4::splat(ATAN[1]);
    p = p * s + f32x4::splat(ATAN[0]);
    t * p
}

/// The angle of `(x, y)` in `[-π, π]`. `atan2(0, 0) = 0`; never NaN.
#[inline]
#[must_use]
pub fn atan2(y: f32, x: f32) -> f32 {
    let ay = y.abs();
    let ax = x.abs();
    let hi = if ay > ax { ay } else { ax };
    let lo = if ay > ax { ax } else { ay };
    let t = lo / hi;
    // 0/0, ∞/∞ and NaN: the comparison below is false and t becomes 0.
    let t = if t <= 1.0 { t } else { 0.0 };
    let mut r = atan_unit(t);
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 {
        r = -r;
    }
    r
}

/// The 4-wide twin of [`atan2`].
#[inline]
#[must_use]
pub fn atan2_4(y: f32x4, x: f32x4) -> f32x4 {
    let r = atan2_upper4(y.abs(), x);
    y.simd_lt(f32x4::ZERO).select(-r, r)
}

/// [`atan2_4`] for `y` that is +0 or positive in every lane (no NaN): the same numbers without
/// the sign of `y` (|y| = y, and no lane is below 0).
#[inline(always)]
pub(crate) fn atan2_upper4(y: f32x4, x: f32x4) -> f32x4 {
    let zero = f32x4::ZERO;
    let r = atan2_first4(y, x.abs());
    x.simd_lt(zero).select(f32x4::splat(PI) - r, r)
}

/// [`atan2_4`] for `y` and `x` that are +0 or positive in every lane (no NaN).
#[inline(always)]
pub(crate) fn atan2_first4(ay: f32x4, ax: f32x4) -> f32x4 {
    let zero = f32x4::ZERO;
    let swap = ay.simd_gt(ax);
    let hi = gt_or(ay, ax);
    let lo = lt_or(ax, ay);
    let t = lo / hi;
    let t = t.simd_le(f32x4::ONE).select(t, zero);
    let r = atan_unit4(t);
    swap.select(f32x4::splat(FRAC_PI_2) - r, r)
}

/// `x` clamped to `[-1, 1]`, NaN to −1 (as the 4-wide `max` does).
#[inline(always)]
#[cfg(any(test, feature = "internals"))]
fn clamp_unit(x: f32) -> f32 {
    let x = if x > -1.0 { x } else { -1.0 };
    if x < 1.0 {
        x
    } else {
        1.0
    }
}

/// Arc sine, argument clamped to `[-1, 1]` (NaN as −1).
#[inline]
#[must_use]
#[cfg(any(test, feature = "internals"))]
pub fn asin(x: f32) -> f32 {
    let x = clamp_unit(x);
    let c = (1.0 - x) * (1.0 + x);
    atan2(x, math::sqrt(c))
}

/// Arc cosine, argument clamped to `[-1, 1]` (NaN as −1).
#[inline]
#[must_use]
#[cfg(any(test, feature = "internals"))]
pub fn acos(x: f32) -> f32 {
    let x = clamp_unit(x);
    let s = (1.0 - x) * (1.0 + x);
    atan2(math::sqrt(s), x)
}

/// The 4-wide twin of [`asin`].
#[inline]
#[must_use]
#[cfg(any(test, feature = "internals"))]
pub fn asin4(x: f32x4) -> f32x4 {
    let one = f32x4::ONE;
    let x = clamp4(x, -one, one);
    let c = (one - x) * (one + x);
    atan2_4(x, c.sqrt())
}

/// The 4-wide twin of [`acos`].
#[inline]
#[must_use]
#[cfg(any(test, feature = "internals"))]
pub fn acos4(x: f32x4) -> f32x4 {
    let one = f32x4::ONE;
    let x = clamp4(x, -one, one);
    let s = (one - x) * (one + x);
    atan2_4(s.sqrt(), x)
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;

    /// Relative error of f32 results against f64, with an absolute floor near zero.
    fn err(got: f32, want: f64) -> f64 {
        (f64::from(got) - want).abs() / want.abs().max(1e-30)
    }

    /// Measures the maximum relative error of `atan2` over a dense sweep of angles and radii,
    /// including tiny angles, and checks it against the bound the cap formulas rely on.
    #[test]
    fn atan2_max_error_is_measured_and_bounded() {
        let mut worst = 0.0f64;
        let mut worst_abs = 0.0f64;
        let n = 200_000;
        for i in 0..=n {
            // Angles over the full circle, densest near the axes.
            let a = -core::f64::consts::PI + 2.0 * core::f64::consts::PI * (i as f64) / (n as f64);
            for r in [1e-20f64, 1e-3, 1.0, 7.5, 1e20] {
                let (y, x) = ((a.sin() * r) as f32, (a.cos() * r) as f32);
                let want = math::atan2_64(f64::from(y), f64::from(x));
                let got = atan2(y, x);
                if want.abs() > 1e-30 {
                    worst = worst.max(err(got, want));
                }
                worst_abs = worst_abs.max((f64::from(got) - want).abs());
            }
        }
        // Tiny angles: relative accuracy must hold.
        for e in 1..38 {
            let t = 10f32.powi(-e);
            let want = math::atan2_64(f64::from(t), 1.0);
            worst = worst.max(err(atan2(t, 1.0), want));
        }
        std::println!("atan2: max relative error {worst:.3e}, max absolute {worst_abs:.3e}");
        assert!(worst < 4e-7, "atan2 relative error {worst:e}");
        assert!(worst_abs < 8e-7, "atan2 absolute error {worst_abs:e}");
    }

    #[test]
    fn asin_acos_max_error_is_measured_and_bounded() {
        let mut worst_asin = 0.0f64;
        let mut worst_acos = 0.0f64;
        let n = 400_000;
        for i in 0..=n {
            let x = (-1.0 + 2.0 * (i as f64) / (n as f64)) as f32;
            let xs = f64::from(x);
            let a = asin(x);
            let c = acos(x);
            worst_asin = worst_asin.max((f64::from(a) - math::asin64(xs)).abs());
            worst_acos = worst_acos.max((f64::from(c) - math::acos64(xs)).abs());
        }
        // Near ±1, where acos is steep: the argument is exact in f32, so the error is ours.
        for k in 1..24 {
            let x = 1.0 - 2f32.powi(-k);
            worst_acos = worst_acos
                .max(err(acos(x), math::acos64(f64::from(x))) * math::acos64(f64::from(x)));
        }
        std::println!("asin: max abs error {worst_asin:.3e}; acos: {worst_acos:.3e}");
        assert!(worst_asin < 6e-7, "asin error {worst_asin:e}");
        assert!(worst_acos < 6e-7, "acos error {worst_acos:e}");
    }

    #[test]
    fn four_wide_equals_scalar_and_nan_gives_zero() {
        let vals = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.25,
            1e-30,
            3.0,
            -7.0,
            1e30,
            f32::NAN,
            f32::INFINITY,
            -f32::INFINITY,
            0.999_999,
            -0.999_99,
        ];
        for &y in &vals {
            for &x in &vals {
                let w = atan2_4(f32x4::splat(y), f32x4::new([x, -x, x * 0.5, 2.0 * x])).to_array();
                for (lane, xx) in [x, -x, x * 0.5, 2.0 * x].into_iter().enumerate() {
                    let s = atan2(y, xx);
                    assert!(
                        s == w[lane] || (s.is_nan() && w[lane].is_nan()),
                        "atan2({y}, {xx})"
                    );
                    assert!(!s.is_nan(), "atan2({y}, {xx}) is NaN");
                }
            }
            let a = asin4(f32x4::splat(y)).to_array()[0];
            let c = acos4(f32x4::splat(y)).to_array()[0];
            assert_eq!(a.to_bits(), asin(y).to_bits(), "asin({y})");
            assert_eq!(c.to_bits(), acos(y).to_bits(), "acos({y})");
            assert!(!a.is_nan() && !c.is_nan());
        }
    }
}
