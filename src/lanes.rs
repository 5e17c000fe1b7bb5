//! The lane operations of the 4-wide importance, on one node's four slots (`f32x4`) or on
//! two nodes' side by side (`f32x8`, [`crate::importance::Importance::eval4_pair`]).
//!
//! Every operation is elementwise and the same IEEE operation in both types (on SSE2 an
//! `f32x8` is two `f32x4`, each operation issued on both halves; with AVX it is one 256-bit
//! instruction of the same rounding), so each half of an `f32x8` result equals, bit for bit,
//! the `f32x4` result on that half's inputs. What the pair gains is only the order of the
//! instructions: two independent dependency chains interleaved, so that one's square roots
//! and divisions wait while the other's run.

use core::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Sub};
use wide::{f32x4, f32x8};

/// `f32x4` or `f32x8`, as the importance uses them. Masks are lanes of all ones or zeros.
pub(crate) trait Lanes:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
{
    const ZERO: Self;
    const ONE: Self;
    fn splat(x: f32) -> Self;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    /// `maxps`: the second operand where either is NaN.
    fn fast_max(self, other: Self) -> Self;
    /// `minps`: the second operand where either is NaN.
    fn fast_min(self, other: Self) -> Self;
    fn simd_ge(self, other: Self) -> Self;
    fn simd_gt(self, other: Self) -> Self;
    fn simd_le(self, other: Self) -> Self;
    fn simd_lt(self, other: Self) -> Self;
    /// Where the mask `self` is set, `t`, else `f`.
    fn select(self, t: Self, f: Self) -> Self;
    /// Some lane of the mask is set.
    fn any(self) -> bool;
}

/// Each operation forwards to the type's own method of the same name.
macro_rules! lanes {
    ($t:ty) => {
        impl Lanes for $t {
            const ZERO: Self = <$t>::ZERO;
            const ONE: Self = <$t>::ONE;
            #[inline(always)]
            fn splat(x: f32) -> Self {
                <$t>::splat(x)
            }
            #[inline(always)]
            fn select(self, t: Self, f: Self) -> Self {
                <$t>::select(self, t, f)
            }
            #[inline(always)]
            fn any(self) -> bool {
                <$t>::any(self)
            }
            lanes!(@unary $t: sqrt, abs);
            lanes!(@binary $t: fast_max, fast_min, simd_ge, simd_gt, simd_le, simd_lt);
        }
    };
    (@unary $t:ty: $($f:ident),*) => {
        $(
            #[inline(always)]
            fn $f(self) -> Self {
                <$t>::$f(self)
            }
        )*
    };
    (@binary $t:ty: $($f:ident),*) => {
        $(
            #[inline(always)]
            fn $f(self, other: Self) -> Self {
                <$t>::$f(self, other)
            }
        )*
    };
}

lanes!(f32x4);
lanes!(f32x8);

/// Whether `fast_max` and `fast_min` are x86's `maxps` and `minps`: `x > k ? x : k` and
/// `x < k ? x : k` lane by lane (`k` where either is NaN), which [`gt_or`] and [`lt_or`] are.
const MINMAX_IS_SELECT: bool = cfg!(all(
    any(target_arch = "x86", target_arch = "x86_64"),
    target_feature = "sse"
));

/// `x` where `x > k`, else `k`, lane by lane (so `k` where either is NaN): the value of
/// `x.simd_gt(k).select(x, k)`, bit for bit, as one `maxps` on x86 and as that select
/// elsewhere.
#[inline(always)]
pub(crate) fn gt_or(x: f32x4, k: f32x4) -> f32x4 {
    if MINMAX_IS_SELECT {
        x.fast_max(k)
    } else {
        x.simd_gt(k).select(x, k)
    }
}

/// `x` where `x < k`, else `k`, lane by lane (so `k` where either is NaN): the value of
/// `x.simd_lt(k).select(x, k)`, bit for bit, as one `minps` on x86 and as that select
/// elsewhere.
#[inline(always)]
pub(crate) fn lt_or(x: f32x4, k: f32x4) -> f32x4 {
    if MINMAX_IS_SELECT {
        x.fast_min(k)
    } else {
        x.simd_lt(k).select(x, k)
    }
}

/// `x` clamped to `[lo, hi]` lane by lane, `lo` where `x` is NaN (for `lo < hi`):
/// [`lt_or`]`(`[`gt_or`]`(x, lo), hi)`.
#[inline(always)]
pub(crate) fn clamp4(x: f32x4, lo: f32x4, hi: f32x4) -> f32x4 {
    lt_or(gt_or(x, lo), hi)
}

/// Two nodes' lanes side by side: `a` in lanes 0–3, `b` in 4–7.
#[inline(always)]
pub(crate) fn pair(a: f32x4, b: f32x4) -> f32x8 {
    bytemuck::cast([a, b])
}

/// The two halves of [`pair`].
#[inline(always)]
pub(crate) fn halves(x: f32x8) -> (f32x4, f32x4) {
    let [a, b]: [f32x4; 2] = bytemuck::cast(x);
    (a, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pair_and_halves_round_trip() {
        let a = f32x4::new([1.0, -2.0, f32::NAN, 0.5]);
        let b = f32x4::new([-0.0, 3.0, f32::INFINITY, 7.0]);
        let (x, y) = halves(pair(a, b));
        assert_eq!(
            bytemuck::cast::<_, [u32; 4]>(x),
            bytemuck::cast::<_, [u32; 4]>(a)
        );
        assert_eq!(
            bytemuck::cast::<_, [u32; 4]>(y),
            bytemuck::cast::<_, [u32; 4]>(b)
        );
    }

    #[test]
    fn the_operations_agree_lane_for_lane() {
        // Edge values in every lane pairing: each f32x8 operation's halves against f32x4's.
        let edge = [
            0.0,
            -0.0,
            1.0,
            -1.5,
            1e-40,
            -1e-40,
            3e38,
            f32::INFINITY,
            -f32::INFINITY,
            f32::NAN,
            0.25,
            7.0,
        ];
        let bits = |x: f32x4| bytemuck::cast::<_, [u32; 4]>(x);
        for (i, &s) in edge.iter().enumerate() {
            let a = f32x4::new([
                s,
                edge[(i + 1) % 12],
                edge[(i + 5) % 12],
                edge[(i + 7) % 12],
            ]);
            for &t in &edge {
                let b = f32x4::new([t, s, edge[(i + 3) % 12], -t]);
                let (pa, pb) = (pair(a, b), pair(b, a));
                let check = |wide: f32x8, x: f32x4, y: f32x4| {
                    let (h0, h1) = halves(wide);
                    assert_eq!((bits(h0), bits(h1)), (bits(x), bits(y)), "{s} {t}");
                };
                check(pa + pb, a + b, b + a);
                check(pa - pb, a - b, b - a);
                check(pa * pb, a * b, b * a);
                check(pa / pb, a / b, b / a);
                check(-pa, -a, -b);
                check(Lanes::sqrt(pa), Lanes::sqrt(a), Lanes::sqrt(b));
                check(Lanes::abs(pa), Lanes::abs(a), Lanes::abs(b));
                check(
                    Lanes::fast_max(pa, pb),
                    Lanes::fast_max(a, b),
                    Lanes::fast_max(b, a),
                );
                check(
                    Lanes::fast_min(pa, pb),
                    Lanes::fast_min(a, b),
                    Lanes::fast_min(b, a),
                );
                let masks = [
                    (
                        Lanes::simd_ge(pa, pb),
                        Lanes::simd_ge(a, b),
                        Lanes::simd_ge(b, a),
                    ),
                    (
                        Lanes::simd_gt(pa, pb),
                        Lanes::simd_gt(a, b),
                        Lanes::simd_gt(b, a),
                    ),
                    (
                        Lanes::simd_le(pa, pb),
                        Lanes::simd_le(a, b),
                        Lanes::simd_le(b, a),
                    ),
                    (
                        Lanes::simd_lt(pa, pb),
                        Lanes::simd_lt(a, b),
                        Lanes::simd_lt(b, a),
                    ),
                ];
                for (m, ma, mb) in masks {
                    check(m, ma, mb);
                    check(m.select(pa, pb), ma.select(a, b), mb.select(b, a));
                    check(m & pa, ma & a, mb & b);
                    check(m | pb, ma | b, mb | a);
                    assert_eq!(Lanes::any(m), Lanes::any(ma) || Lanes::any(mb));
                }
            }
        }
    }

    #[test]
    fn gt_or_and_lt_or_are_their_selects() {
        // Every pairing of edge values (NaN, both zeros, subnormals, infinities), and the
        // scalar forms `if x > k { x } else { k }` / `if x < k { x } else { k }` lane by lane.
        let edge = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            -1.5,
            1e-40,
            -1e-40,
            f32::MIN_POSITIVE,
            3e38,
            f32::INFINITY,
            -f32::INFINITY,
            f32::NAN,
            -f32::NAN,
            0.25,
        ];
        let bits = |x: f32x4| bytemuck::cast::<_, [u32; 4]>(x);
        let n = edge.len();
        for i in 0..n {
            for j in 0..n {
                let x = f32x4::new([
                    edge[i],
                    edge[j],
                    edge[(i + j) % n],
                    edge[(i + 2 * j + 1) % n],
                ]);
                let k = f32x4::new([edge[j], edge[i], edge[(i + 3) % n], edge[(j + 5) % n]]);
                let gt = gt_or(x, k);
                let lt = lt_or(x, k);
                assert_eq!(bits(gt), bits(x.simd_gt(k).select(x, k)), "{i} {j}");
                assert_eq!(bits(lt), bits(x.simd_lt(k).select(x, k)), "{i} {j}");
                let (xs, ks) = (x.to_array(), k.to_array());
                for l in 0..4 {
                    let g = if xs[l] > ks[l] { xs[l] } else { ks[l] };
                    let m = if xs[l] < ks[l] { xs[l] } else { ks[l] };
                    assert_eq!(gt.to_array()[l].to_bits(), g.to_bits());
                    assert_eq!(lt.to_array()[l].to_bits(), m.to_bits());
                }
            }
        }
    }
}
