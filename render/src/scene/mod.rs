//! The renderer's scenes: triangle meshes with a material per triangle, a light set (lights
//! are not part of the meshes and do not block light) with its light tree, and a pinhole
//! camera. The built-in ones are made in code (no downloads); any OBJ + MTL file can be
//! loaded too.
//!
//! - `cornell` ([`cornell()`]): a Cornell box with a diffuse tall box, a glossy plastic short
//!   box and a glossy plastic floor, lit by many tiny sphere lights on the left and right walls
//!   (default [`CORNELL_DEFAULT_LIGHTS`]; any count places them at random on the same walls,
//!   smaller above the default count: [`cornell_light_radius`]).
//! - `exhibition` ([`exhibition()`]): a glossy car-like body (GGX) on a turntable in a
//!   showroom with a glossy plastic floor, lit by [`EXHIBITION_DISKS`] small one-sided disks
//!   in rings under the ceiling and rows along the walls, all facing the car, and one large
//!   rectangular ceiling light ([`EXHIBITION_PANEL_TRIANGLES`] triangle lights): most of what
//!   is seen is glossy and each highlight comes from a few of many lights.
//! - `city` ([`city()`]): a night city block grid, buildings of varying heights (Lambert or
//!   glossy glass façades) along wet glossy streets with cars, lit by [`CITY_LIGHTS`] small
//!   lights: street lamps (spheres), car lights and lit windows (one-sided disks facing away
//!   from the car or façade they sit on).
//! - `city-sun` ([`city_sun()`]): the same city at dusk — a low sun of 0.27° angular radius
//!   ([`manylights::Light::Distant`]), a sky ([`GradientSky`], an environment light) and the
//!   8,000 lamps: light at infinity in the same scene as thousands of local lights.
//! - `stairs` ([`stairs()`]): a staircase between two walls with 18 small sphere lights along
//!   the walls and two large disk lights under the ceiling (20 lights).
//! - `office` ([`office()`]): an office floor, twelve rooms off a corridor, each lit by a grid
//!   of small ceiling disks ([`OFFICE_LIGHTS`] lights in all); walls and doors block the
//!   shadow rays, so from any shading point most lights are behind a wall.
//! - `market` ([`market()`]): a covered night market, lights of very different power side by
//!   side: strings of tiny bulbs and bare stall lamps beside large dim ceiling panels, dim
//!   signs and a large window ([`MARKET_LIGHTS`] lights, powers over three decades), over a
//!   glossy floor.
//! - `billboard` ([`billboard()`]): a video wall showing a picture, a large emissive mesh of
//!   [`BILLBOARD_SCREEN_TRIANGLES`] triangle lights of varying colour, over a glossy GGX plaza
//!   with two glossy cars, street lamps and headlights ([`BILLBOARD_LIGHTS`] lights).
//! - a path ending in `.obj` ([`obj::load`]): the meshes of the file, with Lambert, plastic or
//!   GGX materials from its MTL and a triangle light per emissive triangle; automatic camera.
//!
//! Ray casts against the triangles go through the `bvh` crate ([`Geometry`]); the lights are
//! reached by BRDF rays through the light tree's node spheres
//! ([`manylights::LightTree::trace`]). Lights and albedos are linear RGB: `cornell` and
//! `city` are in colour by default ([`Palette::Colour`]: a red and a green wall, warm and cool
//! lights; warm street lamps, coloured windows, red tail lights, tinted façades and cars), and
//! the same scenes in grey ([`Palette::Grey`], `--grey`) are the scalar scenes they were,
//! number for number. The colours are chosen from each light's or surface's index, never from
//! the placement generator, so both palettes place everything at the same positions, and a
//! light's colour has the luminance its grey power had (its energy in the tree is the same up
//! to rounding). `office`, `market` and `billboard` are in colour the same way (tinted room
//! lights, walls and carpets; coloured bulbs, signs and awnings; the video wall's picture and
//! the cars), and grey in [`Palette::Grey`]. `exhibition` and `stairs` are grey in both
//! palettes.

mod billboard;
mod city;
mod cornell;
mod exhibition;
mod geometry;
mod market;
pub mod obj;
mod office;
pub mod pbrt;
mod stairs;

pub use billboard::{billboard, billboard_with, BILLBOARD_LIGHTS, BILLBOARD_SCREEN_TRIANGLES};
pub use city::{city, city_sun, city_with, CITY_LIGHTS, CITY_SUN_DIRECTION};
pub use cornell::{
    cornell, cornell_light_radius, cornell_with, CORNELL_DEFAULT_LIGHTS, CORNELL_LIGHT_RADIUS,
    CORNELL_WALL_GAP,
};
pub use exhibition::{exhibition, EXHIBITION_DISKS, EXHIBITION_PANEL_TRIANGLES};
pub use geometry::{disk_light, sphere_light};
pub use geometry::{Geometry, Hit, Triangle};
pub use market::{market, market_with, MARKET_LIGHTS};
pub use office::{office, office_with, OFFICE_LIGHTS};
pub use stairs::stairs;

use glam::Vec3;
use manylights::light::GradientSky;
use manylights::{LightSet, Material, Rgb};
use std::path::Path;

/// The built-in scene names, in help order (`by_name` also takes a path to an `.obj` file).
pub const SCENES: [&str; 8] = [
    "cornell",
    "exhibition",
    "city",
    "city-sun",
    "stairs",
    "office",
    "market",
    "billboard",
];

/// Colour or grey (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Palette {
    /// The scenes' colours (the default).
    #[default]
    Colour,
    /// Every light and albedo grey, as the scalar scenes were.
    Grey,
}

impl Palette {
    /// The tint of a light (luminance 1): `colour` scaled to luminance 1, or white in grey.
    pub fn tint(self, colour: Rgb) -> Rgb {
        match self {
            Palette::Grey => Rgb::ONE,
            Palette::Colour => colour * (1.0 / colour.luminance()),
        }
    }

    /// An albedo: `grey` in grey, `colour` (every channel in [0, 1]) in colour.
    pub fn albedo(self, grey: f32, colour: Rgb) -> Rgb {
        match self {
            Palette::Grey => Rgb::grey(grey),
            Palette::Colour => colour,
        }
    }

    /// An albedo of luminance `grey` in the hue of `colour`: `colour` scaled to luminance
    /// `grey` (each channel clamped to 1), or `grey` in grey.
    pub fn albedo_of(self, grey: f32, colour: Rgb) -> Rgb {
        match self {
            Palette::Grey => Rgb::grey(grey),
            Palette::Colour => (colour * (grey / colour.luminance())).map(|c| c.min(1.0)),
        }
    }
}

/// A small integer hash (for choosing colours by index without touching a scene's placement
/// generator).
pub(crate) fn hash(i: u64) -> u64 {
    let mut x = i.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_y: f32,
}

impl Camera {
    /// The camera of `--camera`'s text `eye,target,up,fov`: ten comma-separated numbers, the
    /// eye position, the point looked at and the up direction (x, y, z each) and the vertical
    /// field of view in degrees. Errors name what is wrong: not ten numbers, a number that
    /// does not parse or is not finite, the eye on the target, an up direction along the view
    /// (or zero), a field of view outside (0, 180).
    pub fn parse(text: &str) -> Result<Camera, String> {
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        if parts.len() != 10 {
            return Err(format!(
                "--camera: expected ten numbers eye_x,eye_y,eye_z,target_x,target_y,target_z,\
                 up_x,up_y,up_z,fov (got {} in {text:?})",
                parts.len()
            ));
        }
        const NAMES: [&str; 10] = [
            "eye x", "eye y", "eye z", "target x", "target y", "target z", "up x", "up y", "up z",
            "fov",
        ];
        let mut v = [0f32; 10];
        for (k, (p, name)) in parts.iter().zip(NAMES).enumerate() {
            v[k] = match p.parse::<f32>() {
                Ok(x) if x.is_finite() => x,
                _ => {
                    return Err(format!(
                        "--camera: {name} must be a finite number (got {p:?})"
                    ))
                }
            };
        }
        let eye = Vec3::new(v[0], v[1], v[2]);
        let target = Vec3::new(v[3], v[4], v[5]);
        let up = Vec3::new(v[6], v[7], v[8]);
        let fov_y = v[9];
        let w = target - eye;
        if w.length_squared() == 0.0 {
            return Err("--camera: the eye is on the target (no view direction)".into());
        }
        if !w.length_squared().is_finite() || !up.length_squared().is_finite() {
            return Err(
                "--camera: the eye and the target, or the up direction, are too large \
                        for f32 arithmetic"
                    .into(),
            );
        }
        if w.normalize().cross(up).length_squared() <= 1e-12 {
            return Err(format!(
                "--camera: the up direction {up} is zero or along the view direction"
            ));
        }
        if fov_y <= 0.0 || fov_y >= 180.0 {
            return Err(format!(
                "--camera: fov must be in (0, 180) degrees (got {fov_y})"
            ));
        }
        Ok(Camera {
            eye,
            target,
            up,
            fov_y,
        })
    }

    /// The unit direction through image position (`sx`, `sy`) in `[0, 1]²` (y down).
    pub fn direction(&self, sx: f32, sy: f32, aspect: f32) -> Vec3 {
        let w = (self.target - self.eye).normalize();
        let u = w.cross(self.up).normalize();
        let v = u.cross(w);
        let h = (self.fov_y.to_radians() * 0.5).tan();
        (w + u * ((2.0 * sx - 1.0) * h * aspect) + v * ((1.0 - 2.0 * sy) * h)).normalize()
    }
}

/// A scene: geometry, lights and camera.
#[derive(Debug)]
pub struct RenderScene {
    /// Its name.
    pub name: String,
    /// Triangles and BVH.
    pub geometry: Geometry,
    /// Lights, light tree and the power distribution.
    pub lights: LightSet,
    /// The sky the light set was given as its environment, if any (kept here for the
    /// fingerprint: the light set holds the sky itself).
    pub sky: Option<GradientSky>,
    /// Camera.
    pub camera: Camera,
}

impl RenderScene {
    /// A 64-bit fingerprint of everything that determines the scene's image: camera, every
    /// triangle (vertices and material) and every light (FNV-1a over their `Debug` text, which
    /// prints every f32 exactly). Cached references carry it in their file name, so a changed
    /// scene never reuses a stale reference.
    pub fn fingerprint(&self) -> u64 {
        struct Fnv(u64);
        impl std::fmt::Write for Fnv {
            fn write_str(&mut self, s: &str) -> std::fmt::Result {
                for b in s.bytes() {
                    self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
                }
                Ok(())
            }
        }
        use std::fmt::Write as _;
        let mut h = Fnv(0xcbf2_9ce4_8422_2325);
        // Writing into the hasher cannot fail.
        let _ = write!(h, "{:?}", self.camera);
        for t in &self.geometry.triangles {
            let _ = write!(h, "{:?}{:?}", t.v, t.material);
        }
        for l in self.lights.lights() {
            let _ = write!(h, "{l:?}");
        }
        let _ = write!(h, "{:?}", self.sky);
        h.0
    }
}

/// The class of a material in `compare`'s error split by material: its kind and its glossy
/// lobe (roughness α and specular weight, not the albedo, so that the many albedos of one
/// finish are one class), named after what it is where the scene names it.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct MaterialClass {
    /// The scene's name for the class with its kind and lobe (`wet street (plastic α 0.15 ks
    /// 0.5)`), or its kind and lobe alone (`plastic α 0.15 ks 0.5`, `lambert`).
    pub name: String,
    /// `lambert`, `ggx` or `plastic`.
    pub kind: &'static str,
}

impl RenderScene {
    /// The class of `material` in this scene (see [`MaterialClass`]); only `city` names its
    /// classes.
    pub fn material_class(&self, material: &Material) -> MaterialClass {
        let (kind, lobe) = match *material {
            Material::Lambert { .. } => ("lambert", String::new()),
            Material::Ggx { alpha, specular } => ("ggx", format!(" α {alpha} ks {specular}")),
            Material::Plastic {
                specular, alpha, ..
            } => ("plastic", format!(" α {alpha} ks {specular}")),
            _ => ("material", String::new()),
        };
        let generic = format!("{kind}{lobe}");
        let named = match self.name.as_str() {
            "city" => city::material_name(material),
            _ => None,
        };
        MaterialClass {
            name: named.map_or(generic.clone(), |n| format!("{n} ({generic})")),
            kind,
        }
    }
}

/// Whether `name` is a path to an OBJ file (it ends in `.obj`, any case).
fn is_obj_path(name: &str) -> bool {
    Path::new(name)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"))
}

/// The scene named `name` in colour: [`by_name_with`] with [`Palette::Colour`].
pub fn by_name(name: &str, lights: Option<usize>) -> Result<RenderScene, String> {
    by_name_with(name, lights, Palette::Colour)
}

/// The scene named `name`: one of [`SCENES`], or a path ending in `.obj` loaded by
/// [`obj::load`], in `palette`. `lights` is the light count of `cornell`, default
/// [`CORNELL_DEFAULT_LIGHTS`], any positive count (the range is 1,000 to 100,000);
/// the other scenes ignore it.
pub fn by_name_with(
    name: &str,
    lights: Option<usize>,
    palette: Palette,
) -> Result<RenderScene, String> {
    by_name_with_film(name, lights, palette).map(|(s, _)| s)
}

/// [`by_name_with`], with the image size the scene file asks for: a pbrt-v4 file's `Film`
/// resolution (`None` for the other scenes and for a pbrt file without a `Film`).
pub fn by_name_with_film(
    name: &str,
    lights: Option<usize>,
    palette: Palette,
) -> Result<(RenderScene, Option<(usize, usize)>), String> {
    if Path::new(name)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("pbrt"))
    {
        // A pbrt-v4 file: its warnings (what it uses that is not mapped) go to stderr.
        return pbrt::load(Path::new(name)).map(|p| {
            for w in &p.warnings {
                eprintln!("warning: {w}");
            }
            (p.scene, p.film)
        });
    }
    by_name_builtin(name, lights, palette).map(|s| (s, None))
}

/// A built-in scene or an OBJ file by name.
fn by_name_builtin(
    name: &str,
    lights: Option<usize>,
    palette: Palette,
) -> Result<RenderScene, String> {
    match name {
        "cornell" => match lights.unwrap_or(CORNELL_DEFAULT_LIGHTS) {
            0 => Err("cornell needs at least one light".into()),
            n => Ok(cornell_with(n, 1, palette)),
        },
        "exhibition" => Ok(exhibition()),
        "city" => Ok(city_with(palette)),
        "city-sun" => Ok(city_sun(palette)),
        "stairs" => Ok(stairs()),
        "office" => Ok(office_with(palette)),
        "market" => Ok(market_with(palette)),
        "billboard" => Ok(billboard_with(palette)),
        _ if is_obj_path(name) => obj::load(Path::new(name)),
        _ => Err(format!(
            "unknown scene {name:?} (known: {}, or a path to an .obj or .pbrt file)",
            SCENES.join(", ")
        )),
    }
}
