//! Conservative quantisation of a cluster's orientation cone into two `u32`s of a
//! [`crate::Node4`] slot: the axis as a 16+16-bit octahedral vector, and θo, θe as
//! `sin(θ/2)` in 16 bits each, rounded up so the stored cone always contains the true one.
//!
//! `sin(θ/2)` is linear in θ to first order (resolution ≈ 3e-5 rad everywhere), and decodes to
//! `cos θ = 1 − 2s²`, `sin θ = 2s·sqrt(1 − s²)` without trigonometry.

use crate::bounds::Cone;
use crate::math;
use core::f32::consts::PI;
use glam::Vec3;

const Q: f32 = 65535.0;

/// Encodes a unit vector octahedrally (16 bits per coordinate, rounded to nearest).
pub fn encode_axis(a: Vec3) -> u32 {
    let l1 = a.x.abs() + a.y.abs() + a.z.abs();
    let (mut x, mut y) = if l1 > 0.0 {
        (a.x / l1, a.y / l1)
    } else {
        (0.0, 0.0)
    };
    if a.z < 0.0 {
        let (ox, oy) = (x, y);
        x = (1.0 - oy.abs()) * sign(ox);
        y = (1.0 - ox.abs()) * sign(oy);
    }
    let qx = math::round((x.clamp(-1.0, 1.0) * 0.5 + 0.5) * Q) as u32;
    let qy = math::round((y.clamp(-1.0, 1.0) * 0.5 + 0.5) * Q) as u32;
    qx | (qy << 16)
}

fn sign(v: f32) -> f32 {
    if v >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Decodes [`encode_axis`]; the result is unit length. Mirrors the lane-wise decode of
/// `importance::conty_kulla` operation for operation.
#[inline]
pub fn decode_axis(q: u32) -> Vec3 {
    let x = (q & 0xFFFF) as f32 * (2.0 / Q) - 1.0;
    let y = (q >> 16) as f32 * (2.0 / Q) - 1.0;
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    let x = if x >= 0.0 { x - t } else { x + t };
    let y = if y >= 0.0 { y - t } else { y + t };
    let inv = 1.0 / math::sqrt(x * x + y * y + z * z);
    Vec3::new(x * inv, y * inv, z * inv)
}

/// Encodes an angle in [0, π] as `ceil(sin(θ/2) · 65535)`.
pub fn encode_angle(theta: f32) -> u32 {
    let s = math::sin(theta.clamp(0.0, PI) * 0.5);
    // One step of slack absorbs the rounding of sinf itself.
    let q = math::ceil(s * Q) + if s > 0.0 { 1.0 } else { 0.0 };
    q.min(Q) as u32
}

/// Decodes [`encode_angle`] to `(cos θ, sin θ)`.
#[inline]
pub fn decode_angle(q: u32) -> (f32, f32) {
    let s = (q & 0xFFFF) as f32 * (1.0 / Q);
    let cos = 1.0 - 2.0 * s * s;
    let sin = 2.0 * s * math::sqrt((1.0 - s * s).max(0.0));
    (cos, sin)
}

/// The angle θ of a decoded `(cos θ, sin θ)`, for checks off the hot path.
pub fn angle_of(q: u32) -> f32 {
    let s = (q & 0xFFFF) as f32 * (1.0 / Q);
    2.0 * math::asin(s.min(1.0))
}

/// Packs a cone into `(axis, angles)`: θo widened by the axis' own quantisation error, θo in the
/// low and θe in the high 16 bits of `angles`.
pub fn encode_cone(c: &Cone) -> (u32, u32) {
    let axis = encode_axis(c.axis);
    let theta_o = if c.theta_o >= PI {
        PI
    } else {
        // The angle between two unit vectors is at most their chord times
        // (1 + chord²/20) for chords below 1; the decode error is far below that.
        let chord = (decode_axis(axis) - c.axis).length();
        let err = chord * (1.0 + chord * chord * 0.05) + 1e-7;
        (c.theta_o + err + 1e-5).min(PI)
    };
    let angles = encode_angle(theta_o) | (encode_angle(c.theta_e) << 16);
    (axis, angles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_roundtrip_error_is_small() {
        let mut worst = 0.0f32;
        for i in 0..200 {
            for j in 0..100 {
                let z = -1.0 + 2.0 * (j as f32 + 0.5) / 100.0;
                let phi = 2.0 * PI * i as f32 / 200.0;
                let s = math::sin_from_cos(z);
                let a = Vec3::new(s * math::cos(phi), s * math::sin(phi), z).normalize();
                let b = decode_axis(encode_axis(a));
                worst = worst.max(crate::bounds::angle_between(a, b));
            }
        }
        for a in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z] {
            let b = decode_axis(encode_axis(a));
            worst = worst.max(crate::bounds::angle_between(a, b));
        }
        assert!(worst < 1e-4, "worst axis error {worst}");
    }

    #[test]
    fn angles_round_up() {
        for i in 0..=1000 {
            let t = PI * i as f32 / 1000.0;
            let q = encode_angle(t);
            let back = angle_of(q);
            assert!(back + 1e-6 >= t, "θ={t}: decoded {back}");
            // At most two quantisation steps of s = sin(θ/2) above the true value.
            let allowed = angle_of((math::floor(math::sin(t * 0.5) * Q) as u32 + 2).min(65535));
            assert!(back <= allowed + 1e-5, "θ={t}: decoded {back} > {allowed}");
            let (c, s) = decode_angle(q);
            assert!((c * c + s * s - 1.0).abs() < 1e-5);
            assert!(c <= math::cos(t) + 1e-6, "cos must not grow: θ={t}");
        }
        assert_eq!(encode_angle(0.0), 0);
        assert_eq!(decode_angle(encode_angle(PI)).0, -1.0);
    }
}
