//! `exhibition`: a glossy car-like body on a turntable in a showroom, under many small disk
//! lights and one large ceiling light.

use super::geometry::{cuboid, cylinder, disk_light, quad, superellipsoid, torus, Geometry};
use super::{Camera, LightSet, RenderScene};
use glam::Vec3;
use manylights::Rgb;
use manylights::{Light, Material};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f32::consts::PI;

/// Number of small disk lights of `exhibition` (the scene also has
/// [`EXHIBITION_PANEL_TRIANGLES`] triangle lights).
pub const EXHIBITION_DISKS: usize = 732;

/// Half size of the showroom in x and z.
const HALF: f32 = 5.0;
/// Ceiling height.
const HEIGHT: f32 = 4.0;
/// What every small disk faces: the middle of the car.
const AIM: Vec3 = Vec3::new(0.0, 0.7, 0.0);
/// Radius of the small disks.
const DISK_RADIUS: f32 = 0.05;
/// Total power of the small disks.
const DISKS_POWER: f32 = 300.0;
/// Power of the large ceiling light.
const PANEL_POWER: f32 = 150.0;
/// The large ceiling light's quads along x and z (two triangle lights each).
const PANEL_QUADS: (usize, usize) = (4, 2);
/// Number of triangle lights of `exhibition`'s large ceiling light.
pub const EXHIBITION_PANEL_TRIANGLES: usize = 2 * PANEL_QUADS.0 * PANEL_QUADS.1;

/// How far the small disks hang from the ceiling and the walls (tracks and stands: 7 radii, so
/// that the surface behind a disk, which it lights at a grazing angle, is not in its near
/// field).
const DISK_GAP: f32 = 0.35;

/// The centres of the small disks: rings under the ceiling (radii 2 to 4.5, about 0.3 apart
/// along each ring) and three rows along each wall (heights 1.6, 2.3 and 3.0, 0.34 apart).
fn disk_centres() -> Vec<Vec3> {
    let mut c = Vec::new();
    for k in 0..6 {
        let r = 2.0 + 0.5 * k as f32;
        let n = (2.0 * PI * r / 0.3).round() as usize;
        for i in 0..n {
            let phi = 2.0 * PI * (i as f32 + 0.5 * (k % 2) as f32) / n as f32;
            c.push(Vec3::new(r * phi.cos(), HEIGHT - DISK_GAP, r * phi.sin()));
        }
    }
    let gap = DISK_GAP;
    for y in [1.6, 2.3, 3.0] {
        for i in 0..27 {
            let s = -4.42 + 0.34 * i as f32;
            c.push(Vec3::new(s, y, -HALF + gap));
            c.push(Vec3::new(s, y, HALF - gap));
            c.push(Vec3::new(-HALF + gap, y, s));
            c.push(Vec3::new(HALF - gap, y, s));
        }
    }
    c
}

/// The showroom: `[-5, 5] × [0, 4] × [-5, 5]`, a glossy plastic floor, diffuse walls and
/// ceiling. On a turntable (radius 2) in the middle stands a car-like body: a rounded box
/// (superellipsoid) with a rounded cabin, both GGX (α 0.06 and 0.05), on four dark wheels.
/// Two plinths at the back carry a GGX sphere (α 0.08) and a GGX torus (α 0.1).
///
/// Lights: [`EXHIBITION_DISKS`] one-sided disks of radius 0.05 on rings 0.35 under the
/// ceiling and rows 0.35 off the four walls, each facing the middle of the car, powers
/// log-uniform in [0.5, 2] × 300 / [`EXHIBITION_DISKS`] (about 325 in all; fixed seed); and a
/// 3 × 1.8 rectangle under the ceiling above the car, facing down, of power 150: a 4 × 2 grid
/// of quads, [`EXHIBITION_PANEL_TRIANGLES`] one-sided triangle lights (as an emissive mesh
/// would give it; a single pair would be picked so rarely by the techniques that ignore power
/// that their images would miss its reflection in the car's roof for hundreds of samples).
pub fn exhibition() -> RenderScene {
    let wall = Material::Lambert {
        albedo: Rgb::grey(0.6),
    };
    let ceiling = Material::Lambert {
        albedo: Rgb::grey(0.5),
    };
    let floor = Material::Plastic {
        albedo: Rgb::grey(0.3),
        specular: 0.5,
        alpha: 0.08,
    };
    let turntable = Material::Plastic {
        albedo: Rgb::grey(0.15),
        specular: 0.4,
        alpha: 0.2,
    };
    let paint = Material::Ggx {
        alpha: 0.06,
        specular: 0.9,
    };
    let glass = Material::Ggx {
        alpha: 0.05,
        specular: 0.6,
    };
    let tyre = Material::Lambert {
        albedo: Rgb::grey(0.05),
    };
    let plinth = Material::Lambert {
        albedo: Rgb::grey(0.7),
    };
    let chrome = Material::Ggx {
        alpha: 0.08,
        specular: 0.95,
    };
    let brushed = Material::Ggx {
        alpha: 0.1,
        specular: 0.9,
    };
    let v = |x, y, z| Vec3::new(x, y, z);
    let (h, top) = (HALF, HEIGHT);
    let mut t = Vec::new();
    // Floor, ceiling and the four walls (corners in order around each quad).
    let sides = [
        [v(-h, 0., -h), v(h, 0., -h), v(h, 0., h), v(-h, 0., h)],
        [v(-h, top, -h), v(h, top, -h), v(h, top, h), v(-h, top, h)],
        [v(-h, 0., -h), v(h, 0., -h), v(h, top, -h), v(-h, top, -h)],
        [v(-h, 0., h), v(h, 0., h), v(h, top, h), v(-h, top, h)],
        [v(-h, 0., -h), v(-h, 0., h), v(-h, top, h), v(-h, top, -h)],
        [v(h, 0., -h), v(h, 0., h), v(h, top, h), v(h, top, -h)],
    ];
    let materials = [floor, ceiling, wall, wall, wall, wall];
    for ([a, b, c, d], m) in sides.into_iter().zip(materials) {
        quad(&mut t, a, b, c, d, m);
    }

    // Turntable and car.
    let deck = 0.12;
    cylinder(&mut t, Vec3::ZERO, Vec3::Y, 2.0, deck, 64, turntable);
    let wheel_r = 0.32;
    for x in [-0.85f32, 0.85] {
        for z in [-1.0f32, 1.0] {
            let base = v(x, deck + wheel_r, z * 0.51);
            cylinder(&mut t, base, v(0.0, 0.0, z), wheel_r, 0.22, 24, tyre);
        }
    }
    let body_y = deck + wheel_r + 0.18;
    superellipsoid(
        &mut t,
        v(0.0, body_y, 0.0),
        v(1.35, 0.3, 0.62),
        6.0,
        64,
        24,
        paint,
    );
    superellipsoid(
        &mut t,
        v(-0.15, body_y + 0.3, 0.0),
        v(0.75, 0.3, 0.55),
        4.0,
        48,
        16,
        glass,
    );

    // Two plinths at the back with a sphere and a torus.
    let plinth_h = 1.2;
    let (sphere_at, torus_at) = (v(-3.4, 0.0, -2.2), v(-0.6, 0.0, -3.4));
    for (at, angle) in [(sphere_at, 0.4), (torus_at, -0.4)] {
        let c = at + v(0.0, plinth_h * 0.5, 0.0);
        cuboid(&mut t, c, v(0.35, plinth_h * 0.5, 0.35), angle, plinth);
    }
    superellipsoid(
        &mut t,
        sphere_at + v(0.0, plinth_h + 0.4, 0.0),
        Vec3::splat(0.4),
        2.0,
        48,
        24,
        chrome,
    );
    torus(
        &mut t,
        torus_at + v(0.0, plinth_h + 0.55, 0.0),
        v(1.0, 0.0, 1.0).normalize(),
        0.42,
        0.13,
        (48, 16),
        brushed,
    );

    // Lights.
    let centres = disk_centres();
    debug_assert_eq!(centres.len(), EXHIBITION_DISKS);
    let mut rng = Pcg64Mcg::seed_from_u64(0xe8_4151);
    let mean = DISKS_POWER / centres.len() as f32;
    let mut lights: Vec<Light> = centres
        .iter()
        .map(|&c| {
            let power = mean * rng.random_range((0.5f32).ln()..(2.0f32).ln()).exp();
            disk_light(c, (AIM - c).normalize(), DISK_RADIUS, power, Rgb::ONE)
        })
        .collect();
    // The panel: PANEL_QUADS.0 × PANEL_QUADS.1 quads, two triangles each, wound so that
    // (v1 − v0) × (v2 − v0) points down.
    let (px, pz, py) = (1.5, 0.9, top - 0.03);
    let radiance = PANEL_POWER / (PI * (2.0 * px) * (2.0 * pz));
    let (nx, nz) = PANEL_QUADS;
    let corner = |i: usize, j: usize| {
        v(
            -px + 2.0 * px * i as f32 / nx as f32,
            py,
            -pz + 2.0 * pz * j as f32 / nz as f32,
        )
    };
    for i in 0..nx {
        for j in 0..nz {
            let (a, b, c, d) = (
                corner(i, j),
                corner(i + 1, j),
                corner(i + 1, j + 1),
                corner(i, j + 1),
            );
            for vertices in [[a, b, c], [a, c, d]] {
                lights.push(Light::Triangle {
                    vertices,
                    radiance: radiance.into(),
                    two_sided: false,
                });
            }
        }
    }
    RenderScene {
        name: "exhibition".into(),
        geometry: Geometry::new(t),
        lights: LightSet::build(lights).expect("the built-in lights are valid"),
        sky: None,
        camera: Camera {
            eye: v(2.6, 1.5, 4.2),
            target: v(0.0, 0.55, 0.0),
            up: v(0.0, 1.0, 0.0),
            fov_y: 45.0,
        },
    }
}
