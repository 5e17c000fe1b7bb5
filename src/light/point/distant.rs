//! Distant lights: directions uniform in the cone of half-angle γ about the light's direction,
//! each of radiance `E / (π sin²γ)` (so that the irradiance at normal incidence is E); a delta
//! direction of irradiance E for γ = 0. The point is at infinity: `distance` is +∞ and
//! `position` is the unit direction.
//!
//! Sampling: `1 − cos θ = u₀ (1 − cos γ)`, φ = 2π u₁ about the axis, in f64 with `1 − cos`
//! kept from its own formula (a 0.27° sun has `1 − cos γ ≈ 1.1e-5`, which f32 cosines near 1
//! resolve to a few per cent only). The pdf is `1 / (2π (1 − cos γ))` for every direction in
//! the cone, so a sample's pdf and [`super::pdf_direction`]'s are the same number.

use super::vec64::V64;
use super::LightPoint;
use crate::colour::Rgb;
use crate::math;
use glam::Vec3;

/// `(unit axis, 1 − cos γ, sin²γ)` of a distant light, `None` for a zero direction.
fn cone(direction: Vec3, angular_radius: f32) -> Option<(V64, f64, f64)> {
    let axis = V64::from_f32(direction).normalize()?;
    let g = f64::from(angular_radius.max(0.0));
    let (s, _) = math::sin_cos64(g);
    Some((axis, math::one_minus_cos64(g), s * s))
}

/// The point at infinity along the unit `w` with the cone's pdf and radiance.
fn point(w: V64, pdf: f64, radiance: Rgb, delta: bool) -> Option<LightPoint> {
    let d = math::normalize(w.to_f32());
    LightPoint::checked(d, Vec3::ZERO, d, f32::INFINITY, pdf as f32, delta, radiance)
}

/// The solid-angle pdf of a direction of the cone, and the cone's radiance.
fn density(irradiance: Rgb, omc: f64, sin2: f64) -> (f64, Rgb) {
    let pdf = 1.0 / (2.0 * core::f64::consts::PI * omc);
    let k = 1.0 / (core::f64::consts::PI * sin2);
    (pdf, irradiance.map(|e| (f64::from(e) * k) as f32))
}

/// A direction of the light for `u` in [0, 1)².
pub(super) fn sample(
    direction: Vec3,
    angular_radius: f32,
    irradiance: Rgb,
    u: [f64; 2],
) -> Option<LightPoint> {
    let (axis, omc, sin2) = cone(direction, angular_radius)?;
    if omc.is_nan() || omc <= 0.0 {
        return point(axis, 1.0, irradiance, true);
    }
    let t = u[0] * omc; // 1 − cos θ
    let cos_t = 1.0 - t;
    let sin_t = math::sqrt64((t * (2.0 - t)).max(0.0));
    let (sp, cp) = math::sin_cos64(2.0 * core::f64::consts::PI * u[1]);
    let (b1, b2) = axis.basis();
    let w = axis * cos_t + b1 * (sin_t * cp) + b2 * (sin_t * sp);
    let (pdf, radiance) = density(irradiance, omc, sin2);
    point(w.normalize()?, pdf, radiance, false)
}

/// Where the ray along the unit `w` reaches the light: inside the cone (`|axis × w|² ≤ sin²γ`
/// on the axis' side), `None` otherwise and always for γ = 0.
pub(super) fn intersect(
    direction: Vec3,
    angular_radius: f32,
    irradiance: Rgb,
    w: V64,
) -> Option<LightPoint> {
    let (axis, omc, sin2) = cone(direction, angular_radius)?;
    if omc.is_nan() || omc <= 0.0 || axis.dot(w) <= 0.0 || axis.cross(w).length_squared() > sin2 {
        return None;
    }
    let (pdf, radiance) = density(irradiance, omc, sin2);
    point(w, pdf, radiance, false)
}
