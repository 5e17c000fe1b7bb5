//! The limits the core enforces and what happens at the edges of f32:
//!
//! 1. a light above `MAX_LIGHT_ENERGY` is rejected with an error that names the limit and the
//!    field's own value (not the energy under the field's name), and so are coordinates
//!    beyond `MAX_COORDINATE` and a total above `MAX_TOTAL_ENERGY`;
//! 2. a light that emits is in the tree however small its energy (a spot of half-angle 1e-30
//!    or 1e-45 rad): it has pmf > 0 where it lights a point and no other light outweighs it;
//! 3. the one documented way a light that lights a point has pmf 0: its probability would be
//!    below `MIN_PMF` (2⁻¹²⁶) — here, at a root of two lights, exactly when its share of the
//!    root's importance is below `MIN_PMF`.

mod common;

use common::Rng;
use glam::Vec3;
use manylights::error::{LightField, Problem};
use manylights::importance::Receiver;
use manylights::light::sample_point;
use manylights::Rgb;
use manylights::MIN_PMF;
use manylights::{
    BlImportance, BuildError, Importance, Light, LightTree, Material, ShadingPoint, TlImportance,
    MAX_COORDINATE, MAX_LIGHT_ENERGY, MAX_TOTAL_ENERGY,
};
use std::f32::consts::PI;

#[test]
fn limits_are_named_with_their_value_and_the_fields_own_value() {
    // The report's case: one point light of flux 5e25 (intensity 5e25/4π).
    let intensity = 5e25 / (4.0 * PI);
    let e = LightTree::build(&[Light::Point {
        position: Vec3::ZERO,
        intensity: Rgb::grey(intensity),
    }])
    .unwrap_err();
    assert_eq!(
        e,
        BuildError::InvalidLight {
            index: 0,
            field: LightField::Intensity,
            problem: Problem::EnergyTooLarge,
            value: intensity,
        }
    );
    let msg = e.to_string();
    assert!(
        msg.contains("`intensity`") && msg.contains("MAX_LIGHT_ENERGY (1e24)"),
        "{msg}"
    );
    assert!(msg.contains(&format!("(got {intensity:e})")), "{msg}");
    assert_eq!(MAX_LIGHT_ENERGY, 1e24);
    // An area light names its radiance.
    let e = LightTree::build(&[Light::Sphere {
        center: Vec3::ZERO,
        radius: 1e6,
        radiance: Rgb::grey(1e12),
    }])
    .unwrap_err();
    assert!(
        matches!(e, BuildError::InvalidLight { field: LightField::Radiance, value, .. } if value == 1e12),
        "{e:?}"
    );
    // Coordinates.
    let e = LightTree::build(&[Light::Point {
        position: Vec3::new(0.0, 2e15, 0.0),
        intensity: Rgb::grey(1.0),
    }])
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("`position` exceeds MAX_COORDINATE (1e15) in magnitude (got 2e15)"),
        "{msg}"
    );
    assert_eq!(MAX_COORDINATE, 1e15);
    // The total.
    let each = 0.999e24 / (4.0 * PI);
    let many: Vec<Light> = (0..101)
        .map(|i| Light::Point {
            position: Vec3::new(i as f32, 0.0, 0.0),
            intensity: Rgb::grey(each),
        })
        .collect();
    let msg = LightTree::build(&many).unwrap_err().to_string();
    assert!(msg.contains("MAX_TOTAL_ENERGY (1e26)"), "{msg}");
    assert_eq!(MAX_TOTAL_ENERGY, 1e26);
}

/// A spot of half-angle `a` 1 m above the origin, pointing down at it.
fn narrow_spot(a: f32) -> Light {
    Light::Spot {
        position: Vec3::Z,
        direction: -Vec3::Z,
        intensity: Rgb::grey(1.0),
        half_angle: a,
        falloff_start: 0.0,
    }
}

#[test]
fn a_spot_whose_energy_underflows_f32_is_in_the_tree() {
    let x = Vec3::ZERO;
    for a in [1e-30f32, 1e-45] {
        let spot = narrow_spot(a);
        // It lights the origin (radiance I/d² on its axis) ...
        let p = sample_point(&spot, x, [0.5, 0.5]).unwrap();
        assert!(p.radiance.r > 0.0, "{a}: {p:?}");
        // ... its energy 2π(1 − cos θs)·I is far below f32's range, and kept representable ...
        assert!(spot.energy() > 0.0, "{a}");
        let tree = LightTree::build(&[spot]).unwrap();
        assert_ne!(tree.path(0), 0, "{a}: the spot is not in the tree");
        // ... so it is sampled with pmf 1, by TL and by BL importance.
        let tl = TlImportance::new(x, Vec3::Z);
        let s = tree.sample(&tl, 0.5).expect("the spot is sampled");
        assert_eq!((s.light, s.pmf), (0, 1.0), "{a}");
        assert_eq!(tree.pmf(&tl, 0), 1.0);
        let sp = ShadingPoint {
            position: x,
            normal: Vec3::Z,
            wo: Vec3::new(0.2, 0.0, 1.0),
            material: Material::Lambert {
                albedo: Rgb::grey(0.5),
            },
        };
        let bl = BlImportance::new(&sp).unwrap();
        assert_eq!(tree.pmf(&bl, 0), 1.0, "{a}");
    }
}

/// The share of slot `k` of the root, computed in f64 from the importance's f32 lanes.
fn root_share<I: Importance>(tree: &LightTree, imp: &I, k: usize) -> f64 {
    let w = imp.eval4(&tree.nodes()[0]).to_array();
    let sum: f64 = w.iter().map(|&x| f64::from(x)).sum();
    f64::from(w[k]) / sum
}

#[test]
fn a_contributing_light_has_pmf_0_exactly_when_its_share_is_below_min_pmf() {
    // The report's case: a dim light far away and a bright one close by, omnidirectional
    // receiver at the origin. The dim light lights it (irradiance 1e-40) but its probability,
    // 1e-74, is not an f32.
    let lights = [
        Light::Point {
            position: Vec3::new(1e10, 0.0, 1.0),
            intensity: Rgb::grey(1e-20),
        },
        Light::Point {
            position: Vec3::new(0.0, 0.0, 1e-6),
            intensity: Rgb::grey(1e22),
        },
    ];
    let x = Vec3::ZERO;
    let imp = TlImportance::with_receiver(x, Vec3::Z, Receiver::Omnidirectional);
    for order in [[0usize, 1], [1, 0]] {
        let ls = [lights[order[0]], lights[order[1]]];
        let dim = order.iter().position(|&i| i == 0).unwrap() as u32;
        let tree = LightTree::build(&ls).unwrap();
        assert!(
            sample_point(&ls[dim as usize], x, [0.5; 2])
                .unwrap()
                .radiance
                .r
                > 0.0
        );
        assert_eq!(tree.pmf(&imp, dim), 0.0);
        let (_, k) = tree.slot_at(tree.path(dim)).unwrap();
        assert!(root_share(&tree, &imp, k) < f64::from(MIN_PMF));
    }
    // The bound, swept: a dim light at distance 1, a bright one at distance d, their intensity
    // ratio across 2⁻¹¹⁰ to 2⁻¹⁴⁰: the dim light's pmf is 0 exactly when its share of the
    // root's importance is below MIN_PMF, and otherwise at least MIN_PMF.
    let mut rng = Rng::new(0x2126);
    let (mut zero, mut positive) = (0, 0);
    for _ in 0..4000 {
        let ratio = 2f64.powf(-rng.range64(110.0, 140.0));
        let d = rng.range(0.5, 3.0);
        let ls = [
            Light::Point {
                position: rng.unit() + Vec3::new(0.0, 0.0, 2.0),
                intensity: Rgb::grey((1e10 * ratio) as f32),
            },
            Light::Point {
                position: rng.unit() * d + Vec3::new(0.0, 0.0, 2.0),
                intensity: Rgb::grey(1e10),
            },
        ];
        let tree = LightTree::build(&ls).unwrap();
        let imp = TlImportance::new(x, Vec3::Z);
        let (_, k) = tree.slot_at(tree.path(0)).unwrap();
        let share = root_share(&tree, &imp, k);
        let pmf = tree.pmf(&imp, 0);
        // f32 rounding of the descent's ratio: a band of 1e-6 around the bound is either.
        if (share / f64::from(MIN_PMF) - 1.0).abs() < 1e-6 {
            continue;
        }
        if share < f64::from(MIN_PMF) {
            assert_eq!(pmf, 0.0, "share {share:e}");
            zero += 1;
        } else {
            assert!(pmf >= MIN_PMF, "share {share:e}: pmf {pmf:e}");
            assert!(
                (f64::from(pmf) / share - 1.0).abs() < 1e-5,
                "{pmf:e} {share:e}"
            );
            positive += 1;
        }
        if let Some(s) = tree.sample(&imp, rng.f32()) {
            assert!(s.pmf >= MIN_PMF);
        }
    }
    assert!(zero > 500 && positive > 500, "{zero} {positive}");
}
