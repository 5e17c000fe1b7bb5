//! Distant lights: directions uniform in the cone of half-angle γ about the light's direction,
//! each of radiance `E / (π sin²γ)` (so that the irradiance at normal incidence is E); a delta
//! direction of irradiance E for γ = 0, and for a cone too narrow for f32 (its pdf or radiance
//! would overflow: the delta is its limit, and its light is not lost). The point is at
//! infinity: `distance` is +∞ and `position` is the unit direction.
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

/// A distant light's cone of directions: its unit axis, and, unless it is the delta direction,
/// `1 − cos γ`, `sin²γ`, the pdf of its directions and their radiance ([`density`]).
struct Cone {
    axis: V64,
    spread: Option<Spread>,
}

/// What a cone of γ > 0 spreads its irradiance over.
struct Spread {
    omc: f64,
    sin2: f64,
    pdf: f64,
    radiance: Rgb,
}

/// The cone of a distant light (`None` for a zero direction). It is the delta direction of
/// irradiance E for γ = 0, and for a cone so narrow that its pdf or its radiance overflows f32
/// (a pdf `1 / (2π(1 − cos γ))` for γ below about 3e-20 rad, a radiance `E / (π sin²γ)` above
/// `f32::MAX`): such a cone cannot be sampled in f32, and the delta is its limit.
fn cone(direction: Vec3, angular_radius: f32, irradiance: Rgb) -> Option<Cone> {
    let axis = V64::from_f32(direction).normalize()?;
    let g = f64::from(angular_radius.max(0.0));
    let (s, _) = math::sin_cos64(g);
    let (omc, sin2) = (math::one_minus_cos64(g), s * s);
    if omc.is_nan() || omc <= 0.0 {
        return Some(Cone { axis, spread: None });
    }
    let (pdf, radiance) = density(irradiance, omc, sin2);
    let fits =
        (pdf as f32) < f32::INFINITY && radiance.to_array().iter().all(|c| *c < f32::INFINITY);
    Some(Cone {
        axis,
        spread: fits.then_some(Spread {
            omc,
            sin2,
            pdf,
            radiance,
        }),
    })
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
    let Cone { axis, spread } = cone(direction, angular_radius, irradiance)?;
    let Some(Spread {
        omc, pdf, radiance, ..
    }) = spread
    else {
        return point(axis, 1.0, irradiance, true);
    };
    let t = u[0] * omc; // 1 − cos θ
    let cos_t = 1.0 - t;
    let sin_t = math::sqrt64((t * (2.0 - t)).max(0.0));
    let (sp, cp) = math::sin_cos64(2.0 * core::f64::consts::PI * u[1]);
    let (b1, b2) = axis.basis();
    let w = axis * cos_t + b1 * (sin_t * cp) + b2 * (sin_t * sp);
    point(w.normalize()?, pdf, radiance, false)
}

/// Where the ray along the unit `w` reaches the light: inside the cone (`|axis × w|² ≤ sin²γ`
/// on the axis' side), `None` otherwise and always for the delta direction.
pub(super) fn intersect(
    direction: Vec3,
    angular_radius: f32,
    irradiance: Rgb,
    w: V64,
) -> Option<LightPoint> {
    let Cone { axis, spread } = cone(direction, angular_radius, irradiance)?;
    let Spread {
        sin2,
        pdf,
        radiance,
        ..
    } = spread?;
    if axis.dot(w) <= 0.0 || axis.cross(w).length_squared() > sin2 {
        return None;
    }
    point(w, pdf, radiance, false)
}
