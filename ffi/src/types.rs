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

/// The kind of an `ml_light` (the value of its `kind` field, which names the union's member
/// that holds the light). Units: positions in any length unit m (the same as the scene's),
/// intensity in W/sr, radiance in W/(m²·sr), irradiance in W/m², each per channel of linear
/// RGB; a light's energy (its flux, W, of the luminance: what the tree's importance and
/// `ml_tree_statistics.total_energy` add up) is given at each kind's struct and is at most
/// `ML_MAX_LIGHT_ENERGY` (0 for distant lights). The environment is not a light kind: it is
/// given to the tree as an `ml_environment`.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ml_light_kind {
    /// Isotropic point light: the member `point` (`ml_point_light`).
    Point = 0,
    /// Spot light: the member `spot` (`ml_spot_light`).
    Spot = 1,
    /// Sphere light: the member `sphere` (`ml_sphere_light`).
    Sphere = 2,
    /// Disk light: the member `disk` (`ml_disk_light`).
    Disk = 3,
    /// Triangle light: the member `triangle` (`ml_triangle_light`).
    Triangle = 4,
    /// Virtual point light: the member `vpl` (`ml_vpl_light`).
    Vpl = 5,
    /// Distant light (a sun): the member `distant` (`ml_distant_light`).
    Distant = 6,
}

/// An isotropic point light (`ML_LIGHT_KIND_POINT`). Energy 4πI.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_point_light {
    /// `ML_LIGHT_KIND_POINT`.
    pub kind: u32,
    /// Position.
    pub position: ml_vec3,
    /// Intensity I (W/sr), linear RGB.
    pub intensity: ml_rgb,
}

/// A spot light (`ML_LIGHT_KIND_SPOT`). Intensity towards angle θ from the axis: I for θ ≤ θf,
/// 0 for θ ≥ θs, and between them I · smoothstep(cos θs, cos θf, cos θ)
/// (t = (cos θ − cos θs)/(cos θf − cos θs), 3t² − 2t³; pbrt-v4's spot light). Energy
/// 2π(1 − cos θs)·I (an upper bound of the flux with the falloff).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_spot_light {
    /// `ML_LIGHT_KIND_SPOT`.
    pub kind: u32,
    /// Position.
    pub position: ml_vec3,
    /// Axis (any non-zero length).
    pub axis: ml_vec3,
    /// Intensity I on the axis (W/sr), linear RGB.
    pub intensity: ml_rgb,
    /// Half-angle θs in radians, in (0, π].
    pub half_angle: f32,
    /// Falloff start θf in radians, in [0, θs].
    pub falloff_start: f32,
}

/// A sphere light (`ML_LIGHT_KIND_SPHERE`), emitting outwards from every point. Energy
/// L·π·4πr².
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_sphere_light {
    /// `ML_LIGHT_KIND_SPHERE`.
    pub kind: u32,
    /// Centre.
    pub center: ml_vec3,
    /// Radius, > 0.
    pub radius: f32,
    /// Radiance L (W/(m²·sr)), linear RGB.
    pub radiance: ml_rgb,
}

/// A disk light (`ML_LIGHT_KIND_DISK`). Energy L·π·πr² per emitting side.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_disk_light {
    /// `ML_LIGHT_KIND_DISK`.
    pub kind: u32,
    /// Centre.
    pub center: ml_vec3,
    /// Normal (the emitting side when one-sided; any non-zero length).
    pub normal: ml_vec3,
    /// Radius, > 0.
    pub radius: f32,
    /// Radiance L (W/(m²·sr)), linear RGB.
    pub radiance: ml_rgb,
    /// 1 to emit on both sides, 0 for the normal's side only.
    pub two_sided: u32,
}

/// A triangle light (`ML_LIGHT_KIND_TRIANGLE`); one-sided lights emit on the side of
/// (v1 − v0) × (v2 − v0). Energy L·π·area per emitting side.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_triangle_light {
    /// `ML_LIGHT_KIND_TRIANGLE`.
    pub kind: u32,
    /// Vertex 0.
    pub v0: ml_vec3,
    /// Vertex 1.
    pub v1: ml_vec3,
    /// Vertex 2.
    pub v2: ml_vec3,
    /// Radiance L (W/(m²·sr)), linear RGB.
    pub radiance: ml_rgb,
    /// 1 to emit on both sides, 0 for one side.
    pub two_sided: u32,
}

/// A virtual point light (`ML_LIGHT_KIND_VPL`, Keller 1997): a one-sided Lambertian point
/// emitter of intensity `I · max(0, cos θ)` from the normal; what a diffuse point that
/// received flux Φ with albedo ρ re-emits is I = ρΦ/π. Energy πI.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_vpl_light {
    /// `ML_LIGHT_KIND_VPL`.
    pub kind: u32,
    /// Position.
    pub position: ml_vec3,
    /// Normal (any non-zero length).
    pub normal: ml_vec3,
    /// Intensity I along the normal (W/sr), linear RGB.
    pub intensity: ml_rgb,
}

/// A distant light, a sun (`ML_LIGHT_KIND_DISTANT`); the radiance of its cone is
/// `irradiance / (π sin²γ)`. Energy 0 (it is at infinity).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_distant_light {
    /// `ML_LIGHT_KIND_DISTANT`.
    pub kind: u32,
    /// Direction towards the light (any non-zero length).
    pub direction: ml_vec3,
    /// Angular radius γ in radians, in [0, π/2] (0: a delta direction).
    pub angular_radius: f32,
    /// Irradiance at normal incidence (W/m²), linear RGB.
    pub irradiance: ml_rgb,
}

/// One light, as given to `ml_tree_build`: a union of one struct per kind, each starting with
/// the `kind` (`l.kind` reads it whichever member was written). Zero it, then fill the
/// member of its kind: `ml_light l = {0}; l.sphere.kind = ML_LIGHT_KIND_SPHERE;
/// l.sphere.center = ...`. Coordinates finite with magnitude at most `ML_MAX_COORDINATE`;
/// every channel of the intensity, radiance or irradiance finite and ≥ 0 (black: accepted and
/// never sampled), the light's energy at most `ML_MAX_LIGHT_ENERGY` and all of them together
/// at most `ML_MAX_TOTAL_ENERGY`.
#[repr(C)]
#[derive(Clone, Copy)]
pub union ml_light {
    /// An `ml_light_kind`: which member holds the light.
    pub kind: u32,
    /// `ML_LIGHT_KIND_POINT`.
    pub point: ml_point_light,
    /// `ML_LIGHT_KIND_SPOT`.
    pub spot: ml_spot_light,
    /// `ML_LIGHT_KIND_SPHERE`.
    pub sphere: ml_sphere_light,
    /// `ML_LIGHT_KIND_DISK`.
    pub disk: ml_disk_light,
    /// `ML_LIGHT_KIND_TRIANGLE`.
    pub triangle: ml_triangle_light,
    /// `ML_LIGHT_KIND_VPL`.
    pub vpl: ml_vpl_light,
    /// `ML_LIGHT_KIND_DISTANT`.
    pub distant: ml_distant_light,
}

/// The member of an `ml_light` its kind names (the Rust view of the union).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightDesc {
    /// `point`.
    Point(ml_point_light),
    /// `spot`.
    Spot(ml_spot_light),
    /// `sphere`.
    Sphere(ml_sphere_light),
    /// `disk`.
    Disk(ml_disk_light),
    /// `triangle`.
    Triangle(ml_triangle_light),
    /// `vpl`.
    Vpl(ml_vpl_light),
    /// `distant`.
    Distant(ml_distant_light),
    /// A kind that is not an `ml_light_kind`.
    Unknown(u32),
}

impl ml_light {
    /// The kind (whichever member was written: every member starts with it).
    #[inline]
    pub fn kind(&self) -> u32 {
        // SAFETY: every member is plain old data starting with the `u32` kind, and every bit
        // pattern is a valid `u32`.
        unsafe { self.kind }
    }

    /// The member the kind names, copied out.
    #[inline]
    pub fn desc(&self) -> LightDesc {
        // SAFETY: every member is `repr(C)` plain old data of `u32` and `f32` fields (any bit
        // pattern valid) starting with the kind; the member read is the one the kind names,
        // and a union is at least as large as its largest member, so the read stays inside.
        unsafe {
            match self.kind {
                0 => LightDesc::Point(self.point),
                1 => LightDesc::Spot(self.spot),
                2 => LightDesc::Sphere(self.sphere),
                3 => LightDesc::Disk(self.disk),
                4 => LightDesc::Triangle(self.triangle),
                5 => LightDesc::Vpl(self.vpl),
                6 => LightDesc::Distant(self.distant),
                k => LightDesc::Unknown(k),
            }
        }
    }
}

impl Default for ml_light {
    /// All zero (a point light at the origin of zero intensity).
    #[inline]
    fn default() -> ml_light {
        // The largest member, zeroed: every byte of the union is zero.
        ml_light {
            triangle: ml_triangle_light::default(),
        }
    }
}

impl core::fmt::Debug for ml_light {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self.desc() {
            LightDesc::Point(l) => l.fmt(f),
            LightDesc::Spot(l) => l.fmt(f),
            LightDesc::Sphere(l) => l.fmt(f),
            LightDesc::Disk(l) => l.fmt(f),
            LightDesc::Triangle(l) => l.fmt(f),
            LightDesc::Vpl(l) => l.fmt(f),
            LightDesc::Distant(l) => l.fmt(f),
            LightDesc::Unknown(k) => f.debug_struct("ml_light").field("kind", &k).finish(),
        }
    }
}

impl PartialEq for ml_light {
    /// Equal kinds and equal members of that kind (unknown kinds: the kind alone).
    fn eq(&self, other: &ml_light) -> bool {
        self.desc() == other.desc()
    }
}

macro_rules! light_member {
    ($($ty:ident => $member:ident),* $(,)?) => {$(
        impl From<$ty> for ml_light {
            /// The light of that member, the rest of the union zeroed.
            #[inline]
            fn from(m: $ty) -> ml_light {
                let mut d = ml_light::default();
                d.$member = m;
                d
            }
        }
    )*};
}

light_member!(
    ml_point_light => point,
    ml_spot_light => spot,
    ml_sphere_light => sphere,
    ml_disk_light => disk,
    ml_triangle_light => triangle,
    ml_vpl_light => vpl,
    ml_distant_light => distant,
);

/// The descriptor of a core light, field for field (what a Rust host that also calls the
/// ABI, such as a bench, passes to `ml_tree_build`).
impl From<&Light> for ml_light {
    fn from(l: &Light) -> ml_light {
        match *l {
            Light::Point {
                position,
                intensity,
            } => ml_point_light {
                kind: ml_light_kind::Point as u32,
                position: position.into(),
                intensity: intensity.into(),
            }
            .into(),
            Light::Spot {
                position,
                direction,
                intensity,
                half_angle,
                falloff_start,
            } => ml_spot_light {
                kind: ml_light_kind::Spot as u32,
                position: position.into(),
                axis: direction.into(),
                intensity: intensity.into(),
                half_angle,
                falloff_start,
            }
            .into(),
            Light::Sphere {
                center,
                radius,
                radiance,
            } => ml_sphere_light {
                kind: ml_light_kind::Sphere as u32,
                center: center.into(),
                radius,
                radiance: radiance.into(),
            }
            .into(),
            Light::Disk {
                center,
                normal,
                radius,
                radiance,
                two_sided,
            } => ml_disk_light {
                kind: ml_light_kind::Disk as u32,
                center: center.into(),
                normal: normal.into(),
                radius,
                radiance: radiance.into(),
                two_sided: u32::from(two_sided),
            }
            .into(),
            Light::Triangle {
                vertices,
                radiance,
                two_sided,
            } => ml_triangle_light {
                kind: ml_light_kind::Triangle as u32,
                v0: vertices[0].into(),
                v1: vertices[1].into(),
                v2: vertices[2].into(),
                radiance: radiance.into(),
                two_sided: u32::from(two_sided),
            }
            .into(),
            Light::Vpl {
                position,
                normal,
                intensity,
            } => ml_vpl_light {
                kind: ml_light_kind::Vpl as u32,
                position: position.into(),
                normal: normal.into(),
                intensity: intensity.into(),
            }
            .into(),
            Light::Distant {
                direction,
                angular_radius,
                irradiance,
            } => ml_distant_light {
                kind: ml_light_kind::Distant as u32,
                direction: direction.into(),
                angular_radius,
                irradiance: irradiance.into(),
            }
            .into(),
            // A kind the C ABI has no descriptor for: a kind value `ml_tree_build` rejects
            // (ML_ERR_INVALID_ARGUMENT), never a different light.
            _ => {
                let mut d = ml_light::default();
                d.kind = u32::MAX;
                d
            }
        }
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

/// The `ml_light` member of a kind.
fn member(kind: u32) -> &'static str {
    match kind {
        0 => "point",
        1 => "spot",
        2 => "sphere",
        3 => "disk",
        4 => "triangle",
        5 => "vpl",
        6 => "distant",
        _ => "kind",
    }
}

/// The C field of a light's core field: the kind's member and its field
/// (`sphere.radius`, `spot.axis`, `triangle.v2`).
fn light_field(kind: u32, f: LightField) -> String {
    let c = match f {
        LightField::Position => "position",
        LightField::Center => "center",
        LightField::Direction if kind == ml_light_kind::Spot as u32 => "axis",
        LightField::Direction => "direction",
        LightField::Normal => "normal",
        LightField::Radius => "radius",
        LightField::Vertex(0) => "v0",
        LightField::Vertex(1) => "v1",
        LightField::Vertex(_) => "v2",
        LightField::Intensity => "intensity",
        LightField::Radiance => "radiance",
        LightField::HalfAngle => "half_angle",
        LightField::FalloffStart => "falloff_start",
        LightField::AngularRadius => "angular_radius",
        LightField::Irradiance => "irradiance",
        _ => f.name(),
    };
    format!("{}.{c}", member(kind))
}

/// The core light of an `ml_light` (the kind and `two_sided` checked; the rest is checked by
/// the build, [`build_error`] words its errors).
pub(crate) fn light(l: &ml_light, index: usize, name: &str) -> Result<Light> {
    let two_sided = |v: u32, m: &str| match v {
        0 => Ok(false),
        1 => Ok(true),
        v => Err(Error::invalid(format_args!(
            "{name}[{index}].{m}.two_sided must be 0 or 1 (got {v})"
        ))),
    };
    Ok(match l.desc() {
        LightDesc::Point(l) => Light::Point {
            position: l.position.into(),
            intensity: l.intensity.into(),
        },
        LightDesc::Spot(l) => Light::Spot {
            position: l.position.into(),
            direction: l.axis.into(),
            intensity: l.intensity.into(),
            half_angle: l.half_angle,
            falloff_start: l.falloff_start,
        },
        LightDesc::Sphere(l) => Light::Sphere {
            center: l.center.into(),
            radius: l.radius,
            radiance: l.radiance.into(),
        },
        LightDesc::Disk(l) => Light::Disk {
            center: l.center.into(),
            normal: l.normal.into(),
            radius: l.radius,
            radiance: l.radiance.into(),
            two_sided: two_sided(l.two_sided, "disk")?,
        },
        LightDesc::Triangle(l) => Light::Triangle {
            vertices: [l.v0.into(), l.v1.into(), l.v2.into()],
            radiance: l.radiance.into(),
            two_sided: two_sided(l.two_sided, "triangle")?,
        },
        LightDesc::Vpl(l) => Light::Vpl {
            position: l.position.into(),
            normal: l.normal.into(),
            intensity: l.intensity.into(),
        },
        LightDesc::Distant(l) => Light::Distant {
            direction: l.direction.into(),
            angular_radius: l.angular_radius,
            irradiance: l.irradiance.into(),
        },
        LightDesc::Unknown(7) => {
            return Err(Error::invalid(format_args!(
                "{name}[{index}].kind: 7 is not an ml_light_kind (0 to 6): the environment is \
                 given to the tree as an ml_environment (ml_tree_build's `environment`)"
            )))
        }
        LightDesc::Unknown(k) => {
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
            let kind = desc.map_or(0, ml_light::kind);
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
                    "must be in [0, spot.half_angle]".to_string()
                }
                (LightField::AngularRadius, Problem::OutOfRange) => {
                    "must be in [0, pi/2]".to_string()
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
