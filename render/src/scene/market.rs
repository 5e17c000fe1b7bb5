//! `market`: a covered night market, lights of very different power side by side: strings of
//! tiny bulbs and bare stall lamps beside large dim ceiling panels and a window.

use super::geometry::{cuboid, disk_light, quad, sphere_light, Geometry, Triangle};
use super::{hash, Camera, LightSet, Palette, RenderScene};
use glam::Vec3;
use manylights::{Light, Material, Rgb};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f32::consts::PI;

/// Strings of bulbs across the hall, and bulbs on each.
const STRINGS: (usize, usize) = (48, 56);
/// Stalls on each side of the aisle.
const STALLS_PER_ROW: usize = 10;
/// The large dim ceiling panels along x and z.
const PANELS: (usize, usize) = (3, 8);
/// The window's quads along x and y (two triangle lights each).
const WINDOW_QUADS: (usize, usize) = (8, 4);
/// Number of lights of `market`: the bulbs of the strings, a lamp and a two-triangle sign per
/// stall, the ceiling panels and the window's triangles.
pub const MARKET_LIGHTS: usize = STRINGS.0 * STRINGS.1
    + 2 * STALLS_PER_ROW * 3
    + PANELS.0 * PANELS.1
    + 2 * WINDOW_QUADS.0 * WINDOW_QUADS.1;

/// Half width of the hall (x).
const HALF_WIDTH: f32 = 10.0;
/// The hall's far end (z); the near end is at `NEAR`.
const FAR: f32 = -32.0;
/// The hall's near end (z), behind the camera.
const NEAR: f32 = 2.0;
/// Ceiling height.
const HEIGHT: f32 = 8.0;
/// Half width of the aisle between the stall rows (x).
const AISLE: f32 = 3.0;
/// Radius of a bulb of the strings.
const BULB_RADIUS: f32 = 0.008;
/// Radius of a stall lamp.
const LAMP_RADIUS: f32 = 0.025;

/// Colours of the bulbs: warm white (three in seven), red, green, blue, yellow.
const BULB_COLOURS: [Rgb; 7] = [
    Rgb::new(1.0, 0.78, 0.5),
    Rgb::new(1.0, 0.78, 0.5),
    Rgb::new(1.0, 0.78, 0.5),
    Rgb::new(1.0, 0.15, 0.1),
    Rgb::new(0.2, 1.0, 0.3),
    Rgb::new(0.25, 0.4, 1.0),
    Rgb::new(1.0, 0.85, 0.2),
];
/// Hues of the awnings and signs: red, green, blue, orange, white, violet.
const STALL_HUES: [Rgb; 6] = [
    Rgb::new(1.0, 0.2, 0.15),
    Rgb::new(0.3, 0.85, 0.35),
    Rgb::new(0.25, 0.45, 1.0),
    Rgb::new(1.0, 0.6, 0.15),
    Rgb::new(1.0, 1.0, 1.0),
    Rgb::new(0.7, 0.35, 1.0),
];
/// Hues of the produce on the counters.
const PRODUCE_HUES: [Rgb; 5] = [
    Rgb::new(1.0, 0.3, 0.1),
    Rgb::new(1.0, 0.8, 0.1),
    Rgb::new(0.4, 0.9, 0.2),
    Rgb::new(0.9, 0.5, 0.3),
    Rgb::new(0.6, 0.2, 0.5),
];
/// A stall lamp's colour (incandescent).
const LAMP_COLOUR: Rgb = Rgb::new(1.0, 0.72, 0.42);
/// The ceiling panels' colour (neutral white).
const PANEL_COLOUR: Rgb = Rgb::new(0.92, 0.96, 1.0);
/// The window's colour (the sky at dusk).
const WINDOW_COLOUR: Rgb = Rgb::new(0.5, 0.62, 1.0);

/// Power range of a bulb (log-uniform).
const BULB_POWER: (f32, f32) = (0.1, 1.0);
/// Power range of a stall lamp (log-uniform).
const LAMP_POWER: (f32, f32) = (30.0, 100.0);
/// Power of a ceiling panel.
const PANEL_POWER: f32 = 12.0;
/// Power of a sign (its two triangles together).
const SIGN_POWER: f32 = 3.0;
/// Power of the window (its triangles together).
const WINDOW_POWER: f32 = 1500.0;

/// A colour of `palette` chosen by `key`.
fn pick(palette: &[Rgb], key: u64) -> Rgb {
    palette[(hash(key) % palette.len() as u64) as usize]
}

/// A log-uniform number in `[lo, hi]`.
fn log_uniform(rng: &mut Pcg64Mcg, (lo, hi): (f32, f32)) -> f32 {
    rng.random_range(lo.ln()..hi.ln()).exp()
}

/// A box spanning `lo` to `hi` (corners).
fn slab(t: &mut Vec<Triangle>, lo: Vec3, hi: Vec3, m: Material) {
    cuboid(t, (lo + hi) * 0.5, (hi - lo) * 0.5, 0.0, m);
}

/// The two one-sided triangle lights of the rectangle `a b c d` (in order around it), of
/// radiance `radiance`, emitting on the side of `(b − a) × (c − a)`.
fn quad_light(out: &mut Vec<Light>, [a, b, c, d]: [Vec3; 4], radiance: Rgb) {
    for vertices in [[a, b, c], [a, c, d]] {
        out.push(Light::Triangle {
            vertices,
            radiance,
            two_sided: false,
        });
    }
}

/// The market hall, 20 × 34 × 8 m, in colour (see [`market_with`]): a glossy floor
/// (polished concrete, plastic with GGX α 0.03), Lambert brick walls, two rows of ten stalls
/// along a 6 m aisle (counters, Lambert or brushed-metal GGX tops, crates of produce, posts,
/// back boards, slanted awnings, a sign board above each awning).
///
/// Lights, [`MARKET_LIGHTS`] of powers spanning three decades (0.1 to 100):
/// - 2,688 bulbs, spheres of radius 8 mm, on 48 strings sagging across the hall 0.6 m apart
///   (56 bulbs each, at 4.3 to 5 m), powers log-uniform in [0.1, 1]: radiance 50 to 470 times
///   that of the panels;
/// - 20 stall lamps, bare bulbs of radius 2.5 cm under the awnings, powers log-uniform in
///   [30, 100]: radiance 1,400 to 4,800 times that of the panels;
/// - 20 signs, dim one-sided rectangles (two triangles each, power 3) on the awnings' fronts,
///   facing the aisle;
/// - 24 large dim ceiling panels, one-sided disks of radius 1.2 facing down, power 12 each;
/// - a window at the far end, 14 × 5 m facing in, power 1,500 as 64 one-sided triangle
///   lights.
///
/// The camera stands at the near end and looks down the aisle to the window. Everything is
/// placed with a fixed seed.
pub fn market() -> RenderScene {
    market_with(Palette::Colour)
}

/// [`market`] in `palette`: in colour the bulbs are warm white, red, green, blue or yellow,
/// the lamps incandescent, the panels neutral, the window dusk blue, the awnings, signs and
/// produce coloured (chosen by index); in grey every light and albedo is grey.
pub fn market_with(palette: Palette) -> RenderScene {
    let floor = Material::Plastic {
        albedo: palette.albedo_of(0.3, Rgb::new(1.0, 0.97, 0.92)),
        specular: 0.5,
        alpha: 0.03,
    };
    let brick = Material::Lambert {
        albedo: palette.albedo_of(0.35, Rgb::new(1.0, 0.62, 0.48)),
    };
    let ceiling = Material::Lambert {
        albedo: Rgb::grey(0.4),
    };
    let wood = Material::Lambert {
        albedo: palette.albedo_of(0.35, Rgb::new(1.0, 0.78, 0.55)),
    };
    let metal = Material::Ggx {
        alpha: 0.12,
        specular: 0.8,
    };
    let post = Material::Ggx {
        alpha: 0.25,
        specular: 0.5,
    };
    let v = |x, y, z| Vec3::new(x, y, z);
    let mut rng = Pcg64Mcg::seed_from_u64(0x3a_4e7);
    let mut t: Vec<Triangle> = Vec::new();
    let (w, h) = (HALF_WIDTH, HEIGHT);

    // The hall.
    quad(
        &mut t,
        v(-w, 0.0, FAR),
        v(w, 0.0, FAR),
        v(w, 0.0, NEAR),
        v(-w, 0.0, NEAR),
        floor,
    );
    quad(
        &mut t,
        v(-w, h, FAR),
        v(w, h, FAR),
        v(w, h, NEAR),
        v(-w, h, NEAR),
        ceiling,
    );
    for [a, b, c, d] in [
        [v(-w, 0., FAR), v(w, 0., FAR), v(w, h, FAR), v(-w, h, FAR)],
        [
            v(-w, 0., NEAR),
            v(w, 0., NEAR),
            v(w, h, NEAR),
            v(-w, h, NEAR),
        ],
        [
            v(-w, 0., FAR),
            v(-w, 0., NEAR),
            v(-w, h, NEAR),
            v(-w, h, FAR),
        ],
        [v(w, 0., FAR), v(w, 0., NEAR), v(w, h, NEAR), v(w, h, FAR)],
    ] {
        quad(&mut t, a, b, c, d, brick);
    }

    let mut lights: Vec<Light> = Vec::new();

    // Stalls: side s = −1 (left) and +1 (right), their fronts on the aisle.
    let pitch = (FAR + 2.0 - (NEAR - 3.0)).abs() / STALLS_PER_ROW as f32;
    for stall in 0..2 * STALLS_PER_ROW {
        let s = if stall % 2 == 0 { -1.0f32 } else { 1.0 };
        let zc = NEAR - 3.0 - pitch * ((stall / 2) as f32 + 0.5);
        let key = stall as u64;
        let x = |d: f32| s * (AISLE + d);
        let span = |a: f32, b: f32| (a.min(b), a.max(b));
        let half_len = pitch * 0.5 - 0.15;
        // Counter with its top.
        let (x0, x1) = span(x(0.0), x(1.0));
        slab(
            &mut t,
            v(x0, 0.0, zc - half_len),
            v(x1, 0.95, zc + half_len),
            wood,
        );
        let top = if rng.random_range(0.0f32..1.0) < 0.4 {
            metal
        } else {
            Material::Lambert {
                albedo: palette.albedo_of(0.5, Rgb::new(1.0, 0.9, 0.75)),
            }
        };
        slab(
            &mut t,
            v(x0 - 0.03, 0.95, zc - half_len - 0.03),
            v(x1 + 0.03, 1.0, zc + half_len + 0.03),
            top,
        );
        // Crates of produce on the counter.
        let crates = rng.random_range(2..=4usize);
        for c in 0..crates {
            let cz = zc - half_len + (2.0 * half_len) * (c as f32 + 0.5) / crates as f32;
            let hue = pick(&PRODUCE_HUES, 1000 + key * 8 + c as u64);
            let produce = Material::Lambert {
                albedo: palette.albedo_of(rng.random_range(0.2f32..0.5), hue),
            };
            let ch = rng.random_range(0.12f32..0.25);
            let (cx0, cx1) = span(x(0.2), x(0.8));
            slab(
                &mut t,
                v(cx0, 1.0, cz - 0.25),
                v(cx1, 1.0 + ch, cz + 0.25),
                produce,
            );
        }
        // Back board, posts, awning and sign board.
        let (b0, b1) = span(x(2.5), x(2.6));
        slab(
            &mut t,
            v(b0, 0.0, zc - half_len),
            v(b1, 2.9, zc + half_len),
            wood,
        );
        for dz in [-half_len, half_len] {
            let (p0, p1) = span(x(-0.05), x(0.05));
            slab(
                &mut t,
                v(p0, 0.0, zc + dz - 0.05),
                v(p1, 2.6, zc + dz + 0.05),
                post,
            );
        }
        let awning = Material::Lambert {
            albedo: palette.albedo_of(0.45, pick(&STALL_HUES, key)),
        };
        let (za, zb) = (zc - half_len - 0.1, zc + half_len + 0.1);
        quad(
            &mut t,
            v(x(-0.3), 2.6, za),
            v(x(-0.3), 2.6, zb),
            v(x(2.6), 3.2, zb),
            v(x(2.6), 3.2, za),
            awning,
        );
        let (g0, g1) = span(x(-0.34), x(-0.3));
        slab(
            &mut t,
            v(g0, 2.62, zc - 1.0),
            v(g1, 3.1, zc + 1.0),
            Material::Lambert {
                albedo: Rgb::grey(0.1),
            },
        );
        // The sign: a dim rectangle 1 cm in front of its board, facing the aisle.
        let sx = x(-0.35);
        let corners = [
            v(sx, 2.64, zc - 0.95),
            v(sx, 2.64, zc + 0.95),
            v(sx, 3.08, zc + 0.95),
            v(sx, 3.08, zc - 0.95),
        ];
        // Wound so that the emitting side faces the aisle (−s along x).
        let corners = if s > 0.0 {
            corners
        } else {
            [corners[0], corners[3], corners[2], corners[1]]
        };
        let area = 1.9 * 0.44;
        let tint = palette.tint(pick(&STALL_HUES, 500 + key));
        quad_light(&mut lights, corners, tint * (SIGN_POWER / (PI * area)));
        // The lamp under the awning.
        lights.push(sphere_light(
            v(x(1.1), 2.45, zc + rng.random_range(-0.4f32..0.4)),
            LAMP_RADIUS,
            log_uniform(&mut rng, LAMP_POWER),
            palette.tint(LAMP_COLOUR),
        ));
    }

    // The strings of bulbs across the hall.
    let (n_strings, n_bulbs) = STRINGS;
    for i in 0..n_strings {
        let z = NEAR - 1.0 - 0.6 * i as f32;
        let sag = rng.random_range(0.5f32..0.7);
        for j in 0..n_bulbs {
            let u = (j as f32 + 0.5) / n_bulbs as f32;
            let xb = -w + 0.3 + (2.0 * w - 0.6) * u;
            let y = 5.0 - sag * 4.0 * u * (1.0 - u);
            let tint = palette.tint(pick(&BULB_COLOURS, 10_000 + (i * n_bulbs + j) as u64));
            lights.push(sphere_light(
                v(xb, y, z),
                BULB_RADIUS,
                log_uniform(&mut rng, BULB_POWER),
                tint,
            ));
        }
    }

    // The ceiling panels.
    let (px, pz) = PANELS;
    for i in 0..px {
        for j in 0..pz {
            let x = -w + 2.0 * w * (i as f32 + 0.5) / px as f32;
            let z = FAR + (NEAR - FAR) * (j as f32 + 0.5) / pz as f32;
            lights.push(disk_light(
                v(x, h - 0.03, z),
                Vec3::NEG_Y,
                1.2,
                PANEL_POWER,
                palette.tint(PANEL_COLOUR),
            ));
        }
    }

    // The window: 14 × 5 m on the far wall, 3 cm in front of it, facing in (+z).
    let (wx, wy) = WINDOW_QUADS;
    let (x0, x1, y0, y1) = (-7.0f32, 7.0f32, 1.5f32, 6.5f32);
    let radiance = palette.tint(WINDOW_COLOUR) * (WINDOW_POWER / (PI * (x1 - x0) * (y1 - y0)));
    let corner = |i: usize, j: usize| {
        v(
            x0 + (x1 - x0) * i as f32 / wx as f32,
            y0 + (y1 - y0) * j as f32 / wy as f32,
            FAR + 0.03,
        )
    };
    for i in 0..wx {
        for j in 0..wy {
            quad_light(
                &mut lights,
                [
                    corner(i, j),
                    corner(i + 1, j),
                    corner(i + 1, j + 1),
                    corner(i, j + 1),
                ],
                radiance,
            );
        }
    }
    debug_assert_eq!(lights.len(), MARKET_LIGHTS);

    RenderScene {
        name: "market".into(),
        geometry: Geometry::new(t),
        lights: LightSet::build(lights).expect("the built-in lights are valid"),
        sky: None,
        camera: Camera {
            eye: v(1.2, 1.7, NEAR - 0.8),
            target: v(-0.3, 3.2, FAR),
            up: v(0.0, 1.0, 0.0),
            fov_y: 60.0,
        },
    }
}
