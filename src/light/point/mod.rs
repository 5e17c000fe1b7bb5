//! A point on a chosen light, as seen from a shading point x, with its solid-angle pdf (Liu et
//! al. 2019, "Adaptive BRDF-Oriented Multiple Importance Sampling of Many Lights", section 4.1,
//! "Light sampling", which samples by area; here the better per-shape samplers of "A point on the
//! chosen light" of the design notes), and the pdf of any given point or direction, so that a
//! BRDF ray that hits a light can be weighted against light sampling.
//!
//! | light | sampling | pdf (solid angle at x) |
//! |---|---|---|
//! | point, spot, VPL | the position | delta: reported as `pdf = 1`, `delta = true` (by [`pdf_point`] too, at the position) |
//! | sphere, x outside | uniform in the visible cap | `1 / (2π(1 − cos θmax))` |
//! | sphere, x inside or on it | uniform by area | `d² / (A · abs(cos θy))` |
//! | disk | uniform by area (concentric map) | `d² / (A · abs(cos θy))` |
//! | triangle, Ω ≥ [`MIN_SPHERICAL_SOLID_ANGLE`] | uniform in solid angle (Arvo 1995) | `1 / Ω` |
//! | triangle, smaller | uniform by area | `d² / (A · abs(cos θy))` |
//! | distant, γ > 0 | uniform in its cone of directions | `1 / (2π(1 − cos γ))` |
//! | distant, γ = 0, or a cone whose pdf or radiance overflows f32 | its direction | delta: reported as `pdf = 1`, `delta = true` |
//! | environment | the host's (see [`crate::light::Environment`]; [`crate::LightSet::sample_point`] samples it) | the host's |
//!
//! # The estimator
//!
//! For every light kind, the contribution of a sample to the radiance reflected towards ωo is
//!
//! ```text
//! f(ωo, direction) · radiance · |n · direction| / pdf
//! ```
//!
//! (times the visibility of `position` from x). For area lights `radiance` is the emitted
//! radiance L arriving along `-direction` and `pdf` a solid-angle density. For point and spot
//! lights the pdf is a Dirac delta, reported as `pdf = 1` with [`LightPoint::delta`] set, and
//! `radiance` is `I · falloff / d²` (the irradiance at normal incidence; for a virtual point
//! light the falloff is `max(0, cos θ)` about its normal), so the same formula
//! holds. One convention for delta lights everywhere: their pdf is the delta's weight,
//! reported as 1, by [`sample_point`] and by [`pdf_point`] at the light's position (for a
//! distant light of angular radius 0, its direction; 0 at any other point). A delta light can
//! never be hit by a BRDF ray: [`intersect`] gives `None` and [`pdf_direction`] 0 for it (a
//! direction reaches it with probability 0), and MIS must give its light samples the full
//! weight (the estimators do: a BSDF density of 0). A distant light's point is at infinity
//! (`distance` = +∞, `position` its unit direction) with radiance `E / (π sin²γ)`, or `E` for
//! γ = 0 and for a cone too narrow for f32 (a delta); an environment's points are the host's: [`sample_point`] and [`intersect`]
//! return `None` for it and [`pdf_point`] 0.
//!
//! # Conventions
//!
//! - A sample whose light sends nothing towards x (x behind a one-sided disk or triangle,
//!   inside or on a sphere, outside a spot's cone) is still returned, with `radiance = 0` and
//!   its true pdf, so that the pdfs integrate to 1 regardless of x.
//! - `None` (and a pdf of 0) stands for "no finite density": x exactly at a point light, in the
//!   plane of a disk or triangle, a zero-area triangle, non-finite input, or a pdf that
//!   overflows f32. These carry no light.
//! - `u` is clamped into [0, 1); NaN in `u` gives `None`.
//! - [`pdf_point`] takes the point where the ray from x first reaches the light (a point of the
//!   light that a BRDF ray would hit); for a sphere seen from outside the pdf is the same for
//!   every point.
//!
//! The geometry runs in f64 and is rounded to f32 once. A sample's `pdf` is computed by the same
//! code as [`pdf_point`] for its `position` (up to the f32 rounding of that position for area
//! lights, within 1e-4 relative; to the bit for delta lights).

mod delta;
pub(crate) mod disk;
mod distant;
mod sphere;
mod triangle;
mod vec64;

use crate::colour::Rgb;
use crate::light::Light;
use glam::Vec3;
use vec64::V64;

#[cfg(any(test, feature = "internals"))]
pub use triangle::MIN_SPHERICAL_SOLID_ANGLE;

/// A point sampled on a light (or hit on it by a ray), seen from the shading point x.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPoint {
    /// The point on the light (for point, spot and virtual point lights, their position). For
    /// a distant light or the environment, a point at infinity: the unit direction towards it
    /// (the same as `direction`).
    pub position: Vec3,
    /// Unit surface normal at `position`: outwards for a sphere, the emitting side for a
    /// one-sided disk or triangle, towards x for a two-sided one; zero for point, spot and
    /// virtual point lights, distant lights and the environment.
    pub normal: Vec3,
    /// Unit direction from x to `position`.
    pub direction: Vec3,
    /// Distance from x to `position` (> 0; +∞ for a distant light or the environment: a
    /// shadow ray tests the whole ray).
    pub distance: f32,
    /// Solid-angle pdf at x of having sampled `direction` (> 0, finite); 1 for a delta light.
    pub pdf: f32,
    /// The light is a Dirac delta in direction — a point, spot or virtual point light, or a
    /// distant light whose cone is a single direction (angular radius 0) — and `pdf` is
    /// reported as 1; `radiance` is then the irradiance it delivers at normal incidence. No
    /// BSDF ray reaches it.
    pub delta: bool,
    /// What the estimator multiplies by (≥ 0, finite): the emitted radiance arriving at x along
    /// `-direction` for area lights (0 if x is behind a one-sided emitter, or inside or on a
    /// sphere); for point, spot and virtual point lights the irradiance at normal incidence
    /// `I · falloff / d²`, already divided by the squared distance (do not divide again: the
    /// contribution is `f · radiance · cos θi / pdf` with `pdf` = 1), 0 outside a spot's cone
    /// or behind a VPL.
    pub radiance: Rgb,
}

impl LightPoint {
    /// Whether a ray from the shading point whose first surface is at `hit_distance` (+∞ when
    /// the ray escapes) reaches this point: it lies in front of the surface, or the ray
    /// escapes (the only way to reach a point at infinity). NaN reaches nothing. What
    /// [`crate::Estimator::bsdf_hits`] takes as `visible` for a host that casts the BSDF ray
    /// itself: `|p| p.reached_before(t)`.
    #[inline]
    #[must_use]
    pub fn reached_before(&self, hit_distance: f32) -> bool {
        self.distance < hit_distance || hit_distance == f32::INFINITY
    }

    /// A light point if every field is valid, else `None`.
    #[inline]
    fn checked(
        position: Vec3,
        normal: Vec3,
        direction: Vec3,
        distance: f32,
        pdf: f32,
        delta: bool,
        radiance: Rgb,
    ) -> Option<LightPoint> {
        let ok = position.is_finite()
            && normal.is_finite()
            && direction.is_finite()
            && distance > 0.0
            && !distance.is_nan()
            && pdf > 0.0
            && pdf < f32::INFINITY
            && radiance
                .to_array()
                .iter()
                .all(|c| (0.0..f32::INFINITY).contains(c));
        ok.then_some(LightPoint {
            position,
            normal,
            direction,
            distance,
            pdf,
            delta,
            radiance,
        })
    }
}

/// The largest f64 below 1.
const ONE_MINUS_EPSILON_F64: f64 = 1.0 - f64::EPSILON / 2.0;

/// `u` clamped into [0, 1)², or `None` if it holds a NaN.
#[inline]
fn unit_square(u: [f32; 2]) -> Option<[f64; 2]> {
    if u[0].is_nan() || u[1].is_nan() {
        return None;
    }
    Some(u.map(|v| f64::from(v).clamp(0.0, ONE_MINUS_EPSILON_F64)))
}

/// Samples a point on `light` as seen from the shading point `x`, for `u` uniform in [0, 1)²
/// (see the module documentation for the pdf and the estimator).
///
/// ```
/// use manylights::{light, Light, Rgb};
/// use glam::Vec3;
///
/// let sphere = Light::Sphere {
///     center: Vec3::new(0.0, 0.0, 4.0),
///     radius: 1.0,
///     radiance: Rgb::grey(2.0),
/// };
/// let s = light::sample_point(&sphere, Vec3::ZERO, [0.3, 0.7]).unwrap();
/// assert_eq!(s.pdf, light::pdf_point(&sphere, Vec3::ZERO, s.position));
/// assert_eq!(s.radiance, Rgb::grey(2.0));
/// ```
#[must_use]
pub fn sample_point(light: &Light, x: Vec3, u: [f32; 2]) -> Option<LightPoint> {
    let u = unit_square(u)?;
    if !x.is_finite() {
        return None;
    }
    match *light {
        Light::Point {
            position,
            intensity,
        } => delta::sample(position, intensity, x, |_| 1.0),
        Light::Spot {
            position,
            direction,
            intensity,
            half_angle,
            falloff_start,
        } => {
            let axis = V64::from_f32(direction).normalize()?;
            delta::sample(position, intensity, x, |w| {
                delta::spot_profile(axis, half_angle, falloff_start, w)
            })
        }
        Light::Vpl {
            position,
            normal,
            intensity,
        } => {
            let n = V64::from_f32(normal).normalize()?;
            delta::sample(position, intensity, x, |w| n.dot(w).max(0.0))
        }
        Light::Distant {
            direction,
            angular_radius,
            irradiance,
        } => distant::sample(direction, angular_radius, irradiance, u),
        Light::Environment { .. } => None,
        Light::Sphere {
            center,
            radius,
            radiance,
        } => sphere::sample(center, radius, radiance, x, u),
        Light::Disk {
            center,
            normal,
            radius,
            radiance,
            two_sided,
        } => disk::sample(center, normal, radius, radiance, two_sided, x, u),
        Light::Triangle {
            vertices,
            radiance,
            two_sided,
        } => {
            let view = triangle::view(&vertices, x, None)?;
            let p = view.sample(x, u)?;
            view.at_point(radiance, two_sided, x, p)
        }
    }
}

/// The solid-angle pdf at `x` with which [`sample_point`] returns the point `point` of `light`
/// (taken as the first point of the light on the ray from x through it; for a distant light,
/// `point` is the direction, as its points' `position` is); 0 wherever `sample_point` gives
/// `None`, and for the environment (the host's). For point, spot and virtual point lights and
/// distant ones of angular radius 0 the delta's weight, reported as 1, exactly as
/// `sample_point` reports it: 1 at the light's position (direction), 0 at any other point.
#[must_use]
pub fn pdf_point(light: &Light, x: Vec3, point: Vec3) -> f32 {
    if !(x.is_finite() && point.is_finite()) {
        return 0.0;
    }
    let pdf = match *light {
        Light::Point { .. } | Light::Spot { .. } | Light::Vpl { .. } | Light::Distant { .. } => {
            // A delta (point, spot, VPL, or a cone too narrow for f64): the only point there
            // is, where `sample_point` gives one; a distant light's cone otherwise.
            return match sample_point(light, x, [0.5; 2]) {
                Some(s) if s.delta && s.position == point => s.pdf,
                Some(s) if s.delta => 0.0,
                _ if light.is_infinite() => intersect(light, x, point).map_or(0.0, |lp| lp.pdf),
                _ => 0.0,
            };
        }
        Light::Environment { .. } => 0.0,
        Light::Sphere { center, radius, .. } => sphere::pdf_point(center, radius, x, point),
        Light::Disk {
            center,
            normal,
            radius,
            ..
        } => disk::pdf_point(center, normal, radius, x, point),
        Light::Triangle { vertices, .. } => triangle::view(&vertices, x, None)
            .and_then(|view| view.at_point(Rgb::ZERO, true, x, point))
            .map_or(0.0, |lp| f64::from(lp.pdf)),
    };
    // A density beyond f32 is "no finite density", as in `sample_point`.
    let pdf = pdf as f32;
    if pdf < f32::INFINITY {
        pdf
    } else {
        0.0
    }
}

/// Where the ray from `x` along `direction` (need not be unit length) first reaches `light`: the
/// point, the radiance it sends to x and the pdf with which [`sample_point`] would have chosen
/// it. `None` if the ray misses (always for delta lights). This is what a host needs
/// when a BRDF-sampled ray hits an emitter.
#[must_use]
pub fn intersect(light: &Light, x: Vec3, direction: Vec3) -> Option<LightPoint> {
    if !x.is_finite() {
        return None;
    }
    let w = V64::from_f32(direction).normalize()?;
    match *light {
        Light::Point { .. } | Light::Spot { .. } | Light::Vpl { .. } => None,
        Light::Distant {
            direction,
            angular_radius,
            irradiance,
        } => distant::intersect(direction, angular_radius, irradiance, w),
        Light::Environment { .. } => None,
        Light::Sphere {
            center,
            radius,
            radiance,
        } => sphere::intersect(center, radius, radiance, x, w),
        Light::Disk {
            center,
            normal,
            radius,
            radiance,
            two_sided,
        } => disk::intersect(center, normal, radius, radiance, two_sided, x, w),
        Light::Triangle {
            vertices,
            radiance,
            two_sided,
        } => {
            let view = triangle::view(&vertices, x, None)?;
            let p = view.intersect(x, w)?;
            view.at_point(radiance, two_sided, x, p)
        }
    }
}

/// The solid-angle pdf at `x` with which [`sample_point`] samples `direction` (need not be unit
/// length): the pdf of the first point of the light along it, 0 if the ray misses.
#[must_use]
pub fn pdf_direction(light: &Light, x: Vec3, direction: Vec3) -> f32 {
    intersect(light, x, direction).map_or(0.0, |lp| lp.pdf)
}

#[cfg(test)]
mod tests;
