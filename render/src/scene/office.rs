//! `office`: an office floor, rooms off a corridor, each room under a grid of ceiling lights:
//! from any shading point most of the lights are behind walls.

use super::geometry::{cuboid, disk_light, quad, sphere_light, Geometry, Triangle};
use super::{hash, Camera, LightSet, Palette, RenderScene};
use glam::Vec3;
use manylights::{Light, Material, Rgb};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Rooms on each side of the corridor.
const ROOMS_PER_SIDE: usize = 6;
/// Ceiling lights of a room along x and along z.
const ROOM_GRID: (usize, usize) = (10, 10);
/// Lights along the corridor's ceiling.
const CORRIDOR_LIGHTS: usize = 12;
/// Number of lights of `office`: a grid of 10 × 10 in each of the 12 rooms and 12 along the
/// corridor.
pub const OFFICE_LIGHTS: usize = 2 * ROOMS_PER_SIDE * ROOM_GRID.0 * ROOM_GRID.1 + CORRIDOR_LIGHTS;

/// Half width of the corridor (x).
const HALF_CORRIDOR: f32 = 1.5;
/// Wall thickness.
const WALL: f32 = 0.12;
/// Room depth (x, wall to wall) and length along the corridor (z).
const ROOM: (f32, f32) = (6.0, 6.0);
/// Ceiling height.
const HEIGHT: f32 = 3.0;
/// Door width and height.
const DOOR: (f32, f32) = (1.3, 2.2);
/// The corridor runs from `z = LOBBY` (its open end, behind the camera) to the far end wall.
const LOBBY: f32 = 4.0;
/// Power of a room's ceiling light before its room's scale (log-uniform in [0.5, 2]).
const ROOM_LIGHT_POWER: f32 = 4.0;
/// Power of a corridor light.
const CORRIDOR_LIGHT_POWER: f32 = 10.0;
/// One door in this many is closed (a door leaf fills its opening).
const CLOSED_ONE_IN: u32 = 4;

/// Colours of the rooms' lights: warm white, neutral white, cool white.
const LIGHT_COLOURS: [Rgb; 3] = [
    Rgb::new(1.0, 0.82, 0.62),
    Rgb::new(1.0, 0.95, 0.88),
    Rgb::new(0.82, 0.9, 1.0),
];
/// Hues of the rooms' walls: white, pale green, pale blue, cream, pale rose.
const WALL_HUES: [Rgb; 5] = [
    Rgb::new(1.0, 1.0, 1.0),
    Rgb::new(0.85, 1.0, 0.85),
    Rgb::new(0.82, 0.9, 1.0),
    Rgb::new(1.0, 0.95, 0.8),
    Rgb::new(1.0, 0.85, 0.85),
];
/// Hues of the carpets: grey-blue, green, red-brown, charcoal.
const CARPET_HUES: [Rgb; 4] = [
    Rgb::new(0.5, 0.6, 0.9),
    Rgb::new(0.5, 0.8, 0.5),
    Rgb::new(0.9, 0.5, 0.4),
    Rgb::new(0.7, 0.7, 0.75),
];

/// A colour of `palette` chosen by `key`.
fn pick(palette: &[Rgb], key: u64) -> Rgb {
    palette[(hash(key) % palette.len() as u64) as usize]
}

/// A box spanning `lo` to `hi` (corners).
fn slab(t: &mut Vec<Triangle>, lo: Vec3, hi: Vec3, m: Material) {
    let c = (lo + hi) * 0.5;
    let h = (hi - lo) * 0.5;
    cuboid(t, c, h, 0.0, m);
}

/// The office floor: a corridor 3 m wide and 3 m high along −z, with six rooms of 6 × 6 m on
/// each side (12 rooms), and in colour (see [`office_with`]). Every wall is a 12 cm box
/// blocking shadow rays; each room opens on the corridor by a door 1.3 m wide and 2.2 m high
/// at a random place along its wall, closed by a door leaf with probability 1/4 (three of the
/// twelve; fixed seed).
///
/// Lights, [`OFFICE_LIGHTS`] in all: in every room a 10 × 10 grid of one-sided disks of
/// radius 6 cm, 3 cm under the ceiling and facing down (0.6 m apart, powers log-uniform in
/// [0.5, 2] × 4 times a room scale log-uniform in [0.5, 2]), and 12 spheres of radius 8 cm
/// hanging 35 cm under the corridor's ceiling (power 10). Each room has four to six desks
/// (boxes with a glossy plastic top) with a dark monitor on each, Lambert walls and a Lambert
/// carpet; the corridor's floor is glossy plastic (GGX α 0.08).
///
/// The camera stands in the corridor by the first rooms and looks down it, and through the
/// nearest open door into a room. From a point in the corridor 92 to 97 % of the lights (to
/// their centres) are behind a wall or a closed door: only the corridor's own and those seen
/// through open doors are not.
pub fn office() -> RenderScene {
    office_with(Palette::Colour)
}

/// [`office`] in `palette`: in colour each room's lights are warm, neutral or cool white and
/// its walls and carpet tinted (chosen by the room's index); in grey every light and albedo
/// is grey.
pub fn office_with(palette: Palette) -> RenderScene {
    let corridor_floor = Material::Plastic {
        albedo: palette.albedo_of(0.25, Rgb::new(0.9, 0.95, 1.0)),
        specular: 0.5,
        alpha: 0.08,
    };
    let corridor_wall = Material::Lambert {
        albedo: palette.albedo_of(0.6, Rgb::new(0.9, 0.95, 1.0)),
    };
    let ceiling = Material::Lambert {
        albedo: Rgb::grey(0.7),
    };
    let door_leaf = Material::Lambert {
        albedo: palette.albedo_of(0.3, Rgb::new(1.0, 0.75, 0.5)),
    };
    let desk_top = Material::Plastic {
        albedo: palette.albedo_of(0.45, Rgb::new(1.0, 0.85, 0.65)),
        specular: 0.3,
        alpha: 0.2,
    };
    let desk_leg = Material::Lambert {
        albedo: Rgb::grey(0.2),
    };
    let monitor = Material::Plastic {
        albedo: Rgb::grey(0.03),
        specular: 0.4,
        alpha: 0.1,
    };
    let v = |x, y, z| Vec3::new(x, y, z);
    let mut rng = Pcg64Mcg::seed_from_u64(0x0ff1ce);
    let mut t: Vec<Triangle> = Vec::new();
    let far = -(ROOMS_PER_SIDE as f32) * ROOM.1;
    let outer = HALF_CORRIDOR + WALL + ROOM.0;

    // Corridor floor, the ceiling over everything, the far end wall and the lobby's walls.
    quad(
        &mut t,
        v(-HALF_CORRIDOR, 0.0, far),
        v(HALF_CORRIDOR, 0.0, far),
        v(HALF_CORRIDOR, 0.0, LOBBY),
        v(-HALF_CORRIDOR, 0.0, LOBBY),
        corridor_floor,
    );
    quad(
        &mut t,
        v(-outer, HEIGHT, far),
        v(outer, HEIGHT, far),
        v(outer, HEIGHT, LOBBY),
        v(-outer, HEIGHT, LOBBY),
        ceiling,
    );
    slab(
        &mut t,
        v(-outer - WALL, 0.0, far - WALL),
        v(outer + WALL, HEIGHT, far),
        corridor_wall,
    );
    for s in [-1.0f32, 1.0] {
        let (a, b) = (s * HALF_CORRIDOR, s * (HALF_CORRIDOR + WALL));
        slab(
            &mut t,
            v(a.min(b), 0.0, 0.0),
            v(a.max(b), HEIGHT, LOBBY),
            corridor_wall,
        );
    }
    // The lobby's end behind the camera.
    slab(
        &mut t,
        v(-HALF_CORRIDOR, 0.0, LOBBY),
        v(HALF_CORRIDOR, HEIGHT, LOBBY + WALL),
        corridor_wall,
    );

    let mut lights: Vec<Light> = Vec::new();
    for room in 0..2 * ROOMS_PER_SIDE {
        let s = if room % 2 == 0 { -1.0f32 } else { 1.0 };
        let k = room / 2;
        let (z1, z0) = (-(k as f32) * ROOM.1, -((k + 1) as f32) * ROOM.1);
        // x from the corridor side (`inner`) to the outer wall, as signed coordinates.
        let inner = s * (HALF_CORRIDOR + WALL);
        let x_at = |d: f32| inner + s * d;
        let span = |a: f32, b: f32| (a.min(b), a.max(b));
        let key = room as u64;
        let wall = Material::Lambert {
            albedo: palette.albedo_of(0.65, pick(&WALL_HUES, key)),
        };
        let carpet = Material::Lambert {
            albedo: palette.albedo_of(0.18, pick(&CARPET_HUES, 100 + key)),
        };
        // Floor (under the door too), and the span of the room's walls.
        let (fx0, fx1) = span(inner, x_at(ROOM.0));
        let (cx0, cx1) = span(s * HALF_CORRIDOR, x_at(ROOM.0));
        quad(
            &mut t,
            v(cx0, 0.0, z0),
            v(cx1, 0.0, z0),
            v(cx1, 0.0, z1),
            v(cx0, 0.0, z1),
            carpet,
        );
        // The corridor wall with its door: left of the door, right of it, the lintel.
        let (wx0, wx1) = span(s * HALF_CORRIDOR, inner);
        let door_mid = rng.random_range(z0 + 1.2..z1 - 1.2);
        let (d0, d1) = (door_mid - DOOR.0 * 0.5, door_mid + DOOR.0 * 0.5);
        slab(&mut t, v(wx0, 0.0, z0), v(wx1, HEIGHT, d0), corridor_wall);
        slab(&mut t, v(wx0, 0.0, d1), v(wx1, HEIGHT, z1), corridor_wall);
        slab(
            &mut t,
            v(wx0, DOOR.1, d0),
            v(wx1, HEIGHT, d1),
            corridor_wall,
        );
        let closed = rng.random_range(0..CLOSED_ONE_IN) == 0;
        if closed {
            let (lx0, lx1) = span(s * (HALF_CORRIDOR + 0.03), s * (HALF_CORRIDOR + 0.07));
            slab(&mut t, v(lx0, 0.0, d0), v(lx1, DOOR.1, d1), door_leaf);
        }
        // The room's own faces of its walls (the boxes' inner faces are what is seen), the
        // wall to the next room (at z0) and the outer wall.
        let (ox0, ox1) = span(x_at(ROOM.0), x_at(ROOM.0 + WALL));
        slab(&mut t, v(ox0, 0.0, z0 - WALL), v(ox1, HEIGHT, z1), wall);
        let h = WALL * 0.5;
        slab(&mut t, v(fx0, 0.0, z0 - h), v(fx1, HEIGHT, z0 + h), wall);
        if k == 0 {
            slab(&mut t, v(fx0, 0.0, z1 - h), v(fx1, HEIGHT, z1 + h), wall);
        }

        // Desks: two rows across the room, two or three desks each, a monitor on each.
        for row in 0..2 {
            let d = 1.8 + 2.4 * row as f32 + rng.random_range(-0.2f32..0.2);
            let n = rng.random_range(2..=3usize);
            for j in 0..n {
                let zc = z0 + ROOM.1 * (j as f32 + 0.5) / n as f32 + rng.random_range(-0.2..0.2);
                let xc = x_at(d);
                let top = 0.74;
                slab(
                    &mut t,
                    v(xc - 0.4, top - 0.03, zc - 0.75),
                    v(xc + 0.4, top, zc + 0.75),
                    desk_top,
                );
                for (dx, dz) in [(-0.35, -0.7), (0.35, -0.7), (-0.35, 0.7), (0.35, 0.7)] {
                    slab(
                        &mut t,
                        v(xc + dx - 0.025, 0.0, zc + dz - 0.025),
                        v(xc + dx + 0.025, top - 0.03, zc + dz + 0.025),
                        desk_leg,
                    );
                }
                // The monitor at the desk's far side from the corridor, facing it.
                let mx = xc + s * 0.25;
                slab(
                    &mut t,
                    v(mx - 0.02, top, zc - 0.3),
                    v(mx + 0.02, top + 0.4, zc + 0.3),
                    monitor,
                );
            }
        }

        // The room's ceiling lights.
        let scale = log_uniform(&mut rng, 0.5, 2.0);
        let tint = palette.tint(pick(&LIGHT_COLOURS, 200 + key));
        let (gx, gz) = ROOM_GRID;
        for i in 0..gx {
            for j in 0..gz {
                let x = x_at(ROOM.0 * (i as f32 + 0.5) / gx as f32);
                let z = z0 + ROOM.1 * (j as f32 + 0.5) / gz as f32;
                let power = ROOM_LIGHT_POWER * scale * log_uniform(&mut rng, 0.5, 2.0);
                lights.push(disk_light(
                    v(x, HEIGHT - 0.03, z),
                    Vec3::NEG_Y,
                    0.06,
                    power,
                    tint,
                ));
            }
        }
    }
    // The corridor's lights, from the lobby to the far end.
    for i in 0..CORRIDOR_LIGHTS {
        let z = LOBBY + (far - LOBBY) * (i as f32 + 0.5) / CORRIDOR_LIGHTS as f32;
        lights.push(sphere_light(
            v(0.0, HEIGHT - 0.35, z),
            0.08,
            CORRIDOR_LIGHT_POWER,
            palette.tint(LIGHT_COLOURS[1]),
        ));
    }
    debug_assert_eq!(lights.len(), OFFICE_LIGHTS);

    RenderScene {
        name: "office".into(),
        geometry: Geometry::new(t),
        lights: LightSet::build(lights).expect("the built-in lights are valid"),
        sky: None,
        camera: Camera {
            eye: v(1.1, 1.5, 0.5),
            target: v(-1.2, 1.1, -6.0),
            up: v(0.0, 1.0, 0.0),
            fov_y: 60.0,
        },
    }
}

/// A log-uniform number in `[lo, hi]`.
fn log_uniform(rng: &mut Pcg64Mcg, lo: f32, hi: f32) -> f32 {
    rng.random_range(lo.ln()..hi.ln()).exp()
}
