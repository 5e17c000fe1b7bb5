//! Scalar math routed through one place, so the no_std core has a single backend (libm).
//!
//! Nothing here is used in the per-sample hot path except `sqrt`; trigonometry is for the build.

/// Square root (f32).
#[inline(always)]
pub fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}

/// Square root (f64).
#[inline(always)]
pub fn sqrt64(x: f64) -> f64 {
    libm::sqrt(x)
}

/// Arc cosine with the argument clamped to [-1, 1] (never NaN for finite input).
#[inline]
pub fn acos_clamped(x: f32) -> f32 {
    libm::acosf(x.clamp(-1.0, 1.0))
}

/// Sine and cosine.
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    libm::sincosf(x)
}

/// Cosine.
#[inline]
pub fn cos(x: f32) -> f32 {
    libm::cosf(x)
}

/// Sine.
#[inline]
pub fn sin(x: f32) -> f32 {
    libm::sinf(x)
}

/// `sqrt(max(0, 1 - c²))`: the sine belonging to a cosine, safe against rounding.
#[inline(always)]
pub fn sin_from_cos(c: f32) -> f32 {
    sqrt((1.0 - c * c).max(0.0))
}

/// The next representable f32 above a finite, non-negative `x`.
#[inline]
pub fn next_up(x: f32) -> f32 {
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
