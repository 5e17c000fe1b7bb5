//! The light model: point, spot, sphere, disk, triangle and virtual point lights (VPLs), the
//! distant lights and the host's environment, their validation, and the bounds the tree is
//! built from (Conty & Kulla, "Orientation bounds": box, orientation cone, energy).
//!
//! Units, per kind (every emission linear RGB, per channel; the tree ranks by luminance):
//!
//! | kind | fields | emission | what the tree ranks by |
//! |---|---|---|---|
//! | point | position | intensity I, W/sr | flux 4πI |
//! | spot | position, axis, θs, θf | intensity I on the axis, W/sr | 2π(1 − cos θs)·I (a bound of the flux) |
//! | sphere | centre, radius R | radiance L, W/(m²·sr) | flux L·π·4πR² |
//! | disk | centre, normal, radius R | radiance L, W/(m²·sr) | flux L·π·πR² per side |
//! | triangle | vertices | radiance L, W/(m²·sr) | flux L·π·A per side |
//! | VPL | position, normal | intensity I along the normal, W/sr | flux πI |
//! | distant | direction towards the light, angular radius γ | irradiance E at normal incidence, W/m² | at a point, 4π·E·cos⁺(θ − γ) (not in the node tree) |
//! | environment | — (the host's radiance) | the host's irradiance bounds on receivers facing ±x, ±y, ±z, W/m² | at a point, 4π × the bound for its normal (not in the node tree) |
//!
//! A distant light's radiance is uniform over its cone of directions: L = E / (π sin²γ), so
//! that the irradiance at normal incidence is E; γ = 0 is a delta direction that delivers E.
//! The importances of the node tree are `flux / d²` = 4π × an irradiance, so a distant
//! light's and the environment's are in the same units (docs/formulas.md, section 16).
//!
//! What a light may hold, decided once:
//! - coordinates finite with magnitude ≤ [`MAX_COORDINATE`];
//! - intensity and radiance finite and ≥ 0 (zero is accepted: the light is never sampled);
//! - radii finite and > 0; directions and normals finite and non-zero (normalised here);
//!   a VPL's normal is normalised where it is used (bounds, sampling), like a disk's;
//! - a spot's `half_angle` θs in (0, π], its `falloff_start` θf in [0, θs];
//! - a degenerate triangle (zero area) is accepted and never sampled;
//! - a light's energy at most [`MAX_LIGHT_ENERGY`], all of them together at most
//!   [`MAX_TOTAL_ENERGY`], so that importances cannot overflow f32;
//! - a distant light's direction finite and non-zero (normalised here), its angular radius γ
//!   in [0, π/2], its irradiance's luminance at most [`MAX_LIGHT_ENERGY`]; an environment's
//!   six bounds finite, ≥ 0 and at most [`MAX_LIGHT_ENERGY`]. At most
//!   `MAX_INFINITE_LIGHTS` distant and environment
//!   lights in all, at most one environment (checked by the build).

use crate::bounds::{Aabb, Cone, LightBounds, Sphere};
use crate::colour::Rgb;
use crate::error::{BuildError, LightField, Problem};
pub use crate::limits::MAX_INFINITE_LIGHTS;
mod environment;
pub(crate) mod point;

use crate::math;
use core::f32::consts::{FRAC_PI_2, PI};
pub use environment::{Environment, EnvironmentSample, GradientSky, UniformSky};
use glam::Vec3;
pub use point::{intersect, pdf_direction, pdf_point, sample_point, LightPoint};

pub use crate::limits::{MAX_COORDINATE, MAX_LIGHT_ENERGY, MAX_TOTAL_ENERGY};

/// One light. Powers are radiometric and linear RGB ([`Rgb`]): `intensity` in W/sr,
/// `radiance` in W/(m²·sr), `irradiance` in W/m², per channel (lengths in the scene's unit, m
/// say); [`Light::energy`] is the flux in W (the crate documentation's "Units and limits" has
/// the table). The tree ranks lights by the luminance of these ([`Rgb::luminance`]), so a grey
/// light samples as a scalar one of the same value.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Light {
    /// Isotropic point light.
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity (W/sr).
        intensity: Rgb,
    },
    /// Spot light: intensity `intensity` inside `falloff_start`, falling to 0 at `half_angle`:
    /// towards angle θ from the axis it sends `intensity · s(θ)`, with s = 1 for θ ≤ θf, 0 for
    /// θ ≥ θs, and between them the smoothstep in cos θ, s = 3t² − 2t³ with t = (cos θ −
    /// cos θs)/(cos θf − cos θs) (pbrt-v4's spot light; a hard edge when θf = θs).
    Spot {
        /// Position.
        position: Vec3,
        /// Direction of the cone's axis (need not be unit length).
        direction: Vec3,
        /// Radiant intensity on the axis (W/sr).
        intensity: Rgb,
        /// Cone half-angle θs in radians, in (0, π].
        half_angle: f32,
        /// Angle θf where the falloff starts, in [0, θs].
        falloff_start: f32,
    },
    /// Spherical area light of uniform radiance.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius (> 0).
        radius: f32,
        /// Emitted radiance (W/(m²·sr)).
        radiance: Rgb,
    },
    /// Disk area light of uniform radiance.
    Disk {
        /// Centre.
        center: Vec3,
        /// Normal: the emitting side when one-sided (need not be unit length).
        normal: Vec3,
        /// Radius (> 0).
        radius: f32,
        /// Emitted radiance (W/(m²·sr)).
        radiance: Rgb,
        /// Emits on both sides.
        two_sided: bool,
    },
    /// Triangle area light of uniform radiance; one-sided lights emit on the side of
    /// `(v1 − v0) × (v2 − v0)`.
    Triangle {
        /// Vertices.
        vertices: [Vec3; 3],
        /// Emitted radiance (W/(m²·sr)).
        radiance: Rgb,
        /// Emits on both sides.
        two_sided: bool,
    },
    /// A light at infinity seen in the same cone of directions from every point (a sun): the
    /// directions within `angular_radius` γ of `direction`, each of radiance
    /// `irradiance / (π sin²γ)`, so that a surface facing it receives `irradiance`; γ = 0 is
    /// a delta direction of irradiance `irradiance`. Not in the node tree: the light set
    /// weighs it against the tree at every shading point.
    Distant {
        /// Direction towards the light (need not be unit length).
        direction: Vec3,
        /// Half-angle γ of the cone, radians, in [0, π/2] (0.27° ≈ 0.0047 for the sun).
        angular_radius: f32,
        /// Irradiance at normal incidence (W/m²).
        irradiance: Rgb,
    },
    /// The environment's entry (a sky or an environment map): its radiance, sampling and pdf
    /// belong to the host's [`Environment`]; the light carries what the importance needs,
    /// bounds of the irradiance it delivers ([`Environment::irradiance_bounds`]). At most one
    /// per tree. A [`crate::LightSet`] makes it from the host's environment
    /// ([`crate::LightSet::build_with_environment`]) and refuses it in a plain light list;
    /// [`crate::LightTree::build`] takes it as it is (the tree level samples and answers pmfs
    /// of it; points on it are the environment's own, [`sample_point`] gives none).
    Environment {
        /// Upper bounds of the irradiance (luminance, W/m²) on a receiver facing +x, −x, +y,
        /// −y, +z and −z: `∫ Y(L(ω)) max(0, a·ω) dω` for each axis direction a. The bound at a
        /// normal n is `Σ |n_i| · E(sign(n_i) e_i)`, which is at least the irradiance for any
        /// n. A uniform environment of radiance L has πY(L) in all six.
        irradiance: [f32; 6],
    },
    /// Virtual point light (Keller 1997, "Instant Radiosity"): a point that emits with a cosine
    /// lobe about its normal, radiant intensity `intensity · max(0, cos θ)` with θ the angle to
    /// `normal` (a one-sided Lambertian point emitter). What a diffuse surface point that
    /// received flux Φ with albedo ρ re-emits is the VPL of intensity ρΦ/π.
    Vpl {
        /// Position.
        position: Vec3,
        /// Normal: the emitting side (need not be unit length).
        normal: Vec3,
        /// Radiant intensity along the normal (W/sr).
        intensity: Rgb,
    },
}

fn invalid(index: usize, field: LightField, problem: Problem, value: f32) -> BuildError {
    BuildError::InvalidLight {
        index,
        field,
        problem,
        value,
    }
}

fn check_point(index: usize, field: LightField, p: Vec3) -> Result<(), BuildError> {
    for v in p.to_array() {
        if !v.is_finite() {
            return Err(invalid(index, field, Problem::NotFinite, v));
        }
        if v.abs() > MAX_COORDINATE {
            return Err(invalid(index, field, Problem::OutOfRange, v));
        }
    }
    Ok(())
}

/// Every channel finite and ≥ 0; the error carries the first channel that is not.
fn check_power(index: usize, field: LightField, c: Rgb) -> Result<(), BuildError> {
    for v in c.to_array() {
        if !v.is_finite() {
            return Err(invalid(index, field, Problem::NotFinite, v));
        }
        if v < 0.0 {
            return Err(invalid(index, field, Problem::Negative, v));
        }
    }
    Ok(())
}

fn check_radius(index: usize, v: f32) -> Result<(), BuildError> {
    if !v.is_finite() {
        return Err(invalid(index, LightField::Radius, Problem::NotFinite, v));
    }
    if v <= 0.0 {
        return Err(invalid(index, LightField::Radius, Problem::NotPositive, v));
    }
    if v > MAX_COORDINATE {
        return Err(invalid(index, LightField::Radius, Problem::OutOfRange, v));
    }
    Ok(())
}

fn check_direction(index: usize, field: LightField, d: Vec3) -> Result<Vec3, BuildError> {
    for v in d.to_array() {
        if !v.is_finite() {
            return Err(invalid(index, field, Problem::NotFinite, v));
        }
    }
    math::unit_f64([f64::from(d.x), f64::from(d.y), f64::from(d.z)])
        .ok_or_else(|| invalid(index, field, Problem::ZeroLength, 0.0))
}

/// An irradiance of at most [`MAX_LIGHT_ENERGY`].
fn check_magnitude(index: usize, e: f32) -> Result<(), BuildError> {
    if e > MAX_LIGHT_ENERGY {
        return Err(invalid(
            index,
            LightField::Irradiance,
            Problem::EnergyTooLarge,
            e,
        ));
    }
    Ok(())
}

/// `(v1 − v0) × (v2 − v0)` in f64.
fn triangle_normal(v: &[Vec3; 3]) -> [f64; 3] {
    let d = |k: usize, i: usize| f64::from(v[k][i]) - f64::from(v[0][i]);
    let (a, b) = ([d(1, 0), d(1, 1), d(1, 2)], [d(2, 0), d(2, 1), d(2, 2)]);
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Smallest sphere around a triangle: the midpoint of the longest edge for an obtuse or right
/// triangle, the circumcentre otherwise. Computed in f64 and rounded outwards.
fn triangle_sphere(v: &[Vec3; 3]) -> Sphere {
    let p = v.map(|p| [f64::from(p.x), f64::from(p.y), f64::from(p.z)]);
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let mut centre = [0.0f64; 3];
    let mut found = false;
    for i in 0..3 {
        let (a, b, c) = (p[i], p[(i + 1) % 3], p[(i + 2) % 3]);
        // Angle at c is ≥ 90° when (a − c)·(b − c) ≤ 0: the longest edge is ab.
        if dot(sub(a, c), sub(b, c)) <= 0.0 {
            centre = [
                (a[0] + b[0]) * 0.5,
                (a[1] + b[1]) * 0.5,
                (a[2] + b[2]) * 0.5,
            ];
            found = true;
            break;
        }
    }
    if !found {
        let (a, b) = (sub(p[1], p[0]), sub(p[2], p[0]));
        let axb = cross(a, b);
        let den = 2.0 * dot(axb, axb);
        if den > 0.0 {
            let t1 = cross(axb, a);
            let t2 = cross(b, axb);
            let (sa, sb) = (dot(a, a), dot(b, b));
            for k in 0..3 {
                centre[k] = p[0][k] + (sb * t1[k] + sa * t2[k]) / den;
            }
        } else {
            centre = [
                (p[0][0] + p[1][0] + p[2][0]) / 3.0,
                (p[0][1] + p[1][1] + p[2][1]) / 3.0,
                (p[0][2] + p[1][2] + p[2][2]) / 3.0,
            ];
        }
    }
    sphere_around(centre, &p)
}

/// The sphere centred at `centre` (rounded to f32) holding all `points`, radius rounded up.
fn sphere_around(centre: [f64; 3], points: &[[f64; 3]]) -> Sphere {
    let c = Vec3::new(centre[0] as f32, centre[1] as f32, centre[2] as f32);
    let cf = [f64::from(c.x), f64::from(c.y), f64::from(c.z)];
    let mut r2 = 0.0f64;
    for q in points {
        let d2 = math::sq(q[0] - cf[0]) + math::sq(q[1] - cf[1]) + math::sq(q[2] - cf[2]);
        r2 = r2.max(d2);
    }
    Sphere {
        center: c,
        radius: math::outward(math::sqrt64(r2)),
    }
}

/// The f32 of an energy: rounded to the nearest, and at least the smallest positive f32
/// (2⁻¹⁴⁹) when the energy is positive, so that a light that emits anything is in the tree
/// (a spot of half-angle 1e-30 has an energy far below f32's range).
fn energy_f32(e: f64) -> f32 {
    let f = e as f32;
    if f == 0.0 && e > 0.0 {
        f32::from_bits(1)
    } else {
        f
    }
}

/// The luminance of a colour, as the energies use it (exactly `c` for a grey `c`).
#[inline]
fn lum(c: Rgb) -> f64 {
    f64::from(c.luminance())
}

impl Light {
    /// Checks every field; `index` is the light's position in the caller's list, used in the
    /// error.
    pub fn validate(&self, index: usize) -> Result<(), BuildError> {
        self.validated_energy(index).map(|_| ())
    }

    /// [`Light::validate`], returning the light's [`Light::energy`] when it is valid (the
    /// check computes it).
    pub(crate) fn validated_energy(&self, index: usize) -> Result<f32, BuildError> {
        match *self {
            Light::Point {
                position,
                intensity,
            } => {
                check_point(index, LightField::Position, position)?;
                check_power(index, LightField::Intensity, intensity)?;
            }
            Light::Spot {
                position,
                direction,
                intensity,
                half_angle,
                falloff_start,
            } => {
                check_point(index, LightField::Position, position)?;
                check_direction(index, LightField::Direction, direction)?;
                check_power(index, LightField::Intensity, intensity)?;
                if !half_angle.is_finite() {
                    return Err(invalid(
                        index,
                        LightField::HalfAngle,
                        Problem::NotFinite,
                        half_angle,
                    ));
                }
                if !(half_angle > 0.0 && half_angle <= PI) {
                    return Err(invalid(
                        index,
                        LightField::HalfAngle,
                        Problem::OutOfRange,
                        half_angle,
                    ));
                }
                if !falloff_start.is_finite() {
                    return Err(invalid(
                        index,
                        LightField::FalloffStart,
                        Problem::NotFinite,
                        falloff_start,
                    ));
                }
                if !(0.0..=half_angle).contains(&falloff_start) {
                    return Err(invalid(
                        index,
                        LightField::FalloffStart,
                        Problem::OutOfRange,
                        falloff_start,
                    ));
                }
            }
            Light::Sphere {
                center,
                radius,
                radiance,
            } => {
                check_point(index, LightField::Center, center)?;
                check_radius(index, radius)?;
                check_power(index, LightField::Radiance, radiance)?;
            }
            Light::Disk {
                center,
                normal,
                radius,
                radiance,
                ..
            } => {
                check_point(index, LightField::Center, center)?;
                check_direction(index, LightField::Normal, normal)?;
                check_radius(index, radius)?;
                check_power(index, LightField::Radiance, radiance)?;
            }
            Light::Triangle {
                vertices, radiance, ..
            } => {
                for (k, v) in vertices.iter().enumerate() {
                    check_point(index, LightField::Vertex(k as u8), *v)?;
                }
                check_power(index, LightField::Radiance, radiance)?;
            }
            Light::Vpl {
                position,
                normal,
                intensity,
            } => {
                check_point(index, LightField::Position, position)?;
                check_direction(index, LightField::Normal, normal)?;
                check_power(index, LightField::Intensity, intensity)?;
            }
            Light::Distant {
                direction,
                angular_radius,
                irradiance,
            } => {
                check_direction(index, LightField::Direction, direction)?;
                let field = LightField::AngularRadius;
                if !angular_radius.is_finite() {
                    return Err(invalid(index, field, Problem::NotFinite, angular_radius));
                }
                if !(0.0..=FRAC_PI_2).contains(&angular_radius) {
                    return Err(invalid(index, field, Problem::OutOfRange, angular_radius));
                }
                check_power(index, LightField::Irradiance, irradiance)?;
                check_magnitude(index, irradiance.luminance())?;
            }
            Light::Environment { irradiance } => {
                check_power(
                    index,
                    LightField::Irradiance,
                    Rgb::new(irradiance[0], irradiance[1], irradiance[2]),
                )?;
                check_power(
                    index,
                    LightField::Irradiance,
                    Rgb::new(irradiance[3], irradiance[4], irradiance[5]),
                )?;
                for e in irradiance {
                    check_magnitude(index, e)?;
                }
            }
        }
        let e = self.energy_f64();
        if e > f64::from(MAX_LIGHT_ENERGY) {
            // The error names the field that sets the power, with its own value (luminance).
            let (field, value) = match *self {
                Light::Point { intensity, .. }
                | Light::Spot { intensity, .. }
                | Light::Vpl { intensity, .. } => (LightField::Intensity, intensity.luminance()),
                Light::Sphere { radiance, .. }
                | Light::Disk { radiance, .. }
                | Light::Triangle { radiance, .. } => (LightField::Radiance, radiance.luminance()),
                Light::Distant { irradiance, .. } => {
                    (LightField::Irradiance, irradiance.luminance())
                }
                Light::Environment { irradiance } => (
                    LightField::Irradiance,
                    irradiance.iter().fold(0.0f32, |a, &b| a.max(b)),
                ),
            };
            return Err(invalid(index, field, Problem::EnergyTooLarge, value));
        }
        Ok(energy_f32(e))
    }

    /// Emitting area (0 for point, spot, virtual point, distant and environment lights).
    #[must_use]
    pub fn area(&self) -> f32 {
        self.area_f64() as f32
    }

    /// Whether the light is at infinity (distant or environment): it has no position, is not
    /// in the node tree and is weighed against it at the root (see [`crate::light_set`]).
    #[inline]
    #[must_use]
    pub fn is_infinite(&self) -> bool {
        matches!(self, Light::Distant { .. } | Light::Environment { .. })
    }

    fn area_f64(&self) -> f64 {
        match *self {
            Light::Point { .. }
            | Light::Spot { .. }
            | Light::Vpl { .. }
            | Light::Distant { .. }
            | Light::Environment { .. } => 0.0,
            Light::Sphere { radius, .. } => {
                4.0 * core::f64::consts::PI * math::sq(f64::from(radius))
            }
            Light::Disk { radius, .. } => core::f64::consts::PI * math::sq(f64::from(radius)),
            Light::Triangle { vertices, .. } => {
                let c = triangle_normal(&vertices);
                0.5 * math::sqrt64(math::sq(c[0]) + math::sq(c[1]) + math::sq(c[2]))
            }
        }
    }

    fn energy_f64(&self) -> f64 {
        let pi = core::f64::consts::PI;
        match *self {
            Light::Point { intensity, .. } => 4.0 * pi * lum(intensity),
            // ∫ I·max(0, cos θ) dω over the sphere = πI.
            Light::Vpl { intensity, .. } => pi * lum(intensity),
            Light::Spot {
                intensity,
                half_angle,
                ..
            } => 2.0 * pi * math::one_minus_cos64(f64::from(half_angle)) * lum(intensity),
            Light::Sphere { radiance, .. } => lum(radiance) * pi * self.area_f64(),
            // At infinity: no finite flux, and not in the node tree.
            Light::Distant { .. } | Light::Environment { .. } => 0.0,
            Light::Disk {
                radiance,
                two_sided,
                ..
            }
            | Light::Triangle {
                radiance,
                two_sided,
                ..
            } => {
                let sides = if two_sided { 2.0 } else { 1.0 };
                sides * lum(radiance) * pi * self.area_f64()
            }
        }
    }

    /// Emitted power as luminance (docs/formulas.md, sections 1 and 15; Conty & Kulla,
    /// "Orientation bounds"), with I and L the luminance of the light's colour: 4πI
    /// for points, 2π(1 − cos θs)·I for spots (an upper bound of the flux with falloff;
    /// `1 − cos θs` is computed without cancellation, so a narrow cone keeps its energy), πI
    /// for virtual point lights, L·π·A per emitting side for area lights, in W when
    /// intensity is in W/sr and radiance in W/(m²·sr); 0 for distant and environment lights
    /// (no finite flux: they are weighed at each shading point by their irradiance instead, see
    /// [`crate::light_set`]). Computed in f64 and rounded to the nearest f32, but never to 0 for
    /// a light that emits: a positive energy below f32's range is the smallest positive f32,
    /// 2⁻¹⁴⁹, so that every light that can light a point is in the tree. Valid only for a light
    /// that passed [`Light::validate`].
    #[must_use]
    pub fn energy(&self) -> f32 {
        energy_f32(self.energy_f64())
    }

    /// The light's bounds: box, tight bounding sphere, orientation cone and energy.
    /// Valid only for a light that passed [`Light::validate`].
    pub(crate) fn bounds(&self) -> LightBounds {
        self.bounds_with_energy(self.energy())
    }

    /// [`Light::bounds`] of a light whose [`Light::energy`] is `energy`.
    pub(crate) fn bounds_with_energy(&self, energy: f32) -> LightBounds {
        let (aabb, sphere, cone) = match *self {
            Light::Point { position, .. } => (
                Aabb::point(position),
                Sphere {
                    center: position,
                    radius: 0.0,
                },
                Cone::SPHERE,
            ),
            Light::Spot {
                position,
                direction,
                half_angle,
                ..
            } => {
                let axis = math::unit_f64(direction.as_ref().map(f64::from)).unwrap_or(Vec3::Z);
                // Emission within θs of the axis. Beyond π/2 the spread is carried by θo so that
                // θe stays ≤ π/2 and cos θ' > 0 wherever the importance is positive.
                let cone = if half_angle > FRAC_PI_2 {
                    Cone {
                        axis,
                        theta_o: half_angle - FRAC_PI_2,
                        theta_e: FRAC_PI_2,
                    }
                } else {
                    Cone {
                        axis,
                        theta_o: 0.0,
                        theta_e: half_angle,
                    }
                };
                (
                    Aabb::point(position),
                    Sphere {
                        center: position,
                        radius: 0.0,
                    },
                    cone,
                )
            }
            // Not bounded by the tree: a point at the origin, any orientation.
            Light::Distant { .. } | Light::Environment { .. } => (
                Aabb::point(Vec3::ZERO),
                Sphere {
                    center: Vec3::ZERO,
                    radius: 0.0,
                },
                Cone::SPHERE,
            ),
            Light::Vpl {
                position, normal, ..
            } => (
                Aabb::point(position),
                Sphere {
                    center: position,
                    radius: 0.0,
                },
                // One point emitting into the hemisphere about its normal.
                Cone {
                    axis: math::unit_f64(normal.as_ref().map(f64::from)).unwrap_or(Vec3::Z),
                    theta_o: 0.0,
                    theta_e: FRAC_PI_2,
                },
            ),
            Light::Sphere { center, radius, .. } => {
                let r = Vec3::splat(radius);
                (
                    Aabb::new(center - r, center + r),
                    Sphere { center, radius },
                    Cone::SPHERE,
                )
            }
            Light::Disk {
                center,
                normal,
                radius,
                two_sided,
                ..
            } => {
                let n = math::unit_f64(normal.as_ref().map(f64::from)).unwrap_or(Vec3::Z);
                // Half-extent of a disk along axis k is R·sqrt(1 − n_k²).
                let e = Vec3::new(
                    math::sin_from_cos(n.x),
                    math::sin_from_cos(n.y),
                    math::sin_from_cos(n.z),
                ) * radius
                    * (1.0 + 1e-6);
                let cone = if two_sided {
                    Cone::SPHERE
                } else {
                    Cone {
                        axis: n,
                        theta_o: 0.0,
                        theta_e: FRAC_PI_2,
                    }
                };
                (
                    Aabb::new(center - e, center + e),
                    Sphere { center, radius },
                    cone,
                )
            }
            Light::Triangle {
                vertices,
                two_sided,
                ..
            } => {
                let aabb = Aabb::point(vertices[0]).grow(vertices[1]).grow(vertices[2]);
                let cone = match math::unit_f64(triangle_normal(&vertices)) {
                    Some(axis) if !two_sided => Cone {
                        axis,
                        theta_o: 0.0,
                        theta_e: FRAC_PI_2,
                    },
                    _ => Cone::SPHERE,
                };
                (aabb, triangle_sphere(&vertices), cone)
            }
        };
        LightBounds {
            aabb,
            sphere,
            cone,
            energy,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_sphere_holds_vertices() {
        let cases = [
            [Vec3::ZERO, Vec3::X, Vec3::Y],
            [Vec3::ZERO, Vec3::X * 10.0, Vec3::new(5.0, 0.1, 0.0)],
            [Vec3::ZERO, Vec3::X, Vec3::new(0.5, 0.8, 0.3)],
            [Vec3::ONE, Vec3::ONE, Vec3::ONE],
        ];
        for v in cases {
            let s = triangle_sphere(&v);
            for p in v {
                assert!(
                    (p - s.center).length() <= s.radius * (1.0 + 1e-6) + 1e-7,
                    "{v:?}: {s:?}"
                );
            }
            // Never larger than the centroid sphere.
            let g = (v[0] + v[1] + v[2]) / 3.0;
            let rg = v.iter().map(|p| (*p - g).length()).fold(0.0, f32::max);
            assert!(s.radius <= rg * 1.0001 + 1e-6, "{v:?}: {s:?} vs {rg}");
        }
    }

    #[test]
    fn validation_names_index_and_field() {
        let l = Light::Sphere {
            center: Vec3::ZERO,
            radius: -1.0,
            radiance: Rgb::grey(1.0),
        };
        let e = l.validate(7).unwrap_err();
        assert_eq!(
            e,
            BuildError::InvalidLight {
                index: 7,
                field: LightField::Radius,
                problem: Problem::NotPositive,
                value: -1.0
            }
        );
        let s = alloc::format!("{e}");
        assert!(s.contains("light 7") && s.contains("radius"), "{s}");
    }

    #[test]
    fn energies() {
        let p = Light::Point {
            position: Vec3::ZERO,
            intensity: Rgb::grey(2.0),
        };
        assert!((p.energy() - 8.0 * PI).abs() < 1e-4);
        // The luminance of a colour: Y(1, 2, 4) = 0.2126 + 1.4304 + 0.2888 = 1.9318.
        let c = Light::Point {
            position: Vec3::ZERO,
            intensity: Rgb::new(1.0, 2.0, 4.0),
        };
        assert!((c.energy() - 4.0 * PI * 1.9318).abs() < 1e-4);
        let bad = Light::Point {
            position: Vec3::ZERO,
            intensity: Rgb::new(1.0, -2.0, 1.0),
        };
        assert_eq!(
            bad.validate(3),
            Err(invalid(3, LightField::Intensity, Problem::Negative, -2.0))
        );
        let d = Light::Disk {
            center: Vec3::ZERO,
            normal: Vec3::Z,
            radius: 1.0,
            radiance: Rgb::grey(1.0),
            two_sided: true,
        };
        assert!((d.energy() - 2.0 * PI * PI).abs() < 1e-4);
        let t = Light::Triangle {
            vertices: [Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
            radiance: Rgb::grey(5.0),
            two_sided: false,
        };
        assert_eq!(t.energy(), 0.0);
        assert!(t.validate(0).is_ok());
    }
}
