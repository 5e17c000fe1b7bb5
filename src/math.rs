//! Scalar math routed through one place, so the no_std core has a single backend (libm).
//!
//! Every transcendental and rounding function of the core (square roots, sine and cosine, arc
//! sine, cosine and tangent, floor, ceil and round, in f32 and f64) is a libm call made here and
//! nowhere else; the wrappers add nothing to it, so results are those of libm bit for bit.
//! (The polynomial inverse trigonometry of `importance::sptd::trig` and the [`Fast`] estimates of
//! the SAOH are not libm; [`Fast`] reduces its argument with [`floor`].)
//!
//! In the hot path: [`sqrt`] and [`sqrt64`] (importances, samplers), the f64 [`sin_cos64`],
//! [`atan2_64`] and [`cos64`] of the light samplers (disk, sphere, spherical triangle, spot),
//! once per sample; [`acos`] (the GGX table lookup) and [`ceil`] (the sample budget), once per
//! shading point. The rest ([`sin`], [`cos`], [`sin_cos`], [`Exact`], [`round`], [`asin`],
//! [`floor`], [`cos64`] for light energies) serves the build, the quantised cones and tests.
//!
//! One exception to libm: in a build for x86 with AVX enabled (e.g. `-C
//! target-cpu=x86-64-v3`) the square roots are `wide`'s lane-0 square root, the instruction
//! `vsqrtps`/`vsqrtpd`. libm's x86 square roots are inline `sqrtss`/`sqrtsd` in the legacy SSE
//! encoding, which between AVX instructions stalls on the registers' upper halves: the build
//! at 10⁶ lights took 2.6× as long as the baseline build. IEEE square roots are correctly
//! rounded, so the two give the same bits. glam's `length`, `normalize`, `try_normalize` and
//! `normalize_or_zero` call libm's square root too: the core's hot paths take [`length`],
//! [`normalize`], [`try_normalize`] and [`normalize_or_zero`] instead, glam's operations bit
//! for bit through [`sqrt`].

/// The largest f32 below 1.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Square root (f32).
#[inline(always)]
pub(crate) fn sqrt(x: f32) -> f32 {
    root::sqrtf(x)
}

/// The square roots' backend: libm's, or in AVX builds on x86 `wide`'s lane 0 (see the module
/// documentation).
#[cfg(not(all(
    any(target_arch = "x86", target_arch = "x86_64"),
    target_feature = "avx"
)))]
mod root {
    pub(super) use libm::{sqrt, sqrtf};
}

#[cfg(all(
    any(target_arch = "x86", target_arch = "x86_64"),
    target_feature = "avx"
))]
mod root {
    #[inline(always)]
    pub(super) fn sqrtf(x: f32) -> f32 {
        wide::f32x4::splat(x).sqrt().to_array()[0]
    }

    #[inline(always)]
    pub(super) fn sqrt(x: f64) -> f64 {
        wide::f64x2::splat(x).sqrt().to_array()[0]
    }
}

/// `v.length()` bit for bit, by [`sqrt`] (glam's is libm's).
#[inline(always)]
pub(crate) fn length(v: glam::Vec3) -> f32 {
    sqrt(v.length_squared())
}

/// `v.normalize()` bit for bit (`v · (1 / |v|)`), by [`sqrt`] (glam's is libm's).
#[inline(always)]
pub(crate) fn normalize(v: glam::Vec3) -> glam::Vec3 {
    v * (1.0 / length(v))
}

/// `v.try_normalize()` bit for bit, by [`sqrt`]: `v · (1 / |v|)` where `1 / |v|` is finite and
/// positive, else `None`.
#[inline(always)]
pub(crate) fn try_normalize(v: glam::Vec3) -> Option<glam::Vec3> {
    let rcp = 1.0 / length(v);
    (rcp.is_finite() && rcp > 0.0).then(|| v * rcp)
}

/// `v.normalize_or_zero()` bit for bit, by [`sqrt`].
#[inline(always)]
pub(crate) fn normalize_or_zero(v: glam::Vec3) -> glam::Vec3 {
    try_normalize(v).unwrap_or(glam::Vec3::ZERO)
}

/// `x²` (f64).
#[inline(always)]
pub(crate) fn sq(x: f64) -> f64 {
    x * x
}

/// Square root (f64).
#[inline(always)]
pub(crate) fn sqrt64(x: f64) -> f64 {
    root::sqrt(x)
}

/// Whether an f32 squared length `l2` is safe to normalise by in f32: far from overflow and
/// from the subnormal range, so that `v / sqrt(l2)` is accurate. Outside it (components above
/// about 1e15 or below about 1e-15) use [`unit()`].
#[inline(always)]
pub(crate) fn len2_is_safe(l2: f32) -> bool {
    (1e-30..=1e30).contains(&l2)
}

/// The unit vector of `v`, normalised in f64 so that tiny and huge f32 vectors survive;
/// `None` for a zero or non-finite vector.
pub(crate) fn unit_f64(v: [f64; 3]) -> Option<glam::Vec3> {
    let l = sqrt64(sq(v[0]) + sq(v[1]) + sq(v[2]));
    if !(l > 0.0 && l < f64::INFINITY) {
        return None;
    }
    let n = glam::Vec3::new((v[0] / l) as f32, (v[1] / l) as f32, (v[2] / l) as f32);
    Some(normalize(n))
}

/// [`unit_f64`] of an f32 vector: `None` exactly when `v` is zero or not finite.
pub(crate) fn unit(v: glam::Vec3) -> Option<glam::Vec3> {
    unit_f64(v.to_array().map(f64::from))
}

/// Below this angle [`one_minus_cos64`] uses `2 sin²(θ/2)`.
pub(crate) const SMALL_ANGLE: f64 = 1e-3;

/// `1 − cos θ` in f64, accurate for every θ: `2 sin²(θ/2)` below [`SMALL_ANGLE`], where the
/// subtraction cancels (it is 0 for θ ≤ 1e-8 and 11 % off at 2e-8); the subtraction above it,
/// where its relative error is below 5e-10, far under f32 rounding.
#[inline]
pub(crate) fn one_minus_cos64(theta: f64) -> f64 {
    if theta.abs() < SMALL_ANGLE {
        let s = libm::sin(0.5 * theta);
        2.0 * s * s
    } else {
        1.0 - libm::cos(theta)
    }
}

/// Sine and cosine.
#[inline]
pub(crate) fn sin_cos(x: f32) -> (f32, f32) {
    libm::sincosf(x)
}

/// Cosine.
#[inline]
pub(crate) fn cos(x: f32) -> f32 {
    libm::cosf(x)
}

/// Sine.
#[inline]
pub(crate) fn sin(x: f32) -> f32 {
    libm::sinf(x)
}

/// Sine and cosine (f64).
#[inline(always)]
pub(crate) fn sin_cos64(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

/// Cosine (f64).
#[inline(always)]
pub(crate) fn cos64(x: f64) -> f64 {
    libm::cos(x)
}

/// atan2(y, x) (f64).
#[inline(always)]
pub(crate) fn atan2_64(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

/// Arc cosine (f32).
#[inline(always)]
pub(crate) fn acos(x: f32) -> f32 {
    libm::acosf(x)
}

/// Arc sine (f32).
#[inline(always)]
pub(crate) fn asin(x: f32) -> f32 {
    libm::asinf(x)
}

/// Arc cosine (f64).
/// Round a non-negative f64 length up to an f32 with a little relative slack.
pub(crate) fn outward(r: f64) -> f32 {
    let r = r * (1.0 + 1e-6);
    let f = r as f32;
    if f64::from(f) < r {
        next_up(f)
    } else {
        f
    }
}

/// `cos(max(0, θ − γ))` from `cos θ = c` and γ's cosine and sine (1 when θ ≤ γ).
#[inline]
pub(crate) fn cos_minus(c: f32, cos_g: f32, sin_g: f32) -> f32 {
    if c >= cos_g {
        1.0
    } else {
        let s = sqrt((1.0 - c * c).max(0.0));
        c * cos_g + s * sin_g
    }
}

#[cfg(test)]
#[inline(always)]
pub fn acos64(x: f64) -> f64 {
    libm::acos(x)
}

/// Arc sine (f64).
#[cfg(test)]
#[inline(always)]
pub fn asin64(x: f64) -> f64 {
    libm::asin(x)
}

/// Largest integer not above `x` (f32).
#[inline(always)]
pub(crate) fn floor(x: f32) -> f32 {
    libm::floorf(x)
}

/// Smallest integer not below `x` (f32).
#[inline(always)]
pub(crate) fn ceil(x: f32) -> f32 {
    libm::ceilf(x)
}

/// Nearest integer to `x`, halfway cases away from zero (f32).
#[inline(always)]
pub(crate) fn round(x: f32) -> f32 {
    libm::roundf(x)
}

/// `sqrt(max(0, 1 - c²))`: the sine belonging to a cosine, safe against rounding.
#[inline(always)]
pub(crate) fn sin_from_cos(c: f32) -> f32 {
    sqrt((1.0 - c * c).max(0.0))
}

/// The next representable f32 above a finite, non-negative `x`.
#[inline]
pub(crate) fn next_up(x: f32) -> f32 {
    if x.is_nan() || x == f32::INFINITY {
        return x;
    }
    if x == 0.0 {
        return f32::from_bits(1);
    }
    let bits = x.to_bits();
    if x > 0.0 {
        f32::from_bits(bits + 1)
    } else {
        f32::from_bits(bits - 1)
    }
}

/// The trigonometry the cone algebra needs, so one implementation of it serves both the exact
/// bounds ([`Exact`]) and the SAOH's bucket estimates ([`Fast`]).
pub(crate) trait Trig {
    /// atan2(y, x).
    fn atan2(y: f32, x: f32) -> f32;
    /// (sin x, cos x).
    fn sin_cos(x: f32) -> (f32, f32);
}

/// libm: correctly rounded to within an ulp or two.
pub(crate) struct Exact;

impl Trig for Exact {
    #[inline]
    fn atan2(y: f32, x: f32) -> f32 {
        libm::atan2f(y, x)
    }
    #[inline]
    fn sin_cos(x: f32) -> (f32, f32) {
        libm::sincosf(x)
    }
}

/// Polynomial approximations (absolute error below 2e-5), for heuristics only: the SAOH
/// compares bucket costs with them, while every bound stored in a tree uses [`Exact`].
pub(crate) struct Fast;

impl Trig for Fast {
    #[inline]
    fn atan2(y: f32, x: f32) -> f32 {
        use core::f32::consts::{FRAC_PI_2, PI};
        let (ax, ay) = (x.abs(), y.abs());
        let (num, den) = if ax >= ay { (ay, ax) } else { (ax, ay) };
        if den == 0.0 {
            return 0.0;
        }
        let t = num / den;
        let t2 = t * t;
        // Minimax polynomial of atan on [0, 1], |error| < 1e-5.
        let mut r = t
            * (0.999_866
                + t2 * (-0.330_299_5 + t2 * (0.180_141 + t2 * (-0.085_133 + t2 * 0.020_835_1))));
        if ay > ax {
            r = FRAC_PI_2 - r;
        }
        if x < 0.0 {
            r = PI - r;
        }
        if y < 0.0 {
            -r
        } else {
            r
        }
    }
    #[inline]
    fn sin_cos(x: f32) -> (f32, f32) {
        use core::f32::consts::{FRAC_PI_2, PI, TAU};
        // Reduce to [-π, π], then to [-π/2, π/2] with a sign on the cosine.
        let mut a = x - TAU * floor((x + PI) / TAU);
        let mut cos_sign = 1.0;
        if a > FRAC_PI_2 {
            a = PI - a;
            cos_sign = -1.0;
        } else if a < -FRAC_PI_2 {
            a = -PI - a;
            cos_sign = -1.0;
        }
        let a2 = a * a;
        let s = a
            * (1.0
                + a2 * (-1.0 / 6.0 + a2 * (1.0 / 120.0 + a2 * (-1.0 / 5040.0 + a2 / 362_880.0))));
        let c = 1.0
            + a2 * (-0.5
                + a2 * (1.0 / 24.0
                    + a2 * (-1.0 / 720.0 + a2 * (1.0 / 40320.0 - a2 / 3_628_800.0))));
        (s, cos_sign * c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_trig_is_close() {
        for i in -2000..=2000 {
            let x = i as f32 * 0.005;
            let (s, c) = Fast::sin_cos(x);
            let (es, ec) = Exact::sin_cos(x);
            assert!(
                (s - es).abs() < 2e-5 && (c - ec).abs() < 2e-5,
                "x={x}: {s} {c}"
            );
            for j in -20..=20 {
                let y = j as f32 * 0.37;
                let (a, e) = (Fast::atan2(y, x), Exact::atan2(y, x));
                assert!((a - e).abs() < 2e-5, "atan2({y}, {x}) = {a}, expected {e}");
            }
        }
    }

    /// The glam replacements give glam's bits (or glam's `None`) for ordinary, tiny, huge,
    /// zero, infinite and NaN vectors.
    #[test]
    fn glam_replacements_are_glams_bit_for_bit() {
        use glam::Vec3;
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let mut vs = alloc::vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(1e-30, 0.0, 0.0),
            Vec3::new(1e-20, -3e-21, 2e-20),
            Vec3::new(3e19, 1e19, -2e19),
            Vec3::new(f32::MAX, 0.0, 0.0),
            Vec3::new(f32::INFINITY, 1.0, 0.0),
            Vec3::new(f32::NAN, 1.0, 0.0),
        ];
        let mut h = 0x9e37_79b9u32;
        for _ in 0..2000 {
            let mut c = [0.0f32; 3];
            for x in &mut c {
                h ^= h << 13;
                h ^= h >> 17;
                h ^= h << 5;
                *x = (h as f32 / u32::MAX as f32 - 0.5) * 10.0;
            }
            vs.push(Vec3::from_array(c));
        }
        for v in vs {
            assert_eq!(length(v).to_bits(), v.length().to_bits(), "{v}");
            if v.length() > 0.0 {
                assert_eq!(bits(normalize(v)), bits(v.normalize()), "{v}");
            }
            assert_eq!(
                try_normalize(v).map(bits),
                v.try_normalize().map(bits),
                "{v}"
            );
            assert_eq!(
                bits(normalize_or_zero(v)),
                bits(v.normalize_or_zero()),
                "{v}"
            );
        }
    }
}
