//! Building and validating trees: the empty tree, every invalid input with the error naming
//! the light and the field, `validate()` on trees of many sizes and shapes with the depth
//! bound, and the byte serialisation (round trip, and corrupt input never panicking).

mod common;

use common::{random_importance, reseal, styled_scene, u_values, Rng};
use glam::Vec3;
use manylights::baseline::BinaryLightTree;
use manylights::error::{LightField, Problem};
use manylights::internals::light::LightExt;
use manylights::internals::tree::Node4Ext;
use manylights::tree::Slot;
use manylights::Rgb;
use manylights::{
    BuildError, BuildOptions, FormatError, Light, LightTree, TlImportance, MAX_COORDINATE,
};
use proptest::prelude::{any, prop_assert, prop_assert_eq, prop_oneof, Strategy};
use std::f32::consts::{FRAC_PI_2, PI};

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

fn point(x: f32) -> Light {
    Light::Point {
        position: Vec3::new(x, 0.0, 0.0),
        intensity: Rgb::grey(1.0),
    }
}

fn spot(half_angle: f32, falloff_start: f32) -> Light {
    Light::Spot {
        position: Vec3::ZERO,
        direction: Vec3::Z,
        intensity: Rgb::grey(1.0),
        half_angle,
        falloff_start,
    }
}

fn sphere(radius: f32, radiance: f32) -> Light {
    Light::Sphere {
        center: Vec3::ONE,
        radius,
        radiance: radiance.into(),
    }
}

fn disk(normal: Vec3, radius: f32, radiance: f32) -> Light {
    Light::Disk {
        center: Vec3::ONE,
        normal,
        radius,
        radiance: radiance.into(),
        two_sided: false,
    }
}

fn triangle(vertices: [Vec3; 3], radiance: f32) -> Light {
    Light::Triangle {
        vertices,
        radiance: radiance.into(),
        two_sided: true,
    }
}

/// Checks a tree's invariants, its statistics, and that every light of positive energy has a
/// path leading to its own leaf.
fn check_tree(tree: &LightTree, lights: &[Light]) {
    tree.validate_lights(lights)
        .unwrap_or_else(|e| panic!("{} lights: {e}", lights.len()));
    let st = tree.stats();
    assert!(st.depth <= 31, "depth {}", st.depth);
    assert_eq!(st.lights as usize, lights.len());
    let sampled = lights.iter().filter(|l| l.energy() > 0.0).count();
    assert_eq!(st.sampled_lights as usize, sampled);
    assert_eq!(tree.light_count() as usize, lights.len());
    for (l, light) in lights.iter().enumerate() {
        let path = tree.path(l as u32);
        if light.energy() > 0.0 {
            let (node, k) = tree.slot_at(path).expect("path leads into the tree");
            assert_eq!(
                tree.slot(&tree.nodes()[node as usize], k),
                Slot::Light(l as u32)
            );
        } else {
            assert_eq!(path, 0, "zero-energy light {l} has a path");
        }
    }
    // The stored energies are rounded up (2⁻¹¹ relative) and the sums of a level's rounded
    // values are rounded up again: at most 0.1 % per level above the truth.
    let total: f64 = lights.iter().map(|l| f64::from(l.energy())).sum();
    let stored = f64::from(tree.total_energy());
    assert!(
        stored >= total * (1.0 - 1e-6) && stored <= total * 1.001f64.powi(st.depth as i32),
        "total energy {} vs {total}",
        tree.total_energy()
    );
}

// ---------------------------------------------------------------------------------------------
// Empty trees
// ---------------------------------------------------------------------------------------------

#[test]
fn empty_light_list_samples_nothing() {
    let tree = LightTree::build(&[]).unwrap();
    assert!(tree.is_empty());
    tree.validate().unwrap();
    assert_eq!(tree.stats().depth, 0);
    assert_eq!(tree.total_energy(), 0.0);
    let bin = BinaryLightTree::build(&[]).unwrap();
    let mut rng = Rng::new(1);
    for _ in 0..20 {
        let imp = random_importance(&mut rng, &[], 10.0);
        for u in u_values(&mut rng, 5) {
            assert_eq!(tree.sample(&imp, u), None);
            assert_eq!(bin.sample(&imp, u), None);
        }
        assert_eq!(tree.pmf(&imp, 0), 0.0);
        assert_eq!(bin.pmf(&imp, 0), 0.0);
    }
    // And it round-trips through bytes.
    assert_eq!(LightTree::from_bytes(&tree.as_bytes()).unwrap(), tree);
}

/// A non-finite shading point samples nothing and has pmf 0 everywhere (never a panic or NaN).
#[test]
fn non_finite_shading_point_samples_nothing() {
    let (lights, _) = styled_scene(3, 50);
    let tree = LightTree::build(&lights).unwrap();
    let bin = BinaryLightTree::build(&lights).unwrap();
    for x in [
        Vec3::new(f32::NAN, 0.0, 0.0),
        Vec3::new(0.0, f32::INFINITY, 0.0),
        Vec3::splat(f32::NEG_INFINITY),
    ] {
        let imp = TlImportance::new(x, Vec3::Z);
        for u in [0.0, 0.5, 0.9] {
            assert_eq!(tree.sample(&imp, u), None, "{x:?}");
            assert_eq!(bin.sample(&imp, u), None, "{x:?}");
        }
        for l in 0..50 {
            assert_eq!(tree.pmf(&imp, l), 0.0);
            assert_eq!(bin.pmf(&imp, l), 0.0);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Invalid input
// ---------------------------------------------------------------------------------------------

/// Puts `bad` at index 3 of five lights (a second invalid light after it must not be the one
/// reported) and checks that both builds and `Light::validate` report exactly `field` and
/// `problem` for index 3, with the offending value (`value` None: NaN expected).
fn expect_invalid(bad: Light, field: LightField, problem: Problem, value: Option<f32>) {
    let lights = [
        point(0.0),
        sphere(1.0, 1.0),
        point(2.0),
        bad,
        sphere(-1.0, 1.0), // also invalid, but later
    ];
    for (who, err) in [
        ("LightTree", LightTree::build(&lights).unwrap_err()),
        (
            "BinaryLightTree",
            BinaryLightTree::build(&lights).unwrap_err(),
        ),
        ("Light::validate", bad.validate(3).unwrap_err()),
    ] {
        match err {
            BuildError::InvalidLight {
                index,
                field: f,
                problem: p,
                value: v,
            } => {
                assert_eq!(
                    (index, f, p),
                    (3, field, problem),
                    "{who}: {bad:?} gave {err:?}"
                );
                match value {
                    Some(x) => assert!(v == x, "{who}: {bad:?}: value {v}, expected {x}"),
                    None => assert!(v.is_nan(), "{who}: {bad:?}: value {v}, expected NaN"),
                }
                let msg = err.to_string();
                assert!(
                    msg.contains("light 3") && msg.contains(field.name()),
                    "{who}: message {msg:?}"
                );
            }
            other => panic!("{who}: {bad:?} gave {other:?}"),
        }
    }
    for (i, l) in lights[..3].iter().enumerate() {
        assert!(l.validate(i).is_ok());
    }
}

#[test]
fn invalid_coordinates_are_reported() {
    use LightField::*;
    use Problem::*;
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let big = 2.0 * MAX_COORDINATE;
    for (k, v, problem, value) in [
        (0, nan, NotFinite, None),
        (1, inf, NotFinite, Some(inf)),
        (2, -inf, NotFinite, Some(-inf)),
        (1, big, OutOfRange, Some(big)),
        (2, -big, OutOfRange, Some(-big)),
    ] {
        let mut p = Vec3::ZERO;
        p[k] = v;
        expect_invalid(
            Light::Point {
                position: p,
                intensity: Rgb::grey(1.0),
            },
            Position,
            problem,
            value,
        );
        expect_invalid(
            Light::Spot {
                position: p,
                direction: Vec3::Z,
                intensity: Rgb::grey(1.0),
                half_angle: 1.0,
                falloff_start: 0.5,
            },
            Position,
            problem,
            value,
        );
        expect_invalid(
            Light::Sphere {
                center: p,
                radius: 1.0,
                radiance: Rgb::grey(1.0),
            },
            Center,
            problem,
            value,
        );
        expect_invalid(
            Light::Disk {
                center: p,
                normal: Vec3::Z,
                radius: 1.0,
                radiance: Rgb::grey(1.0),
                two_sided: true,
            },
            Center,
            problem,
            value,
        );
        for j in 0..3 {
            let mut vs = [Vec3::ZERO, Vec3::X, Vec3::Y];
            vs[j] = p;
            expect_invalid(triangle(vs, 1.0), Vertex(j as u8), problem, value);
        }
    }
    // The largest accepted coordinate is accepted.
    let edge = [Light::Point {
        position: Vec3::new(MAX_COORDINATE, -MAX_COORDINATE, 0.0),
        intensity: Rgb::grey(1.0),
    }];
    check_tree(&LightTree::build(&edge).unwrap(), &edge);
}

#[test]
fn invalid_powers_are_reported() {
    use LightField::*;
    use Problem::*;
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    for (v, problem, value) in [
        (nan, NotFinite, None),
        (inf, NotFinite, Some(inf)),
        (-inf, NotFinite, Some(-inf)),
        (-1.0, Negative, Some(-1.0)),
        (-f32::MIN_POSITIVE, Negative, Some(-f32::MIN_POSITIVE)),
    ] {
        expect_invalid(
            Light::Point {
                position: Vec3::ZERO,
                intensity: Rgb::grey(v),
            },
            Intensity,
            problem,
            value,
        );
        expect_invalid(
            Light::Spot {
                position: Vec3::ZERO,
                direction: Vec3::Z,
                intensity: Rgb::grey(v),
                half_angle: 1.0,
                falloff_start: 0.5,
            },
            Intensity,
            problem,
            value,
        );
        expect_invalid(sphere(1.0, v), Radiance, problem, value);
        expect_invalid(disk(Vec3::Z, 1.0, v), Radiance, problem, value);
        expect_invalid(
            triangle([Vec3::ZERO, Vec3::X, Vec3::Y], v),
            Radiance,
            problem,
            value,
        );
    }
    // Energy above MAX_LIGHT_ENERGY (1e24): 4π·1e24 for a point.
    for l in [
        Light::Point {
            position: Vec3::ZERO,
            intensity: Rgb::grey(1e24),
        },
        spot_with_intensity(1e25),
    ] {
        let e = LightTree::build(&[l]).unwrap_err();
        assert!(
            matches!(
                e,
                BuildError::InvalidLight {
                    index: 0,
                    field: Intensity,
                    problem: EnergyTooLarge,
                    ..
                }
            ),
            "{l:?}: {e:?}"
        );
    }
    let e = LightTree::build(&[sphere(1e6, 1e12)]).unwrap_err();
    assert!(
        matches!(
            e,
            BuildError::InvalidLight {
                index: 0,
                field: Radiance,
                problem: EnergyTooLarge,
                ..
            }
        ),
        "{e:?}"
    );
    // Together above MAX_TOTAL_ENERGY (1e26): 101 lights of energy 1e24 each (intensity
    // 1e24/(4π) is just below the per-light cap).
    let each = 0.999e24 / (4.0 * PI);
    let many: Vec<Light> = (0..101)
        .map(|i| Light::Point {
            position: Vec3::new(i as f32, 0.0, 0.0),
            intensity: Rgb::grey(each),
        })
        .collect();
    assert_eq!(
        LightTree::build(&many).unwrap_err(),
        BuildError::TotalEnergyTooLarge
    );
    assert_eq!(
        BinaryLightTree::build(&many).unwrap_err(),
        BuildError::TotalEnergyTooLarge
    );
    // Below both caps: builds, and the importances stay finite even at a light's position.
    let fewer = &many[..99];
    let tree = LightTree::build(fewer).unwrap();
    check_tree(&tree, fewer);
    let imp = TlImportance::new(Vec3::ZERO, Vec3::X);
    let s = tree.sample(&imp, 0.5).expect("lights above the horizon");
    assert!(s.pmf.is_finite() && s.pmf > 0.0);
    let sum: f64 = (0..99).map(|l| f64::from(tree.pmf(&imp, l))).sum();
    assert!((sum - 1.0).abs() < 1e-4, "{sum}");
}

fn spot_with_intensity(intensity: f32) -> Light {
    Light::Spot {
        position: Vec3::ZERO,
        direction: Vec3::Z,
        intensity: intensity.into(),
        half_angle: PI,
        falloff_start: 0.0,
    }
}

#[test]
fn invalid_radii_and_directions_are_reported() {
    use LightField::*;
    use Problem::*;
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    for (r, problem, value) in [
        (0.0, NotPositive, Some(0.0)),
        (-0.0, NotPositive, Some(-0.0)),
        (-1.0, NotPositive, Some(-1.0)),
        (nan, NotFinite, None),
        (inf, NotFinite, Some(inf)),
        (2.0 * MAX_COORDINATE, OutOfRange, Some(2.0 * MAX_COORDINATE)),
    ] {
        expect_invalid(sphere(r, 1.0), Radius, problem, value);
        expect_invalid(disk(Vec3::Z, r, 1.0), Radius, problem, value);
    }
    for (d, problem, value) in [
        (Vec3::ZERO, ZeroLength, Some(0.0)),
        (Vec3::new(0.0, nan, 1.0), NotFinite, None),
        (Vec3::new(inf, 0.0, 0.0), NotFinite, Some(inf)),
        (Vec3::new(0.0, 0.0, -inf), NotFinite, Some(-inf)),
    ] {
        expect_invalid(disk(d, 1.0, 1.0), Normal, problem, value);
        expect_invalid(
            Light::Spot {
                position: Vec3::ZERO,
                direction: d,
                intensity: Rgb::grey(1.0),
                half_angle: 1.0,
                falloff_start: 0.0,
            },
            Direction,
            problem,
            value,
        );
    }
    // Tiny but non-zero directions are fine (normalised in f64), and so are huge ones.
    for d in [
        Vec3::new(f32::from_bits(1), 0.0, 0.0),
        Vec3::new(0.0, 1e-30, -1e-30),
        Vec3::splat(f32::MAX),
    ] {
        let lights = [
            disk(d, 1.0, 1.0),
            Light::Spot {
                position: Vec3::ZERO,
                direction: d,
                intensity: Rgb::grey(1.0),
                half_angle: 0.5,
                falloff_start: 0.1,
            },
        ];
        let tree = LightTree::build(&lights).unwrap_or_else(|e| panic!("{d:?}: {e}"));
        check_tree(&tree, &lights);
    }
}

#[test]
fn invalid_spot_angles_are_reported() {
    use LightField::*;
    use Problem::*;
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let above_pi = f32::from_bits(PI.to_bits() + 1);
    for (h, problem, value) in [
        (0.0, OutOfRange, Some(0.0)),
        (-0.0, OutOfRange, Some(-0.0)),
        (-0.5, OutOfRange, Some(-0.5)),
        (above_pi, OutOfRange, Some(above_pi)),
        (4.0, OutOfRange, Some(4.0)),
        (nan, NotFinite, None),
        (inf, NotFinite, Some(inf)),
        (-inf, NotFinite, Some(-inf)),
    ] {
        expect_invalid(spot(h, 0.0), HalfAngle, problem, value);
    }
    let above_one = f32::from_bits(1.0f32.to_bits() + 1);
    for (h, f, problem, value) in [
        (1.0, -0.1, OutOfRange, Some(-0.1)),
        (1.0, above_one, OutOfRange, Some(above_one)),
        (PI, 3.5, OutOfRange, Some(3.5)),
        (1.0, nan, NotFinite, None),
        (1.0, inf, NotFinite, Some(inf)),
    ] {
        expect_invalid(spot(h, f), FalloffStart, problem, value);
    }
    // The edges of the accepted ranges are accepted.
    let ok = [
        spot(PI, PI),
        spot(PI, 0.0),
        spot(f32::from_bits(1), 0.0),
        spot(FRAC_PI_2, FRAC_PI_2),
        spot(1.0, 1.0),
    ];
    check_tree(&LightTree::build(&ok).unwrap(), &ok);
}

/// Any f32 at all: random bit patterns (NaN, infinities, subnormals, huge values) and the
/// special values.
fn wild_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        1 => any::<u32>().prop_map(f32::from_bits),
        1 => proptest::sample::select(vec![
            0.0f32, -0.0, 1.0, -1.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX,
            f32::MIN, f32::MIN_POSITIVE, f32::from_bits(1), PI, FRAC_PI_2, 1e15, -1e15, 1e16,
            1e24, 1e30,
        ]),
    ]
}

/// A field: usually in `sane`, one time in 25 anything at all.
fn field(sane: std::ops::Range<f32>) -> impl Strategy<Value = f32> {
    prop_oneof![24 => sane, 1 => wild_f32()]
}

fn coord() -> impl Strategy<Value = Vec3> {
    (field(-1e3..1e3), field(-1e3..1e3), field(-1e3..1e3)).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn dir() -> impl Strategy<Value = Vec3> {
    (field(-1.0..1.0), field(-1.0..1.0), field(-1.0..1.0)).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn wild_light() -> impl Strategy<Value = Light> {
    prop_oneof![
        (coord(), field(0.0..100.0)).prop_map(|(position, intensity)| Light::Point {
            position,
            intensity: intensity.into()
        }),
        (
            coord(),
            dir(),
            field(0.0..100.0),
            field(0.0..3.2),
            field(0.0..3.2)
        )
            .prop_map(
                |(position, direction, intensity, half_angle, falloff_start)| Light::Spot {
                    position,
                    direction,
                    intensity: intensity.into(),
                    half_angle,
                    falloff_start: falloff_start.min(half_angle),
                }
            ),
        (coord(), field(0.0..10.0), field(0.0..100.0)).prop_map(|(center, radius, radiance)| {
            Light::Sphere {
                center,
                radius,
                radiance: radiance.into(),
            }
        }),
        (
            coord(),
            dir(),
            field(0.0..10.0),
            field(0.0..100.0),
            any::<bool>()
        )
            .prop_map(
                |(center, normal, radius, radiance, two_sided)| Light::Disk {
                    center,
                    normal,
                    radius,
                    radiance: radiance.into(),
                    two_sided
                }
            ),
        (coord(), coord(), coord(), field(0.0..100.0), any::<bool>()).prop_map(
            |(a, b, c, radiance, two_sided)| Light::Triangle {
                vertices: [a, b, c],
                radiance: radiance.into(),
                two_sided
            }
        ),
    ]
}

proptest::proptest! {
    #![proptest_config(common::proptest_config(4096, 0x7769_6c64))]

    /// Lights whose fields are sane except, one time in 25 per field, any f32 at all: the build
    /// returns Ok (and then a tree that validates and samples consistently) or the error of
    /// the first light `Light::validate` rejects (or `TotalEnergyTooLarge`) — never a panic,
    /// and both builds agree.
    #[test]
    fn build_never_panics_on_wild_input(
        lights in proptest::collection::vec(wild_light(), 0..10),
        seed in any::<u64>(),
    ) {
        let tree = LightTree::build(&lights);
        let bin = BinaryLightTree::build(&lights);
        let first_bad = lights.iter().enumerate().find_map(|(i, l)| l.validate(i).err());
        match (&tree, first_bad) {
            (Err(e @ BuildError::InvalidLight { .. }), Some(v)) => {
                // Compared as Debug strings: NaN values make PartialEq fail.
                prop_assert_eq!(format!("{e:?}"), format!("{v:?}"));
            }
            (Err(BuildError::TotalEnergyTooLarge), None) => {}
            (Ok(t), None) => {
                prop_assert!(t.validate().is_ok(), "{:?}", t.validate());
                let mut rng = Rng::new(seed);
                for _ in 0..4 {
                    let imp = random_importance(&mut rng, &lights, 10.0);
                    let mut sum = 0.0f64;
                    for l in 0..lights.len() as u32 {
                        sum += f64::from(t.pmf(&imp, l));
                    }
                    for u in u_values(&mut rng, 4) {
                        if let Some(s) = t.sample(&imp, u) {
                            prop_assert_eq!(s.pmf, t.pmf(&imp, s.light));
                            prop_assert!((sum - 1.0).abs() <= 1e-4, "sum {}", sum);
                        } else {
                            prop_assert_eq!(sum, 0.0);
                        }
                    }
                }
            }
            (t, v) => prop_assert!(false, "build gave {:?}, validate gave {:?}", t, v),
        }
        prop_assert_eq!(format!("{:?}", tree.err()), format!("{:?}", bin.err()));
    }
}

// ---------------------------------------------------------------------------------------------
// validate() on many shapes
// ---------------------------------------------------------------------------------------------

#[test]
fn validate_small_trees() {
    for n in 1..=40usize {
        for seed in 0..10u64 {
            let (lights, _) = styled_scene(seed * 100 + n as u64, n);
            let tree = LightTree::build(&lights).unwrap();
            check_tree(&tree, &lights);
            // Other bucket counts (clamped to 12..=64) build valid trees too.
            for buckets in [0, 12, 33, 64, 1000] {
                let opts = BuildOptions {
                    buckets,
                    compact: buckets % 2 == 0,
                };
                let t = LightTree::build_with(&lights, &opts).unwrap();
                check_tree(&t, &lights);
                BinaryLightTree::build_with(&lights, &opts).unwrap();
            }
        }
    }
}

#[test]
fn validate_medium_trees() {
    for (i, n) in [100usize, 1000, 5000, 20_000].into_iter().enumerate() {
        for s in 0..3u64 {
            let (lights, _) = styled_scene(7 * i as u64 + s, n);
            let tree = LightTree::build(&lights).unwrap();
            check_tree(&tree, &lights);
            // The compact packing: valid, and fuller nodes.
            let compact = LightTree::build_with(
                &lights,
                &BuildOptions {
                    compact: true,
                    ..BuildOptions::default()
                },
            )
            .unwrap();
            check_tree(&compact, &lights);
            assert!(compact.stats().nodes <= tree.stats().nodes);
        }
    }
}

#[test]
fn validate_100k_lights() {
    let mut rng = Rng::new(100_000);
    let spec = common::SceneSpec::default();
    let lights = common::random_scene(&mut rng, 100_000, &spec);
    let tree = LightTree::build(&lights).unwrap();
    check_tree(&tree, &lights);
    let st = tree.stats();
    assert!(
        st.depth >= 5,
        "100k lights in {} levels of 4-wide nodes?",
        st.depth
    );
    let compact = LightTree::build_with(
        &lights,
        &BuildOptions {
            compact: true,
            ..BuildOptions::default()
        },
    )
    .unwrap();
    check_tree(&compact, &lights);
    // A few consistency checks on the big tree.
    let bin = BinaryLightTree::build(&lights).unwrap();
    for _ in 0..4 {
        let imp = random_importance(&mut rng, &lights, spec.half);
        for u in u_values(&mut rng, 50) {
            if let Some(s) = tree.sample(&imp, u) {
                assert_eq!(s.pmf, tree.pmf(&imp, s.light));
            }
            if let Some(s) = compact.sample(&imp, u) {
                assert_eq!(s.pmf, compact.pmf(&imp, s.light));
            }
            if let Some(s) = bin.sample(&imp, u) {
                assert_eq!(s.pmf, bin.pmf(&imp, s.light));
            }
        }
    }
}

/// All lights at one point (coincident centroids: the SAOH cannot split by position), of all
/// kinds, up to 50,000 of them: valid, depth ≤ 31.
#[test]
fn validate_coincident_lights() {
    for n in [2usize, 3, 4, 5, 17, 1000, 50_000] {
        let lights: Vec<Light> = (0..n)
            .map(|i| Light::Point {
                position: Vec3::new(1.0, 2.0, 3.0),
                intensity: Rgb::grey(1.0 + (i % 7) as f32),
            })
            .collect();
        let tree = LightTree::build(&lights).unwrap();
        check_tree(&tree, &lights);
        let mut rng = Rng::new(n as u64);
        let mut spec = common::SceneSpec {
            zero_energy: 0.1,
            ..common::SceneSpec::default()
        };
        spec.half = 10.0;
        let mut mixed = common::random_scene(&mut rng, n.min(5000), &spec);
        for l in &mut mixed {
            common::move_to(l, Vec3::new(-4.0, 0.5, 9.0));
        }
        let tree = LightTree::build(&mixed).unwrap();
        check_tree(&tree, &mixed);
    }
}

/// Scenes that drive a greedy SAOH into a chain (positions and powers growing geometrically,
/// so every split peels off one light): the depth guard keeps the tree within 31 levels.
#[test]
fn depth_stays_within_31_on_chains() {
    for (ratio, n) in [(2.0f64, 49usize), (1.5, 85), (1.1, 360), (1.02, 1700)] {
        let lights: Vec<Light> = (0..n)
            .map(|i| {
                let x = ratio.powi(i as i32);
                Light::Point {
                    position: Vec3::new(x as f32, 0.0, 0.0),
                    intensity: Rgb::grey((x.min(1e20)) as f32),
                }
            })
            .collect();
        let tree = LightTree::build(&lights).unwrap_or_else(|e| panic!("ratio {ratio}: {e}"));
        check_tree(&tree, &lights);
        let bin = BinaryLightTree::build(&lights).unwrap();
        let imp = TlImportance::with_receiver(
            Vec3::new(-1.0, 1.0, 0.0),
            Vec3::ZERO,
            manylights::importance::Receiver::Omnidirectional,
        );
        let sum: f64 = (0..n as u32).map(|l| f64::from(tree.pmf(&imp, l))).sum();
        let sum_bin: f64 = (0..n as u32).map(|l| f64::from(bin.pmf(&imp, l))).sum();
        assert!(
            (sum - 1.0).abs() < 1e-4 && (sum_bin - 1.0).abs() < 1e-4,
            "{sum} {sum_bin}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Serialisation
// ---------------------------------------------------------------------------------------------

fn sample_trees() -> Vec<(Vec<Light>, LightTree)> {
    let mut out = Vec::new();
    let zero = vec![Light::Point {
        position: Vec3::ZERO,
        intensity: Rgb::grey(0.0),
    }];
    out.push((zero.clone(), LightTree::build(&zero).unwrap()));
    for (seed, n) in [(1u64, 1usize), (2, 2), (3, 5), (4, 37), (5, 300)] {
        let (lights, _) = styled_scene(seed, n);
        let tree = LightTree::build(&lights).unwrap();
        out.push((lights, tree));
    }
    out
}

#[test]
fn bytes_round_trip_exactly() {
    for (lights, tree) in sample_trees() {
        let bytes = tree.as_bytes();
        let back = LightTree::from_bytes(&bytes).unwrap();
        assert_eq!(back, tree, "{} lights", lights.len());
        assert_eq!(back.as_bytes(), bytes);
        check_tree(&back, &lights);
        // The copy samples exactly like the original.
        let mut rng = Rng::new(lights.len() as u64);
        for _ in 0..10 {
            let imp = random_importance(&mut rng, &lights, 100.0);
            for u in u_values(&mut rng, 10) {
                assert_eq!(back.sample(&imp, u), tree.sample(&imp, u));
            }
        }
    }
}

#[test]
fn truncated_extended_and_bad_header_bytes_are_rejected() {
    for (lights, tree) in sample_trees() {
        let bytes = tree.as_bytes();
        let len = bytes.len();
        // Every prefix (for the big tree every 7th length, and all of the last 64).
        for cut in 0..len {
            if len > 4096 && cut % 7 != 0 && cut + 64 < len {
                continue;
            }
            assert_eq!(
                LightTree::from_bytes(&bytes[..cut]),
                Err(FormatError::Truncated),
                "{} lights, cut at {cut} of {len}",
                lights.len()
            );
        }
        for extra in [1usize, 7, 8, 128, len] {
            let mut longer = bytes.clone();
            longer.extend(vec![0u8; extra]);
            assert_eq!(
                LightTree::from_bytes(&longer),
                Err(FormatError::TrailingBytes)
            );
        }
        // Magic (bytes 0..7).
        for i in 0..7 {
            let mut bad = bytes.clone();
            bad[i] ^= 0x20;
            assert_eq!(
                LightTree::from_bytes(&bad),
                Err(FormatError::BadHeader),
                "byte {i}"
            );
        }
        // The byte-order mark (payload bytes 28..32, after the 24-byte header), with the
        // checksum rewritten so that the parser sees it.
        for i in 24 + 28..24 + 32 {
            let mut bad = bytes.clone();
            bad[i] ^= 0x20;
            assert!(matches!(
                LightTree::from_bytes(&bad),
                Err(FormatError::Checksum { .. })
            ));
            reseal(&mut bad);
            assert_eq!(
                LightTree::from_bytes(&bad),
                Err(FormatError::BadHeader),
                "byte {i}"
            );
        }
        // The format version (byte 7): another version (1: 128-byte nodes; 2: 32-bit leaf
        // entries and 32- or 64-bit paths; 3: no checksum) is named as such.
        for found in [1, 2, 3, 5] {
            let mut other = bytes.clone();
            other[7] = found;
            assert_eq!(
                LightTree::from_bytes(&other),
                Err(FormatError::UnsupportedVersion {
                    found,
                    supported: 4
                })
            );
        }
        // A payload length (bytes 8..16) other than the payload's.
        for value in [0u64, len as u64, u64::MAX] {
            let mut bad = bytes.clone();
            bad[8..16].copy_from_slice(&value.to_le_bytes());
            let want = if value > (len - 24) as u64 {
                FormatError::Truncated
            } else {
                FormatError::TrailingBytes
            };
            assert_eq!(LightTree::from_bytes(&bad), Err(want), "length {value}");
        }
        // Counts that announce absurd sizes (payload bytes 0, 8, 16), behind a valid checksum.
        for (offset, value) in [
            (0usize, u64::MAX),
            (0, 1 << 31),
            (8, u64::MAX),
            (8, 1 << 40),
            (16, u64::MAX),
            (16, 1 << 33),
        ] {
            let mut bad = bytes.clone();
            bad[24 + offset..24 + offset + 8].copy_from_slice(&value.to_le_bytes());
            assert!(
                matches!(
                    LightTree::from_bytes(&bad),
                    Err(FormatError::Checksum { .. })
                ),
                "count {value} at {offset}"
            );
            reseal(&mut bad);
            assert!(
                LightTree::from_bytes(&bad).is_err(),
                "count {value} at {offset}"
            );
        }
    }
}

/// Checks a tree that `from_bytes` accepted from corrupt bytes: it validates, and sampling it
/// neither panics nor disagrees with its pmfs.
fn check_accepted(tree: &LightTree, rng: &mut Rng) {
    tree.validate()
        .expect("from_bytes returned a tree that does not validate");
    let n = tree.light_count();
    let lights: Vec<Light> = Vec::new();
    for _ in 0..2 {
        let imp = random_importance(rng, &lights, 100.0);
        let sum: f64 = (0..n).map(|l| f64::from(tree.pmf(&imp, l))).sum();
        for u in u_values(rng, 3) {
            match tree.sample(&imp, u) {
                Some(s) => {
                    assert!(s.light < n);
                    assert_eq!(s.pmf, tree.pmf(&imp, s.light));
                    assert!(
                        (sum - 1.0).abs() <= 1e-4,
                        "corrupt-but-valid tree: pmfs sum to {sum}"
                    );
                }
                None => assert_eq!(sum, 0.0),
            }
        }
    }
}

/// Thousands of random single-byte replacements and single-bit flips (fixed seed) in trees of
/// 1 to 300 lights, each behind a rewritten checksum so that the structural checks see it:
/// `from_bytes` returns an error or a tree that validates, never panics (without the rewrite
/// the checksum rejects every one).
#[test]
fn corrupt_bytes_never_panic() {
    let mut rng = Rng::new(0xB17F);
    let (mut rejected, mut accepted) = (0usize, 0usize);
    for (_, tree) in sample_trees() {
        let bytes = tree.as_bytes();
        for i in 0..3000 {
            let mut bad = bytes.clone();
            let at = rng.below(bad.len());
            if i % 2 == 0 {
                let old = bad[at];
                let mut new = rng.next_u64() as u8;
                if new == old {
                    new ^= 0xFF;
                }
                bad[at] = new;
            } else {
                bad[at] ^= 1 << rng.below(8);
            }
            assert!(LightTree::from_bytes(&bad).is_err(), "byte {at} changed");
            reseal(&mut bad);
            match LightTree::from_bytes(&bad) {
                Ok(t) => {
                    accepted += 1;
                    check_accepted(&t, &mut rng);
                }
                Err(_) => rejected += 1,
            }
        }
    }
    // Most corruptions are caught (those in the low bits of floats may not matter).
    assert!(
        rejected > accepted / 4,
        "rejected {rejected}, accepted {accepted}"
    );
}

// ---------------------------------------------------------------------------------------------
// Regressions: bugs these tests found, now fixed
// ---------------------------------------------------------------------------------------------

/// Regression: the population variance of a cluster's energies was stored as an f32 and
/// became +inf once the energies of one cluster differed by more than about 1.8e19 (a light may
/// have up to `MAX_LIGHT_ENERGY` = 1e24), so `validate()` rejected the built tree. It is now
/// stored relative to the squared mean (at most count − 1).
/// Input: two point lights, intensities 1e19 and 1 (energies 1.26e20 and 12.6).
#[test]
fn energy_variance_of_wide_energy_ranges_stays_finite() {
    let lights = [
        Light::Point {
            position: Vec3::ZERO,
            intensity: Rgb::grey(1e19),
        },
        Light::Point {
            position: Vec3::X,
            intensity: Rgb::grey(1.0),
        },
    ];
    for (i, l) in lights.iter().enumerate() {
        l.validate(i)
            .expect("both lights are within MAX_LIGHT_ENERGY");
    }
    let built = std::panic::catch_unwind(|| LightTree::build(&lights));
    let tree = match built {
        Ok(r) => r.expect("valid lights build"),
        Err(_) => {
            panic!("LightTree::build panicked on two valid lights (energies 1.26e20, 12.6)")
        }
    };
    let variances: Vec<f32> = (0..tree.nodes().len() as u32)
        .map(|n| tree.energy_rel_variance(n))
        .collect();
    assert!(
        variances.iter().all(|v| v.is_finite()),
        "infinite energy variance {variances:?}"
    );
    tree.validate().expect("built tree fails validation");
    assert_eq!(LightTree::from_bytes(&tree.as_bytes()).unwrap(), tree);
}

/// The orientation of a spot, disk or one-sided triangle light, from `Light::bounds()`: a unit
/// axis, and a box holding the emitter.
fn check_light_bounds(l: &Light) -> Result<(), String> {
    let b = l.bounds();
    let a = b.cone.axis;
    if !(a.is_finite() && (a.length() - 1.0).abs() < 1e-5) {
        return Err(format!("{l:?}: cone axis {a:?} is not a unit vector"));
    }
    if let Light::Disk {
        center,
        normal,
        radius,
        ..
    } = *l
    {
        let n = normal.as_dvec3().normalize();
        let (t, s) = n.any_orthonormal_pair();
        for q in [t, -t, s, -s] {
            let p = center.as_dvec3() + q * f64::from(radius) * 0.999;
            // Slack for the f64 rounding of the rim point itself.
            let tol = glam::DVec3::splat(1e-9 * f64::from(radius));
            let (lo, hi) = (b.aabb.min.as_dvec3() - tol, b.aabb.max.as_dvec3() + tol);
            if p.cmplt(lo).any() || p.cmpgt(hi).any() {
                return Err(format!(
                    "{l:?}: rim point {p:?} outside the box {:?}",
                    b.aabb
                ));
            }
        }
    }
    Ok(())
}

/// Regression: `Light::validate` accepts any finite, non-zero direction or normal, but
/// `bounds()` used to normalise it in f32, where |d|² overflows for |d| ≳ 1.8e19 (zero axis) and
/// underflows for |d| ≲ 1e-19 (±inf/NaN axis, a disk's box collapsed to its centre); a triangle
/// with edges longer than about 4e9 got a zero axis. Directions are now normalised in f64.
#[test]
fn light_bounds_of_huge_or_tiny_directions() {
    let mut failures = Vec::new();
    for m in [1e-30f32, 1e-20, 1e-3, 1.0, 1e3, 1e18, 1e20, 1e30] {
        for d in [Vec3::new(-1.0, 0.0, 0.0), Vec3::new(0.3, -0.5, 0.8)] {
            let d = d * m;
            let lights = [
                Light::Spot {
                    position: Vec3::ZERO,
                    direction: d,
                    intensity: Rgb::grey(1.0),
                    half_angle: 0.3,
                    falloff_start: 0.1,
                },
                Light::Disk {
                    center: Vec3::ZERO,
                    normal: d,
                    radius: 0.1,
                    radiance: Rgb::grey(1.0),
                    two_sided: false,
                },
            ];
            for l in &lights {
                l.validate(0).expect("finite non-zero direction is valid");
                if let Err(e) = check_light_bounds(l) {
                    failures.push(e);
                }
            }
        }
    }
    let big = Light::Triangle {
        vertices: [
            Vec3::ZERO,
            Vec3::new(0.0, 1e10, 0.0),
            Vec3::new(0.0, 0.0, 1e10),
        ],
        radiance: Rgb::grey(1e-5),
        two_sided: false,
    };
    big.validate(0).unwrap();
    if let Err(e) = check_light_bounds(&big) {
        failures.push(e);
    }
    assert!(
        failures.is_empty(),
        "{} lights with bad bounds:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Regression (same root cause as `light_bounds_of_huge_or_tiny_directions`): with the zero
/// axis the quantised cone pointed along +z with θo ≈ 0, so the importance was not
/// conservative — lights that shine straight at the shading point got pmf 0:
/// - a spot at the origin with direction (0, −1e20, 0), half-angle 0.3, seen from (0, −10, 0)
///   (on its axis);
/// - a one-sided disk at the origin with normal (−1e20, 0, 0), radius 0.1, seen from
///   (−1, 0, −1) (in front of it);
/// - a one-sided triangle (0,0,0), (0,1e10,0), (0,0,1e10) (normal +x), seen from
///   (2e10, 3e9, −2e10).
///
/// Each with a point light at (0, 0, −50) so that the root has two slots.
#[test]
fn huge_directions_stay_conservative() {
    let omni = |x: Vec3| {
        TlImportance::with_receiver(
            x,
            Vec3::ZERO,
            manylights::importance::Receiver::Omnidirectional,
        )
    };
    let cases = [
        (
            Light::Spot {
                position: Vec3::ZERO,
                direction: Vec3::new(0.0, -1e20, 0.0),
                intensity: Rgb::grey(1.0),
                half_angle: 0.3,
                falloff_start: 0.1,
            },
            Vec3::new(0.0, -10.0, 0.0),
        ),
        (
            Light::Disk {
                center: Vec3::ZERO,
                normal: Vec3::new(-1e20, 0.0, 0.0),
                radius: 0.1,
                radiance: Rgb::grey(1.0),
                two_sided: false,
            },
            Vec3::new(-1.0, 0.0, -1.0),
        ),
        (
            Light::Triangle {
                vertices: [
                    Vec3::ZERO,
                    Vec3::new(0.0, 1e10, 0.0),
                    Vec3::new(0.0, 0.0, 1e10),
                ],
                radiance: Rgb::grey(1e-5),
                two_sided: false,
            },
            Vec3::new(2e10, 3e9, -2e10),
        ),
    ];
    let mut failures = Vec::new();
    for (light, x) in cases {
        let lights = [
            light,
            Light::Point {
                position: Vec3::new(0.0, 0.0, -50.0),
                intensity: Rgb::grey(1.0),
            },
        ];
        let imp = omni(x);
        assert!(
            common::contributes(
                &light,
                x,
                Vec3::ZERO,
                manylights::importance::Receiver::Omnidirectional,
                1e-4
            ),
            "{light:?} should light {x:?}"
        );
        let tree = LightTree::build(&lights).unwrap();
        let bin = BinaryLightTree::build(&lights).unwrap();
        let (p, pb) = (tree.pmf(&imp, 0), bin.pmf(&imp, 0));
        if !(p > 0.0 && pb > 0.0) {
            failures.push(format!("{light:?} at {x:?}: pmf {p} / {pb}"));
        }
    }
    assert!(
        failures.is_empty(),
        "contributing lights with pmf 0:\n{}",
        failures.join("\n")
    );
}

/// Regression: a tree read from corrupt bytes that still validates could sample a light with
/// a subnormal pmf or pmf 0. Here one light's stored energy (a bfloat16 code in its leaf
/// slot) is replaced by the subnormal 1e-40 (a valid, non-negative energy): its importance
/// share underflows, so its pmf must be 0, and `sample` must neither return it nor disagree
/// with `pmf`.
#[test]
fn corrupt_but_valid_tiny_energy_is_never_sampled_with_pmf_zero() {
    let lights = [
        Light::Point {
            position: Vec3::new(1.0, 1.0, 1.0),
            intensity: Rgb::grey(2.0),
        },
        Light::Point {
            position: Vec3::new(0.0, 0.0, 2.0),
            intensity: Rgb::grey(1.0),
        },
        Light::Sphere {
            center: Vec3::new(-1.0, 0.5, 1.5),
            radius: 0.25,
            radiance: Rgb::grey(3.0),
        },
    ];
    let tree = LightTree::build(&lights).unwrap();
    let mut bytes = tree.as_bytes();
    // The tree is one node of three light slots; light 1's energy code is the upper 16 bits at
    // byte 56 (headers) + 48 + 2·slot and 4 more bits at 56 + 60.
    let (node, k) = tree.slot_at(tree.path(1)).unwrap();
    assert_eq!(node, 0);
    let mut root = tree.nodes()[0];
    root.set_energy_code(k, 1e-40f32.to_bits() >> 12);
    let at = 56;
    bytes[at..at + 64].copy_from_slice(bytemuck::bytes_of(&root));
    reseal(&mut bytes);
    // The parent's energy is the sum of its slots': the root has no parent, so the tree stays
    // valid.
    let bad = LightTree::from_bytes(&bytes).expect("a tiny energy is still a valid tree");
    assert!(bad.nodes()[0].energy_of(k) < 1e-39);
    bad.validate().unwrap();
    // The light is 1 straight above the point: importance 1e-40, a share far below f32's
    // smallest normal number.
    let imp = TlImportance::new(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.3, 1.0));
    let mut rng = Rng::new(0xE40);
    for l in 0..3 {
        let p = bad.pmf(&imp, l);
        assert!(
            p == 0.0 || p >= f32::MIN_POSITIVE,
            "light {l} has pmf {p:e}"
        );
    }
    let sum: f64 = (0..3).map(|l| f64::from(bad.pmf(&imp, l))).sum();
    assert!((sum - 1.0).abs() <= 1e-6, "pmfs sum to {sum}");
    for u in u_values(&mut rng, 50) {
        let s = bad.sample(&imp, u).expect("two lights contribute");
        assert!(s.pmf >= f32::MIN_POSITIVE, "u={u}: {s:?}");
        assert_eq!(s.pmf, bad.pmf(&imp, s.light), "u={u}: {s:?}");
    }
}

/// Regression: a spot's energy 2π(1 − cos θs)·I was computed with the subtraction in f64,
/// which is 0 for θs ≤ 1e-8 (the spot was never sampled though it lights the points on its
/// axis) and 11 % high at 2e-8. It is now 4π sin²(θs/2)·I for narrow cones: within f32
/// rounding (1e-6 relative allows for a few roundings) of the series
/// π θ² (1 − θ²/12) I, and a narrow spot is sampled at a point on its axis.
#[test]
fn narrow_spot_energy_does_not_cancel() {
    let spot = |half_angle: f32, intensity: f32| Light::Spot {
        position: Vec3::new(0.0, 0.0, 2.0),
        direction: -Vec3::Z,
        intensity: intensity.into(),
        half_angle,
        falloff_start: 0.5 * half_angle,
    };
    for theta in [
        1e-20f32, 1e-10, 1e-8, 2e-8, 3e-7, 1e-6, 1e-4, 9.99e-4, 1e-3, 2e-3, 1e-2,
    ] {
        let t = f64::from(theta);
        let want = PI as f64 * t * t * (1.0 - t * t / 12.0) * 3.0;
        let e = f64::from(spot(theta, 3.0).energy());
        assert!(
            (e - want).abs() <= 1e-6 * want,
            "θs = {theta}: energy {e}, expected {want}"
        );
    }
    // Ordinary angles: 2π(1 − cos θs)·I.
    for k in 1..=100 {
        let theta = PI * k as f32 / 100.0;
        let want = 2.0 * std::f64::consts::PI * (1.0 - f64::from(theta).cos()) * 3.0;
        let e = f64::from(spot(theta, 3.0).energy());
        assert!(
            (e - want).abs() <= 1e-6 * want,
            "θs = {theta}: {e} vs {want}"
        );
    }
    // A spot of half-angle 1e-8 (energy ≈ 3.1) next to a point light: on its axis it is
    // sampled, with the pmf `pmf` gives.
    let lights = [
        spot(1e-8, 1e16),
        Light::Point {
            position: Vec3::new(1.0, 0.0, 1.0),
            intensity: Rgb::grey(1.0),
        },
    ];
    assert!(lights[0].energy() > 3.0, "{}", lights[0].energy());
    let tree = LightTree::build(&lights).unwrap();
    let imp = TlImportance::new(Vec3::ZERO, Vec3::Z);
    let p = tree.pmf(&imp, 0);
    assert!(p > 0.1, "the spot's pmf on its axis is {p}");
    let s = tree.sample(&imp, 0.0).unwrap();
    let s2 = tree.sample(&imp, 0.999).unwrap();
    assert!(s.light == 0 || s2.light == 0, "{s:?} {s2:?}");
    for s in [s, s2] {
        assert_eq!(s.pmf, tree.pmf(&imp, s.light));
    }
}

/// Found by the `build_bad_input` fuzz target: two spots whose axes are nearly opposite, among
/// tiny lights, gave a union cone whose rotated axis (from the f32 cancellation of nearly
/// opposite axes) no longer contained one of them; `validate` caught it in debug builds. The
/// union now widens θo to what its axis needs.
#[test]
// The fuzzer's input written out bit for bit; one value happens to be close to π/4.
#[allow(clippy::approx_constant)]
fn nearly_opposite_cones_stay_in_their_union() {
    let lights: Vec<Light> = vec![
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 3.3494143e-8_f32),
            direction: Vec3::new(3.291384e-38_f32, 4.172308e-8_f32, 4.172325e-8_f32),
            intensity: Rgb::grey(4.172325e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.4537227e-8_f32),
            direction: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            intensity: Rgb::grey(4.172325e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 2.1614789e-29_f32,
        },
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            direction: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            intensity: Rgb::grey(4.172325e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Spot {
            position: Vec3::new(4.17087e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            direction: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 49258120000000.0_f32),
            intensity: Rgb::grey(4.172325e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 2.1614789e-29_f32),
            direction: Vec3::new(4.1734243e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            intensity: Rgb::grey(4.172325e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 6.4101185e-10_f32),
            direction: Vec3::new(6.4096906e-10_f32, 6.4096906e-10_f32, 6.4096906e-10_f32),
            intensity: Rgb::grey(6.4096906e-10_f32),
            half_angle: 0.00016802619_f32,
            falloff_start: 4.2007494e-5_f32,
        },
        Light::Sphere {
            center: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 1e-45_f32),
            radius: 1.5046328e-36_f32,
            radiance: Rgb::grey(4.172325e-8_f32),
        },
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            direction: Vec3::new(-5.0440315e16_f32, 3.8e-43_f32, 0.0_f32),
            intensity: Rgb::grey(4.1723084e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 0.7853982_f32),
            direction: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            intensity: Rgb::grey(4.172325e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            direction: Vec3::new(4.172325e-8_f32, 4.1723194e-8_f32, 4.172325e-8_f32),
            intensity: Rgb::grey(8.0704504e17_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.373469e-8_f32, 4.172325e-8_f32),
            direction: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, -110729624.0_f32),
            intensity: Rgb::grey(4.185567e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.9872323e-8_f32, 4.172325e-8_f32),
            direction: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            intensity: Rgb::grey(4.172325e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 2.1614789e-29_f32,
        },
        Light::Spot {
            position: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            direction: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            intensity: Rgb::grey(4.172325e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Spot {
            position: Vec3::new(2.1614789e-29_f32, 1e-45_f32, 2.9802322e-8_f32),
            direction: Vec3::new(4.172325e-8_f32, -107374184.0_f32, -107374180.0_f32),
            intensity: Rgb::grey(4.172325e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Spot {
            position: Vec3::new(4.1755083e-8_f32, 4.172325e-8_f32, 4.1723265e-8_f32),
            direction: Vec3::new(4.172325e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
            intensity: Rgb::grey(4.172325e-8_f32),
            half_angle: 4.172325e-8_f32,
            falloff_start: 4.172325e-8_f32,
        },
        Light::Triangle {
            vertices: [
                Vec3::new(4.1731106e-8_f32, 4.172325e-8_f32, 4.172325e-8_f32),
                Vec3::new(4.172325e-8_f32, -107387290.0_f32, 4.1723766e-8_f32),
                Vec3::new(4.172325e-8_f32, 3.2875686e-8_f32, 4.3486356e-31_f32),
            ],
            radiance: Rgb::grey(1.3136396e-7_f32),
            two_sided: true,
        },
        Light::Point {
            position: Vec3::new(0.0_f32, 0.0_f32, 0.0_f32),
            intensity: Rgb::grey(0.0_f32),
        },
    ];
    let tree = LightTree::build(&lights).expect("valid lights");
    assert_eq!(tree.validate(), Ok(()));
}

/// `sampled_lights` counts every light the tree can sample: those of the node tree, and the
/// distant and environment lights (not a black sun, nor a light of zero energy).
#[test]
fn sampled_lights_counts_the_lights_at_infinity() {
    let point = |z: f32, i: f32| Light::Point {
        position: Vec3::new(0.0, 0.0, z),
        intensity: i.into(),
    };
    let sun = |e: f32| Light::Distant {
        direction: Vec3::new(0.2, 0.1, 1.0),
        angular_radius: 0.0047,
        irradiance: e.into(),
    };
    let lights = vec![
        point(1.0, 1.0),
        sun(2.0),
        point(2.0, 0.0),
        Light::Environment {
            irradiance: [0.5, 0.5, 0.5, 0.5, 1.0, 0.0],
        },
        sun(0.0),
        point(3.0, 2.0),
    ];
    let tree = LightTree::build(&lights).unwrap();
    let st = tree.stats();
    assert_eq!(st.lights, 6);
    assert_eq!(
        st.sampled_lights, 4,
        "two points, the sun and the sky: {st:?}"
    );
    // Lights at infinity alone.
    let tree = LightTree::build(&[sun(1.0)]).unwrap();
    assert_eq!(tree.stats().sampled_lights, 1);
    assert_eq!(tree.stats().nodes, 0);
}
