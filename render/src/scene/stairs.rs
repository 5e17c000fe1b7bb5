//! `stairs`: a staircase between two walls, a few sphere lights and two ceiling disks.

use super::geometry::{cuboid, quad, sphere_light, Geometry};
use super::{Camera, LightSet, RenderScene};
use glam::Vec3;
use manylights::Rgb;
use manylights::{Light, Material};

/// A staircase of 10 steps between two walls, 18 small sphere lights along the walls and two
/// large one-sided disk lights under the ceiling.
pub fn stairs() -> RenderScene {
    let wall = Material::Lambert {
        albedo: Rgb::grey(0.6),
    };
    let step = Material::Plastic {
        albedo: Rgb::grey(0.5),
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
        lights.push(sphere_light(v(0.05, y, z), 0.02, 1.5, Rgb::ONE));
        lights.push(sphere_light(v(w - 0.05, y + 0.1, z), 0.02, 1.5, Rgb::ONE));
    }
    for z in [len * 0.3, len * 0.75] {
        lights.push(Light::Disk {
            center: v(w * 0.5, height - 0.01, z),
            normal: v(0.0, -1.0, 0.0),
            radius: 0.35,
            radiance: Rgb::grey(4.0),
            two_sided: false,
        });
    }
    RenderScene {
        name: "stairs".into(),
        geometry: Geometry::new(t),
        lights: LightSet::build(lights).expect("the built-in lights are valid"),
        sky: None,
        camera: Camera {
            eye: v(w * 0.5, 1.5, len + 1.2),
            target: v(w * 0.5, 1.2, 0.0),
            up: v(0.0, 1.0, 0.0),
            fov_y: 55.0,
        },
    }
}
