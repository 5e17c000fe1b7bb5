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
//! - `stairs` ([`stairs()`]): a staircase between two walls with 18 small sphere lights along
//!   the walls and two large disk lights under the ceiling (20 lights).
//! - a path ending in `.obj` ([`obj::load`]): the meshes of the file, with Lambert, plastic or
//!   GGX materials from its MTL and a triangle light per emissive triangle; automatic camera.
//!
//! Ray casts against the triangles go through the `bvh` crate ([`Geometry`]); the lights are
//! reached by BRDF rays through the light tree's node spheres
//! ([`manylights::LightTree::trace`]). Materials are scalar (grey): the images are
//! grey-level.

mod city;
mod cornell;
mod exhibition;
mod geometry;
pub mod obj;
mod stairs;

pub use city::{city, CITY_LIGHTS};
pub use cornell::{
    cornell, cornell_light_radius, CORNELL_DEFAULT_LIGHTS, CORNELL_LIGHT_RADIUS, CORNELL_WALL_GAP,
};
pub use exhibition::{exhibition, EXHIBITION_DISKS, EXHIBITION_PANEL_TRIANGLES};
pub(crate) use geometry::{disk_light, sphere_light};
pub use geometry::{Geometry, Hit, Triangle};
pub use stairs::stairs;

use glam::Vec3;
use manylights::{LightSet, Material};
use std::path::Path;

/// The built-in scene names, in help order (`by_name` also takes a path to an `.obj` file).
pub const SCENES: [&str; 4] = ["cornell", "exhibition", "city", "stairs"];

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

/// The scene named `name`: one of [`SCENES`], or a path ending in `.obj` loaded by
/// [`obj::load`]. `lights` is the light count of `cornell`, default
/// [`CORNELL_DEFAULT_LIGHTS`], any positive count (the range is 1,000 to 100,000);
/// the other scenes ignore it.
pub fn by_name(name: &str, lights: Option<usize>) -> Result<RenderScene, String> {
    match name {
        "cornell" => match lights.unwrap_or(CORNELL_DEFAULT_LIGHTS) {
            0 => Err("cornell needs at least one light".into()),
            n => Ok(cornell(n, 1)),
        },
        "exhibition" => Ok(exhibition()),
        "city" => Ok(city()),
        "stairs" => Ok(stairs()),
        _ if is_obj_path(name) => obj::load(Path::new(name)),
        _ => Err(format!(
            "unknown scene {name:?} (known: {}, or a path to an .obj file)",
            SCENES.join(", ")
        )),
    }
}
