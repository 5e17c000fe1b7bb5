//! The plain C structs and enums of the ABI, and their checked conversion into the core's
//! types (every error names the argument, the element index and the field).

use crate::error::{Error, Result};
use glam::Vec3;
use manylights::error::ShadingField;
use manylights::error::{LightField, Num, Problem};
use manylights::importance::Receiver;
use manylights::{
    BuildError, Light, LightPoint, Material, Rgb, SampledLight, ShadingError, ShadingPoint,
    TlImportance,
};

/// A 3-vector (positions, directions, normals).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_vec3 {
    /// x.
    pub x: f32,
    /// y.
    pub y: f32,
    /// z.
    pub z: f32,
}

impl From<ml_vec3> for Vec3 {
    #[inline]
    fn from(v: ml_vec3) -> Vec3 {
        Vec3::new(v.x, v.y, v.z)
    }
}

impl From<Vec3> for ml_vec3 {
    #[inline]
    fn from(v: Vec3) -> ml_vec3 {
        ml_vec3 {
            x: v.x,
            y: v.y,
            z: v.z,
        }
    }
}

/// A linear RGB triple (emission, albedo, radiance), per channel.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_rgb {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
}

impl From<ml_rgb> for Rgb {
    #[inline]
    fn from(c: ml_rgb) -> Rgb {
        Rgb::new(c.r, c.g, c.b)
    }
}

impl From<Rgb> for ml_rgb {
    #[inline]
    fn from(c: Rgb) -> ml_rgb {
        ml_rgb {
            r: c.r,
            g: c.g,
            b: c.b,
        }
    }
}

/// An estimate in linear RGB, summed in double precision.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_rgb64 {
    /// Red.
    pub r: f64,
    /// Green.
    pub g: f64,
    /// Blue.
    pub b: f64,
}

impl From<[f64; 3]> for ml_rgb64 {
    #[inline]
    fn from(c: [f64; 3]) -> ml_rgb64 {
        ml_rgb64 {
            r: c[0],
            g: c[1],
            b: c[2],
        }
    }
}

/// The kind of an `ml_light` (the value of its `kind` field). Units: positions in any length
/// unit m (the same as the scene's), intensity in W/sr, radiance in W/(m²·sr), irradiance in
/// W/m², each per channel of linear RGB; a light's energy (its flux, W, of the luminance:
/// what the tree's importance and `ml_tree_statistics.total_energy` add up) is given at each
/// kind and is at most `ML_MAX_LIGHT_ENERGY` (0 for distant lights). The environment is not a
/// light kind: it is given to the tree as an `ml_environment`.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ml_light_kind {
    /// Isotropic point light: `position`, `power` = intensity I (W/sr). Energy 4πI.
    Point = 0,
    /// Spot light: `position`, `direction` (axis, any non-zero length), `power` = intensity I
    /// on the axis (W/sr), `half_angle` θs in (0, π], `falloff_start` θf in [0, θs] (radians).
    /// Intensity towards angle θ from the axis: I for θ ≤ θf, 0 for θ ≥ θs, and between them
    /// I · smoothstep(cos θs, cos θf, cos θ) (t = (cos θ − cos θs)/(cos θf − cos θs), 3t² − 2t³;
    /// pbrt-v4's spot light). Energy 2π(1 − cos θs)·I (an upper bound of the flux with the
    /// falloff).
    Spot = 1,
    /// Sphere light: `position` = centre, `radius` > 0, `power` = radiance L (W/(m²·sr)),
    /// emitted outwards from every point. Energy L·π·4πr².
    Sphere = 2,
    /// Disk light: `position` = centre, `direction` = normal (the emitting side when
    /// one-sided), `radius` > 0, `power` = radiance L, `two_sided` 0 or 1. Energy L·π·πr² per
    /// emitting side.
    Disk = 3,
    /// Triangle light: vertices `position`, `direction`, `vertex2` (one-sided lights emit on
    /// the side of (v1 − v0) × (v2 − v0)), `power` = radiance L, `two_sided` 0 or 1. Energy
    /// L·π·area per emitting side.
    Triangle = 4,
    /// Virtual point light (Keller 1997): `position`, `direction` = normal, `power` =
    /// intensity I along the normal (a one-sided Lambertian point emitter, intensity
    /// `I · max(0, cos θ)`; what a diffuse point that received flux Φ with albedo ρ re-emits
    /// is I = ρΦ/π). Energy πI.
    Vpl = 5,
    /// Distant light (a sun): `direction` towards the light (any non-zero length),
    /// `half_angle` its angular radius γ in [0, π/2] radians (0: a delta direction), `power`
    /// its irradiance at normal incidence (W/m²); the radiance of its cone is
    /// `power / (π sin²γ)`.
    Distant = 6,
}

/// One light, as given to `ml_tree_build`. Which fields a kind reads is listed at each
/// `ml_light_kind`; the others are ignored (zero them). Coordinates finite with magnitude at
/// most `ML_MAX_COORDINATE`; every channel of `power` finite and ≥ 0 (black: accepted and
/// never sampled), the light's energy at most `ML_MAX_LIGHT_ENERGY` and all of them together
/// at most `ML_MAX_TOTAL_ENERGY`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_light {
    /// An `ml_light_kind`.
    pub kind: u32,
    /// Disk and triangle lights: 1 to emit on both sides, 0 for one side.
    pub two_sided: u32,
    /// Position (point, spot, VPL), centre (sphere, disk) or vertex 0 (triangle).
    pub position: ml_vec3,
    /// Axis (spot), normal (disk, VPL) or vertex 1 (triangle).
    pub direction: ml_vec3,
    /// Vertex 2 (triangle).
    pub vertex2: ml_vec3,
    /// Intensity in W/sr (point, spot, VPL) or radiance in W/(m²·sr) (sphere, disk,
    /// triangle), linear RGB; the tree ranks lights by its luminance.
    pub power: ml_rgb,
    /// Radius (sphere, disk).
    pub radius: f32,
    /// Spot half-angle θs in radians, in (0, π].
    pub half_angle: f32,
    /// Spot falloff start θf in radians, in [0, θs].
    pub falloff_start: f32,
}

/// The descriptor of a core light, field for field (what a Rust host that also calls the
/// ABI, such as a bench, passes to `ml_tree_build`).
impl From<&Light> for ml_light {
    fn from(l: &Light) -> ml_light {
        let mut d = ml_light::default();
        match *l {
            Light::Point {
                position,
                intensity,
            } => {
                d.kind = ml_light_kind::Point as u32;
                d.position = position.into();
                d.power = intensity.into();
            }
            Light::Spot {
                position,
                direction,
                intensity,
                half_angle,
                falloff_start,
            } => {
                d.kind = ml_light_kind::Spot as u32;
                d.position = position.into();
                d.direction = direction.into();
                d.power = intensity.into();
                d.half_angle = half_angle;
                d.falloff_start = falloff_start;
            }
            Light::Sphere {
                center,
                radius,
                radiance,
            } => {
                d.kind = ml_light_kind::Sphere as u32;
                d.position = center.into();
                d.radius = radius;
                d.power = radiance.into();
            }
            Light::Disk {
                center,
                normal,
                radius,
                radiance,
                two_sided,
            } => {
                d.kind = ml_light_kind::Disk as u32;
                d.position = center.into();
                d.direction = normal.into();
                d.radius = radius;
                d.power = radiance.into();
                d.two_sided = u32::from(two_sided);
            }
            Light::Triangle {
                vertices,
                radiance,
                two_sided,
            } => {
                d.kind = ml_light_kind::Triangle as u32;
                d.position = vertices[0].into();
                d.direction = vertices[1].into();
                d.vertex2 = vertices[2].into();
                d.power = radiance.into();
                d.two_sided = u32::from(two_sided);
            }
            Light::Vpl {
                position,
                normal,
                intensity,
            } => {
                d.kind = ml_light_kind::Vpl as u32;
                d.position = position.into();
                d.direction = normal.into();
                d.power = intensity.into();
            }
            Light::Distant {
                direction,
                angular_radius,
                irradiance,
            } => {
                d.kind = ml_light_kind::Distant as u32;
                d.direction = direction.into();
                d.half_angle = angular_radius;
                d.power = irradiance.into();
            }
            // A kind the C ABI has no descriptor for: a kind value `ml_tree_build` rejects
            // (ML_ERR_INVALID_ARGUMENT), never a different light.
            _ => d.kind = u32::MAX,
        }
        d
    }
}

/// The kind of an `ml_material` (the value of its `kind` field).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ml_material_kind {
    /// Diffuse: f = albedo/π (reads `albedo`).
    Lambert = 0,
    /// Glossy: f = specular · GGX(α) (reads `specular`, `alpha`).
    Ggx = 1,
    /// Plastic: f = albedo/π + specular · GGX(α) (reads all three).
    Plastic = 2,
}

/// A surface's reflectance: albedo (every channel) and specular weight in [0, 1], GGX roughness
/// α in (0, 1].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_material {
    /// An `ml_material_kind`.
    pub kind: u32,
    /// Diffuse albedo, linear RGB, every channel in [0, 1] (Lambert, plastic).
    pub albedo: ml_rgb,
    /// Weight of the GGX lobe in [0, 1] (GGX, plastic).
    pub specular: f32,
    /// GGX roughness α in (0, 1] (GGX, plastic).
    pub alpha: f32,
}

/// A point being shaded for BRDF-aware techniques (BL sampling, cuts, estimators, BRDF
/// sampling): position, normal and direction towards the viewer (finite, non-zero; any
/// length), and the material.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_shading_point {
    /// Position.
    pub position: ml_vec3,
    /// Surface normal (any finite, non-zero length).
    pub normal: ml_vec3,
    /// Direction towards the viewer, ωo (any finite, non-zero length).
    pub wo: ml_vec3,
    /// The material.
    pub material: ml_material,
}

/// How a TL point receives light (the value of `ml_tl_point.receiver`): which side of its
/// normal a light must be on to count, and how its angle weighs it.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ml_receiver {
    /// A reflecting surface: lights on the normal's side only, weighed by max(cos θi, 0).
    Reflective = 0,
    /// A two-sided surface (thin translucent surfaces: leaves, paper, curtains): lights on
    /// both sides, weighed by |cos θi| (pbrt-v4's rule for transmissive BSDFs).
    Transmissive = 1,
    /// A point with no surface (a medium): lights in every direction, the normal ignored.
    Omnidirectional = 2,
}

/// A point for TL (Conty–Kulla) importance: position, normal (finite) and the kind of receiver.
/// A zero normal makes the point omnidirectional whatever `receiver` says. Zero-initialised,
/// it is a reflective point.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_tl_point {
    /// Position.
    pub position: ml_vec3,
    /// Surface normal (any finite length; zero: omnidirectional).
    pub normal: ml_vec3,
    /// An `ml_receiver` (0: `ML_RECEIVER_REFLECTIVE`).
    pub receiver: u32,
}

/// `light` of an `ml_sampled_light` when no light was sampled (no light can contribute).
pub const ML_NO_LIGHT: u32 = u32::MAX;

/// A sampled light: its index in the array the tree was built from and the probability of
/// the choice (finite, in [`ML_MIN_PMF`, 1]); `light = ML_NO_LIGHT` and `pmf = 0`
/// (`ML_SAMPLED_LIGHT_NONE`) when no light can contribute.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_sampled_light {
    /// The light's index, or `ML_NO_LIGHT`.
    pub light: u32,
    /// Its probability (0 with `ML_NO_LIGHT`).
    pub pmf: f32,
}

impl ml_sampled_light {
    /// No light (`ML_SAMPLED_LIGHT_NONE` in the header, an initializer written in
    /// `cbindgen.toml`: a struct constant would be a C99 compound literal, not C++).
    pub(crate) const NONE: ml_sampled_light = ml_sampled_light {
        light: ML_NO_LIGHT,
        pmf: 0.0,
    };
}

impl From<Option<SampledLight>> for ml_sampled_light {
    #[inline]
    fn from(s: Option<SampledLight>) -> ml_sampled_light {
        match s {
            Some(s) => ml_sampled_light {
                light: s.light,
                pmf: s.pmf,
            },
            None => ml_sampled_light::NONE,
        }
    }
}

/// A point on a light seen from a shading point x (sampled, or reached by a ray).
/// `pdf = 0` (and every other field 0) when there is none.
///
/// A distant light or the environment gives a point at infinity: `position` = `direction`
/// (the unit direction towards it), `normal` zero, `distance` = +infinity (a shadow ray tests
/// the whole ray). A distant light of angular radius 0 is a delta direction: `pdf` 1, `delta`
/// 1 and `radiance` its irradiance at normal incidence; a wider one has the uniform radiance of
/// its cone and the cone's pdf.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_light_point {
    /// The point on the light (point, spot and VPL: their position; distant lights and the
    /// environment: the unit direction towards them).
    pub position: ml_vec3,
    /// Unit surface normal there (zero for point, spot and VPL lights, distant lights and the
    /// environment).
    pub normal: ml_vec3,
    /// Unit direction from x to `position`.
    pub direction: ml_vec3,
    /// Distance from x to `position` (> 0; +infinity for distant lights and the environment).
    pub distance: f32,
    /// Solid-angle pdf of `direction` at x (> 0, finite); 1 for delta lights (as
    /// `ml_light_pdf_point` reports it at their position or direction); 0: no point.
    pub pdf: f32,
    /// What the estimate multiplies by (every channel ≥ 0), linear RGB: the radiance arriving
    /// at x for area lights, wide distant lights and the environment (W/(m²·sr)); for point,
    /// spot and VPL lights `I · falloff / d²` (W/m²), already divided by the squared distance:
    /// do not divide again (the contribution is `f · radiance · cos θi / pdf`, `pdf` = 1); for
    /// a distant light of angular radius 0 its irradiance (W/m², `pdf` = 1).
    pub radiance: ml_rgb,
    /// 1 for point, spot and VPL lights, and for a distant light of angular radius 0 or of a
    /// cone too narrow for f32 (`pdf` is a Dirac delta reported as 1; no BSDF ray reaches
    /// them), else 0.
    pub delta: u32,
}

impl From<Option<LightPoint>> for ml_light_point {
    #[inline]
    fn from(p: Option<LightPoint>) -> ml_light_point {
        match p {
            Some(p) => ml_light_point {
                position: p.position.into(),
                normal: p.normal.into(),
                direction: p.direction.into(),
                distance: p.distance,
                pdf: p.pdf,
                radiance: p.radiance.into(),
                delta: u32::from(p.delta),
            },
            None => ml_light_point::default(),
        }
    }
}

/// What is wrong with a value, in words.
pub(crate) fn describe(p: Problem) -> &'static str {
    match p {
        Problem::NotFinite => "is NaN or infinite",
        Problem::Negative => "is negative",
        Problem::NotPositive => "must be positive",
        Problem::ZeroLength => "has zero length",
        Problem::OutOfRange => "is out of range",
        Problem::EnergyTooLarge => "gives an energy above ML_MAX_LIGHT_ENERGY (1e24)",
        _ => "is invalid",
    }
}

fn kind_name(kind: u32) -> &'static str {
    match kind {
        0 => "point",
        1 => "spot",
        2 => "sphere",
        3 => "disk",
        4 => "triangle",
        6 => "distant",
        _ => "VPL",
    }
}

/// The C field of a light's core field, with the core's name where they differ.
fn light_field(kind: u32, f: LightField) -> String {
    let (c, core) = match f {
        LightField::Position => ("position", None),
        LightField::Center => ("position", Some("centre")),
        LightField::Direction => ("direction", Some("axis")),
        LightField::Normal => ("direction", Some("normal")),
        LightField::Radius => ("radius", None),
        LightField::Vertex(0) => ("position", Some("vertex 0")),
        LightField::Vertex(1) => ("direction", Some("vertex 1")),
        LightField::Vertex(_) => ("vertex2", None),
        LightField::Intensity => ("power", Some("intensity")),
        LightField::Radiance => ("power", Some("radiance")),
        LightField::HalfAngle => ("half_angle", None),
        LightField::FalloffStart => ("falloff_start", None),
        LightField::AngularRadius => ("half_angle", Some("angular radius")),
        LightField::Irradiance => ("power", Some("irradiance")),
        _ => ("a field", Some(f.name())),
    };
    match core {
        Some(core) => format!("{c} (the {} light's {core})", kind_name(kind)),
        None => c.to_string(),
    }
}

/// The core light of an `ml_light` (the kind and `two_sided` checked; the rest is checked by
/// the build, [`build_error`] words its errors).
pub(crate) fn light(l: &ml_light, index: usize, name: &str) -> Result<Light> {
    let two_sided = match l.two_sided {
        0 => false,
        1 => true,
        v => {
            return Err(Error::invalid(format_args!(
                "{name}[{index}].two_sided must be 0 or 1 (got {v})"
            )))
        }
    };
    let (p, d, v2) = (l.position.into(), l.direction.into(), l.vertex2.into());
    Ok(match l.kind {
        0 => Light::Point {
            position: p,
            intensity: l.power.into(),
        },
        1 => Light::Spot {
            position: p,
            direction: d,
            intensity: l.power.into(),
            half_angle: l.half_angle,
            falloff_start: l.falloff_start,
        },
        2 => Light::Sphere {
            center: p,
            radius: l.radius,
            radiance: l.power.into(),
        },
        3 => Light::Disk {
            center: p,
            normal: d,
            radius: l.radius,
            radiance: l.power.into(),
            two_sided,
        },
        4 => Light::Triangle {
            vertices: [p, d, v2],
            radiance: l.power.into(),
            two_sided,
        },
        5 => Light::Vpl {
            position: p,
            normal: d,
            intensity: l.power.into(),
        },
        6 => Light::Distant {
            direction: d,
            angular_radius: l.half_angle,
            irradiance: l.power.into(),
        },
        7 => {
            return Err(Error::invalid(format_args!(
                "{name}[{index}].kind: 7 is not an ml_light_kind (0 to 6): the environment is \
                 given to the tree as an ml_environment (ml_tree_build's `environment`)"
            )))
        }
        k => {
            return Err(Error::invalid(format_args!(
                "{name}[{index}].kind: {k} is not an ml_light_kind (0 to 6)"
            )))
        }
    })
}

/// A build error in the C struct's terms.
pub(crate) fn build_error(e: BuildError, lights: &[ml_light], name: &str) -> Error {
    match e {
        BuildError::InvalidLight {
            index,
            field: _,
            problem,
            value,
        } if index >= lights.len() => {
            // The light after the descriptors: the environment's, of its bounds.
            let what = match problem {
                Problem::EnergyTooLarge => "exceeds ML_MAX_LIGHT_ENERGY (1e24)",
                p => describe(p),
            };
            Error::invalid(format_args!(
                "environment->irradiance_bounds: a bound {what} (got {})",
                Num(value)
            ))
        }
        BuildError::InvalidLight {
            index,
            field,
            problem,
            value,
        } => {
            let desc = lights.get(index);
            let kind = desc.map_or(0, |l| l.kind);
            let what = match (field, problem) {
                (_, Problem::EnergyTooLarge) => {
                    // The energy the field's value gives, with the macro it exceeds.
                    let energy = desc
                        .and_then(|d| light(d, index, name).ok())
                        .map_or(f32::INFINITY, |l| l.energy());
                    format!(
                        "gives an energy of {} W, above ML_MAX_LIGHT_ENERGY (1e24)",
                        Num(energy)
                    )
                }
                (
                    LightField::Position
                    | LightField::Center
                    | LightField::Vertex(_)
                    | LightField::Radius,
                    Problem::OutOfRange,
                ) => "exceeds ML_MAX_COORDINATE (1e15) in magnitude".to_string(),
                (LightField::HalfAngle, Problem::OutOfRange) => "must be in (0, pi]".to_string(),
                (LightField::FalloffStart, Problem::OutOfRange) => {
                    "must be in [0, half_angle]".to_string()
                }
                _ => describe(problem).to_string(),
            };
            Error::invalid(format_args!(
                "{name}[{index}].{} {what} (got {})",
                light_field(kind, field),
                Num(value)
            ))
        }
        BuildError::TooManyLights { count } => Error::invalid(format_args!(
            "count: {count} lights, at most ML_MAX_LIGHTS (2147483646) are supported"
        )),
        BuildError::TotalEnergyTooLarge => Error::invalid(format_args!(
            "{name}: the lights' total energy exceeds ML_MAX_TOTAL_ENERGY (1e26)"
        )),
        BuildError::TooDeep { depth } => Error::invalid(format_args!(
            "{name}: the tree would be {depth} levels deep, above ML_MAX_DEPTH (31)"
        )),
        BuildError::SecondEnvironment { index } => Error::invalid(format_args!(
            "{name}[{index}]: a second environment light (at most one per tree)"
        )),
        BuildError::TooManyInfiniteLights { count } => Error::invalid(format_args!(
            "{name}: {count} distant and environment lights (at most {})",
            manylights::light::MAX_INFINITE_LIGHTS
        )),
        _ => Error::invalid(format_args!("{name}: {e}")),
    }
}

/// The core material (kind checked; values are checked with the shading point).
pub(crate) fn material(m: &ml_material, path: &dyn Fn() -> String) -> Result<Material> {
    Ok(match m.kind {
        0 => Material::Lambert {
            albedo: m.albedo.into(),
        },
        1 => Material::Ggx {
            alpha: m.alpha,
            specular: m.specular,
        },
        2 => Material::Plastic {
            albedo: m.albedo.into(),
            specular: m.specular,
            alpha: m.alpha,
        },
        k => {
            return Err(Error::invalid(format_args!(
                "{}.kind: {k} is not an ml_material_kind (0 to 2)",
                path()
            )))
        }
    })
}

/// A shading point error in the C struct's terms.
pub(crate) fn shading_error(e: ShadingError, path: &dyn Fn() -> String) -> Error {
    let field = match e.field {
        ShadingField::Position => "position",
        ShadingField::Normal => "normal",
        ShadingField::Wo => "wo",
        ShadingField::Albedo => "material.albedo",
        ShadingField::Specular => "material.specular",
        ShadingField::Alpha => "material.alpha",
        _ => e.field.name(),
    };
    let what = match (e.field, e.problem) {
        (_, Problem::NotFinite) => "is NaN or infinite",
        (_, Problem::ZeroLength) => "has zero length",
        (ShadingField::Alpha, _) => "must be in (0, 1]",
        (ShadingField::Albedo | ShadingField::Specular, _) => "must be in [0, 1]",
        _ => describe(e.problem),
    };
    Error::invalid(format_args!("{}.{field} {what} (got {})", path(), e.value))
}

/// The checked core shading point of an `ml_shading_point`; `path` names it in errors
/// (`sp`, `points[12]`).
pub(crate) fn shading_point(
    sp: &ml_shading_point,
    path: &dyn Fn() -> String,
) -> Result<ShadingPoint> {
    let s = ShadingPoint {
        position: sp.position.into(),
        normal: sp.normal.into(),
        wo: sp.wo.into(),
        material: material(&sp.material, &|| format!("{}.material", path()))?,
    };
    s.validate().map_err(|e| shading_error(e, path))?;
    Ok(s)
}

/// Checks a vector is finite.
#[inline]
pub(crate) fn finite3(v: ml_vec3, path: &dyn Fn() -> String) -> Result<Vec3> {
    for c in [v.x, v.y, v.z] {
        if !c.is_finite() {
            return Err(Error::invalid(format_args!(
                "{} is NaN or infinite (got {c})",
                path()
            )));
        }
    }
    Ok(v.into())
}

/// Checks a finite, non-zero direction.
pub(crate) fn direction3(v: ml_vec3, path: &dyn Fn() -> String) -> Result<Vec3> {
    let d = finite3(v, path)?;
    if d == Vec3::ZERO {
        return Err(Error::invalid(format_args!("{} has zero length", path())));
    }
    Ok(d)
}

/// The core's receiver of an `ml_receiver` value (`None`: not one).
#[inline(always)]
pub(crate) fn receiver(r: u32) -> Option<Receiver> {
    match r {
        0 => Some(Receiver::Reflective),
        1 => Some(Receiver::Transmissive),
        2 => Some(Receiver::Omnidirectional),
        _ => None,
    }
}

/// The TL importance of a point, its position and normal checked finite and its receiver
/// checked.
#[inline]
pub(crate) fn tl_point(p: &ml_tl_point, path: &dyn Fn() -> String) -> Result<TlImportance> {
    let x = finite3(p.position, &|| format!("{}.position", path()))?;
    let n = finite3(p.normal, &|| format!("{}.normal", path()))?;
    let r = receiver(p.receiver).ok_or_else(|| {
        Error::invalid(format_args!(
            "{}.receiver: {} is not an ml_receiver (0 to 2)",
            path(),
            p.receiver
        ))
    })?;
    Ok(TlImportance::with_receiver(x, n, r))
}

/// A uniform number, checked in [0, 1).
#[inline]
pub(crate) fn unit(u: f32, path: &dyn Fn() -> String) -> Result<f32> {
    if (0.0..1.0).contains(&u) {
        Ok(u)
    } else {
        Err(Error::invalid(format_args!(
            "{} must be in [0, 1) (got {u})",
            path()
        )))
    }
}
