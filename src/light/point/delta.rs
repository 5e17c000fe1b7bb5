//! Point and spot lights: the only "point" is the light's position, reached with a delta pdf.
//!
//! The spot's profile is the smooth step of pbrt-v4's spot light (Pharr, Jakob, Humphreys,
//! "Physically Based Rendering", 4th ed., section "Spotlights"): full intensity within
//! `falloff_start` θf of the axis, zero beyond `half_angle` θs, and `smoothstep` in cos θ between
//! them (a hard edge when θf = θs).

use super::vec64::V64;
use super::LightPoint;
use crate::colour::Rgb;
use crate::math;
use glam::Vec3;

/// The sample of a point or spot light at `position` seen from `x`; `profile` is the fraction
/// of the intensity sent towards x given the unit direction light → x (1 for a point light).
pub(super) fn sample(
    position: Vec3,
    intensity: Rgb,
    x: Vec3,
    profile: impl FnOnce(V64) -> f64,
) -> Option<LightPoint> {
    let d = V64::from_f32(position) - V64::from_f32(x);
    let dist2 = d.length_squared();
    let dist = math::sqrt64(dist2);
    let w = d.normalize()?;
    let p = profile(-w);
    let irradiance = intensity.map(|i| (f64::from(i) * p / dist2) as f32);
    LightPoint::checked(
        position,
        Vec3::ZERO,
        math::normalize(w.to_f32()),
        dist as f32,
        1.0,
        true,
        irradiance,
    )
}

/// `smoothstep(cos θs, cos θf, cos θ)` for the unit `axis` and unit direction `w` from the spot.
///
/// For a narrow cone (θs below [`math::SMALL_ANGLE`]) the cosines all round to nearly 1, so the
/// profile is computed from `1 − cos` instead ([`narrow_spot_profile`]).
pub(super) fn spot_profile(axis: V64, half_angle: f32, falloff_start: f32, w: V64) -> f64 {
    if f64::from(half_angle) < math::SMALL_ANGLE {
        return narrow_spot_profile(axis, half_angle, falloff_start, w);
    }
    let cos_theta = axis.dot(w);
    let cos_s = cos_angle(half_angle);
    let cos_f = cos_angle(falloff_start);
    let inside = cos_theta >= cos_s;
    if !inside {
        return 0.0; // outside the cone, or NaN
    }
    let hard_edge = cos_f <= cos_s;
    if hard_edge {
        return 1.0;
    }
    let t = ((cos_theta - cos_s) / (cos_f - cos_s)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// [`spot_profile`] from `1 − cos` of each angle, with `cos θ − cos θs = (1 − cos θs) −
/// (1 − cos θ)`: `1 − cos θ = sin²θ / (1 + cos θ)` with `sin θ = |axis × w|`, which keeps its
/// precision for tiny θ where `1 − axis·w` cancels.
fn narrow_spot_profile(axis: V64, half_angle: f32, falloff_start: f32, w: V64) -> f64 {
    let cos_theta = axis.dot(w);
    if cos_theta.is_nan() || cos_theta <= 0.0 {
        return 0.0; // behind the spot (θs < π/2), or NaN
    }
    let omc = axis.cross(w).length_squared() / (1.0 + cos_theta);
    let omc_s = math::one_minus_cos64(f64::from(half_angle));
    let omc_f = math::one_minus_cos64(f64::from(falloff_start.max(0.0)));
    let inside = omc <= omc_s;
    if !inside {
        return 0.0; // outside the cone, or NaN
    }
    if omc_s <= omc_f {
        return 1.0;
    }
    let t = ((omc_s - omc) / (omc_s - omc_f)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// cos of an angle in [0, π], exact at the ends (f32 π is a little above π).
fn cos_angle(a: f32) -> f64 {
    if a >= core::f32::consts::PI {
        -1.0
    } else if a <= 0.0 {
        1.0
    } else {
        math::cos64(f64::from(a))
    }
}
