//! The renderer's scenes, built in code (no downloads): triangle meshes with a material per
//! triangle, a light set (sphere and disk lights, not part of the meshes) with its light tree,
//! and a pinhole camera.
//!
//! - `cornell` ([`cornell`]): a Cornell box with a diffuse tall box, a glossy plastic short box
//!   and a glossy plastic floor, lit by many tiny sphere lights on the left and right walls
//!   (default [`CORNELL_DEFAULT_LIGHTS`]; any count places them at random on the same walls).
//! - `stairs` ([`stairs`]): a staircase between two walls with 18 small sphere lights along
//!   the walls and two large disk lights under the ceiling (20 lights).
//!
//! Ray casts against the triangles go through the `bvh` crate ([`Geometry`]); the lights are
//! reached by BRDF rays through the light tree's node spheres
//! ([`crate::estimator::techniques::trace`]). Materials are scalar (grey): the images are
//! grey-level.

use crate::estimator::scene::Scene as LightSet;
use crate::estimator::techniques::Occluder;
use bvh::aabb::{Aabb, Bounded};
use bvh::bounding_hierarchy::BHShape;
use bvh::bvh::Bvh;
use glam::Vec3;
use manylights::{Light, Material};
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f32::consts::PI;

/// Default number of lights of `cornell`.
pub const CORNELL_DEFAULT_LIGHTS: usize = 1494;

/// The scene names, in help order.
pub const SCENES: [&str; 2] = ["cornell", "stairs"];

/// One triangle with its material.
#[derive(Clone, Copy, Debug)]
pub struct Triangle {
    /// Vertices.
    pub v: [Vec3; 3],
    /// Material.
    pub material: Material,
    node_index: usize,
}

impl Bounded<f32, 3> for Triangle {
    fn aabb(&self) -> Aabb<f32, 3> {
        let lo = self.v[0].min(self.v[1]).min(self.v[2]) - Vec3::splat(1e-5);
        let hi = self.v[0].max(self.v[1]).max(self.v[2]) + Vec3::splat(1e-5);
        Aabb::with_bounds(Point3::new(lo.x, lo.y, lo.z), Point3::new(hi.x, hi.y, hi.z))
    }
}

impl BHShape<f32, 3> for Triangle {
    fn set_bh_node_index(&mut self, index: usize) {
        self.node_index = index;
    }

    fn bh_node_index(&self) -> usize {
        self.node_index
    }
}

impl Triangle {
    /// Möller–Trumbore: the distance along the ray, if it hits in (`t_min`, `t_max`).
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let e1 = self.v[1] - self.v[0];
        let e2 = self.v[2] - self.v[0];
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let inv = 1.0 / det;
        let s = o - self.v[0];
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = d.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = e2.dot(q) * inv;
        (t > t_min && t < t_max).then_some(t)
    }

    /// Unit geometric normal.
    pub fn normal(&self) -> Vec3 {
        (self.v[1] - self.v[0])
            .cross(self.v[2] - self.v[0])
            .normalize()
    }
}

/// The triangles and their BVH.
pub struct Geometry {
    /// The triangles.
    pub triangles: Vec<Triangle>,
    bvh: Bvh<f32, 3>,
}

impl std::fmt::Debug for Geometry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Geometry")
            .field("triangles", &self.triangles.len())
            .finish()
    }
}

/// A surface hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f32,
    /// Unit geometric normal of the triangle hit.
    pub normal: Vec3,
    /// Its material.
    pub material: Material,
}

/// Shadow rays stop this far (relative) before the light point.
const SHADOW_EPS: f32 = 1e-4;

impl Geometry {
    /// Builds the BVH.
    pub fn new(mut triangles: Vec<Triangle>) -> Geometry {
        let bvh = Bvh::build(&mut triangles);
        Geometry { triangles, bvh }
    }

    fn ray(o: Vec3, d: Vec3) -> bvh::ray::Ray<f32, 3> {
        bvh::ray::Ray::new(Point3::new(o.x, o.y, o.z), Vector3::new(d.x, d.y, d.z))
    }

    /// The nearest hit along the ray from `o` along the unit `d`, beyond `t_min`.
    pub fn nearest(&self, o: Vec3, d: Vec3, t_min: f32) -> Option<Hit> {
        let ray = Self::ray(o, d);
        let mut best: Option<Hit> = None;
        for tri in self.bvh.traverse_iterator(&ray, &self.triangles) {
            let t_max = best.map_or(f32::INFINITY, |h| h.t);
            if let Some(t) = tri.intersect(o, d, t_min, t_max) {
                best = Some(Hit {
                    t,
                    normal: tri.normal(),
                    material: tri.material,
                });
            }
        }
        best
    }
}

impl Occluder for Geometry {
    fn occluded(&self, x: Vec3, d: Vec3, t: f32) -> bool {
        let ray = Self::ray(x, d);
        let t_max = t * (1.0 - SHADOW_EPS);
        self.bvh
            .traverse_iterator(&ray, &self.triangles)
            .any(|tri| tri.intersect(x, d, 0.0, t_max).is_some())
    }

    fn first_hit(&self, x: Vec3, d: Vec3) -> f32 {
        self.nearest(x, d, 0.0).map_or(f32::INFINITY, |h| h.t)
    }
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

/// The scene named `name` (`lights`: the light count of `cornell`, default
/// [`CORNELL_DEFAULT_LIGHTS`], any positive count (the range is 1,000 to 100,000);
/// ignored by `stairs`).
pub fn by_name(name: &str, lights: Option<usize>) -> Result<RenderScene, String> {
    match name {
        "cornell" => match lights.unwrap_or(CORNELL_DEFAULT_LIGHTS) {
            0 => Err("cornell needs at least one light".into()),
            n => Ok(cornell(n, 1)),
        },
        "stairs" => Ok(stairs()),
        _ => Err(format!(
            "unknown scene {name:?} (known: {})",
            SCENES.join(", ")
        )),
    }
}

fn tri(a: Vec3, b: Vec3, c: Vec3, material: Material) -> Triangle {
    Triangle {
        v: [a, b, c],
        material,
        node_index: 0,
    }
}

/// Two triangles of the quad a b c d (in order around it).
fn quad(out: &mut Vec<Triangle>, a: Vec3, b: Vec3, c: Vec3, d: Vec3, m: Material) {
    out.push(tri(a, b, c, m));
    out.push(tri(a, c, d, m));
}

/// A box of half sizes `h` centred at `c` (bottom at `c.y - h.y`), turned by `angle` about y.
fn cuboid(out: &mut Vec<Triangle>, c: Vec3, h: Vec3, angle: f32, m: Material) {
    let (s, co) = angle.sin_cos();
    let p = |x: f32, y: f32, z: f32| {
        let (x, z) = (x * h.x, z * h.z);
        c + Vec3::new(co * x + s * z, y * h.y, -s * x + co * z)
    };
    let v = [
        p(-1.0, -1.0, -1.0),
        p(1.0, -1.0, -1.0),
        p(1.0, 1.0, -1.0),
        p(-1.0, 1.0, -1.0),
        p(-1.0, -1.0, 1.0),
        p(1.0, -1.0, 1.0),
        p(1.0, 1.0, 1.0),
        p(-1.0, 1.0, 1.0),
    ];
    for f in [
        [0, 1, 2, 3],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [3, 2, 6, 7],
        [0, 3, 7, 4],
        [1, 2, 6, 5],
    ] {
        quad(out, v[f[0]], v[f[1]], v[f[2]], v[f[3]], m);
    }
}

/// Sphere light of total power `power`.
fn sphere_light(center: Vec3, radius: f32, power: f32) -> Light {
    Light::Sphere {
        center,
        radius,
        radiance: power / (PI * 4.0 * PI * radius * radius),
    }
}

/// Radius of `cornell`'s sphere lights.
pub const CORNELL_LIGHT_RADIUS: f32 = 0.004;

/// Distance of `cornell`'s light centres from their wall (a few radii: the wall's
/// irradiance peak under a light stays moderate).
pub const CORNELL_WALL_GAP: f32 = 0.015;

/// The Cornell box, `[0, 1]³` (open at z = 1, where the camera is), with `n_lights` tiny sphere
/// lights at random on the left (x = 0) and right (x = 1) walls, powers log-uniform in
/// `[0.25, 4]` × the mean, total power 12; `seed` places them.
pub fn cornell(n_lights: usize, seed: u64) -> RenderScene {
    let white = Material::Lambert { albedo: 0.7 };
    let wall_l = Material::Lambert { albedo: 0.5 };
    let floor = Material::Plastic {
        albedo: 0.5,
        specular: 0.5,
        alpha: 0.08,
    };
    let glossy = Material::Plastic {
        albedo: 0.3,
        specular: 0.7,
        alpha: 0.05,
    };
    let diffuse = Material::Lambert { albedo: 0.6 };
    let v = |x, y, z| Vec3::new(x, y, z);
    let mut t = Vec::new();
    quad(
        &mut t,
        v(0., 0., 0.),
        v(1., 0., 0.),
        v(1., 0., 1.),
        v(0., 0., 1.),
        floor,
    );
    quad(
        &mut t,
        v(0., 1., 0.),
        v(1., 1., 0.),
        v(1., 1., 1.),
        v(0., 1., 1.),
        white,
    );
    quad(
        &mut t,
        v(0., 0., 0.),
        v(1., 0., 0.),
        v(1., 1., 0.),
        v(0., 1., 0.),
        white,
    );
    quad(
        &mut t,
        v(0., 0., 0.),
        v(0., 1., 0.),
        v(0., 1., 1.),
        v(0., 0., 1.),
        wall_l,
    );
    quad(
        &mut t,
        v(1., 0., 0.),
        v(1., 1., 0.),
        v(1., 1., 1.),
        v(1., 0., 1.),
        wall_l,
    );
    cuboid(&mut t, v(0.33, 0.3, 0.38), v(0.14, 0.3, 0.14), 0.3, diffuse);
    cuboid(
        &mut t,
        v(0.68, 0.15, 0.62),
        v(0.14, 0.15, 0.14),
        -0.3,
        glossy,
    );

    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0xc0_4e11);
    let r = CORNELL_LIGHT_RADIUS;
    let mean_power = 12.0 / n_lights.max(1) as f32;
    let lights: Vec<Light> = (0..n_lights)
        .map(|i| {
            let x = if i % 2 == 0 {
                CORNELL_WALL_GAP
            } else {
                1.0 - CORNELL_WALL_GAP
            };
            let y = rng.random_range(0.05f32..0.95);
            let z = rng.random_range(0.05f32..0.95);
            let power = mean_power * rng.random_range((0.25f32).ln()..(4.0f32).ln()).exp();
            sphere_light(v(x, y, z), r, power)
        })
        .collect();
    RenderScene {
        name: "cornell".into(),
        geometry: Geometry::new(t),
        lights: LightSet::with_lights(lights, Vec::new()),
        camera: Camera {
            eye: v(0.5, 0.5, 2.3),
            target: v(0.5, 0.5, 0.0),
            up: v(0.0, 1.0, 0.0),
            fov_y: 38.0,
        },
    }
}

/// A staircase of 10 steps between two walls, 18 small sphere lights along the walls and two
/// large one-sided disk lights under the ceiling.
pub fn stairs() -> RenderScene {
    let wall = Material::Lambert { albedo: 0.6 };
    let step = Material::Plastic {
        albedo: 0.5,
        specular: 0.4,
        alpha: 0.15,
    };
    let rail = Material::Ggx {
        alpha: 0.1,
        specular: 0.9,
    };
    let v = |x, y, z| Vec3::new(x, y, z);
    let mut t = Vec::new();
    let (w, depth, rise, n) = (1.2f32, 0.3f32, 0.18f32, 10usize);
    let len = depth * n as f32 + 1.0;
    let height = rise * n as f32 + 2.0;
    // Floor, ceiling, side walls, back wall.
    quad(
        &mut t,
        v(0., 0., 0.),
        v(w, 0., 0.),
        v(w, 0., len),
        v(0., 0., len),
        wall,
    );
    quad(
        &mut t,
        v(0., height, 0.),
        v(w, height, 0.),
        v(w, height, len),
        v(0., height, len),
        wall,
    );
    quad(
        &mut t,
        v(0., 0., 0.),
        v(0., height, 0.),
        v(0., height, len),
        v(0., 0., len),
        wall,
    );
    quad(
        &mut t,
        v(w, 0., 0.),
        v(w, height, 0.),
        v(w, height, len),
        v(w, 0., len),
        wall,
    );
    quad(
        &mut t,
        v(0., 0., 0.),
        v(w, 0., 0.),
        v(w, height, 0.),
        v(0., height, 0.),
        wall,
    );
    // Steps climb towards z = 0.
    for i in 0..n {
        let z1 = len - 1.0 - depth * i as f32;
        let top = rise * (i + 1) as f32;
        cuboid(
            &mut t,
            v(w * 0.5, top * 0.5, z1 - depth * 0.5),
            v(w * 0.5 - 0.01, top * 0.5, depth * 0.5),
            0.0,
            step,
        );
    }
    // A glossy hand rail along the right wall.
    cuboid(
        &mut t,
        v(w - 0.06, 1.2, len * 0.5),
        v(0.02, 0.02, len * 0.45),
        0.0,
        rail,
    );

    let mut lights = Vec::new();
    for i in 0..9 {
        let z = 0.3 + (len - 0.6) * i as f32 / 8.0;
        let y = 0.9 + rise * n as f32 * (1.0 - z / len);
        lights.push(sphere_light(v(0.05, y, z), 0.02, 1.5));
        lights.push(sphere_light(v(w - 0.05, y + 0.1, z), 0.02, 1.5));
    }
    for z in [len * 0.3, len * 0.75] {
        lights.push(Light::Disk {
            center: v(w * 0.5, height - 0.01, z),
            normal: v(0.0, -1.0, 0.0),
            radius: 0.35,
            radiance: 4.0,
            two_sided: false,
        });
    }
    RenderScene {
        name: "stairs".into(),
        geometry: Geometry::new(t),
        lights: LightSet::with_lights(lights, Vec::new()),
        camera: Camera {
            eye: v(w * 0.5, 1.5, len + 1.2),
            target: v(w * 0.5, 1.2, 0.0),
            up: v(0.0, 1.0, 0.0),
            fov_y: 55.0,
        },
    }
}
