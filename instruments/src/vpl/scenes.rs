//! The scenes of `mlmeasure vpl`, built in code: diffuse (Lambert) rooms lit by one point light.
//!
//! - `corner`: an L-shaped corridor, 3 m wide and 3 m high. The point light sits near the
//!   closed end of the first leg ([`CORNER_LEG_A`] long, along x); the camera stands in the second leg
//!   (12 m long, along z, turning off the end of the first) and looks down it, away from the
//!   corner. No point the camera sees is in the light's view: everything visible is lit by
//!   light that has bounced at least once, and most of that has bounced twice or more (as the
//!   "EG" scene of Georgiev & Slusallek 2010, section 4, with its light around the corner).
//!   Most light paths start and die in the first leg, where their VPLs light nothing visible.
//! - `room`: a 5 m × 3 m × 5 m room with a box on the floor, the light in the camera's view:
//!   nearly every VPL lights something visible.

use glam::Vec3;
use manylights::LightSet;
use manylights::Rgb;
use manylights::{Light, Material};
use manylights_render::scene::{Camera, Geometry, RenderScene, Triangle};

/// The scene names, in help order.
pub const VPL_SCENES: [&str; 2] = ["corner", "room"];

/// A scene for instant radiosity: geometry and camera (in a [`RenderScene`], whose light set
/// holds the one point light), the light, and the clamp of the geometry term.
#[derive(Debug)]
pub struct VplScene {
    /// Geometry, camera, and the point light as the scene's one light.
    pub scene: RenderScene,
    /// Position of the point light.
    pub light: Vec3,
    /// Its radiant intensity (W/sr; power 4π times this).
    pub intensity: f32,
    /// The bound of the geometry term G = cos θx cos θy / d² in the gathers (1/m²).
    pub g_max: f32,
}

fn quad(out: &mut Vec<Triangle>, c: [Vec3; 4], m: Material) {
    out.push(Triangle::new(c[0], c[1], c[2], m));
    out.push(Triangle::new(c[0], c[2], c[3], m));
}

/// The floor (y = `y`) or ceiling rectangle `[x0, x1] × [z0, z1]`.
fn horizontal(out: &mut Vec<Triangle>, y: f32, (x0, x1): (f32, f32), (z0, z1): (f32, f32)) {
    let v = |x, z| Vec3::new(x, y, z);
    quad(
        out,
        [v(x0, z0), v(x1, z0), v(x1, z1), v(x0, z1)],
        Material::Lambert {
            albedo: Rgb::grey(0.7),
        },
    );
}

/// A wall x = `x` over `[z0, z1]`, floor to height `h`.
fn wall_x(out: &mut Vec<Triangle>, x: f32, (z0, z1): (f32, f32), h: f32, albedo: f32) {
    let v = |y, z| Vec3::new(x, y, z);
    quad(
        out,
        [v(0.0, z0), v(0.0, z1), v(h, z1), v(h, z0)],
        Material::Lambert {
            albedo: albedo.into(),
        },
    );
}

/// A wall z = `z` over `[x0, x1]`, floor to height `h`.
fn wall_z(out: &mut Vec<Triangle>, z: f32, (x0, x1): (f32, f32), h: f32, albedo: f32) {
    let v = |x, y| Vec3::new(x, y, z);
    quad(
        out,
        [v(x0, 0.0), v(x1, 0.0), v(x1, h), v(x0, h)],
        Material::Lambert {
            albedo: albedo.into(),
        },
    );
}

fn with_light(
    name: &str,
    t: Vec<Triangle>,
    camera: Camera,
    light: Vec3,
    intensity: f32,
    g_max: f32,
) -> VplScene {
    let point = Light::Point {
        position: light,
        intensity: intensity.into(),
    };
    VplScene {
        scene: RenderScene {
            name: name.into(),
            geometry: Geometry::new(t),
            lights: LightSet::build(vec![point]).expect("the scene's light is valid"),
            sky: None,
            camera,
        },
        light,
        intensity,
        g_max,
    }
}

/// `corner` (see the module documentation).
pub fn corner() -> VplScene {
    let (h, len, w, leg_b) = (3.0, CORNER_LEG_A, 3.0, 12.0);
    let mut t = Vec::new();
    // Leg A: x ∈ [0, len], z ∈ [0, w]; leg B: x ∈ [len − w, len], z ∈ [w, w + leg_b].
    let (xb, zb) = (len - w, w + leg_b);
    for y in [0.0, h] {
        horizontal(&mut t, y, (0.0, len), (0.0, w));
        horizontal(&mut t, y, (xb, len), (w, zb));
    }
    wall_z(&mut t, 0.0, (0.0, len), h, 0.7);
    wall_x(&mut t, 0.0, (0.0, w), h, 0.7);
    wall_z(&mut t, w, (0.0, xb), h, 0.7);
    wall_x(&mut t, len, (0.0, zb), h, 0.7);
    wall_x(&mut t, xb, (w, zb), h, 0.7);
    wall_z(&mut t, zb, (xb, len), h, 0.5);
    let cx = len - 0.5 * w;
    let camera = Camera {
        eye: Vec3::new(cx, 1.5, w + 1.0),
        target: Vec3::new(cx, 1.2, zb),
        up: Vec3::Y,
        fov_y: 60.0,
    };
    with_light("corner", t, camera, Vec3::new(1.0, 2.0, 1.5), 50.0, 4.0)
}

/// Length of `corner`'s first leg (the light's), in metres.
pub const CORNER_LEG_A: f32 = 18.0;

/// `room` (see the module documentation).
pub fn room() -> VplScene {
    let h = 3.0;
    let mut t = Vec::new();
    horizontal(&mut t, 0.0, (0.0, 5.0), (0.0, 5.0));
    horizontal(&mut t, h, (0.0, 5.0), (0.0, 5.0));
    wall_x(&mut t, 0.0, (0.0, 5.0), h, 0.6);
    wall_x(&mut t, 5.0, (0.0, 5.0), h, 0.6);
    wall_z(&mut t, 0.0, (0.0, 5.0), h, 0.7);
    wall_z(&mut t, 5.0, (0.0, 5.0), h, 0.7);
    // A box on the floor, 1.2 m on a side.
    let (lo, hi) = (Vec3::new(3.0, 0.0, 1.2), Vec3::new(4.2, 1.2, 2.4));
    let m = Material::Lambert {
        albedo: Rgb::grey(0.5),
    };
    let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    quad(
        &mut t,
        [
            v(lo.x, hi.y, lo.z),
            v(hi.x, hi.y, lo.z),
            v(hi.x, hi.y, hi.z),
            v(lo.x, hi.y, hi.z),
        ],
        m,
    );
    for (a, b) in [
        (v(lo.x, 0.0, lo.z), v(hi.x, 0.0, lo.z)),
        (v(hi.x, 0.0, lo.z), v(hi.x, 0.0, hi.z)),
        (v(hi.x, 0.0, hi.z), v(lo.x, 0.0, hi.z)),
        (v(lo.x, 0.0, hi.z), v(lo.x, 0.0, lo.z)),
    ] {
        let up = Vec3::Y * hi.y;
        quad(&mut t, [a, b, b + up, a + up], m);
    }
    let camera = Camera {
        eye: Vec3::new(2.5, 1.6, 4.8),
        target: Vec3::new(2.5, 1.1, 0.0),
        up: Vec3::Y,
        fov_y: 60.0,
    };
    with_light("room", t, camera, Vec3::new(1.5, 2.2, 2.0), 10.0, 4.0)
}

/// The scene named `name` (one of [`VPL_SCENES`]).
pub fn by_name(name: &str) -> Result<VplScene, String> {
    match name {
        "corner" => Ok(corner()),
        "room" => Ok(room()),
        _ => Err(format!(
            "unknown VPL scene {name:?} (known: {})",
            VPL_SCENES.join(", ")
        )),
    }
}
