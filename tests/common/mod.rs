//! Shared helpers of the integration tests: a deterministic RNG, random scenes and shading
//! points, an independent f64 "does this light contribute here" predicate, and small
//! statistics helpers.
//!
//! Everything is seeded: the same seed gives the same scene on every machine (the generators
//! only use integer arithmetic and correctly rounded f32/f64 operations, plus `sin`/`cos` of
//! std, which is deterministic on one platform).

#![allow(dead_code)] // each test binary uses a different subset

pub mod cut;

use glam::{DVec3, Vec3};
use manylights::importance::Receiver;
use manylights::internals::tree::Node4Ext;
use manylights::tree::{Node4, SlotBounds};
use manylights::Rgb;
use manylights::{Importance, Light, TlImportance};
use std::f32::consts::{FRAC_PI_2, PI};

// ---------------------------------------------------------------------------------------------
// RNG
// ---------------------------------------------------------------------------------------------

/// The tests' generator (SplitMix64), shared with the core's unit tests.
pub use manylights_testkit::SplitMix64 as Rng;

// ---------------------------------------------------------------------------------------------
// Scenes
// ---------------------------------------------------------------------------------------------

/// How random scenes are drawn.
#[derive(Clone, Copy, Debug)]
pub struct SceneSpec {
    /// Positions lie in [-half, half]^3.
    pub half: f32,
    /// Probability that a light has zero power (or zero area for a triangle).
    pub zero_energy: f64,
    /// Relative weights of point, spot, sphere, disk, triangle, VPL (virtual point light).
    pub kinds: [u32; 6],
    /// Intensities and radiances are log-uniform in this range.
    pub power: (f32, f32),
}

impl Default for SceneSpec {
    fn default() -> Self {
        SceneSpec {
            half: 100.0,
            zero_energy: 0.08,
            // No VPLs by default: the fixed-seed scenes of the older tests stay what they were
            // (a zero weight draws nothing and shifts no pick); `vpl_scene` mixes them in.
            kinds: [1, 1, 1, 1, 1, 0],
            power: (1e-2, 1e2),
        }
    }
}

/// A random spot half-angle in (0, π], with the edges and π/2 drawn often.
fn half_angle(rng: &mut Rng) -> f32 {
    match rng.below(10) {
        0 => PI,
        1 => FRAC_PI_2,
        2 => f32::from_bits(FRAC_PI_2.to_bits() + 1), // just above π/2
        3 => 1e-3,
        _ => {
            // (0, π]: 1 - f32() is in (0, 1].
            PI * (1.0 - rng.f32())
        }
    }
}

/// One random light; `zero` asks for a light of zero energy.
pub fn random_light(rng: &mut Rng, spec: &SceneSpec, zero: bool) -> Light {
    let total: u32 = spec.kinds.iter().sum();
    let mut pick = (rng.next_u64() % u64::from(total)) as u32;
    let mut kind = 0;
    for (k, &w) in spec.kinds.iter().enumerate() {
        if pick < w {
            kind = k;
            break;
        }
        pick -= w;
    }
    let power = |rng: &mut Rng| rng.log_range(spec.power.0, spec.power.1);
    let p = |rng: &mut Rng| if zero { 0.0 } else { power(rng) };
    match kind {
        0 => Light::Point {
            position: rng.in_cube(spec.half),
            intensity: Rgb::grey(p(rng)),
        },
        1 => {
            let half_angle = half_angle(rng);
            let falloff_start = match rng.below(4) {
                0 => 0.0,
                1 => half_angle,
                _ => half_angle * rng.f32(),
            };
            Light::Spot {
                position: rng.in_cube(spec.half),
                direction: rng.direction(),
                intensity: Rgb::grey(p(rng)),
                half_angle,
                falloff_start,
            }
        }
        2 => Light::Sphere {
            center: rng.in_cube(spec.half),
            radius: rng.log_range(1e-3, 0.05 * spec.half),
            radiance: Rgb::grey(p(rng)),
        },
        3 => Light::Disk {
            center: rng.in_cube(spec.half),
            normal: rng.direction(),
            radius: rng.log_range(1e-3, 0.05 * spec.half),
            radiance: Rgb::grey(p(rng)),
            two_sided: rng.chance(0.5),
        },
        5 => Light::Vpl {
            position: rng.in_cube(spec.half),
            normal: rng.direction(),
            intensity: Rgb::grey(p(rng)),
        },
        _ => {
            let v0 = rng.in_cube(spec.half);
            let size = rng.log_range(1e-3, 0.05 * spec.half);
            let vertices = if zero && rng.chance(0.5) {
                // Zero area: a repeated vertex, or three points on an axis-parallel line (both
                // exactly degenerate in f32, so the cross product is exactly zero).
                let a = v0 + Vec3::X * size;
                if rng.chance(0.5) {
                    [v0, a, v0]
                } else {
                    [v0, a, v0 + Vec3::X * (2.0 * size)]
                }
            } else {
                [v0, v0 + rng.unit() * size, v0 + rng.unit() * size]
            };
            let radiance = if zero && vertices_area(&vertices) == 0.0 {
                power(rng) // zero area carries the zero energy
            } else {
                p(rng)
            };
            Light::Triangle {
                vertices,
                radiance: radiance.into(),
                two_sided: rng.chance(0.5),
            }
        }
    }
}

fn vertices_area(v: &[Vec3; 3]) -> f64 {
    let a = (v[1] - v[0]).as_dvec3();
    let b = (v[2] - v[0]).as_dvec3();
    a.cross(b).length()
}

/// `n` random lights; a fraction `spec.zero_energy` of them has zero energy.
pub fn random_scene(rng: &mut Rng, n: usize, spec: &SceneSpec) -> Vec<Light> {
    (0..n)
        .map(|_| {
            let zero = rng.chance(spec.zero_energy);
            random_light(rng, spec, zero)
        })
        .collect()
}

/// Whether the light has exactly zero energy, computed here from the fields (not via the
/// crate): zero power, or a triangle of zero area.
pub fn zero_energy(l: &Light) -> bool {
    match *l {
        Light::Point { intensity, .. }
        | Light::Spot { intensity, .. }
        | Light::Vpl { intensity, .. } => intensity == 0.0.into(),
        Light::Sphere { radiance, .. } | Light::Disk { radiance, .. } => radiance == 0.0.into(),
        Light::Triangle {
            vertices, radiance, ..
        } => radiance == 0.0.into() || vertices_area(&vertices) == 0.0,
        Light::Distant { .. } | Light::Environment { .. } => {
            unreachable!("lights at infinity are tested in tests/infinite.rs")
        }
        _ => unimplemented!("a light kind the tests do not know"),
    }
}

/// Stress points of one slot's bounding sphere `b`, pushed onto `xs`: its centre, a point at
/// a random depth inside, one on its surface and one just outside (1.001 radii).
pub fn push_sphere_points(rng: &mut Rng, b: &SlotBounds, xs: &mut Vec<Vec3>) {
    xs.push(b.center);
    xs.push(b.center + rng.unit() * b.radius * rng.f32());
    xs.push(b.center + rng.unit() * b.radius);
    xs.push(b.center + rng.unit() * b.radius * 1.001);
}

/// Stress points around two random emitters of `lights`, pushed onto `xs`: for each, a point
/// on it, then a point behind and one in front of it (along its normal or direction; a random
/// direction for points and spheres) at a random distance of 1e-4 to 10 times `half`.
pub fn push_emitter_points(rng: &mut Rng, lights: &[Light], half: f32, xs: &mut Vec<Vec3>) {
    for _ in 0..2 {
        let l = &lights[rng.below(lights.len())];
        xs.push(point_on_light(rng, l));
        // Behind (or in front of) an emitter, near and far.
        let (c, m) = match *l {
            Light::Disk { center, normal, .. } => (center, normal.normalize()),
            Light::Triangle { vertices, .. } => (
                (vertices[0] + vertices[1] + vertices[2]) / 3.0,
                (vertices[1] - vertices[0])
                    .cross(vertices[2] - vertices[0])
                    .normalize_or_zero(),
            ),
            Light::Spot {
                position,
                direction,
                ..
            } => (position, direction.normalize()),
            Light::Vpl {
                position, normal, ..
            } => (position, normal.normalize()),
            Light::Point { position, .. }
            | Light::Sphere {
                center: position, ..
            } => (position, rng.unit()),
            Light::Distant { .. } | Light::Environment { .. } => {
                unreachable!("lights at infinity are tested in tests/infinite.rs")
            }
            _ => unimplemented!("a light kind the tests do not know"),
        };
        let t = half * rng.log_range(1e-4, 10.0);
        xs.push(c - m * t);
        xs.push(c + m * t);
    }
}

/// A point on the light's emitting geometry (the position itself for points and spots).
pub fn point_on_light(rng: &mut Rng, l: &Light) -> Vec3 {
    match *l {
        Light::Point { position, .. }
        | Light::Spot { position, .. }
        | Light::Vpl { position, .. } => position,
        Light::Sphere { center, radius, .. } => center + rng.unit() * radius,
        Light::Disk {
            center,
            normal,
            radius,
            ..
        } => {
            let n = normal.normalize();
            let (t, b) = n.any_orthonormal_pair();
            let r = radius * rng.f32().sqrt();
            let phi = 2.0 * PI * rng.f32();
            center + (t * phi.cos() + b * phi.sin()) * r
        }
        Light::Triangle { vertices, .. } => {
            let (mut a, mut b) = (rng.f32(), rng.f32());
            if a + b > 1.0 {
                a = 1.0 - a;
                b = 1.0 - b;
            }
            vertices[0] + (vertices[1] - vertices[0]) * a + (vertices[2] - vertices[0]) * b
        }
        Light::Distant { .. } | Light::Environment { .. } => {
            unreachable!("lights at infinity are tested in tests/infinite.rs")
        }
        _ => unimplemented!("a light kind the tests do not know"),
    }
}

/// Where a random shading point is taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Where {
    /// Uniform in the scene's cube.
    Inside,
    /// 10 to 10^4 scene half-sizes away.
    Far,
    /// On a random light's surface.
    OnLight,
    /// Exactly at a point or spot light's position (or inside when there is none).
    AtPointLight,
}

pub const RECEIVERS: [Receiver; 3] = [
    Receiver::Reflective,
    Receiver::Transmissive,
    Receiver::Omnidirectional,
];

/// A random shading point of the given kind.
pub fn shading_point(rng: &mut Rng, lights: &[Light], half: f32, kind: Where) -> Vec3 {
    match kind {
        Where::Inside => rng.in_cube(half),
        Where::Far => rng.unit() * half * rng.log_range(10.0, 1e4),
        Where::OnLight if !lights.is_empty() => {
            let l = lights[rng.below(lights.len())];
            point_on_light(rng, &l)
        }
        Where::AtPointLight => {
            let points: Vec<Vec3> = lights
                .iter()
                .filter_map(|l| match *l {
                    Light::Point { position, .. }
                    | Light::Spot { position, .. }
                    | Light::Vpl { position, .. } => Some(position),
                    _ => None,
                })
                .collect();
            if points.is_empty() {
                rng.in_cube(half)
            } else {
                points[rng.below(points.len())]
            }
        }
        Where::OnLight => rng.in_cube(half),
    }
}

/// A random normal: usually unit, sometimes not normalised, rarely zero (which the API turns
/// into an omnidirectional receiver).
pub fn random_normal(rng: &mut Rng) -> Vec3 {
    match rng.below(20) {
        0 => Vec3::ZERO,
        1..=3 => rng.unit() * rng.log_range(1e-3, 1e3),
        _ => rng.unit(),
    }
}

/// A random importance of each kind of shading point, normal and receiver.
pub fn random_importance(rng: &mut Rng, lights: &[Light], half: f32) -> TlImportance {
    let x = random_shading_point(rng, lights, half);
    let n = random_normal(rng);
    TlImportance::with_receiver(x, n, RECEIVERS[rng.below(3)])
}

/// A shading point of a random kind among inside the scene, far away, on a light and at a
/// point light (see [`shading_point`]).
pub fn random_shading_point(rng: &mut Rng, lights: &[Light], half: f32) -> Vec3 {
    let kind = [
        Where::Inside,
        Where::Far,
        Where::OnLight,
        Where::AtPointLight,
    ][rng.below(4)];
    shading_point(rng, lights, half, kind)
}

/// The u values every sampling check uses: 0, tiny ones, 0.5, the largest f32 below 1, and
/// `extra` random ones.
pub fn u_values(rng: &mut Rng, extra: usize) -> Vec<f32> {
    let mut u = vec![
        0.0,
        f32::from_bits(1), // smallest subnormal
        f32::MIN_POSITIVE,
        1e-7,
        0.5,
        1.0 - f32::EPSILON / 2.0, // 1 - 2^-24
    ];
    u.extend((0..extra).map(|_| rng.f32()));
    u
}

// ---------------------------------------------------------------------------------------------
// SIMD vs scalar, for every importance
// ---------------------------------------------------------------------------------------------

/// Lane k of `imp.eval4(node)` against its scalar twin `imp.eval_lane(node, k)` (for most
/// importances `eval_slot(&node.bounds(k))`), for any importance: equal within `rel` relative
/// plus `abs` absolute (see [`close`]; the two perform the same operations), and the
/// documented range of both: never negative or NaN, 0 for a slot of zero energy. Returns the
/// four `(eval4 lane, eval_lane)` pairs for further checks.
pub fn lanes_match_scalar<I: Importance + std::fmt::Debug>(
    imp: &I,
    node: &Node4,
    rel: f64,
    abs: f64,
) -> Result<[(f32, f32); 4], String> {
    let wide = imp.eval4(node).to_array();
    let mut pairs = [(0.0, 0.0); 4];
    for (k, &w) in wide.iter().enumerate() {
        let b = node.bounds(k);
        let s = imp.eval_lane(node, k);
        if !(w >= 0.0 && s >= 0.0) {
            return Err(format!(
                "lane {k}: eval4 {w}, eval_lane {s} for {b:?} at {imp:?}"
            ));
        }
        if !close(f64::from(w), f64::from(s), rel, abs) {
            return Err(format!(
                "lane {k}: eval4 {w:e} vs eval_lane {s:e} (tolerance {rel:e} relative, {abs:e} \
                 absolute) for {b:?} of {node:?} at {imp:?}"
            ));
        }
        if node.energy_of(k) == 0.0 && (w != 0.0 || s != 0.0) {
            return Err(format!(
                "lane {k}: zero-energy slot has importance {w} / {s} at {imp:?}"
            ));
        }
        pairs[k] = (w, s);
    }
    Ok(pairs)
}

/// A synthetic node near `x` whose every field is random — any axis and angle bits, centres at
/// `x`, close by or far, radii from 0 to huge, energies over 40 decades, empty slots — so the
/// whole input domain of the decode is covered, not only what the build produces.
pub fn random_node(rng: &mut Rng, x: Vec3) -> Node4 {
    let mut node = Node4::EMPTY;
    // The frame: a scale from 2⁻³⁰ to 2⁴ (codes of 255 steps reach from ~2e-7 to 4e3 away),
    // the origin at x (so centres can be exactly x) or offset so the codes straddle it.
    node.raw_mut().exponent = (127 - 30 + rng.below(35)) as u8;
    let scale = f32::from_bits(u32::from(node.raw().exponent) << 23);
    node.raw_mut().origin = if rng.chance(0.3) {
        x.to_array()
    } else {
        let o = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * (255.0 * scale);
        (x - o).to_array()
    };
    for k in 0..4 {
        if rng.chance(0.15) {
            continue; // empty slot
        }
        let b = |rng: &mut Rng| rng.below(256) as u8;
        let centre = if rng.chance(0.25) {
            [0, 0, 0]
        } else {
            [b(rng), b(rng), b(rng)]
        };
        let radius = if rng.chance(0.25) { 0 } else { b(rng) };
        node.raw_mut().sphere[k] = u32::from_le_bytes([centre[0], centre[1], centre[2], radius]);
        node.raw_mut().energy[k] = (rng.log_range(1e-20, 1e20).to_bits() >> 16) as u16;
        node.raw_mut().cone[k] = match rng.below(4) {
            0 => 0xFFFF_FFFF,
            1 => (rng.next_u64() as u32) & 0xFF00_FFFF,
            _ => rng.next_u64() as u32,
        };
        node.raw_mut().mask |= 1 << (4 + k);
    }
    node
}

/// The shading points and synthetic nodes ([`random_node`]) every importance's lane test
/// draws: the same `count` pairs for every importance, from their own seed, so TL and BL are
/// checked on the same nodes whatever else each test draws.
pub fn random_nodes(count: usize) -> Vec<(Vec3, Node4)> {
    let mut rng = Rng::new(0x5EED);
    (0..count)
        .map(|_| {
            let x = rng.in_cube(10.0);
            (x, random_node(&mut rng, x))
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Independent contribution predicate (f64)
// ---------------------------------------------------------------------------------------------

fn d(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

/// Receiver factor of a direction `w` (not necessarily unit) from the shading point: the cosine
/// with the normal for a reflective receiver, its absolute value for a transmissive one, 1 for
/// an omnidirectional one. A zero normal is omnidirectional (as in the API).
fn receiver_cos(n: DVec3, receiver: Receiver, w: DVec3) -> f64 {
    if n == DVec3::ZERO || receiver == Receiver::Omnidirectional {
        return 1.0;
    }
    let c = n.normalize().dot(w) / w.length();
    match receiver {
        Receiver::Reflective => c,
        Receiver::Transmissive => c.abs(),
        Receiver::Omnidirectional => 1.0,
    }
}

/// Whether `light` sends light to the shading point `x` (normal `n`, `receiver`) with no
/// occluder, decided in f64 from the light's geometry alone, with every cosine that decides it
/// required to exceed `margin` (so that a light exactly at a zero boundary — grazing, in the
/// plane of a one-sided emitter, on the edge of a spot cone — does not count).
///
/// Per kind (exact, no sampling of the surface):
/// - point: receiver cosine of p − x;
/// - spot: that, and cos∠(direction, x − p) > cos θs;
/// - sphere (emits outward, x must be outside): the sphere seen from x is the cone of half-angle
///   asin(R/d) around c − x, so some point is above the horizon iff cos θn + R/d > 0;
/// - disk: x on the emitting side (one-sided: m·(x − c) > 0; two-sided: ≠ 0), a condition that
///   is the same for every point of the plane; and the point of the disk maximising n·(q − x),
///   q* = c + R·t with t the unit projection of n onto the disk's plane, above the horizon;
/// - triangle: the same side test with m = (v1 − v0)×(v2 − v0); n·(q − x) is linear on the
///   triangle, so its maximum is at a vertex.
///
/// For the emitting-side test the normalised quantity is m·(x − c)/(|x − c| + R), a lower bound
/// of the emission cosine at every point of the light.
pub fn contributes(light: &Light, x: Vec3, n: Vec3, receiver: Receiver, margin: f64) -> bool {
    let (x, n) = (d(x), d(n));
    let transmissive = receiver == Receiver::Transmissive;
    // For a transmissive receiver the receiver cosine is |cos|: the side of the horizon
    // does not matter, but grazing still does.
    let rec = |w: DVec3| receiver_cos(n, receiver, w) > margin;
    match *light {
        Light::Point { position, .. } => {
            let w = d(position) - x;
            w.length() > 0.0 && rec(w)
        }
        Light::Spot {
            position,
            direction,
            half_angle,
            ..
        } => {
            let w = d(position) - x;
            if w.length() == 0.0 || !rec(w) {
                return false;
            }
            let a = d(direction).normalize();
            let cos = a.dot(-w) / w.length();
            cos > f64::from(half_angle).cos() + margin
        }
        Light::Vpl {
            position, normal, ..
        } => {
            // x on the emitting side of the VPL's cosine lobe, and the VPL above x's horizon.
            let w = d(position) - x;
            if w.length() == 0.0 || !rec(w) {
                return false;
            }
            let m = d(normal).normalize();
            m.dot(-w) / w.length() > margin
        }
        Light::Sphere { center, radius, .. } => {
            let w = d(center) - x;
            let dist = w.length();
            let r = f64::from(radius);
            if dist <= r * (1.0 + margin) {
                return false; // inside: a sphere light emits outwards only
            }
            if n == DVec3::ZERO || receiver == Receiver::Omnidirectional {
                return true;
            }
            let cos_n = n.normalize().dot(w) / dist;
            let sin_u = r / dist;
            if transmissive {
                // Some direction of the cone not perpendicular to n: always, unless the cone is
                // a single direction in the tangent plane; with the margin: |cos θn| + sin θu.
                cos_n.abs() + sin_u > margin
            } else {
                cos_n + sin_u > margin
            }
        }
        Light::Disk {
            center,
            normal,
            radius,
            two_sided,
            ..
        } => {
            let m = d(normal).normalize();
            let c = d(center);
            let r = f64::from(radius);
            let side = m.dot(x - c) / ((x - c).length() + r);
            let side_ok = if two_sided {
                side.abs() > margin
            } else {
                side > margin
            };
            if !side_ok {
                return false;
            }
            if n == DVec3::ZERO || receiver == Receiver::Omnidirectional {
                return true;
            }
            let nn = n.normalize();
            // Maximise (or for |cos|, extremise both ways) n·(q − x) over the disk.
            let t = nn - m * nn.dot(m);
            let t = if t.length() > 1e-12 {
                t.normalize()
            } else {
                DVec3::ZERO
            };
            let best = |sign: f64| {
                let q = c + t * (sign * r);
                receiver_cos(n, receiver, q - x)
            };
            best(1.0) > margin || (transmissive && best(-1.0) > margin)
        }
        Light::Triangle {
            vertices,
            two_sided,
            ..
        } => {
            let v = vertices.map(d);
            let m = (v[1] - v[0]).cross(v[2] - v[0]);
            if m.length() == 0.0 {
                return false;
            }
            let m = m.normalize();
            let c = (v[0] + v[1] + v[2]) / 3.0;
            let r = v.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
            let side = m.dot(x - c) / ((x - c).length() + r);
            let side_ok = if two_sided {
                side.abs() > margin
            } else {
                side > margin
            };
            side_ok && v.iter().any(|&p| (p - x).length() > 0.0 && rec(p - x))
        }
        Light::Distant { .. } | Light::Environment { .. } => {
            unreachable!("lights at infinity are tested in tests/infinite.rs")
        }
        _ => unimplemented!("a light kind the tests do not know"),
    }
}

// ---------------------------------------------------------------------------------------------
// Statistics
// ---------------------------------------------------------------------------------------------

/// z-score of the upper 0.001 tail of the standard normal (Φ(z) = 0.999).
pub const Z_999: f64 = 3.090_232_306_167_813;

/// Upper-α critical value of χ² with `k` degrees of freedom by the Wilson–Hilferty
/// approximation: χ²_α(k) ≈ k·(1 − 2/(9k) + z_α·sqrt(2/(9k)))³, z_α the upper-α normal quantile.
/// At α = 0.001 it slightly overestimates the exact quantile: k = 10: 29.76 vs 29.59 (+0.6 %),
/// k = 30: 59.81 vs 59.70 (+0.2 %), k = 63: 103.51 vs 103.44 (+0.07 %); k = 1: +3 %. (Exact
/// values from the regularised incomplete gamma function.) The test's real level is therefore a
/// little below 0.001 — never above it.
pub fn chi2_critical(k: usize, z: f64) -> f64 {
    let k = k as f64;
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Pearson's statistic of `observed` counts against `expected` counts (same length; bins whose
/// expected count is below 5 are merged, in order, until every bin reaches 5; a remainder
/// below 5 is merged into the last bin). Returns (statistic, degrees of freedom).
pub fn chi2_statistic(observed: &[u64], expected: &[f64]) -> (f64, usize) {
    assert_eq!(observed.len(), expected.len());
    let mut bins: Vec<(f64, f64)> = Vec::new();
    let (mut o, mut e) = (0.0, 0.0);
    for (&ob, &ex) in observed.iter().zip(expected) {
        o += ob as f64;
        e += ex;
        if e >= 5.0 {
            bins.push((o, e));
            o = 0.0;
            e = 0.0;
        }
    }
    if e > 0.0 || o > 0.0 {
        match bins.last_mut() {
            Some(last) => {
                last.0 += o;
                last.1 += e;
            }
            None => bins.push((o, e)),
        }
    }
    let stat = bins.iter().map(|&(o, e)| (o - e) * (o - e) / e).sum();
    (stat, bins.len().saturating_sub(1))
}

/// |a − b| ≤ rel·max(|a|, |b|) + abs.
pub fn close(a: f64, b: f64, rel: f64, abs: f64) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + abs
}

// ---------------------------------------------------------------------------------------------
// Scene styles for the property tests
// ---------------------------------------------------------------------------------------------

/// A scene drawn from `seed`: a random style (mixed kinds, one kind only, all lights at one
/// point) at a random scale. Returns the lights and the half-size of the cube they are in.
///
/// Scenes of different `n` with the same `seed` share their first lights (the generator draws
/// the style first, then one light after the other), so proptest's shrinking of `n` shrinks the
/// failing scene to a prefix.
pub fn styled_scene(seed: u64, n: usize) -> (Vec<Light>, f32) {
    let mut rng = Rng::new(seed);
    let half = [1e-2, 1.0, 100.0, 100.0, 100.0, 1e4][rng.below(6)];
    let style = rng.below(8);
    let mut spec = SceneSpec {
        half,
        ..SceneSpec::default()
    };
    if (1..=5).contains(&style) {
        spec.kinds = [0; 6];
        spec.kinds[style - 1] = 1;
    }
    let mut lights = random_scene(&mut rng, n, &spec);
    if style == 6 {
        // Every light at one point: degenerate clusters of zero extent.
        let c = rng.in_cube(half);
        for l in &mut lights {
            move_to(l, c);
        }
    }
    (lights, half)
}

/// Like [`styled_scene`], with virtual point lights among the kinds: a random style of mixed
/// kinds (VPLs one sixth of them), VPLs only, or all lights (VPLs among them) at one point.
pub fn vpl_scene(seed: u64, n: usize) -> (Vec<Light>, f32) {
    let mut rng = Rng::new(seed);
    let half = [1e-2, 1.0, 100.0, 100.0, 100.0, 1e4][rng.below(6)];
    let style = rng.below(3);
    let mut spec = SceneSpec {
        half,
        kinds: [1, 1, 1, 1, 1, 1],
        ..SceneSpec::default()
    };
    if style == 1 {
        spec.kinds = [0, 0, 0, 0, 0, 1];
    }
    let mut lights = random_scene(&mut rng, n, &spec);
    if style == 2 {
        let c = rng.in_cube(half);
        for l in &mut lights {
            move_to(l, c);
        }
    }
    (lights, half)
}

/// Moves a light so that its position (centre, first vertex) is `c`.
pub fn move_to(l: &mut Light, c: Vec3) {
    match l {
        Light::Point { position, .. }
        | Light::Spot { position, .. }
        | Light::Vpl { position, .. } => *position = c,
        Light::Sphere { center, .. } | Light::Disk { center, .. } => *center = c,
        Light::Triangle { vertices, .. } => {
            let t = c - vertices[0];
            for v in vertices.iter_mut() {
                *v += t;
            }
        }
        Light::Distant { .. } | Light::Environment { .. } => {
            unreachable!("lights at infinity are tested in tests/infinite.rs")
        }
        _ => unimplemented!("a light kind the tests do not know"),
    }
}

/// The proptest configuration of every property test: `cases` cases from a fixed seed, no
/// failure persistence files, a bounded shrink.
pub fn proptest_config(cases: u32, seed: u64) -> proptest::test_runner::Config {
    proptest::test_runner::Config {
        cases,
        failure_persistence: None,
        rng_algorithm: proptest::test_runner::RngAlgorithm::ChaCha,
        rng_seed: proptest::test_runner::RngSeed::Fixed(seed),
        max_shrink_iters: 200,
        ..proptest::test_runner::Config::default()
    }
}

/// The power check of a chi-square test: the statistic of the same observed counts `obs`
/// against the expected counts `exp` (of `samples` draws) with the largest one 5 % too big
/// (renormalised to `samples`). A test with power rejects it (the result exceeds the critical
/// value).
pub fn chi2_skewed_statistic(obs: &[u64], exp: &[f64], samples: usize) -> f64 {
    let big = (0..exp.len())
        .max_by(|&a, &b| exp[a].total_cmp(&exp[b]))
        .unwrap();
    let mut skewed = exp.to_vec();
    skewed[big] *= 1.05;
    let norm: f64 = skewed.iter().sum::<f64>() / samples as f64;
    skewed.iter_mut().for_each(|e| *e /= norm);
    chi2_statistic(obs, &skewed).0
}

/// Running mean and standard error of a sample of finite values.
#[derive(Default)]
pub struct Stats {
    n: f64,
    s: f64,
    s2: f64,
}

impl Stats {
    pub fn add(&mut self, v: f64) {
        assert!(v.is_finite(), "non-finite value {v}");
        self.n += 1.0;
        self.s += v;
        self.s2 += v * v;
    }

    pub fn mean(&self) -> f64 {
        self.s / self.n
    }

    /// Standard error of the mean (the i.i.d. formula).
    pub fn se(&self) -> f64 {
        let m = self.mean();
        ((self.s2 / self.n - m * m).max(0.0) / (self.n - 1.0)).sqrt()
    }
}

// ---------------------------------------------------------------------------------------------
// Fixed scenes
// ---------------------------------------------------------------------------------------------

/// 64 small one-sided disks facing +z on a unit circle in the plane z = 0, and the shading
/// point just below the plane at the circle's centre: every disk faces away from it (zero
/// importance), but a cluster of several disks has a bounding sphere wide enough (θu) for its
/// cone bound to reach the point, and the root's sphere contains it. Plus four point lights far
/// above, so the root also holds clusters that do contribute.
pub fn ring_scene() -> (Vec<Light>, TlImportance) {
    let mut lights = Vec::new();
    let tau = 2.0 * std::f32::consts::PI;
    for i in 0..64 {
        let phi = tau * i as f32 / 64.0;
        lights.push(Light::Disk {
            center: Vec3::new(phi.cos(), phi.sin(), 0.0),
            normal: Vec3::Z,
            radius: 0.005,
            radiance: Rgb::grey(1.0 + (i % 5) as f32),
            two_sided: false,
        });
    }
    for i in 0..4 {
        lights.push(Light::Point {
            position: Vec3::new(i as f32 - 1.5, 0.5, -30.0),
            intensity: Rgb::grey(1.0),
        });
    }
    let imp = TlImportance::with_receiver(
        Vec3::new(0.0, 0.0, -0.05),
        Vec3::ZERO,
        Receiver::Omnidirectional,
    );
    (lights, imp)
}

/// A random scene of 60 disks, triangles and spots (no zero-energy lights) in a cube of half
/// side 10, built to sit near the zero boundaries: every second light is flattened into the
/// plane z = 0 with its normal (or direction) in the plane's normal, so that from a point in
/// that plane it is exactly edge-on and from just above or below it nearly so.
pub fn boundary_scene(rng: &mut Rng) -> Vec<Light> {
    let spec = SceneSpec {
        half: 10.0,
        zero_energy: 0.0,
        kinds: [0, 2, 0, 1, 1, 0],
        ..SceneSpec::default()
    };
    let mut lights = random_scene(rng, 60, &spec);
    for l in lights.iter_mut().step_by(2) {
        match l {
            Light::Disk { center, normal, .. } => {
                center.z = 0.0;
                *normal = Vec3::Z;
            }
            Light::Triangle { vertices, .. } => {
                for v in vertices.iter_mut() {
                    v.z = 0.0;
                }
            }
            Light::Spot {
                position,
                direction,
                ..
            } => {
                position.z = 0.0;
                direction.z = 0.0;
                if direction.length_squared() == 0.0 {
                    *direction = Vec3::X;
                }
            }
            _ => {}
        }
    }
    lights
}

// ---------------------------------------------------------------------------------------------
// Tree bytes
// ---------------------------------------------------------------------------------------------

/// Rewrites the checksum in the header of a tree's bytes (the CRC-64 of everything after the
/// header, stored at bytes 16..24 as the format documents it), so that an edit of the payload
/// reaches the structural checks behind the checksum.
pub fn reseal(bytes: &mut [u8]) {
    let h = manylights::internals::tree::HEADER_BYTES;
    if bytes.len() >= h {
        let c = manylights::internals::checksum::crc64(&bytes[h..]);
        bytes[16..24].copy_from_slice(&c.to_le_bytes());
    }
}
