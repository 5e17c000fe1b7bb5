//! The tree's byte form as a host caching trees meets it:
//!
//! 1. corrupt bytes never load: 10⁵ random corruptions of a serialized tree of 4,000 mixed
//!    lights (bit flips, byte replacements, truncations, insertions, swaps of ranges, at random
//!    positions and widths), every one that changes the bytes rejected; and a sweep XOR-ing
//!    0xFF into every 97th byte;
//! 2. a tree loaded with its lights ([`LightSet::from_bytes`]) is the set it was saved from:
//!    samples, pmfs, points on lights and every technique's estimates bit for bit;
//! 3. the wrong lights (one moved, one removed, another order, another power) are rejected
//!    with an error naming the first mismatch.

mod common;

use common::{Rng, Stats};
use glam::Vec3;
use manylights::direct::{Estimator, Params, Technique, Unoccluded};
use manylights::error::LightMismatch;
use manylights::light::sample_point;
use manylights::Rgb;
use manylights::{
    BlImportance, FormatError, Light, LightSet, LightTree, Material, ShadingPoint, TlImportance,
};
use manylights_testkit::TestUniforms;

/// The mixed scene of the corruption test: 4,000 lights of every kind (seeded).
fn scene(n: usize, seed: u64) -> Vec<Light> {
    let mut rng = Rng::new(seed);
    let spec = common::SceneSpec {
        half: 20.0,
        kinds: [1, 1, 1, 1, 1, 1],
        zero_energy: 0.0,
        ..common::SceneSpec::default()
    };
    common::random_scene(&mut rng, n, &spec)
}

/// One random corruption of `bytes`: its kind, and the corrupted bytes.
fn corrupt(rng: &mut Rng, bytes: &[u8]) -> (&'static str, Vec<u8>) {
    let n = bytes.len();
    let wide = rng.chance(0.5);
    let width = 1 + rng.below(if wide { 256 } else { 8 });
    let at = rng.below(n);
    let mut b = bytes.to_vec();
    match rng.below(5) {
        0 => {
            // Flip 1 to `width` random bits within `width` bytes from `at`.
            let end = (at + width).min(n);
            for _ in 0..1 + rng.below(width) {
                let i = at + rng.below(end - at);
                b[i] ^= 1 << rng.below(8);
            }
            ("flips", b)
        }
        1 => {
            // Replace `width` bytes with random ones.
            for v in &mut b[at..(at + width).min(n)] {
                *v = rng.next_u64() as u8;
            }
            ("replacement", b)
        }
        2 => {
            // Truncate to a random length, or cut `width` bytes out.
            if rng.chance(0.5) {
                b.truncate(at);
            } else {
                b.drain(at..(at + width).min(n));
            }
            ("truncation", b)
        }
        3 => {
            // Insert `width` random bytes.
            let ins: Vec<u8> = (0..width).map(|_| rng.next_u64() as u8).collect();
            b.splice(at..at, ins);
            ("insertion", b)
        }
        _ => {
            // Swap two ranges of `width` bytes (or two single bytes far apart).
            let w = width.min(n / 2);
            let (i, j) = (rng.below(n - w + 1), rng.below(n - w + 1));
            let (lo, hi) = (i.min(j), i.max(j));
            if hi >= lo + w {
                let (left, right) = b.split_at_mut(hi);
                left[lo..lo + w].swap_with_slice(&mut right[..w]);
            } else {
                b.swap(lo, hi);
            }
            ("swap", b)
        }
    }
}

#[test]
fn no_corruption_of_a_serialized_tree_loads() {
    let lights = scene(4000, 0x5EED);
    let tree = LightTree::build(&lights).unwrap();
    let bytes = tree.as_bytes();
    let mut rng = Rng::new(0xC0DE);
    let (mut tried, mut unchanged) = (0usize, 0usize);
    let mut kinds = std::collections::BTreeMap::new();
    for _ in 0..100_000 {
        let (kind, bad) = corrupt(&mut rng, &bytes);
        if bad == bytes {
            unchanged += 1;
            continue;
        }
        tried += 1;
        *kinds.entry(kind).or_insert(0usize) += 1;
        if let Ok(t) = LightTree::from_bytes(&bad) {
            panic!(
                "a {kind} of the bytes ({} of {} bytes) loaded: {} lights",
                bad.len(),
                bytes.len(),
                t.light_count()
            );
        }
    }
    eprintln!(
        "{tried} corruptions of {} bytes rejected ({unchanged} left the bytes unchanged): {kinds:?}",
        bytes.len()
    );
    assert!(tried > 99_000, "{tried}");
    // The sweep of the report that found the flaw: 0xFF into every 97th byte, one at a time.
    let mut b = bytes.clone();
    for i in (0..b.len()).step_by(97) {
        b[i] ^= 0xFF;
        assert!(LightTree::from_bytes(&b).is_err(), "byte {i} ^ 0xFF loaded");
        b[i] ^= 0xFF;
    }
    assert_eq!(LightTree::from_bytes(&b).unwrap(), tree);
}

fn shading_points(rng: &mut Rng, m: usize) -> Vec<ShadingPoint> {
    (0..m)
        .map(|i| {
            let material = match i % 3 {
                0 => Material::Lambert {
                    albedo: Rgb::grey(0.7),
                },
                1 => Material::Ggx {
                    alpha: rng.range(0.05, 0.6),
                    specular: 0.9,
                },
                _ => Material::Plastic {
                    albedo: Rgb::grey(0.4),
                    specular: 0.5,
                    alpha: rng.range(0.1, 0.8),
                },
            };
            let normal = rng.unit();
            let mut wo = rng.unit();
            if wo.dot(normal) < 0.0 {
                wo = -wo;
            }
            ShadingPoint {
                position: rng.in_cube(20.0),
                normal,
                wo,
                material,
            }
        })
        .collect()
}

#[test]
fn a_tree_loaded_with_its_lights_estimates_bit_for_bit() {
    let lights = scene(600, 0xBEEF);
    let set = LightSet::build(lights.clone()).unwrap();
    let bytes = set.tree().as_bytes();
    let loaded = LightSet::from_bytes(&bytes, lights.clone()).unwrap();
    assert_eq!(loaded.tree(), set.tree());
    assert_eq!(loaded.lights(), set.lights());
    let mut rng = Rng::new(17);
    let points = shading_points(&mut rng, 60);
    let params = Params::default();
    let mut compared = 0usize;
    let mut sum = Stats::default();
    for sp in &points {
        // Sampling and pmfs.
        let tl = TlImportance::new(sp.position, sp.normal);
        let bl = BlImportance::new(sp).unwrap();
        for _ in 0..8 {
            let u = rng.f32();
            assert_eq!(loaded.tree().sample(&tl, u), set.tree().sample(&tl, u));
            assert_eq!(loaded.tree().sample(&bl, u), set.tree().sample(&bl, u));
            let l = rng.below(lights.len()) as u32;
            assert_eq!(
                loaded.tree().pmf(&tl, l).to_bits(),
                set.tree().pmf(&tl, l).to_bits()
            );
            let (a, b) = (&loaded.lights()[l as usize], &set.lights()[l as usize]);
            let uv = rng.u2();
            assert_eq!(
                sample_point(a, sp.position, uv),
                sample_point(b, sp.position, uv)
            );
            assert_eq!(
                loaded.energies().sample(f64::from(u)),
                set.energies().sample(f64::from(u))
            );
        }
        // Every technique: the same estimates from the same uniform numbers.
        for t in Technique::ALL {
            let mut a = Estimator::new(&set, sp, t, &params).unwrap();
            let mut b = Estimator::new(&loaded, sp, t, &params).unwrap();
            let seed = rng.next_u64();
            let (mut ua, mut ub) = (TestUniforms::new(seed), TestUniforms::new(seed));
            for _ in 0..6 {
                let ea = a.estimate(&Unoccluded, &mut ua).unwrap();
                let eb = b.estimate(&Unoccluded, &mut ub).unwrap();
                assert_eq!(ea.map(f64::to_bits), eb.map(f64::to_bits), "{t} at {sp:?}");
                sum.add(ea[1]);
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 60 * Technique::ALL.len() * 6);
    assert!(sum.mean() > 0.0, "the scene lights the points");
}

/// A light moved by `d`.
fn moved(l: &Light, d: Vec3) -> Light {
    let mut l = *l;
    match &mut l {
        Light::Point { position, .. }
        | Light::Spot { position, .. }
        | Light::Vpl { position, .. } => *position += d,
        Light::Sphere { center, .. } | Light::Disk { center, .. } => *center += d,
        Light::Triangle { vertices, .. } => {
            for v in vertices {
                *v += d;
            }
        }
        Light::Distant { direction, .. } => *direction += d,
        Light::Environment { irradiance } => irradiance[0] += d.x,
        _ => unimplemented!("a light kind the tests do not know"),
    }
    l
}

/// A light with its power scaled by `k`.
fn scaled(l: &Light, k: f32) -> Light {
    let mut l = *l;
    match &mut l {
        Light::Point { intensity, .. }
        | Light::Spot { intensity, .. }
        | Light::Vpl { intensity, .. } => *intensity = *intensity * k,
        Light::Sphere { radiance, .. }
        | Light::Disk { radiance, .. }
        | Light::Triangle { radiance, .. } => *radiance = *radiance * k,
        Light::Distant { irradiance, .. } => *irradiance = *irradiance * k,
        Light::Environment { irradiance } => {
            for e in irradiance {
                *e *= k;
            }
        }
        _ => unimplemented!("a light kind the tests do not know"),
    }
    l
}

fn lights_error(bytes: &[u8], lights: &[Light]) -> LightMismatch {
    match LightSet::from_bytes(bytes, lights.to_vec()) {
        Err(FormatError::Lights(e)) => e,
        other => panic!("expected a light mismatch, got {other:?}"),
    }
}

#[test]
fn the_wrong_lights_are_rejected_naming_the_first_mismatch() {
    let mut lights = scene(300, 0xFACE);
    // Two lights of no power: never in the tree.
    lights[7] = scaled(&lights[7], 0.0);
    lights[250] = scaled(&lights[250], 0.0);
    let tree = LightTree::build(&lights).unwrap();
    let bytes = tree.as_bytes();
    assert!(LightSet::from_bytes(&bytes, lights.clone()).is_ok());
    assert_eq!(tree.check_lights(&lights), Ok(()));

    // One removed, one added.
    assert_eq!(
        lights_error(&bytes, &lights[..299]),
        LightMismatch::Count {
            tree: 300,
            given: 299
        }
    );
    let mut more = lights.clone();
    more.push(lights[0]);
    assert!(matches!(
        lights_error(&bytes, &more),
        LightMismatch::Count { given: 301, .. }
    ));

    // One moved far: outside its slot.
    let mut m = lights.clone();
    m[123] = moved(&m[123], Vec3::new(0.0, 0.0, 1000.0));
    let e = lights_error(&bytes, &m);
    assert_eq!(e, LightMismatch::Escapes { light: 123 });
    assert!(e.to_string().contains("light 123"), "{e}");
    // One moved by a hair: inside its slot, caught by its block's checksum (lights 64..128).
    let mut m = lights.clone();
    m[100] = moved(&m[100], Vec3::new(1e-5, 0.0, 0.0));
    let e = lights_error(&bytes, &m);
    assert_eq!(
        e,
        LightMismatch::Changed {
            first: 64,
            end: 128
        }
    );
    assert!(e.to_string().contains("lights 64 to 127"), "{e}");
    // The first mismatch is named: a hair's move at 30 comes before a far one at 200.
    m[30] = moved(&m[30], Vec3::new(0.0, 1e-5, 0.0));
    m[200] = moved(&m[200], Vec3::splat(500.0));
    assert_eq!(
        lights_error(&bytes, &m),
        LightMismatch::Changed { first: 0, end: 64 }
    );

    // Another order: the first light out of place escapes its slot (or, if it fits there,
    // its block's checksum differs).
    let mut r = lights.clone();
    r.reverse();
    match lights_error(&bytes, &r) {
        LightMismatch::Escapes { light } | LightMismatch::Sampled { light, .. } => {
            assert!(light < 64, "{light}")
        }
        LightMismatch::Changed { first, .. } => assert_eq!(first, 0),
        other => panic!("{other:?}"),
    }
    let mut s = lights.clone();
    s.swap(140, 141);
    let e = lights_error(&bytes, &s);
    assert!(
        matches!(
            e,
            LightMismatch::Escapes { light: 140 | 141 }
                | LightMismatch::Changed {
                    first: 128,
                    end: 192
                }
        ),
        "{e:?}"
    );

    // Brighter: its energy exceeds its slot's; a little dimmer: inside, the checksum says so.
    let mut p = lights.clone();
    p[5] = scaled(&p[5], 4.0);
    assert_eq!(
        lights_error(&bytes, &p),
        LightMismatch::Escapes { light: 5 }
    );
    let mut p = lights.clone();
    p[5] = scaled(&p[5], 0.999);
    assert_eq!(
        lights_error(&bytes, &p),
        LightMismatch::Changed { first: 0, end: 64 }
    );
    // A light of no power given power, and one put out.
    let mut p = lights.clone();
    p[7] = lights[8];
    assert_eq!(
        lights_error(&bytes, &p),
        LightMismatch::Sampled {
            light: 7,
            in_tree: false
        }
    );
    let mut p = lights.clone();
    p[9] = scaled(&p[9], 0.0);
    let e = lights_error(&bytes, &p);
    assert_eq!(
        e,
        LightMismatch::Sampled {
            light: 9,
            in_tree: true
        }
    );
    assert!(e.to_string().contains("light 9"), "{e}");
    // An invalid light is named with its field, as the build names it.
    let mut p = lights.clone();
    p[3] = Light::Sphere {
        center: Vec3::ZERO,
        radius: -1.0,
        radiance: Rgb::grey(1.0),
    };
    let e = lights_error(&bytes, &p);
    assert!(matches!(e, LightMismatch::Invalid(_)), "{e:?}");
    assert!(e.to_string().contains("light 3: field `radius`"), "{e}");

    // Without lights the tree loads as before; with corrupt bytes the checksum speaks first.
    assert_eq!(LightTree::from_bytes(&bytes).unwrap(), tree);
    let mut bad = bytes.clone();
    bad[100] ^= 1;
    assert!(matches!(
        LightSet::from_bytes(&bad, lights.clone()),
        Err(FormatError::Checksum { .. })
    ));
}

#[test]
fn empty_and_tiny_sets_round_trip_with_their_lights() {
    for lights in [
        Vec::new(),
        vec![Light::Point {
            position: Vec3::Z,
            intensity: Rgb::grey(0.0),
        }],
        scene(1, 3),
        scene(64, 4),
        scene(65, 5),
    ] {
        let set = LightSet::build(lights.clone()).unwrap();
        let bytes = set.tree().as_bytes();
        let loaded = LightSet::from_bytes(&bytes, lights.clone()).unwrap();
        assert_eq!(loaded.tree(), set.tree(), "{} lights", lights.len());
        assert_eq!(loaded.tree().as_bytes(), bytes);
    }
}
