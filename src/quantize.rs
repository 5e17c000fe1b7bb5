//! Conservative quantisation of a [`crate::Node4`]'s four child clusters into one cache line
//! (the layout is documented on [`crate::Node4`]; the derivation is in docs/formulas.md,
//! section 14).
//!
//! Every encoding rounds outwards, so the decoded bounds always contain what they bound and
//! the importance computed from them stays conservative:
//! - **Spheres**: each node stores an origin (three f32) and a power-of-two scale `2^e`; a
//!   child's centre is `origin + q · 2^e` with `q` in 0..=255 per axis (rounded to nearest)
//!   and its radius `q_r · 2^e` with `q_r` in 0..=255, rounded up past the true radius plus
//!   the distance the rounding moved the centre (as compressed wide BVHs quantise child boxes
//!   to 8 bits of the parent's frame, Ylitie, Karras & Laine 2017).
//! - **Cones**: the axis as an 8+8-bit octahedral vector, θo widened by the axis' own
//!   quantisation error, and θo as `ceil(255 · sin(θ/2))` (8 bits): `sin(θ/2)` decodes
//!   to `cos θ = 1 − 2s²`, `sin θ = 2s·sqrt(1 − s²)` without trigonometry; θe ≤ π/2 is coded
//!   on `√2 · sin(θe/2)` instead, so that π/2 decodes exactly.
//! - **Energies**: the upper 20 bits of the f32 (11 mantissa bits), rounded up: 2⁻¹¹ relative,
//!   so that the far-field pmfs stay proportional to power.
//!
//! The decoders here are the scalar twins of the lane-wise decode in
//! `importance::tl`, operation for operation, so a slot decodes to the same numbers
//! whichever path reads it.

use crate::bounds::{Cone, Sphere};
use crate::math;
use core::f32::consts::{FRAC_PI_2, PI, SQRT_2};
use glam::Vec3;
use wide::{f32x4, i32x4};

/// Steps of an 8-bit code.
const Q8: f32 = 255.0;

/// Byte `shift / 8` of each lane of `v` (words of four packed bytes), as a number in 0..=255:
/// the one decode of the node's 8-bit fields (sphere coordinates and radii, cone axes and
/// angles) in the 4-wide hot path.
#[inline(always)]
pub(crate) fn byte_lanes(v: i32x4, shift: u32) -> f32x4 {
    (v.unbounded_shr_scalar(shift) & i32x4::splat(0xFF)).round_float()
}

/// Encodes a unit vector octahedrally (8 bits per coordinate, rounded to nearest), as the low
/// 16 bits of a slot's cone word.
pub(crate) fn encode_axis(a: Vec3) -> u32 {
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
    let qx = math::round((x.clamp(-1.0, 1.0) * 0.5 + 0.5) * Q8) as u32;
    let qy = math::round((y.clamp(-1.0, 1.0) * 0.5 + 0.5) * Q8) as u32;
    qx | (qy << 8)
}

fn sign(v: f32) -> f32 {
    if v >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Decodes [`encode_axis`] (the low 16 bits of `q`); the result is unit length.
#[inline]
pub(crate) fn decode_axis(q: u32) -> Vec3 {
    let a = decode_axis_raw(q);
    let inv = 1.0 / math::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
    Vec3::new(a.x * inv, a.y * inv, a.z * inv)
}

/// [`decode_axis`] before its normalisation: the point of the octahedron |x| + |y| + |z| = 1
/// (length in [1/√3, 1]) that the 4-wide TL importance works with.
#[inline]
pub(crate) fn decode_axis_raw(q: u32) -> Vec3 {
    let x = (q & 0xFF) as f32 * (2.0 / Q8) - 1.0;
    let y = ((q >> 8) & 0xFF) as f32 * (2.0 / Q8) - 1.0;
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    let x = if x >= 0.0 { x - t } else { x + t };
    let y = if y >= 0.0 { y - t } else { y + t };
    Vec3::new(x, y, z)
}

/// Encodes an angle in [0, π] as `ceil(255 · sin(θ/2))`, never below the true value.
pub(crate) fn encode_angle(theta: f32) -> u32 {
    let s = math::sin(theta.clamp(0.0, PI) * 0.5);
    if s <= 0.0 {
        return 0;
    }
    // The relative slack absorbs the rounding of sinf and of the product.
    let q = math::ceil(s * Q8 * (1.0 + 4e-6));
    q.min(Q8) as u32
}

/// Decodes [`encode_angle`] (the low 8 bits of `q`) to `(cos θ, sin θ)`.
#[inline]
pub(crate) fn decode_angle(q: u32) -> (f32, f32) {
    let s = (q & 0xFF) as f32 * (1.0 / Q8);
    let cos = 1.0 - 2.0 * s * s;
    let sin = 2.0 * s * math::sqrt((1.0 - s * s).max(0.0));
    (cos, sin)
}

/// Encodes an emission angle θe in [0, π/2] as `ceil(255 · √2 · sin(θe/2))`, never below
/// the true value: the code 255 is exactly π/2 (the common θe of area lights), where
/// [`decode_emission`] gives `cos θe = 0` exactly.
pub(crate) fn encode_emission(theta_e: f32) -> u32 {
    let s = math::sin(theta_e.clamp(0.0, FRAC_PI_2) * 0.5) * SQRT_2;
    if s <= 0.0 {
        return 0;
    }
    math::ceil(s * Q8 * (1.0 + 4e-6)).min(Q8) as u32
}

/// Decodes [`encode_emission`] (the low 8 bits of `q`) to `cos θe = (255² − q²) / 255²`.
#[inline]
pub(crate) fn decode_emission(q: u32) -> f32 {
    let q = (q & 0xFF) as f32;
    (Q8 * Q8 - q * q) * (1.0 / (Q8 * Q8))
}

/// The angle θe of a code of [`encode_emission`], for checks off the hot path.
pub(crate) fn emission_angle_of(q: u32) -> f32 {
    math::acos(decode_emission(q).clamp(-1.0, 1.0))
}

/// The angle θ of a code of [`encode_angle`], for checks off the hot path.
pub(crate) fn angle_of(q: u32) -> f32 {
    let s = (q & 0xFF) as f32 * (1.0 / Q8);
    2.0 * math::asin(s.min(1.0))
}

/// Packs a cone into a slot's cone word: the axis in bits 0..16, θo (widened by the axis'
/// quantisation error) in bits 16..24 (`encode_angle`), θe in bits 24..32
/// (`encode_emission`).
#[must_use]
pub fn encode_cone(c: &Cone) -> u32 {
    let axis = encode_axis(c.axis);
    let theta_o = if c.theta_o >= PI {
        PI
    } else {
        // The angle between two unit vectors is at most their chord times
        // (1 + chord²/20) for chords below 1; the decode's own rounding is far below that.
        let chord = math::length(decode_axis(axis) - c.axis);
        let err = chord * (1.0 + chord * chord * 0.05) + 1e-6;
        (c.theta_o + err + 1e-5).min(PI)
    };
    axis | (encode_angle(theta_o) << 16) | (encode_emission(c.theta_e) << 24)
}

/// Decodes a slot's cone word.
pub(crate) fn decode_cone(word: u32) -> Cone {
    Cone {
        axis: decode_axis(word),
        theta_o: angle_of(word >> 16),
        theta_e: emission_angle_of(word >> 24),
    }
}

/// The 20-bit code of an energy `e ≥ 0` (the upper 20 bits of its f32: sign, exponent and
/// 11 mantissa bits), rounded up: at most 2⁻¹¹ above `e`, and a positive `e` never becomes 0.
#[must_use]
pub fn encode_energy(e: f32) -> u32 {
    let e = if e > 0.0 { e } else { 0.0 };
    let bits = e.to_bits();
    let code = bits >> 12;
    let up = if bits & 0xFFF != 0 { code + 1 } else { code };
    // 0x7F800 is +∞; the energies the build accepts stay far below f32::MAX.
    up.min(0x7F7FF)
}

/// Decodes [`encode_energy`].
#[inline]
pub(crate) fn decode_energy(code: u32) -> f32 {
    f32::from_bits((code & 0xF_FFFF) << 12)
}

/// The bfloat16 code of `x ≥ 0` (the upper 16 bits of its f32), rounded up.
pub(crate) fn encode_bf16(x: f32) -> u16 {
    let bits = if x > 0.0 { x.to_bits() } else { 0 };
    let up = (bits >> 16) + u32::from(bits & 0xFFFF != 0);
    up.min(0x7F7F) as u16
}

/// Decodes [`encode_bf16`].
#[inline]
pub(crate) fn decode_bf16(q: u16) -> f32 {
    f32::from_bits(u32::from(q) << 16)
}

/// The scale `2^(exponent − 127)` of a node's sphere codes (`exponent` in 1..=254).
#[inline]
pub(crate) fn scale_of(exponent: u8) -> f32 {
    f32::from_bits(u32::from(exponent.clamp(1, 254)) << 23)
}

/// Decodes a slot's sphere word (x, y, z, radius codes in bytes 0..4) in the frame
/// `(origin, scale)`.
#[inline]
pub(crate) fn decode_sphere(word: u32, origin: [f32; 3], scale: f32) -> Sphere {
    let b = word.to_le_bytes();
    Sphere {
        center: Vec3::new(
            f32::from(b[0]) * scale + origin[0],
            f32::from(b[1]) * scale + origin[1],
            f32::from(b[2]) * scale + origin[2],
        ),
        radius: f32::from(b[3]) * scale,
    }
}

/// The frame `(origin, exponent)` and sphere words of up to four spheres: the codes of each
/// sphere decode to a sphere that contains it. `spheres` must be finite.
#[must_use]
pub fn encode_spheres(spheres: &[Sphere]) -> ([f32; 3], u8, [u32; 4]) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    let mut r_max = 0.0f32;
    for s in spheres {
        lo = lo.min(s.center);
        hi = hi.max(s.center);
        r_max = r_max.max(s.radius);
    }
    if spheres.is_empty() {
        return ([0.0; 3], 127, [0; 4]);
    }
    let origin = [lo.x, lo.y, lo.z];
    let extent = (hi - lo).max_element();
    // The smallest power of two that leaves room for the extent in 255 steps and for the
    // largest radius plus the centre's rounding in 255 steps; raised while a code overflows.
    let need = (extent / Q8).max(r_max / 250.0);
    let mut exponent = exponent_at_least(need);
    'grow: loop {
        let scale = scale_of(exponent);
        let mut words = [0u32; 4];
        for (k, s) in spheres.iter().enumerate() {
            let mut q = [0u8; 4];
            let c = [s.center.x, s.center.y, s.center.z];
            for a in 0..3 {
                let t = math::round((c[a] - origin[a]) / scale);
                if !(0.0..=Q8).contains(&t) && exponent < 254 {
                    exponent += 1;
                    continue 'grow;
                }
                q[a] = t.clamp(0.0, Q8) as u8;
            }
            let decoded = decode_sphere(u32::from_le_bytes(q), origin, scale);
            let moved = math::length(decoded.center - s.center);
            // A quarter step beyond the light: a shading point on the light (a surface point
            // lit by a light sitting on it) is then well inside the sphere, not on its rim
            // where the direction to the centre says nothing about the light's.
            let need_r = (moved + s.radius) * (1.0 + 1e-6) + 0.25 * scale;
            let mut qr = math::ceil(need_r / scale);
            while qr <= Q8 && qr * scale < need_r {
                qr += 1.0;
            }
            if qr > Q8 && exponent < 254 {
                exponent += 1;
                continue 'grow;
            }
            // At the largest scale (2^127 · 255 spans every finite f32 distance) the codes
            // saturate; the build's coordinates (|x| ≤ 1e15) never get there.
            q[3] = qr.min(Q8) as u8;
            words[k] = u32::from_le_bytes(q);
        }
        return (origin, exponent, words);
    }
}

/// The smallest exponent (biased, 1..=254) whose scale is at least `x`.
fn exponent_at_least(x: f32) -> u8 {
    // NaN and anything at or below the smallest normal number: the smallest scale.
    if x.is_nan() || x <= f32::MIN_POSITIVE {
        return 1;
    }
    let bits = x.to_bits();
    let e = (bits >> 23) & 0xFF;
    let e = if bits & 0x7F_FFFF != 0 { e + 1 } else { e };
    e.clamp(1, 254) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The worst angle between a unit vector and its 8+8-bit octahedral decode.
    pub(crate) fn worst_axis_error() -> f32 {
        let mut worst = 0.0f32;
        for i in 0..400 {
            for j in 0..200 {
                let z = -1.0 + 2.0 * (j as f32 + 0.5) / 200.0;
                let phi = 2.0 * PI * i as f32 / 400.0;
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
        worst
    }

    #[test]
    fn axis_roundtrip_error_is_small_and_covered() {
        let worst = worst_axis_error();
        // Half a step of 2/255 in the octahedral domain (0.0055 along each coordinate),
        // stretched by the mapping to the sphere near the octahedron's edges.
        assert!(worst < 0.02, "worst axis error {worst}");
        // The widening of θo covers it: a cone of half-angle 0 around any axis decodes to a
        // cone containing that axis.
        for i in 0..300 {
            let t = i as f32 * 0.021;
            let a = Vec3::new(math::cos(t * 3.1), math::sin(t * 1.7), math::cos(t)).normalize();
            let c = Cone {
                axis: a,
                theta_o: 0.0,
                theta_e: 0.5,
            };
            let d = decode_cone(encode_cone(&c));
            assert!(
                crate::bounds::angle_between(d.axis, a) <= d.theta_o,
                "axis {a}"
            );
            assert!(d.theta_e >= c.theta_e);
        }
    }

    #[test]
    fn angles_round_up() {
        for i in 0..=1000 {
            let t = PI * i as f32 / 1000.0;
            let q = encode_angle(t);
            let back = angle_of(q);
            assert!(back + 1e-6 >= t, "θ={t}: decoded {back}");
            // At most one step of s = sin(θ/2) above the true value.
            let allowed = angle_of((math::floor(math::sin(t * 0.5) * Q8) as u32 + 2).min(255));
            assert!(back <= allowed + 1e-5, "θ={t}: decoded {back} > {allowed}");
            let (c, s) = decode_angle(q);
            assert!((c * c + s * s - 1.0).abs() < 1e-5);
            assert!(c <= math::cos(t) + 1e-6, "cos must not grow: θ={t}");
        }
        assert_eq!(encode_angle(0.0), 0);
        assert_eq!(decode_angle(encode_angle(PI)).0, -1.0);
    }

    #[test]
    fn emission_angles_round_up_and_keep_a_right_angle() {
        for i in 0..=1000 {
            let t = FRAC_PI_2 * i as f32 / 1000.0;
            let q = encode_emission(t);
            assert!(decode_emission(q) <= math::cos(t) + 1e-6, "θe={t}");
            assert!(emission_angle_of(q) + 1e-6 >= t, "θe={t}");
            assert!(emission_angle_of(q) <= t + 0.02, "θe={t}");
        }
        assert_eq!(decode_emission(encode_emission(FRAC_PI_2)), 0.0);
        assert_eq!(decode_emission(encode_emission(0.0)), 1.0);
    }

    #[test]
    fn energies_round_up_and_stay_positive() {
        for e in [1e-40f32, 1e-38, 1.0, 1.0 + 1e-7, 3.7, 1e20, 1e30] {
            let d = decode_energy(encode_energy(e));
            // 2⁻¹¹ relative; below f32's normal range a step of the code's subnormals, 2⁻¹³⁷.
            let step = f32::MIN_POSITIVE / 2048.0;
            assert!(d >= e && d <= e * (1.0 + 1.0 / 2048.0) + step, "{e} -> {d}");
            assert!(d > 0.0);
        }
        assert_eq!(encode_energy(0.0), 0);
        assert_eq!(decode_energy(encode_energy(2.0)), 2.0);
        assert_eq!(decode_bf16(encode_bf16(0.75)), 0.75);
        assert!(decode_bf16(encode_bf16(0.7)) >= 0.7);
    }

    #[test]
    fn spheres_decode_to_containing_spheres() {
        let cases: [&[Sphere]; 4] = [
            &[
                Sphere {
                    center: Vec3::new(1.0, 2.0, 3.0),
                    radius: 0.0,
                },
                Sphere {
                    center: Vec3::new(-4.0, 2.5, 3.0),
                    radius: 0.3,
                },
                Sphere {
                    center: Vec3::new(0.0, 0.0, 9.0),
                    radius: 2.0,
                },
            ],
            &[Sphere {
                center: Vec3::new(1e4, -1e4, 0.5),
                radius: 1e-6,
            }],
            &[
                Sphere {
                    center: Vec3::splat(7.0),
                    radius: 0.0,
                },
                Sphere {
                    center: Vec3::splat(7.0),
                    radius: 0.0,
                },
            ],
            &[
                Sphere {
                    center: Vec3::new(1e15, 0.0, 0.0),
                    radius: 3.0,
                },
                Sphere {
                    center: Vec3::new(-1e15, 1e15, -1e15),
                    radius: 1e14,
                },
            ],
        ];
        for spheres in cases {
            let (origin, e, words) = encode_spheres(spheres);
            let scale = scale_of(e);
            for (k, s) in spheres.iter().enumerate() {
                let d = decode_sphere(words[k], origin, scale);
                assert!(
                    (d.center - s.center).length() + s.radius <= d.radius,
                    "{s:?} decodes to {d:?}"
                );
            }
        }
    }
}
