//! The TL importance: the 4-wide `eval4` against its scalar twin `eval_lane` lane by lane, every
//! form against the formula of docs/formulas.md, section 4 computed in f64, and conservativeness
//! (every light that can contribute at a point has a positive pmf).

mod common;

use common::{
    boundary_scene, close, contributes, lanes_match_scalar, proptest_config, push_emitter_points,
    push_sphere_points, random_nodes, random_normal, styled_scene, vpl_scene, Rng, Where,
    RECEIVERS,
};
use glam::{DVec3, Vec3};
use manylights::baseline::BinaryLightTree;
use manylights::importance::Receiver;
use manylights::internals::tree::Node4Ext;
use manylights::tree::{Node4, SlotBounds};
use manylights::Rgb;
use manylights::{Importance, Light, LightTree, TlImportance};
use proptest::prelude::{any, prop_oneof, Strategy};
use proptest::test_runner::TestCaseError;

// ---------------------------------------------------------------------------------------------
// SIMD vs scalar
// ---------------------------------------------------------------------------------------------

/// Relative tolerance of TL's lane comparison: `eval4` and `eval_lane` are written operation
/// for operation alike, so any difference is a bug; 1e-5 only allows for a compiler reordering
/// nothing here depends on. Tighter than BL's (`tests/bl.rs`), whose cap integrals go through
/// an ill-conditioned lens area that TL does not have.
const LANE_REL: f64 = 1e-5;

/// Absolute floor of TL's lane comparison, for results too small to carry relative precision.
const LANE_ABS: f64 = 1e-30;

/// `eval4(node)` lane k equals `eval_lane(node, k)` within [`LANE_REL`] and
/// [`LANE_ABS`], and both are in the documented range ([`common::lanes_match_scalar`], the
/// check every importance shares).
fn check_lanes(imp: &TlImportance, node: &Node4) -> Result<(), String> {
    lanes_match_scalar(imp, node, LANE_REL, LANE_ABS).map(|_| ())
}

/// Shading points that stress one node: inside a slot's bounding sphere (at its centre, at
/// random depths, on its surface), behind a one-sided emitter of the scene, on a light, exactly
/// at a point light, in the scene, far away.
fn stress_points(rng: &mut Rng, node: &Node4, lights: &[Light], half: f32) -> Vec<Vec3> {
    let mut xs = Vec::new();
    for k in 0..4 {
        push_sphere_points(rng, &node.bounds(k), &mut xs);
    }
    push_emitter_points(rng, lights, half, &mut xs);
    xs.push(rng.in_cube(half));
    xs.push(rng.unit() * half * rng.log_range(10.0, 1e4));
    xs
}

fn check_tree_lanes(
    lights: &[Light],
    half: f32,
    rng: &mut Rng,
    max_nodes: usize,
) -> Result<(), String> {
    let tree = LightTree::build(lights).map_err(|e| e.to_string())?;
    let nodes = tree.nodes();
    if nodes.is_empty() {
        return Ok(());
    }
    for _ in 0..max_nodes.min(nodes.len()) {
        let node = &nodes[rng.below(nodes.len())];
        for x in stress_points(rng, node, lights, half) {
            for receiver in RECEIVERS {
                let imp = TlImportance::with_receiver(x, random_normal(rng), receiver);
                check_lanes(&imp, node)?;
            }
        }
    }
    Ok(())
}

fn scene_size() -> impl Strategy<Value = usize> {
    prop_oneof![3 => 1usize..=8, 2 => 9usize..=500, 1 => 501usize..=3000]
}

proptest::proptest! {
    #![proptest_config(proptest_config(160, 0x5349_4d44))]

    /// Property 4 on random nodes of trees built from random scenes (all styles, including
    /// all lights at one point, i.e. clusters of zero radius).
    #[test]
    fn eval4_matches_scalar_on_built_trees(n in scene_size(), seed in any::<u64>()) {
        let (lights, half) = styled_scene(seed, n);
        let mut rng = Rng::new(seed ^ 0x4);
        check_tree_lanes(&lights, half, &mut rng, 24).map_err(TestCaseError::fail)?;
    }
}

proptest::proptest! {
    #![proptest_config(proptest_config(96, 0x5650_4c34))]

    /// Property 4 on trees of scenes with virtual point lights (see `vpl_scene`).
    #[test]
    fn eval4_matches_scalar_on_vpl_trees(n in scene_size(), seed in any::<u64>()) {
        let (lights, half) = vpl_scene(seed, n);
        let mut rng = Rng::new(seed ^ 0x54);
        check_tree_lanes(&lights, half, &mut rng, 24).map_err(TestCaseError::fail)?;
    }
}

/// Property 4 on hand-made clusters: coincident point lights (a zero-radius cluster), one-sided
/// disks all facing +z seen from below and above, and coincident one-sided triangles.
#[test]
fn eval4_matches_scalar_on_degenerate_clusters() {
    let mut rng = Rng::new(0xDE6);
    let c = Vec3::new(1.0, -2.0, 3.0);
    let points: Vec<Light> = (0..40)
        .map(|i| Light::Point {
            position: c,
            intensity: Rgb::grey(1.0 + i as f32),
        })
        .collect();
    let disks: Vec<Light> = (0..64)
        .map(|i| Light::Disk {
            center: Vec3::new((i % 8) as f32, (i / 8) as f32, 0.0),
            normal: Vec3::Z,
            radius: 0.3,
            radiance: Rgb::grey(1.0),
            two_sided: false,
        })
        .collect();
    let triangles: Vec<Light> = (0..16)
        .map(|_| Light::Triangle {
            vertices: [c, c + Vec3::X, c + Vec3::Y],
            radiance: Rgb::grey(2.0),
            two_sided: false,
        })
        .collect();
    for lights in [&points, &disks, &triangles] {
        check_tree_lanes(lights, 8.0, &mut rng, 100).unwrap();
        // And the points right at the cluster centre / the shared position, all receivers.
        let tree = LightTree::build(lights).unwrap();
        for node in tree.nodes() {
            for x in [c, Vec3::new(3.5, 3.5, -0.01), Vec3::new(3.5, 3.5, 0.01)] {
                for receiver in RECEIVERS {
                    for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::ZERO] {
                        let imp = TlImportance::with_receiver(x, n, receiver);
                        check_lanes(&imp, node).unwrap();
                    }
                }
            }
        }
    }
}

/// Property 4 on synthetic nodes whose every field is random ([`common::random_node`]): the
/// whole input domain of the decode, not only what the build produces. `tests/bl.rs` checks BL
/// on the same nodes.
#[test]
fn eval4_matches_scalar_on_random_nodes() {
    let mut rng = Rng::new(0x5EED);
    for (x, node) in random_nodes(20_000) {
        for receiver in RECEIVERS {
            let imp = TlImportance::with_receiver(x, random_normal(&mut rng), receiver);
            check_lanes(&imp, &node).unwrap();
        }
    }
}

/// `eval4_pair` (two shading points in the lanes of one f32x8) is bit for bit the two `eval4`
/// calls: random nodes two by two, every pair of receivers (different ones take the two
/// calls), one point of each pair at the other's slot centre (the tiny-offset rescaling in one
/// half only), and invalid points.
#[test]
fn eval4_pair_is_two_eval4_calls() {
    let mut rng = Rng::new(0x9A1E);
    let nodes = random_nodes(10_000);
    let bits = |w: wide::f32x4| w.to_array().map(f32::to_bits);
    for pair in nodes.chunks_exact(2) {
        let ((xa, na), (xb, nb)) = (&pair[0], &pair[1]);
        let at_centre = nb.bounds(rng.below(4)).center;
        for (pa, pb) in [
            (*xa, *xb),
            (*xa, at_centre),
            (Vec3::NAN, *xb),
            (*xa, Vec3::INFINITY),
        ] {
            for ra in RECEIVERS {
                for rb in RECEIVERS {
                    let a = TlImportance::with_receiver(pa, random_normal(&mut rng), ra);
                    let b = TlImportance::with_receiver(pb, random_normal(&mut rng), rb);
                    let (wa, wb) = a.eval4_pair(na, &b, nb);
                    assert_eq!(bits(wa), bits(a.eval4(na)), "{pa} {ra:?} / {pb} {rb:?}");
                    assert_eq!(bits(wb), bits(b.eval4(nb)), "{pa} {ra:?} / {pb} {rb:?}");
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The scalar importance against docs/formulas.md, section 4, in f64
// ---------------------------------------------------------------------------------------------

/// docs/formulas.md, section 4 in f64, with acos/asin, from decoded bounds:
/// θu = asin(min(r/d, 1)) (π inside the sphere), θ = ∠(a, −ωi), θ' = max(0, θ − θo − θu),
/// θi = ∠(n, ωi), θi' = max(0, θi − θu), I = E·cos θ'·cos θi' / max(d², (r/2)², 1e-12), zero when
/// θ' ≥ θe or (reflective) θi' ≥ π/2; |cos θi| for a transmissive receiver; no receiver term
/// for an omnidirectional one. Returns (I, distance of the decision to the nearest zero
/// boundary in radians).
fn tl_reference(imp: &TlImportance, b: &SlotBounds) -> (f64, f64) {
    use std::f64::consts::{FRAC_PI_2, PI};
    let x = imp.position().as_dvec3();
    let c = b.center.as_dvec3();
    let v = c - x;
    let d = v.length();
    let r = f64::from(b.radius);
    let inside = d <= r;
    let theta_u = if inside { PI } else { (r / d).min(1.0).asin() };
    let w = if d > 0.0 { v / d } else { DVec3::ZERO };
    let a = b.axis.as_dvec3().normalize();
    let theta = a.dot(-w).clamp(-1.0, 1.0).acos();
    let theta_o = f64::from(b.sin_o).atan2(f64::from(b.cos_o));
    let theta_e = f64::from(b.cos_e).clamp(-1.0, 1.0).acos();
    let theta_p = (theta - theta_o - theta_u).max(0.0);
    let mut margin = (theta_p - theta_e).abs();
    if theta_p >= theta_e {
        return (0.0, margin);
    }
    let n = imp.normal().as_dvec3();
    let cos_i = match imp.receiver() {
        manylights::importance::Receiver::Omnidirectional => 1.0,
        _ if inside => 1.0,
        receiver => {
            let mut ci = n.dot(w).clamp(-1.0, 1.0);
            if receiver == manylights::importance::Receiver::Transmissive {
                ci = ci.abs();
            }
            let theta_ip = (ci.acos() - theta_u).max(0.0);
            margin = margin.min((theta_ip - FRAC_PI_2).abs());
            if theta_ip >= FRAC_PI_2 {
                return (0.0, margin);
            }
            theta_ip.cos()
        }
    };
    let d2 = (d * d).max(0.25 * r * r).max(1e-12);
    (f64::from(b.energy) * theta_p.cos() * cos_i / d2, margin)
}

/// `TlImportance::eval` (the scalar reference, the binary baseline's), `eval_slot` (its scaled
/// form), `eval_lane` and `eval4` (the scaled form on the axis before its normalisation) all
/// follow the formula of docs/formulas.md, section 4 (computed independently in
/// f64 with acos/asin, on the decoded bounds): zero exactly when the formula is zero and
/// within 2e-3 relative otherwise, wherever the decision is at least 1e-3 rad from a zero
/// boundary and the point is not within 1e-4·r of the sphere's surface (where f32 rounding may
/// legitimately decide either way, or the 2e-6 cosine slack keeps a floor value).
///
/// Tolerance: the f32 evaluation computes the cosines with ~10 roundings (≤ 1e-6 absolute);
/// away from a boundary by ≥ 1e-3 rad each cosine factor is ≥ sin(1e-3) ≈ 1e-3, so each
/// factor is within 1e-3 relative, the product within 2e-3.
#[test]
fn eval_matches_math_md_formula() {
    let mut rng = Rng::new(0xF0);
    let mut compared = 0;
    let mut zeros = 0;
    for _ in 0..200_000 {
        let x = rng.in_cube(10.0);
        let c = x + rng.unit() * rng.log_range(1e-2, 1e2);
        let axis = rng.unit();
        let theta_o = match rng.below(4) {
            0 => 0.0,
            1 => std::f32::consts::PI,
            _ => std::f32::consts::PI * rng.f32(),
        };
        let theta_e = match rng.below(3) {
            0 => std::f32::consts::FRAC_PI_2,
            _ => std::f32::consts::FRAC_PI_2 * rng.f32(),
        };
        // A node written with the crate's own quantisation and decoded, so the reference sees
        // exactly the bounds eval sees.
        let cone = manylights::internals::bounds::Cone {
            axis,
            theta_o,
            theta_e,
        };
        let radius = match rng.below(3) {
            0 => 0.0,
            _ => rng.log_range(1e-3, 50.0),
        };
        let sphere = manylights::internals::bounds::Sphere { center: c, radius };
        let (origin, exponent, words) = manylights::internals::quantize::encode_spheres(&[sphere]);
        let mut node = Node4::EMPTY;
        node.raw_mut().origin = origin;
        node.raw_mut().exponent = exponent;
        node.raw_mut().sphere[0] = words[0];
        node.set_energy_code(
            0,
            manylights::internals::quantize::encode_energy(rng.log_range(1e-3, 1e3)),
        );
        node.raw_mut().cone[0] = manylights::internals::quantize::encode_cone(&cone);
        node.raw_mut().mask = 0x10;
        let b = node.bounds(0);
        let receiver = RECEIVERS[rng.below(3)];
        let imp = TlImportance::with_receiver(x, rng.unit(), receiver);
        let (reference, margin) = tl_reference(&imp, &b);
        let d = (b.center - x).as_dvec3().length();
        let r = f64::from(b.radius);
        if margin < 1e-3 || (d - r).abs() <= 1e-4 * r.max(d) {
            continue;
        }
        let forms = [
            ("eval", imp.eval(&b)),
            ("eval_slot", imp.eval_slot(&b)),
            ("eval_lane", imp.eval_lane(&node, 0)),
            ("eval4", imp.eval4(&node).to_array()[0]),
        ];
        if reference == 0.0 {
            zeros += 1;
        } else {
            compared += 1;
        }
        for (form, got) in forms {
            let got = f64::from(got);
            if reference == 0.0 {
                assert_eq!(got, 0.0, "formula gives 0, {form} {got}: {b:?} at {imp:?}");
            } else {
                assert!(
                    close(got, reference, 2e-3, 0.0),
                    "{form} {got} vs formula {reference}: {b:?} at {imp:?}"
                );
            }
        }
    }
    // Not vacuous: most draws are decided away from a boundary, both ways.
    assert!(compared > 50_000 && zeros > 20_000, "{compared} / {zeros}");
}

// ---------------------------------------------------------------------------------------------
// Conservativeness
// ---------------------------------------------------------------------------------------------

/// Property 5 at `points` random shading points of one scene: every light of positive energy
/// whose unoccluded contribution is positive (`common::contributes`, in f64 from the light's
/// geometry, every deciding cosine above 1e-4) has a positive pmf in both trees.
///
/// Margin: the importance is computed in f32 from f32 geometry; the cosines it compares with
/// a zero boundary carry ~1e-6 of rounding (and the crate already keeps a 2e-6 cosine slack
/// for that). A light whose deciding cosine is within 1e-4 of 0 is skipped: two orders of
/// magnitude above the rounding, and far below any cosine a renderer cares about.
fn check_conservative(
    lights: &[Light],
    half: f32,
    rng: &mut Rng,
    points: usize,
) -> Result<usize, String> {
    let tree = LightTree::build(lights).map_err(|e| e.to_string())?;
    let bin = BinaryLightTree::build(lights).map_err(|e| e.to_string())?;
    let mut checked = 0;
    for i in 0..points {
        let kind = [
            Where::Inside,
            Where::Far,
            Where::OnLight,
            Where::AtPointLight,
        ][i % 4];
        let x = common::shading_point(rng, lights, half, kind);
        let n = random_normal(rng);
        for receiver in RECEIVERS {
            let imp = TlImportance::with_receiver(x, n, receiver);
            // What the API made of the normal (zero → omnidirectional).
            let (n, receiver) = (imp.normal(), imp.receiver());
            for (l, light) in lights.iter().enumerate() {
                if light.energy() <= 0.0 || !contributes(light, x, n, receiver, 1e-4) {
                    continue;
                }
                checked += 1;
                let p = tree.pmf(&imp, l as u32);
                let pb = bin.pmf(&imp, l as u32);
                if !(p > 0.0 && pb > 0.0) {
                    return Err(format!(
                        "light {l} {light:?} contributes at {imp:?} but has pmf {p} \
                         (LightTree) / {pb} (BinaryLightTree)"
                    ));
                }
            }
        }
    }
    Ok(checked)
}

proptest::proptest! {
    #![proptest_config(proptest_config(160, 0x434f_4e53))]

    /// Property 5 over random scenes of 1 to 3,000 lights of all kinds and styles.
    #[test]
    fn contributing_lights_have_positive_pmf(n in scene_size(), seed in any::<u64>()) {
        let (lights, half) = styled_scene(seed, n);
        let mut rng = Rng::new(seed ^ 0xC0);
        let points = if n > 500 { 4 } else { 12 };
        check_conservative(&lights, half, &mut rng, points).map_err(TestCaseError::fail)?;
    }
}

proptest::proptest! {
    #![proptest_config(proptest_config(128, 0x5650_4c35))]

    /// Property 5 over random scenes with virtual point lights (mixed, alone, at one point):
    /// a VPL that reaches the shading point (x in front of its cosine lobe, the VPL above x's
    /// horizon) has a positive pmf.
    #[test]
    fn contributing_vpls_have_positive_pmf(n in scene_size(), seed in any::<u64>()) {
        let (lights, half) = vpl_scene(seed, n);
        let mut rng = Rng::new(seed ^ 0xC5);
        let points = if n > 500 { 4 } else { 12 };
        check_conservative(&lights, half, &mut rng, points).map_err(TestCaseError::fail)?;
    }
}

/// Property 5 on scenes built to sit near the boundaries: one-sided emitters and spots seen
/// almost edge-on, shading points just above the horizon of a light. Asserts the test is not
/// vacuous (many contributing pairs checked).
#[test]
fn contributing_lights_have_positive_pmf_near_boundaries() {
    let mut rng = Rng::new(0xB0);
    let mut checked = 0;
    for _ in 0..40 {
        let lights = boundary_scene(&mut rng);
        let tree = LightTree::build(&lights).unwrap();
        let bin = BinaryLightTree::build(&lights).unwrap();
        for _ in 0..12 {
            let mut x = rng.in_cube(10.0);
            x.z = [0.0, 1e-3, -1e-3, 0.05, -0.05][rng.below(5)];
            let n = [Vec3::Z, -Vec3::Z, Vec3::X, rng.unit()][rng.below(4)];
            for receiver in RECEIVERS {
                let imp = TlImportance::with_receiver(x, n, receiver);
                for (l, light) in lights.iter().enumerate() {
                    if light.energy() > 0.0
                        && contributes(light, x, imp.normal(), imp.receiver(), 1e-4)
                    {
                        checked += 1;
                        let (p, pb) = (tree.pmf(&imp, l as u32), bin.pmf(&imp, l as u32));
                        assert!(
                            p > 0.0 && pb > 0.0,
                            "light {l} {light:?} contributes at {imp:?}: pmf {p} / {pb}"
                        );
                    }
                }
            }
        }
    }
    assert!(checked > 10_000, "only {checked} contributing pairs");
}

/// The predicate itself, on cases decided by hand (so that a wrong predicate cannot make the
/// conservativeness tests vacuous).
#[test]
fn contribution_predicate_sanity() {
    use manylights::importance::Receiver::{
        Omnidirectional as O, Reflective as R, Transmissive as T,
    };
    let disk = |two_sided| Light::Disk {
        center: Vec3::ZERO,
        normal: Vec3::Z,
        radius: 1.0,
        radiance: Rgb::grey(1.0),
        two_sided,
    };
    let up = Vec3::Z;
    // In front of a one-sided disk, facing it / facing away / transmissive.
    assert!(contributes(&disk(false), Vec3::Z, -up, R, 1e-4));
    assert!(!contributes(&disk(false), Vec3::Z, up, R, 1e-4));
    assert!(contributes(&disk(false), Vec3::Z, up, T, 1e-4));
    // Behind it: only a two-sided disk reaches.
    assert!(!contributes(&disk(false), -Vec3::Z, up, O, 1e-4));
    assert!(contributes(&disk(true), -Vec3::Z, up, R, 1e-4));
    // Beside it, the normal tilted: the disk's rim is above the horizon.
    let x = Vec3::new(3.0, 0.0, 0.5);
    let n = Vec3::new(-0.1, 0.0, 1.0).normalize();
    assert!(!contributes(&disk(false), x, n, R, 1e-4)); // all of the disk is below the horizon
    let n = Vec3::new(-1.0, 0.0, 0.1).normalize();
    assert!(contributes(&disk(false), x, n, R, 1e-4));
    // A sphere below the horizon but poking above it.
    let s = Light::Sphere {
        center: Vec3::new(0.0, 0.0, -0.5),
        radius: 1.0,
        radiance: Rgb::grey(1.0),
    };
    assert!(contributes(&s, Vec3::new(5.0, 0.0, 0.0), up, R, 1e-4));
    assert!(!contributes(&s, Vec3::new(5.0, 0.0, 0.6), up, R, 1e-4));
    assert!(!contributes(&s, Vec3::ZERO, up, O, 1e-4)); // inside
                                                        // A spot of half-angle 100° pointing up lights a point slightly below its plane.
    let spot = Light::Spot {
        position: Vec3::ZERO,
        direction: Vec3::Z,
        intensity: Rgb::grey(1.0),
        half_angle: 100f32.to_radians(),
        falloff_start: 0.0,
    };
    assert!(contributes(
        &spot,
        Vec3::new(1.0, 0.0, -0.1),
        Vec3::X * -1.0,
        R,
        1e-4
    ));
    assert!(!contributes(
        &spot,
        Vec3::new(1.0, 0.0, -0.5),
        Vec3::X * -1.0,
        R,
        1e-4
    ));
    // A point light exactly at the shading point does not count.
    let p = Light::Point {
        position: Vec3::ONE,
        intensity: Rgb::grey(1.0),
    };
    assert!(!contributes(&p, Vec3::ONE, up, O, 1e-4));
    // A triangle facing +z, seen from above by a receiver looking down.
    let t = Light::Triangle {
        vertices: [Vec3::ZERO, Vec3::X, Vec3::Y],
        radiance: Rgb::grey(1.0),
        two_sided: false,
    };
    assert!(contributes(&t, Vec3::new(0.2, 0.2, 1.0), -up, R, 1e-4));
    assert!(!contributes(&t, Vec3::new(0.2, 0.2, -1.0), up, R, 1e-4));
}

/// Regression: `TlImportance` normalised its normal in f32 and, when the squared length
/// overflowed or underflowed (`(0, 0, 1e20)`, `(0, 0, 1e-30)`), silently made the point
/// omnidirectional: a light below the surface then got pmf 0.5 instead of 0. A finite non-zero
/// normal of any length is now normalised (in f64 where f32 would fail); only the zero vector
/// (and a non-finite normal) still means "omnidirectional".
#[test]
fn tiny_and_huge_normals_keep_the_surface() {
    let lights = [
        Light::Point {
            position: Vec3::new(0.3, 0.0, 2.0),
            intensity: Rgb::grey(1.0),
        },
        Light::Point {
            position: Vec3::new(-0.3, 0.0, -2.0),
            intensity: Rgb::grey(1.0),
        },
    ];
    let tree = LightTree::build(&lights).unwrap();
    let bin = BinaryLightTree::build(&lights).unwrap();
    for normal in [
        Vec3::new(0.0, 0.0, 1e20),
        Vec3::new(0.0, 0.0, 1e-30),
        Vec3::new(0.0, 0.0, f32::from_bits(1)),
        Vec3::new(0.0, 0.0, f32::MAX),
        Vec3::new(1e-45, 0.0, 3e-45),
        Vec3::new(3e38, 0.0, 1e38),
    ] {
        let want = normal.as_dvec3().normalize().as_vec3();
        for receiver in [Receiver::Reflective, Receiver::Transmissive] {
            let imp = TlImportance::with_receiver(Vec3::ZERO, normal, receiver);
            assert_eq!(imp.receiver(), receiver, "normal {normal}");
            assert!(
                (imp.normal() - want).length() <= 1e-6,
                "normal {normal}: unit normal {}",
                imp.normal()
            );
        }
        if normal.z > 0.0 && normal.x == 0.0 {
            let imp = TlImportance::new(Vec3::ZERO, normal);
            assert_eq!(tree.pmf(&imp, 0), 1.0, "normal {normal}");
            assert_eq!(tree.pmf(&imp, 1), 0.0, "normal {normal}: light below");
            assert_eq!(
                bin.pmf(&imp, 1),
                0.0,
                "normal {normal}: light below (binary)"
            );
        }
    }
    // The zero vector and non-finite normals keep their documented meaning.
    for normal in [
        Vec3::ZERO,
        Vec3::new(0.0, 0.0, f32::NAN),
        Vec3::new(f32::INFINITY, 0.0, 1.0),
    ] {
        let imp = TlImportance::new(Vec3::ZERO, normal);
        assert_eq!(imp.receiver(), Receiver::Omnidirectional, "normal {normal}");
        assert_eq!(imp.normal(), Vec3::ZERO);
    }
}

/// The same defect the `sptd` fuzz target found for BL (`tests/bl.rs`,
/// `a_cluster_a_femtometre_away_keeps_its_cap`): the direction x → cluster was divided by the
/// distance floored at `MIN_DISTANCE2` (1e-6), so within 1e-6 it shrank, here to a tenth of
/// a unit vector, and a narrow spot 1e-7 above x pointing straight at it looked as if it
/// pointed away: importance 0, pmf 0, the tree sampled nothing although the spot lights x.
/// The direction now comes from the true distance, down to distances whose square is below
/// f32's normal range.
#[test]
fn a_spot_a_tenth_of_a_micrometre_away_is_sampled() {
    for d in [1e-7f32, 1e-12, 1e-20, 1e-30] {
        let lights = [Light::Spot {
            position: Vec3::new(0.0, 0.0, d),
            direction: -Vec3::Z,
            intensity: Rgb::grey(1.0),
            half_angle: 0.1,
            falloff_start: 0.05,
        }];
        let tree = LightTree::build(&lights).unwrap();
        let imp = TlImportance::new(Vec3::ZERO, Vec3::Z);
        assert_eq!(tree.pmf(&imp, 0), 1.0, "d = {d}");
        let s = tree
            .sample(&imp, 0.5)
            .unwrap_or_else(|| panic!("d = {d}: no sample"));
        assert_eq!((s.light, s.pmf), (0, 1.0), "d = {d}");
        let b = tree.nodes()[0].bounds(0);
        let (one, four) = (imp.eval_slot(&b), imp.eval4(&tree.nodes()[0]).to_array()[0]);
        assert!(one > 0.0 && one.is_finite(), "d = {d}: {one}");
        assert!(
            (one - four).abs() <= 1e-4 * one.max(four),
            "d = {d}: scalar {one}, 4-wide {four}"
        );
    }
}
