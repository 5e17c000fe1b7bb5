//! `billboard`: a large emissive triangle mesh, a video wall showing a picture, over a glossy
//! plaza with two glossy cars.

use super::geometry::{cuboid, cylinder, disk_light, quad, sphere_light, superellipsoid};
use super::geometry::{Geometry, Triangle};
use super::{Camera, LightSet, Palette, RenderScene};
use glam::Vec3;
use manylights::{Light, Material, Rgb};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// The video wall's quads along x and y (two triangle lights each).
const SCREEN_QUADS: (usize, usize) = (64, 48);
/// Number of triangle lights of `billboard`'s video wall.
pub const BILLBOARD_SCREEN_TRIANGLES: usize = 2 * SCREEN_QUADS.0 * SCREEN_QUADS.1;
/// Street lamps around the plaza.
const LAMPS: usize = 8;
/// Number of lights of `billboard`: the video wall's triangles, the street lamps and the two
/// cars' headlights.
pub const BILLBOARD_LIGHTS: usize = BILLBOARD_SCREEN_TRIANGLES + LAMPS + 4;

/// The video wall's width and height (m).
const SCREEN_SIZE: (f32, f32) = (12.0, 9.0);
/// Height of the video wall's lower edge.
const SCREEN_BOTTOM: f32 = 2.5;
/// The video wall's plane (z); it faces +z.
const SCREEN_Z: f32 = -12.0;
/// The video wall's mean radiance (luminance) scale.
const SCREEN_RADIANCE: f32 = 3.0;
/// Power of a street lamp.
const LAMP_POWER: f32 = 150.0;
/// Power of a headlight.
const HEADLIGHT_POWER: f32 = 30.0;

/// `a + (b − a) t`, per channel.
fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    a * (1.0 - t) + b * t
}

/// The picture on the video wall at `(u, v)` in `[0, 1]²` (v up), linear RGB: a sunset over
/// mountains (a sky from orange to deep blue, a sun, two ridges), a red ticker along the
/// bottom with white blocks of "text". Every channel is positive.
fn picture(u: f32, v: f32) -> Rgb {
    let ticker = 0.12;
    if v < ticker {
        // White blocks on red: "letters" 3 quads wide with a gap, two lines.
        let col = (u * 64.0) as usize;
        let line = (v / ticker * 6.0) as usize;
        let on = line % 3 != 0 && col % 4 != 3 && (super::hash((col / 4) as u64 + 7) % 5) != 0;
        return if on {
            Rgb::new(1.0, 1.0, 0.95)
        } else {
            Rgb::new(0.7, 0.04, 0.03)
        };
    }
    let sky_v = (v - ticker) / (1.0 - ticker);
    let sky = mix(
        Rgb::new(1.0, 0.45, 0.12),
        Rgb::new(0.12, 0.22, 0.75),
        sky_v.powf(0.7),
    );
    let (su, sv, sr) = (0.68, 0.5, 0.11);
    let d = ((u - su) * 4.0 / 3.0).hypot(sky_v - sv);
    let mut c = if d < sr {
        Rgb::new(1.0, 0.85, 0.4) * 2.5
    } else {
        // A halo around the sun.
        sky + Rgb::new(1.0, 0.6, 0.25) * (0.6 * (-(d - sr) * 8.0).exp())
    };
    let far_ridge = 0.32 + 0.08 * (u * 9.0).sin() + 0.04 * (u * 23.0 + 1.0).sin();
    let near_ridge = 0.2 + 0.1 * (u * 5.0 + 2.0).sin() + 0.03 * (u * 31.0).sin();
    if sky_v < near_ridge {
        c = Rgb::new(0.03, 0.02, 0.05);
    } else if sky_v < far_ridge {
        c = Rgb::new(0.2, 0.1, 0.25);
    }
    c
}

/// A plaza at night before a video wall, in colour (see [`billboard_with`]): a 12 × 9 m wall
/// of 64 × 48 quads ([`BILLBOARD_SCREEN_TRIANGLES`] one-sided triangle lights, 2.5 m above
/// the ground, facing the plaza) showing a picture (a sunset over mountains above a ticker;
/// radiance three times the picture's linear colour), on a dark backing box. Before it a
/// glossy GGX plaza (α 0.02), two glossy cars (plastic paint, GGX α 0.05, on dark wheels)
/// with two headlights each (one-sided disks, power 30), a row of low concrete blocks and 8
/// street lamps (spheres of radius 0.2 at 5 m, power 150) along the plaza's sides:
/// [`BILLBOARD_LIGHTS`] lights. The camera looks at the wall across the plaza, its
/// reflection in the ground and on the cars.
pub fn billboard() -> RenderScene {
    billboard_with(Palette::Colour)
}

/// [`billboard`] in `palette`: in colour the wall shows its picture in colour, the cars are
/// red and blue, the lamps sodium orange; in grey every light has the luminance of its
/// colour and every albedo is grey.
pub fn billboard_with(palette: Palette) -> RenderScene {
    let ground = Material::Ggx {
        alpha: 0.02,
        specular: 0.7,
    };
    let backing = Material::Lambert {
        albedo: Rgb::grey(0.04),
    };
    let concrete = Material::Lambert {
        albedo: palette.albedo_of(0.45, Rgb::new(1.0, 0.97, 0.92)),
    };
    let building = Material::Lambert {
        albedo: palette.albedo_of(0.3, Rgb::new(0.85, 0.9, 1.0)),
    };
    let tyre = Material::Lambert {
        albedo: Rgb::grey(0.04),
    };
    let chrome = Material::Ggx {
        alpha: 0.05,
        specular: 0.9,
    };
    let v = |x, y, z| Vec3::new(x, y, z);
    let mut rng = Pcg64Mcg::seed_from_u64(0xb111_b0a2d);
    let mut t: Vec<Triangle> = Vec::new();

    // Ground, the building the wall hangs on, the wall's backing box.
    let e = 40.0;
    quad(
        &mut t,
        v(-e, 0.0, -e),
        v(e, 0.0, -e),
        v(e, 0.0, e),
        v(-e, 0.0, e),
        ground,
    );
    cuboid(
        &mut t,
        v(0.0, 10.0, SCREEN_Z - 4.6),
        v(14.0, 10.0, 4.0),
        0.0,
        building,
    );
    let (sw, sh) = SCREEN_SIZE;
    cuboid(
        &mut t,
        v(0.0, SCREEN_BOTTOM + sh * 0.5, SCREEN_Z - 0.32),
        v(sw * 0.5 + 0.3, sh * 0.5 + 0.3, 0.3),
        0.0,
        backing,
    );

    // Concrete blocks in a row before the wall.
    for k in 0..7 {
        let x = -9.0 + 3.0 * k as f32 + rng.random_range(-0.3f32..0.3);
        cuboid(
            &mut t,
            v(x, 0.25, -6.0),
            v(0.8, 0.25, 0.4),
            rng.random_range(-0.2f32..0.2),
            concrete,
        );
    }

    // Two cars: a rounded body and cabin (plastic paint), four wheels.
    let mut lights: Vec<Light> = Vec::new();
    let cars = [
        (v(-4.2, 0.0, 4.0), 0.5f32, Rgb::new(1.0, 0.12, 0.08)),
        (v(4.2, 0.0, 6.5), -0.7f32, Rgb::new(0.15, 0.3, 1.0)),
    ];
    for (k, &(at, angle, hue)) in cars.iter().enumerate() {
        let paint = Material::Plastic {
            albedo: palette.albedo_of(0.12 + 0.1 * k as f32, hue),
            specular: 0.8,
            alpha: 0.05,
        };
        // The car's frame: `fwd` along its length (x before turning), `side` across.
        let (s, c) = angle.sin_cos();
        let fwd = v(c, 0.0, -s);
        let side = v(s, 0.0, c);
        let wheel_r = 0.33;
        for a in [-1.3f32, 1.3] {
            for b in [-1.0f32, 1.0] {
                let base = at + fwd * a + side * (b * 0.62) + v(0.0, wheel_r, 0.0);
                cylinder(&mut t, base, side * b, wheel_r, 0.2, 20, tyre);
            }
        }
        let body_y = wheel_r + 0.35;
        let mut body = Vec::new();
        superellipsoid(
            &mut body,
            Vec3::ZERO,
            v(2.2, 0.38, 0.85),
            6.0,
            48,
            20,
            paint,
        );
        superellipsoid(
            &mut body,
            v(-0.3, 0.42, 0.0),
            v(1.2, 0.36, 0.75),
            4.0,
            40,
            14,
            chrome,
        );
        // Turn the body by `angle` about y and move it to the car's place.
        let place = |p: Vec3| at + v(0.0, body_y, 0.0) + fwd * p.x + side * p.z + v(0.0, p.y, 0.0);
        for tri in body {
            t.push(Triangle::new(
                place(tri.v[0]),
                place(tri.v[1]),
                place(tri.v[2]),
                tri.material,
            ));
        }
        // Headlights: one-sided disks 2 cm before the body's front, facing forward and a
        // little down.
        let head = (fwd - v(0.0, 0.12, 0.0)).normalize();
        for b in [-0.55f32, 0.55] {
            let p = at + v(0.0, body_y, 0.0) + fwd * 2.22 + side * b;
            lights.push(disk_light(
                p,
                head,
                0.09,
                HEADLIGHT_POWER,
                palette.tint(Rgb::new(1.0, 0.96, 0.88)),
            ));
        }
    }

    // Street lamps along the plaza's sides, on poles.
    for k in 0..LAMPS {
        let side = if k % 2 == 0 { -1.0f32 } else { 1.0 };
        let z = -8.0 + 6.0 * (k / 2) as f32;
        let base = v(side * 12.0, 0.0, z);
        cuboid(
            &mut t,
            base + v(0.0, 2.3, 0.0),
            v(0.06, 2.3, 0.06),
            0.0,
            chrome,
        );
        lights.push(sphere_light(
            base + v(0.0, 5.0, 0.0),
            0.2,
            LAMP_POWER * rng.random_range(0.8f32..1.25),
            palette.tint(Rgb::new(1.0, 0.72, 0.4)),
        ));
    }

    // The video wall: quads of the picture's colour at their centres, wound to face +z.
    let (nx, ny) = SCREEN_QUADS;
    let corner = |i: usize, j: usize| {
        v(
            -sw * 0.5 + sw * i as f32 / nx as f32,
            SCREEN_BOTTOM + sh * j as f32 / ny as f32,
            SCREEN_Z,
        )
    };
    for j in 0..ny {
        for i in 0..nx {
            let colour = picture((i as f32 + 0.5) / nx as f32, (j as f32 + 0.5) / ny as f32);
            let radiance = match palette {
                Palette::Colour => colour * SCREEN_RADIANCE,
                Palette::Grey => Rgb::grey(colour.luminance() * SCREEN_RADIANCE),
            };
            let (a, b, c, d) = (
                corner(i, j),
                corner(i + 1, j),
                corner(i + 1, j + 1),
                corner(i, j + 1),
            );
            for vertices in [[a, b, c], [a, c, d]] {
                lights.push(Light::Triangle {
                    vertices,
                    radiance,
                    two_sided: false,
                });
            }
        }
    }
    debug_assert_eq!(lights.len(), BILLBOARD_LIGHTS);

    RenderScene {
        name: "billboard".into(),
        geometry: Geometry::new(t),
        lights: LightSet::build(lights).expect("the built-in lights are valid"),
        sky: None,
        camera: Camera {
            eye: v(1.5, 4.0, 14.0),
            target: v(0.0, 2.5, -6.0),
            up: v(0.0, 1.0, 0.0),
            fov_y: 50.0,
        },
    }
}
