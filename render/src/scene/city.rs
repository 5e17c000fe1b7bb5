//! `city`: a night city, a grid of buildings along wet streets, lit by thousands of small
//! lights: street lamps, car lights and lit windows.

use super::geometry::{cuboid, disk_light, quad, sphere_light, Geometry, Triangle};
use super::{hash, Camera, LightSet, Palette, RenderScene};
use glam::Vec3;
use manylights::light::GradientSky;
use manylights::Rgb;
use manylights::{BuildOptions, Light, Material, Serial};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f32::consts::FRAC_PI_2;

/// Number of lights of `city`.
pub const CITY_LIGHTS: usize = 8000;

/// Blocks per side of the grid.
const BLOCKS: usize = 10;
/// Block size (sidewalk edge to sidewalk edge).
const BLOCK: f32 = 20.0;
/// Street width.
const STREET: f32 = 12.0;
/// Block centre to next block centre.
const PITCH: f32 = BLOCK + STREET;
/// Height of the sidewalks.
const CURB: f32 = 0.15;
/// Number of cars (four lights each).
const CARS: usize = 600;
/// Street lamps per block side.
const LAMPS_PER_SIDE: usize = 3;
/// Power of a street lamp.
const LAMP_POWER: f32 = 400.0;
/// Power of a headlight (a tail light has a quarter).
const HEADLIGHT_POWER: f32 = 60.0;
/// Power scale of a lit window (powers are log-uniform in [0.3, 3] × this).
const WINDOW_POWER: f32 = 40.0;

/// Centre of block (or street crossing) coordinate `i` along one axis.
fn block_centre(i: usize) -> f32 {
    (i as f32 - (BLOCKS as f32 - 1.0) * 0.5) * PITCH
}

/// A log-uniform number in `[lo, hi]`.
fn log_uniform(rng: &mut Pcg64Mcg, lo: f32, hi: f32) -> f32 {
    rng.random_range(lo.ln()..hi.ln()).exp()
}

/// A colour of `palette` chosen by `key`.
fn pick(palette: &[Rgb], key: u64) -> Rgb {
    palette[(hash(key) % palette.len() as u64) as usize]
}

/// Hues of the Lambert façades: brick, sand, concrete, ochre.
const FACADE_HUES: [Rgb; 4] = [
    Rgb::new(1.0, 0.75, 0.6),
    Rgb::new(1.0, 0.93, 0.75),
    Rgb::new(0.95, 0.97, 1.0),
    Rgb::new(1.0, 0.85, 0.55),
];
/// Hues of the cars: red, blue, white, silver, green, yellow.
const CAR_HUES: [Rgb; 6] = [
    Rgb::new(1.0, 0.15, 0.1),
    Rgb::new(0.2, 0.35, 1.0),
    Rgb::new(1.0, 1.0, 1.0),
    Rgb::new(0.9, 0.93, 1.0),
    Rgb::new(0.3, 0.8, 0.4),
    Rgb::new(1.0, 0.85, 0.2),
];
/// Colours of the lit windows: incandescent, neutral, fluorescent, television blue, yellow.
const WINDOW_COLOURS: [Rgb; 5] = [
    Rgb::new(1.0, 0.75, 0.45),
    Rgb::new(1.0, 0.92, 0.8),
    Rgb::new(0.75, 0.85, 1.0),
    Rgb::new(0.55, 0.65, 1.0),
    Rgb::new(1.0, 0.85, 0.5),
];
/// A street lamp's colour (high-pressure sodium).
const LAMP_COLOUR: Rgb = Rgb::new(1.0, 0.72, 0.4);
/// A headlight's colour.
const HEADLIGHT_COLOUR: Rgb = Rgb::new(1.0, 0.96, 0.88);
/// A tail light's colour.
const TAIL_COLOUR: Rgb = Rgb::new(1.0, 0.1, 0.06);

/// A building.
struct Building {
    /// Centre of its footprint (on the sidewalk).
    centre: Vec3,
    /// Half width in x, height, half depth in z.
    half: Vec3,
}

/// The city: 10 × 10 blocks of 20 m (raised sidewalks) between 12 m streets, one building
/// per block (footprint 13 to 17 m, height log-uniform in 10 to 70 m, Lambert façades of
/// albedo 0.3 to 0.7 or, one in three, glossy glass façades), 600 cars (glossy boxes) in the
/// lanes, and [`CITY_LIGHTS`] lights:
/// - 1,200 street lamps: spheres of radius 0.25 on poles at 7 m, three per block side;
/// - 2,400 car lights: two headlights (radius 0.1, tilted a little down) and two dimmer tail
///   lights (radius 0.08) per car, one-sided disks just off the car's front and back, facing
///   away from it;
/// - 4,400 lit windows: one-sided disks of radius 0.6 just off the façades facing out, chosen
///   at random among the window slots (3.5 m floors, 2.5 m apart), powers log-uniform.
///
/// The streets are wet (plastic, GGX α 0.15), the glass façades plastic with GGX α 0.1, the
/// cars plastic with GGX α 0.07. The camera looks down the middle street (along −z) from
/// above the +z edge of the city. Everything is placed with a fixed seed. In colour:
/// [`city_with`].
pub fn city() -> RenderScene {
    city_with(Palette::Colour)
}

/// [`city`] in `palette`: in colour the street lamps are sodium orange, windows incandescent,
/// neutral, fluorescent or television blue, headlights warm white and tail lights red (each
/// of the luminance of its grey power); façades, cars, sidewalks and glass are tinted.
pub fn city_with(palette: Palette) -> RenderScene {
    let street = Material::Plastic {
        albedo: palette.albedo_of(0.08, Rgb::new(0.95, 1.0, 1.05)),
        specular: 0.5,
        alpha: 0.15,
    };
    let sidewalk = Material::Lambert {
        albedo: palette.albedo_of(0.35, Rgb::new(1.0, 0.97, 0.9)),
    };
    let pole = Material::Ggx {
        alpha: 0.2,
        specular: 0.6,
    };
    let glass = Material::Plastic {
        albedo: palette.albedo_of(0.08, Rgb::new(0.6, 0.95, 1.3)),
        specular: 0.7,
        alpha: 0.1,
    };
    let v = |x, y, z| Vec3::new(x, y, z);
    let mut rng = Pcg64Mcg::seed_from_u64(0xc1_7e5);
    let mut t: Vec<Triangle> = Vec::new();
    let extent = PITCH * BLOCKS as f32 * 0.5 + 40.0;
    quad(
        &mut t,
        v(-extent, 0.0, -extent),
        v(extent, 0.0, -extent),
        v(extent, 0.0, extent),
        v(-extent, 0.0, extent),
        street,
    );

    // Blocks, buildings and street lamps.
    let mut buildings = Vec::new();
    let mut lights: Vec<Light> = Vec::new();
    let lamp_inset = 0.7;
    let lamp_height = 7.0;
    let lamp_radius = 0.25;
    for i in 0..BLOCKS {
        for j in 0..BLOCKS {
            let (cx, cz) = (block_centre(i), block_centre(j));
            let hb = BLOCK * 0.5;
            cuboid(
                &mut t,
                v(cx, CURB * 0.5, cz),
                v(hb, CURB * 0.5, hb),
                0.0,
                sidewalk,
            );
            let half = v(
                rng.random_range(6.5f32..8.5),
                0.0,
                rng.random_range(6.5f32..8.5),
            );
            let height = log_uniform(&mut rng, 10.0, 70.0);
            let facade = if rng.random_range(0.0f32..1.0) < 1.0 / 3.0 {
                glass
            } else {
                let a = rng.random_range(0.3f32..0.7);
                Material::Lambert {
                    albedo: palette.albedo_of(a, pick(&FACADE_HUES, (i * BLOCKS + j) as u64)),
                }
            };
            let centre = v(cx, CURB, cz);
            cuboid(
                &mut t,
                centre + v(0.0, height * 0.5, 0.0),
                v(half.x, height * 0.5, half.z),
                0.0,
                facade,
            );
            buildings.push(Building {
                centre,
                half: v(half.x, height, half.z),
            });
            let e = hb - lamp_inset;
            for k in 0..LAMPS_PER_SIDE {
                let s = (k as f32 + 0.5) / LAMPS_PER_SIDE as f32 * 2.0 * e - e;
                for (dx, dz) in [(s, -e), (s, e), (-e, s), (e, s)] {
                    let base = v(cx + dx, CURB, cz + dz);
                    let top = lamp_height - lamp_radius - 0.15;
                    cuboid(
                        &mut t,
                        base + v(0.0, top * 0.5, 0.0),
                        v(0.06, top * 0.5, 0.06),
                        0.0,
                        pole,
                    );
                    lights.push(sphere_light(
                        v(base.x, lamp_height, base.z),
                        lamp_radius,
                        LAMP_POWER * rng.random_range(0.8f32..1.25),
                        palette.tint(LAMP_COLOUR),
                    ));
                }
            }
        }
    }

    // Cars: in the lanes (3 m either side of a street's middle, driving on the right), three
    // slots per lane along each block span (none in a crossing), 600 of the slots taken.
    let streets = BLOCKS - 1;
    let (car_half, car_y) = (v(0.9, 0.65, 2.2), 0.8);
    let mut car_slots: Vec<(bool, usize, usize, f32, f32)> = Vec::new();
    for along_x in [false, true] {
        for street in 0..streets {
            for span in 0..BLOCKS {
                for forward in [-1.0f32, 1.0] {
                    for offset in [-6.5f32, 0.0, 6.5] {
                        car_slots.push((along_x, street, span, forward, offset));
                    }
                }
            }
        }
    }
    for k in 0..CARS.min(car_slots.len()) {
        let r = rng.random_range(k..car_slots.len());
        car_slots.swap(k, r);
        let (along_x, street, span, forward, offset) = car_slots[k];
        let s = block_centre(street) + PITCH * 0.5;
        let u = block_centre(span) + offset + rng.random_range(-0.5f32..0.5);
        // Right-hand traffic: the lane is to the right of the direction of travel.
        let lane = 3.0 * forward;
        let (centre, dir, side) = if along_x {
            (v(u, car_y, s + lane), v(forward, 0.0, 0.0), Vec3::Z)
        } else {
            (v(s - lane, car_y, u), v(0.0, 0.0, forward), Vec3::X)
        };
        let angle = if along_x { FRAC_PI_2 } else { 0.0 };
        let a = rng.random_range(0.05f32..0.6);
        let paint = Material::Plastic {
            albedo: palette.albedo_of(a, pick(&CAR_HUES, 1_000_000 + k as u64)),
            specular: 0.6,
            alpha: 0.07,
        };
        cuboid(&mut t, centre, car_half, angle, paint);
        // One-sided disks 2 cm off the car's front and back, facing away from it (the car's
        // own faces are behind them); the headlights tilted a little down to the street.
        let head = (dir - v(0.0, 0.15, 0.0)).normalize();
        for w in [-0.6f32, 0.6] {
            let front = centre + dir * (car_half.z + 0.02) + side * w - v(0.0, 0.1, 0.0);
            let back = centre - dir * (car_half.z + 0.02) + side * w;
            let (head_tint, tail_tint) =
                (palette.tint(HEADLIGHT_COLOUR), palette.tint(TAIL_COLOUR));
            lights.push(disk_light(front, head, 0.1, HEADLIGHT_POWER, head_tint));
            lights.push(disk_light(
                back,
                -dir,
                0.08,
                HEADLIGHT_POWER * 0.25,
                tail_tint,
            ));
        }
    }

    // Window slots on every façade; as many as the light budget has left are lit.
    let mut slots: Vec<(Vec3, Vec3)> = Vec::new();
    let off = 0.08;
    for b in &buildings {
        let (c, h) = (b.centre, b.half);
        let mut y = 3.0;
        while y < h.y - 2.0 {
            for (normal, half_len) in [
                (Vec3::X, h.z),
                (Vec3::NEG_X, h.z),
                (Vec3::Z, h.x),
                (Vec3::NEG_Z, h.x),
            ] {
                let along = if normal.x != 0.0 { Vec3::Z } else { Vec3::X };
                let dist = if normal.x != 0.0 { h.x } else { h.z };
                let mut s = -half_len + 1.5;
                while s <= half_len - 1.5 {
                    let p = c + normal * (dist + off) + along * s + v(0.0, y, 0.0);
                    slots.push((p, normal));
                    s += 2.5;
                }
            }
            y += 3.5;
        }
    }
    let windows = CITY_LIGHTS.saturating_sub(lights.len()).min(slots.len());
    // Partial Fisher–Yates: the first `windows` slots are a uniform random choice.
    for k in 0..windows {
        let r = rng.random_range(k..slots.len());
        slots.swap(k, r);
    }
    for (k, &(p, normal)) in slots[..windows].iter().enumerate() {
        let power = WINDOW_POWER * log_uniform(&mut rng, 0.3, 3.0);
        let tint = palette.tint(pick(&WINDOW_COLOURS, 2_000_000 + k as u64));
        lights.push(disk_light(p, normal, 0.6, power, tint));
    }

    RenderScene {
        name: "city".into(),
        geometry: Geometry::new(t),
        lights: LightSet::build(lights).expect("the built-in lights are valid"),
        sky: None,
        camera: Camera {
            eye: v(4.0, 24.0, block_centre(BLOCKS - 1) + 30.0),
            target: v(0.0, 2.0, block_centre(BLOCKS / 2)),
            up: v(0.0, 1.0, 0.0),
            fov_y: 50.0,
        },
    }
}

/// The name of a material of [`city`] by its kind and glossy lobe (the albedo aside): the
/// classes of `compare`'s error split by material. `None` for a material the city does not
/// use.
pub(crate) fn material_name(material: &Material) -> Option<&'static str> {
    match *material {
        Material::Lambert { .. } => Some("sidewalks and stone façades"),
        Material::Plastic {
            specular, alpha, ..
        } if (specular, alpha) == (0.5, 0.15) => Some("wet street"),
        Material::Plastic {
            specular, alpha, ..
        } if (specular, alpha) == (0.7, 0.1) => Some("glass façades"),
        Material::Plastic {
            specular, alpha, ..
        } if (specular, alpha) == (0.6, 0.07) => Some("cars"),
        Material::Ggx { alpha, specular } if (specular, alpha) == (0.6, 0.2) => Some("lamp poles"),
        _ => None,
    }
}

/// The direction towards the sun of `city-sun`: 12° above the horizon (+y up), from the
/// west-south-west of the grid, so that the sunlit façades, the long shadows of the
/// buildings and the streets in their shade are all in view.
pub const CITY_SUN_DIRECTION: Vec3 = Vec3::new(-0.8, 0.208, -0.42);
/// The sun's angular radius: 0.27°.
const SUN_RADIUS: f32 = 0.27 * std::f32::consts::PI / 180.0;
/// The sun's irradiance at normal incidence: a low, reddened sun of luminance 4.2 W/m².
const SUN_IRRADIANCE: Rgb = Rgb::new(6.0, 3.8, 2.1);

/// `city` at dusk in `palette`: the 8,000 lamps, a low sun ([`CITY_SUN_DIRECTION`], angular
/// radius 0.27°, irradiance (6, 3.8, 2.1) W/m²) and a dusk sky ([`GradientSky`] about +y:
/// deep blue at the zenith, warm at the horizon, black below), the sky an environment light
/// of the light set. At this sun the lamps under their poles and the lit windows are as
/// bright as the sun on the streets, and the shaded streets are lit by the lamps and the sky
/// alone: lights at infinity and thousands of local lights in one scene. In grey the sun and
/// sky have the luminance of their colours.
pub fn city_sun(palette: Palette) -> RenderScene {
    let city = city_with(palette);
    let tint = |c: Rgb| match palette {
        Palette::Colour => c,
        Palette::Grey => Rgb::grey(c.luminance()),
    };
    let sky = GradientSky {
        up: Vec3::Y,
        zenith: tint(Rgb::new(0.08, 0.14, 0.36)),
        horizon: tint(Rgb::new(0.44, 0.32, 0.26)),
        ground: Rgb::ZERO,
    };
    let mut lights = city.lights.lights().to_vec();
    lights.push(Light::Distant {
        direction: CITY_SUN_DIRECTION,
        angular_radius: SUN_RADIUS,
        irradiance: tint(SUN_IRRADIANCE),
    });
    RenderScene {
        name: "city-sun".into(),
        // The sky is the set's last light.
        lights: LightSet::build_with_environment(lights, sky, &BuildOptions::default(), &Serial)
            .expect("the built-in lights are valid"),
        sky: Some(sky),
        ..city
    }
}
