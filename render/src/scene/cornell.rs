//! `cornell`: a Cornell box lit by many tiny sphere lights on its side walls.

use super::geometry::{cuboid, quad, sphere_light, Geometry};
use super::{Camera, LightSet, Palette, RenderScene};
use glam::Vec3;
use manylights::Rgb;
use manylights::{Light, Material};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Default number of lights of `cornell`.
pub const CORNELL_DEFAULT_LIGHTS: usize = 1494;

/// Radius of `cornell`'s sphere lights up to [`CORNELL_DEFAULT_LIGHTS`] lights (see
/// [`cornell_light_radius`]).
pub const CORNELL_LIGHT_RADIUS: f32 = 0.004;

/// Radius of the sphere lights of `cornell` with `n_lights` lights: [`CORNELL_LIGHT_RADIUS`] up
/// to the default count, and `CORNELL_LIGHT_RADIUS · √(default / n)` above it, so that the
/// lights keep covering the same small fraction of the walls (about 4.6 %) and stay tiny
/// against their spacing. At a fixed 4 mm, 100,000 lights would cover the walls three times
/// over and intersect each other; every BRDF ray towards a wall would hit several lights.
pub fn cornell_light_radius(n_lights: usize) -> f32 {
    let n = n_lights.max(1) as f32;
    CORNELL_LIGHT_RADIUS * (CORNELL_DEFAULT_LIGHTS as f32 / n).sqrt().min(1.0)
}

/// Distance of `cornell`'s light centres from their wall (a few radii: the wall's
/// irradiance peak under a light stays moderate).
pub const CORNELL_WALL_GAP: f32 = 0.015;

/// The Cornell box, `[0, 1]³` (open at z = 1, where the camera is), with `n_lights` tiny sphere
/// lights at random on the left (x = 0) and right (x = 1) walls, powers `12/n × e^U` with U
/// uniform in `[ln 0.25, ln 4]` (a 16:1 spread; E[e^U] = 3.75/ln 16 ≈ 1.35, so the expected
/// total power is about 16.2 for any n); `seed` places them. In colour: [`cornell_with`].
pub fn cornell(n_lights: usize, seed: u64) -> RenderScene {
    cornell_with(n_lights, seed, Palette::Colour)
}

/// [`cornell`] in `palette`: in colour the left wall is red, the right one green, the floor a
/// warm grey, the tall box pale blue and the short one yellow plastic; the lights on the left
/// wall are warm white, those on the right cool white (each of the luminance of its grey
/// power).
pub fn cornell_with(n_lights: usize, seed: u64, palette: Palette) -> RenderScene {
    let white = Material::Lambert {
        albedo: palette.albedo(0.7, Rgb::new(0.73, 0.71, 0.68)),
    };
    let wall_l = Material::Lambert {
        albedo: palette.albedo(0.5, Rgb::new(0.63, 0.065, 0.05)),
    };
    let wall_r = Material::Lambert {
        albedo: palette.albedo(0.5, Rgb::new(0.14, 0.45, 0.091)),
    };
    let floor = Material::Plastic {
        albedo: palette.albedo(0.5, Rgb::new(0.55, 0.5, 0.42)),
        specular: 0.5,
        alpha: 0.08,
    };
    let glossy = Material::Plastic {
        albedo: palette.albedo(0.3, Rgb::new(0.6, 0.45, 0.08)),
        specular: 0.7,
        alpha: 0.05,
    };
    let diffuse = Material::Lambert {
        albedo: palette.albedo(0.6, Rgb::new(0.45, 0.6, 0.75)),
    };
    let (warm, cool) = (
        palette.tint(Rgb::new(1.0, 0.8, 0.6)),
        palette.tint(Rgb::new(0.7, 0.85, 1.0)),
    );
    let v = |x, y, z| Vec3::new(x, y, z);
    let mut t = Vec::new();
    // Floor, ceiling, back wall, left and right walls (corners in order around each quad).
    let walls = [
        [v(0., 0., 0.), v(1., 0., 0.), v(1., 0., 1.), v(0., 0., 1.)],
        [v(0., 1., 0.), v(1., 1., 0.), v(1., 1., 1.), v(0., 1., 1.)],
        [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)],
        [v(0., 0., 0.), v(0., 1., 0.), v(0., 1., 1.), v(0., 0., 1.)],
        [v(1., 0., 0.), v(1., 1., 0.), v(1., 1., 1.), v(1., 0., 1.)],
    ];
    for ([a, b, c, d], m) in walls.into_iter().zip([floor, white, white, wall_l, wall_r]) {
        quad(&mut t, a, b, c, d, m);
    }
    cuboid(&mut t, v(0.33, 0.3, 0.38), v(0.14, 0.3, 0.14), 0.3, diffuse);
    cuboid(
        &mut t,
        v(0.68, 0.15, 0.62),
        v(0.14, 0.15, 0.14),
        -0.3,
        glossy,
    );

    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0xc0_4e11);
    let r = cornell_light_radius(n_lights);
    let base_power = 12.0 / n_lights.max(1) as f32;
    let lights: Vec<Light> = (0..n_lights)
        .map(|i| {
            let x = if i % 2 == 0 {
                CORNELL_WALL_GAP
            } else {
                1.0 - CORNELL_WALL_GAP
            };
            let y = rng.random_range(0.05f32..0.95);
            let z = rng.random_range(0.05f32..0.95);
            let power = base_power * rng.random_range((0.25f32).ln()..(4.0f32).ln()).exp();
            sphere_light(v(x, y, z), r, power, if i % 2 == 0 { warm } else { cool })
        })
        .collect();
    RenderScene {
        name: "cornell".into(),
        geometry: Geometry::new(t),
        lights: LightSet::build(lights).expect("the built-in lights are valid"),
        sky: None,
        camera: Camera {
            eye: v(0.5, 0.5, 2.3),
            target: v(0.5, 0.5, 0.0),
            up: v(0.0, 1.0, 0.0),
            fov_y: 38.0,
        },
    }
}
