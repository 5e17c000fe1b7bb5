//! Sampling and pmfs of `LightTree` and `BinaryLightTree`: sample/pmf agreement, pmfs summing
//! to 1, zero-energy lights never sampled (property tests over random scenes), a chi-square
//! test of the sampled frequencies, the far-field limit, and the zero-importance fallback of
//! docs/formulas.md, section 12.

mod common;

use common::{
    chi2_critical, chi2_skewed_statistic, chi2_statistic, close, contributes, proptest_config,
    random_importance, ring_scene, styled_scene, u_values, vpl_scene, zero_energy, Rng, Z_999,
};
use glam::Vec3;
use manylights::baseline::BinaryLightTree;
use manylights::importance::Receiver;
use manylights::tree::{Slot, SlotBounds};
use manylights::Rgb;
use manylights::MIN_PMF;
use manylights::{Importance, Light, LightTree, SampledLight, TlImportance};
use proptest::prelude::{any, prop_assert, prop_assert_eq, prop_oneof, Strategy};
use proptest::test_runner::TestCaseError;

/// Both trees behind one interface, so every check runs on both.
trait Sampler {
    const NAME: &'static str;
    fn sample(&self, imp: &TlImportance, u: f32) -> Option<SampledLight>;
    fn pmf(&self, imp: &TlImportance, light: u32) -> f32;
}

impl Sampler for LightTree {
    const NAME: &'static str = "LightTree";
    fn sample(&self, imp: &TlImportance, u: f32) -> Option<SampledLight> {
        LightTree::sample(self, imp, u)
    }
    fn pmf(&self, imp: &TlImportance, light: u32) -> f32 {
        LightTree::pmf(self, imp, light)
    }
}

impl Sampler for BinaryLightTree {
    const NAME: &'static str = "BinaryLightTree";
    fn sample(&self, imp: &TlImportance, u: f32) -> Option<SampledLight> {
        BinaryLightTree::sample(self, imp, u)
    }
    fn pmf(&self, imp: &TlImportance, light: u32) -> f32 {
        BinaryLightTree::pmf(self, imp, light)
    }
}

/// Properties 1a–1c at one shading point:
/// a. the pmf `sample` reports is `pmf()` of that light (1e-5 relative; they are computed by the
///    same operations, so in fact equal);
/// b. the pmfs of all lights sum to 1 within 1e-4 when a light is returned, and are all 0 when
///    none is (f32 products of ≤ 31 ratios, each ratio a few ulps off: far below 1e-4);
/// c. zero-energy lights are never returned and have pmf 0, for u = 0, tiny, 0.5, 1 − 2^-24 and
///    random u.
fn check_point<S: Sampler>(
    tree: &S,
    lights: &[Light],
    imp: &TlImportance,
    us: &[f32],
) -> Result<(), TestCaseError> {
    let name = S::NAME;
    let n = lights.len();
    let pmfs: Vec<f32> = (0..n as u32).map(|l| tree.pmf(imp, l)).collect();
    for (l, (&p, light)) in pmfs.iter().zip(lights).enumerate() {
        prop_assert!(
            p.is_finite() && (0.0..=1.0 + 1e-6).contains(&p),
            "{name}: pmf of light {l} is {p} at {imp:?}"
        );
        if zero_energy(light) {
            prop_assert!(
                p == 0.0,
                "{name}: zero-energy light {l} {light:?} has pmf {p}"
            );
        }
    }
    prop_assert_eq!(tree.pmf(imp, n as u32), 0.0, "{}: pmf of index n", name);
    prop_assert_eq!(
        tree.pmf(imp, u32::MAX),
        0.0,
        "{}: pmf of index u32::MAX",
        name
    );

    let (mut some, mut none) = (0usize, 0usize);
    for &u in us {
        match tree.sample(imp, u) {
            Some(s) => {
                some += 1;
                let l = s.light as usize;
                prop_assert!(l < n, "{name}: u={u} returned light {l} of {n}");
                prop_assert!(
                    !zero_energy(&lights[l]),
                    "{name}: u={u} returned zero-energy light {l} {:?}",
                    lights[l]
                );
                prop_assert!(s.pmf > 0.0, "{name}: u={u} light {l} with pmf {}", s.pmf);
                prop_assert!(
                    close(f64::from(s.pmf), f64::from(pmfs[l]), 1e-5, 0.0),
                    "{name}: u={u} light {l}: sample pmf {} vs pmf() {} at {imp:?}",
                    s.pmf,
                    pmfs[l]
                );
            }
            None => none += 1,
        }
    }
    // Whether a light is returned depends on the root only, never on u.
    prop_assert!(
        some == 0 || none == 0,
        "{name}: {some} u values sampled a light, {none} did not, at {imp:?}"
    );
    let sum: f64 = pmfs.iter().map(|&p| f64::from(p)).sum();
    if some > 0 {
        prop_assert!(
            (sum - 1.0).abs() <= 1e-4,
            "{name}: pmfs sum to {sum} at {imp:?}"
        );
    } else {
        prop_assert!(sum == 0.0, "{name}: nothing sampled but pmfs sum to {sum}");
    }

    // u outside [0, 1) is clamped into it (NaN to 0).
    prop_assert_eq!(
        tree.sample(imp, 1.0),
        tree.sample(imp, 1.0 - f32::EPSILON / 2.0)
    );
    prop_assert_eq!(
        tree.sample(imp, 7.5),
        tree.sample(imp, 1.0 - f32::EPSILON / 2.0)
    );
    prop_assert_eq!(tree.sample(imp, f32::NAN), tree.sample(imp, 0.0));
    prop_assert_eq!(tree.sample(imp, -1.0), tree.sample(imp, 0.0));
    prop_assert_eq!(tree.sample(imp, f32::NEG_INFINITY), tree.sample(imp, 0.0));
    Ok(())
}

/// Builds both trees over `lights` and runs [`check_point`] at `points` random shading points
/// (in the scene, far away, on a light, exactly at a point light; random normals, all three
/// receivers) with the fixed u values plus `extra_u` random ones.
fn check_scene(
    lights: &[Light],
    half: f32,
    rng: &mut Rng,
    points: usize,
    extra_u: usize,
) -> Result<(), TestCaseError> {
    let tree = LightTree::build(lights).map_err(|e| TestCaseError::fail(format!("{e}")))?;
    let bin = BinaryLightTree::build(lights).map_err(|e| TestCaseError::fail(format!("{e}")))?;
    prop_assert!(tree.validate().is_ok(), "{:?}", tree.validate());
    // Exactly the lights of positive energy are in the tree.
    for (l, light) in lights.iter().enumerate() {
        let path = tree.path(l as u32);
        prop_assert_eq!(
            path != 0,
            light.energy() > 0.0,
            "light {} {:?}: path {:#x}",
            l,
            light,
            path
        );
        if zero_energy(light) {
            prop_assert_eq!(path, 0, "zero-energy light {} is in the tree", l);
        }
    }
    for _ in 0..points {
        let imp = random_importance(rng, lights, half);
        let us = u_values(rng, extra_u);
        check_point(&tree, lights, &imp, &us)?;
        check_point(&bin, lights, &imp, &us)?;
    }
    Ok(())
}

/// Scene sizes: mostly small (where the corner cases are), some medium, a few up to 5,000.
fn scene_size() -> impl Strategy<Value = usize> {
    prop_oneof![
        5 => 1usize..=8,
        4 => 9usize..=300,
        1 => 301usize..=5000,
    ]
}

proptest::proptest! {
    #![proptest_config(proptest_config(256, 0x6d61_6e79_6c69_6768))]

    /// Properties 1a–1d over random scenes of 1 to 5,000 lights of all kinds.
    #[test]
    fn sample_and_pmf_agree_and_sum_to_one(n in scene_size(), seed in any::<u64>()) {
        let (lights, half) = styled_scene(seed, n);
        let mut rng = Rng::new(seed ^ 0xABCD);
        check_scene(&lights, half, &mut rng, 8, 24)?;
    }
}

proptest::proptest! {
    #![proptest_config(proptest_config(128, 0x5650_4c53))]

    /// Properties 1a–1d over random scenes with virtual point lights (mixed with every other
    /// kind, VPLs alone, all at one point): the VPL kind samples like every other.
    #[test]
    fn vpl_scenes_sample_and_pmf_agree_and_sum_to_one(n in scene_size(), seed in any::<u64>()) {
        let (lights, half) = vpl_scene(seed, n);
        let mut rng = Rng::new(seed ^ 0x5F1);
        check_scene(&lights, half, &mut rng, 8, 24)?;
    }
}

/// The same properties on fixed sizes: 1 to 5 lights (every shape of a root node) and one scene
/// of exactly 5,000 lights.
#[test]
fn sample_and_pmf_fixed_sizes() {
    for (i, n) in [1usize, 2, 3, 4, 5, 5000].into_iter().enumerate() {
        for s in 0..8u64 {
            let seed = 1000 * i as u64 + s;
            let (lights, half) = styled_scene(seed, n);
            let mut rng = Rng::new(seed);
            let points = if n > 1000 { 12 } else { 24 };
            if let Err(e) = check_scene(&lights, half, &mut rng, points, 32) {
                panic!("n = {n}, seed = {seed}: {e}");
            }
        }
    }
}

/// A scene where the root has positive importance only because of zero-energy lights would be
/// wrong: a scene of zero-energy lights only samples nothing, whatever u.
#[test]
fn only_zero_energy_lights_sample_nothing() {
    let lights = [
        Light::Point {
            position: Vec3::ZERO,
            intensity: Rgb::grey(0.0),
        },
        Light::Triangle {
            vertices: [Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
            radiance: Rgb::grey(3.0),
            two_sided: true,
        },
        Light::Sphere {
            center: Vec3::ONE,
            radius: 1.0,
            radiance: Rgb::grey(0.0),
        },
    ];
    let tree = LightTree::build(&lights).unwrap();
    let bin = BinaryLightTree::build(&lights).unwrap();
    assert!(tree.is_empty());
    let mut rng = Rng::new(5);
    for _ in 0..50 {
        let imp = random_importance(&mut rng, &lights, 2.0);
        for u in u_values(&mut rng, 10) {
            assert_eq!(tree.sample(&imp, u), None);
            assert_eq!(bin.sample(&imp, u), None);
        }
        for l in 0..3 {
            assert_eq!(tree.pmf(&imp, l), 0.0);
            assert_eq!(bin.pmf(&imp, l), 0.0);
        }
    }
}

/// The pmf recomputed from the documented algorithm (docs/formulas.md, section 12), in f64, from the
/// public nodes and `eval4`: at each node the slot weights are the importances, or below the
/// root the slots' energies when all importances are 0; at the root a zero sum means no light.
fn reference_pmf(tree: &LightTree, imp: &TlImportance, light: u32) -> f64 {
    let path = tree.path(light);
    if path == 0 {
        return 0.0;
    }
    let levels = (63 - path.leading_zeros()) / 2;
    let mut node = 0usize;
    let mut pmf = 1.0f64;
    for level in 0..levels {
        let k = ((path >> (2 * (levels - 1 - level))) & 3) as usize;
        let n = &tree.nodes()[node];
        let w = imp.eval4(n).to_array().map(f64::from);
        let sum: f64 = w.iter().sum();
        let (w, sum) = if sum > 0.0 {
            (w, sum)
        } else if level == 0 {
            return 0.0;
        } else {
            let e = n.energies().map(f64::from);
            (e, e.iter().sum())
        };
        pmf *= w[k] / sum;
        match tree.slot(n, k) {
            Slot::Node(c) => node = c as usize,
            Slot::Light(l) => {
                assert_eq!(l, light, "path of light {light} ends at light {l}");
                assert_eq!(level + 1, levels);
            }
            Slot::Empty => panic!("path of light {light} ends at an empty slot"),
        }
    }
    pmf
}

/// `pmf` equals the f64 recomputation of the documented descent within 1e-5 relative (an f32
/// product of at most 31 ratios, each a sum of four and a division, is within ~5·31 ulps).
#[test]
fn pmf_matches_reference_descent() {
    for seed in 0..40u64 {
        let n = [7usize, 64, 500, 3000][seed as usize % 4];
        let (lights, half) = styled_scene(seed + 77, n);
        let tree = LightTree::build(&lights).unwrap();
        let mut rng = Rng::new(seed);
        for _ in 0..4 {
            let imp = random_importance(&mut rng, &lights, half);
            for l in 0..n as u32 {
                let (p, r) = (f64::from(tree.pmf(&imp, l)), reference_pmf(&tree, &imp, l));
                assert!(
                    close(p, r, 1e-5, 1e-30),
                    "seed {seed} light {l}: pmf {p} vs reference {r} at {imp:?}"
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Chi-square
// ---------------------------------------------------------------------------------------------

/// Draws `samples` lights with u from `rng` and tests the counts against the pmfs with
/// Pearson's chi-square at level 0.001. Lights of pmf 0 must never be drawn; bins of expected
/// count below 5 are merged; the critical value is Wilson–Hilferty's (see `chi2_critical`).
fn chi_square<S: Sampler>(
    tree: &S,
    n: usize,
    imp: &TlImportance,
    samples: usize,
    rng: &mut Rng,
) -> (f64, f64, usize) {
    let mut counts = vec![0u64; n];
    for _ in 0..samples {
        let s = tree
            .sample(imp, rng.f32())
            .expect("the scene lights the point");
        counts[s.light as usize] += 1;
    }
    let pmfs: Vec<f64> = (0..n as u32).map(|l| f64::from(tree.pmf(imp, l))).collect();
    let total: f64 = pmfs.iter().sum();
    assert!((total - 1.0).abs() < 1e-4);
    let (mut obs, mut exp) = (Vec::new(), Vec::new());
    for l in 0..n {
        if pmfs[l] == 0.0 {
            assert_eq!(counts[l], 0, "{}: light {l} of pmf 0 drawn", S::NAME);
        } else {
            obs.push(counts[l]);
            // Normalised so that the expected counts add up to exactly `samples`.
            exp.push(samples as f64 * pmfs[l] / total);
        }
    }
    let (stat, dof) = chi2_statistic(&obs, &exp);
    let crit = chi2_critical(dof, Z_999);
    // The test has power: the same counts against the pmfs with the largest one 5 % too big
    // (renormalised) are rejected. (With p ≥ 1/64 and N = 10^6 the shift is ≥ 780 counts, at
    // least six standard deviations of that bin alone.)
    let skewed_stat = chi2_skewed_statistic(&obs, &exp, samples);
    assert!(
        skewed_stat > crit,
        "{}: a 5 % error in the largest pmf goes unnoticed ({skewed_stat} ≤ {crit})",
        S::NAME
    );
    (stat, crit, dof)
}

/// 10^6 samples at each of three shading points of a 64-light scene (fixed seeds), against the
/// pmfs (and 10^6 for the baseline tree at one of them): the chi-square statistic must be below the 0.999 quantile.
#[test]
fn chi_square_against_pmf() {
    // Powers within one decade so that most lights have expected counts well above 5.
    let spec = common::SceneSpec {
        half: 10.0,
        zero_energy: 0.05,
        power: (0.5, 5.0),
        ..common::SceneSpec::default()
    };
    let mut rng = Rng::new(0xC41);
    let lights = common::random_scene(&mut rng, 64, &spec);
    let tree = LightTree::build(&lights).unwrap();
    let bin = BinaryLightTree::build(&lights).unwrap();
    let points = [
        TlImportance::new(Vec3::new(0.5, -1.0, 0.2), Vec3::new(0.2, 0.3, 1.0)),
        TlImportance::with_receiver(Vec3::new(3.0, 2.0, -4.0), Vec3::X, Receiver::Transmissive),
        TlImportance::with_receiver(Vec3::ZERO, Vec3::ZERO, Receiver::Omnidirectional),
    ];
    for (i, imp) in points.iter().enumerate() {
        let (stat, crit, dof) = chi_square(&tree, lights.len(), imp, 1_000_000, &mut rng);
        eprintln!("LightTree point {i}: chi2 = {stat:.2}, critical {crit:.2}, dof {dof}");
        assert!(dof >= 30, "point {i}: only {dof} degrees of freedom");
        assert!(
            stat < crit,
            "LightTree point {i}: chi2 = {stat:.2} ≥ {crit:.2} (dof {dof})"
        );
    }
    // The baseline at the first point.
    let (stat, crit, dof) = chi_square(&bin, lights.len(), &points[0], 1_000_000, &mut rng);
    eprintln!("BinaryLightTree: chi2 = {stat:.2}, critical {crit:.2}, dof {dof}");
    assert!(
        stat < crit,
        "BinaryLightTree: chi2 = {stat:.2} ≥ {crit:.2} (dof {dof})"
    );
}

// ---------------------------------------------------------------------------------------------
// Far field
// ---------------------------------------------------------------------------------------------

/// 16 omnidirectional emitters (8 points, 8 spheres of radius ≤ 5, powers in [1, 3]) in
/// [-100, 100]^3.
fn far_field_scene() -> Vec<Light> {
    let pi = std::f32::consts::PI;
    let mut rng = Rng::new(0xFA4);
    (0..16)
        .map(|i| {
            let energy = rng.range(1.0, 3.0);
            let p = rng.in_cube(100.0);
            if i % 2 == 0 {
                Light::Point {
                    position: p,
                    intensity: Rgb::grey(energy / (4.0 * pi)),
                }
            } else {
                let radius = rng.range(0.5, 5.0);
                Light::Sphere {
                    center: p,
                    radius,
                    radiance: Rgb::grey(energy / (4.0 * pi * pi * radius * radius)),
                }
            }
        })
        .collect()
}

fn power_shares(lights: &[Light]) -> Vec<f64> {
    let total: f64 = lights.iter().map(|l| f64::from(l.energy())).sum();
    lights
        .iter()
        .map(|l| f64::from(l.energy()) / total)
        .collect()
}

/// The largest relative deviation of the pmfs from the power shares.
fn far_field_delta(pmf: impl Fn(u32) -> f32, share: &[f64]) -> f64 {
    (0..share.len())
        .map(|l| (f64::from(pmf(l as u32)) / share[l] - 1.0).abs())
        .fold(0.0, f64::max)
}

/// The pmfs converge to the power shares as 1/D: seen from distance D, every weight E/d² of
/// a cluster has d within D ± ρ (ρ = the largest distance of a light's centre from the origin
/// plus the largest radius), so each pmf is its power share times a factor within
/// [((D − ρ)/(D + ρ))², ((D + ρ)/(D − ρ))²] — a relative deviation ≤ ((D + ρ)/(D − ρ))² − 1
/// ≈ 4ρ/D (measured: about half of that). Checked exactly (no sampling) at D = 10^4, 10^5, 10^6
/// from several directions, with an omnidirectional receiver and one facing the scene.
#[test]
fn far_field_pmfs_converge_to_power() {
    let lights = far_field_scene();
    let share = power_shares(&lights);
    let rho = lights
        .iter()
        .map(|l| match *l {
            Light::Point { position, .. } => position.as_dvec3().length(),
            Light::Sphere { center, radius, .. } => center.as_dvec3().length() + f64::from(radius),
            _ => unreachable!(),
        })
        .fold(0.0, f64::max);
    let tree = LightTree::build(&lights).unwrap();
    let bin = BinaryLightTree::build(&lights).unwrap();
    let mut rng = Rng::new(0xFA5);
    for dir in [
        Vec3::X,
        -Vec3::Y,
        Vec3::ONE.normalize(),
        rng.unit(),
        rng.unit(),
    ] {
        for dist in [1e4f64, 1e5, 1e6] {
            let bound = ((dist + rho) / (dist - rho)).powi(2) - 1.0;
            let x = dir * dist as f32;
            for imp in [
                TlImportance::with_receiver(x, Vec3::ZERO, Receiver::Omnidirectional),
                TlImportance::new(x, -dir),
            ] {
                let d4 = far_field_delta(|l| tree.pmf(&imp, l), &share);
                let d2 = far_field_delta(|l| bin.pmf(&imp, l), &share);
                assert!(
                    d4 <= bound && d2 <= bound,
                    "{imp:?}: pmfs deviate from power shares by {d4} / {d2} > {bound}"
                );
            }
        }
    }
}

/// Sampled frequencies are proportional to power within 3 %, seen from D = 10^5 (an
/// omnidirectional receiver on an axis, a reflective one facing the scene from a random
/// direction), for both trees.
///
/// Why 10^5 and not 10^4: the TL importance keeps its 1/d² factor, and across a scene of
/// half-size 100 that factor alone spreads the pmfs by up to ≈ 4ρ/D around the power shares
/// (measured 2.1–2.5 % at 10^4; see `far_field_pmfs_converge_to_power`), leaving no room under
/// 3 % for the statistical error at a reasonable sample count. At 10^5 the systematic deviation
/// δ is ≈ 0.25 %, measured exactly from `pmf()` and asserted ≤ 0.5 %.
///
/// Sample count: the relative standard error of a frequency is σ = sqrt((1 − p)/(N·p)), so
/// N = 25·(1 − p_min)/(p_min·(0.03 − δ)²) makes the remaining margin 0.03 − δ five standard
/// errors for the least likely light (two-sided tail 6e-7 per light, 1e-5 for all 16 lights of
/// both trees at both points).
#[test]
fn far_field_frequencies_follow_power() {
    let lights = far_field_scene();
    let share = power_shares(&lights);
    let p_min = share.iter().cloned().fold(1.0, f64::min);
    let tree = LightTree::build(&lights).unwrap();
    let bin = BinaryLightTree::build(&lights).unwrap();
    let mut rng = Rng::new(0xFA6);
    let dir = rng.unit();
    for imp in [
        TlImportance::with_receiver(Vec3::X * 1e5, Vec3::ZERO, Receiver::Omnidirectional),
        TlImportance::new(dir * 1e5, -dir),
    ] {
        let delta = far_field_delta(|l| tree.pmf(&imp, l), &share)
            .max(far_field_delta(|l| bin.pmf(&imp, l), &share));
        assert!(delta <= 0.005, "{imp:?}: systematic deviation {delta}");
        let margin = 0.03 - delta;
        let n = (25.0 * (1.0 - p_min) / (p_min * margin * margin)).ceil() as usize;
        let mut counts = vec![0u64; lights.len()];
        let mut counts_bin = vec![0u64; lights.len()];
        for _ in 0..n {
            let u = rng.f32();
            counts[tree.sample(&imp, u).unwrap().light as usize] += 1;
            counts_bin[bin.sample(&imp, u).unwrap().light as usize] += 1;
        }
        for l in 0..lights.len() {
            for (name, c) in [("LightTree", counts[l]), ("BinaryLightTree", counts_bin[l])] {
                let f = c as f64 / n as f64;
                assert!(
                    (f / share[l] - 1.0).abs() <= 0.03,
                    "{name} {imp:?} light {l}: frequency {f} vs power share {} ({n} samples, \
                     systematic δ {delta})",
                    share[l]
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Zero-importance fallback (docs/formulas.md, section 12)
// ---------------------------------------------------------------------------------------------

/// Every light under node `node`.
fn lights_under(tree: &LightTree, node: u32, out: &mut Vec<u32>) {
    let n = &tree.nodes()[node as usize];
    for k in 0..4 {
        match tree.slot(n, k) {
            Slot::Light(l) => out.push(l),
            Slot::Node(c) => lights_under(tree, c, out),
            Slot::Empty => {}
        }
    }
}

/// A slot of positive importance whose node has four slots of importance 0: the descent falls
/// back to the slots' energies there. Checks that such a node is reached (its lights have
/// pmf > 0 and are sampled), that within it the pmfs are in the ratio of the energies, that
/// `sample` and `pmf` agree and the pmfs sum to 1 — and that none of its lights contributes
/// (conservativeness: the fallback only ever spends samples on useless lights).
#[test]
fn zero_importance_fallback() {
    let (lights, imp) = ring_scene();
    let tree = LightTree::build(&lights).unwrap();
    let bin = BinaryLightTree::build(&lights).unwrap();

    let mut fallback = Vec::new();
    for (i, parent) in tree.nodes().iter().enumerate() {
        for k in 0..4 {
            if let Slot::Node(c) = tree.slot(parent, k) {
                let child = &tree.nodes()[c as usize];
                let positive = imp.eval(&parent.bounds(k)) > 0.0;
                let w = imp.eval4(child).to_array();
                if positive && w.iter().all(|&x| x == 0.0) {
                    fallback.push((i, k, c));
                }
            }
        }
    }
    assert!(!fallback.is_empty(), "the scene has no fallback node");

    let mut reached = 0;
    for &(_, _, c) in &fallback {
        let mut under = Vec::new();
        lights_under(&tree, c, &mut under);
        for &l in &under {
            assert!(
                !contributes(
                    &lights[l as usize],
                    imp.position(),
                    imp.normal(),
                    imp.receiver(),
                    0.0
                ),
                "light {l} under fallback node {c} contributes"
            );
        }
        let pmfs: Vec<f32> = under.iter().map(|&l| tree.pmf(&imp, l)).collect();
        if pmfs.iter().all(|&p| p > 0.0) {
            reached += 1;
        }
        // Leaf slots of the fallback node: pmfs in the ratio of their energies.
        let node = &tree.nodes()[c as usize];
        let leaves: Vec<(u32, f32)> = (0..4)
            .filter_map(|k| match tree.slot(node, k) {
                Slot::Light(l) => Some((l, node.energy_of(k))),
                _ => None,
            })
            .collect();
        for w in leaves.windows(2) {
            let ((a, ea), (b, eb)) = (w[0], w[1]);
            let (pa, pb) = (tree.pmf(&imp, a), tree.pmf(&imp, b));
            if pa > 0.0 || pb > 0.0 {
                assert!(
                    close(
                        f64::from(pa) / f64::from(pb),
                        f64::from(ea) / f64::from(eb),
                        1e-5,
                        0.0
                    ),
                    "fallback node {c}: pmfs {pa}, {pb} vs energies {ea}, {eb}"
                );
            }
        }
    }
    assert!(reached > 0, "no fallback node is reached: {fallback:?}");

    // pmf() is the documented descent, fallback included.
    for l in 0..lights.len() as u32 {
        let (p, r) = (f64::from(tree.pmf(&imp, l)), reference_pmf(&tree, &imp, l));
        assert!(
            close(p, r, 1e-5, 1e-30),
            "light {l}: pmf {p} vs reference {r}"
        );
    }

    // Consistency and sum to 1 at this point, for both trees, with many u.
    let mut rng = Rng::new(0xFA11);
    let us = u_values(&mut rng, 4000);
    check_point(&tree, &lights, &imp, &us).unwrap();
    check_point(&bin, &lights, &imp, &us).unwrap();

    // The fallback lights are drawn as often as their pmfs say: the fraction of N = 10^5 draws
    // landing under a fallback node is within 5 binomial standard errors sqrt(P(1 − P)/N) of
    // the sum P of their pmfs.
    let mut under_all = Vec::new();
    for &(_, _, c) in &fallback {
        lights_under(&tree, c, &mut under_all);
    }
    let p_total: f64 = under_all
        .iter()
        .map(|&l| f64::from(tree.pmf(&imp, l)))
        .sum();
    assert!(p_total > 0.0);
    let n = 100_000;
    let drawn = (0..n)
        .filter(|_| {
            let s = tree.sample(&imp, rng.f32()).unwrap();
            under_all.contains(&s.light)
        })
        .count();
    let f = drawn as f64 / n as f64;
    let sigma = (p_total * (1.0 - p_total) / n as f64).sqrt();
    assert!(
        (f - p_total).abs() <= 5.0 * sigma,
        "fallback lights drawn with frequency {f}, pmf sum {p_total} (σ {sigma})"
    );

    // The baseline tree falls back the same way: find an inner node of positive importance
    // whose two children both have importance 0 (the same geometry makes one).
    let nodes = bin.nodes();
    let bounds = |i: usize| {
        let n = &nodes[i];
        SlotBounds {
            center: Vec3::from_array(n.center),
            radius: n.radius,
            axis: Vec3::from_array(n.axis),
            cos_o: n.cos_o,
            sin_o: n.sin_o,
            cos_e: n.cos_e,
            energy: n.energy,
        }
    };
    let bin_fallback = (0..nodes.len()).any(|i| {
        nodes[i].child & (1 << 31) == 0
            && imp.eval(&bounds(i)) > 0.0
            && imp.eval(&bounds(i + 1)) == 0.0
            && imp.eval(&bounds(nodes[i].child as usize)) == 0.0
    });
    assert!(bin_fallback, "the baseline tree has no fallback node here");
}

// ---------------------------------------------------------------------------------------------
// Regressions: vanishing probabilities
// ---------------------------------------------------------------------------------------------

/// Every pmf `sample` reports and `pmf` gives is 0 or at least `MIN_PMF` (so a renderer can
/// divide by it), `sample` agrees with `pmf` bit for bit, the pmfs sum to 1, and u = 0, NaN,
/// negative and the u values of `u_values` (plus `extra` random ones) all give such samples.
fn check_no_vanishing_pmf<S: Sampler>(
    tree: &S,
    n: usize,
    imp: &TlImportance,
    rng: &mut Rng,
    extra: usize,
) {
    let name = S::NAME;
    let pmfs: Vec<f32> = (0..n as u32).map(|l| tree.pmf(imp, l)).collect();
    for (l, &p) in pmfs.iter().enumerate() {
        assert!(
            p == 0.0 || (MIN_PMF..=1.0).contains(&p),
            "{name}: light {l} has pmf {p:e} at {imp:?}"
        );
    }
    let mut us = u_values(rng, extra);
    us.extend([f32::NAN, -1.0, -0.0, f32::NEG_INFINITY]);
    let mut sampled = false;
    for u in us {
        let Some(s) = tree.sample(imp, u) else {
            continue;
        };
        sampled = true;
        assert!(
            (MIN_PMF..=1.0).contains(&s.pmf),
            "{name}: u={u} sampled light {} with pmf {:e} at {imp:?}",
            s.light,
            s.pmf
        );
        assert_eq!(
            s.pmf, pmfs[s.light as usize],
            "{name}: u={u} light {}: sample pmf vs pmf()",
            s.light
        );
    }
    let sum: f64 = pmfs.iter().map(|&p| f64::from(p)).sum();
    if sampled {
        // Products of at most 32 ratios, each a few ulps off.
        assert!((sum - 1.0).abs() <= 1e-4, "{name}: pmfs sum to {sum}");
    } else {
        assert_eq!(sum, 0.0, "{name}: nothing sampled but pmfs sum to {sum}");
    }
}

/// Both trees over `lights`, checked at `imp` and at `points` random shading points.
fn check_vanishing_scene(lights: &[Light], imp: &TlImportance, points: usize, seed: u64) {
    let tree = LightTree::build(lights).unwrap();
    let bin = BinaryLightTree::build(lights).unwrap();
    let mut rng = Rng::new(seed);
    let n = lights.len();
    check_no_vanishing_pmf(&tree, n, imp, &mut rng, 16);
    check_no_vanishing_pmf(&bin, n, imp, &mut rng, 16);
    for _ in 0..points {
        let imp = random_importance(&mut rng, lights, 4.0);
        check_no_vanishing_pmf(&tree, n, &imp, &mut rng, 4);
        check_no_vanishing_pmf(&bin, n, &imp, &mut rng, 4);
    }
}

/// Regression: a light whose share of its node's importance is below f32's smallest numbers
/// had pmf 0, and u = 0 (or NaN or negative u, clamped to 0) still sampled it, so `sample`
/// returned `Some { light: 1, pmf: 0.0 }` here. Such a light is now never sampled (its slot
/// gets weight 0 in both `sample` and `pmf`) and the others share its probability.
#[test]
fn vanishing_share_is_never_sampled() {
    let lights = [
        Light::Point {
            position: Vec3::new(1.0, 1.0, 1.0),
            intensity: Rgb::grey(2.0),
        },
        Light::Point {
            position: Vec3::new(0.0, 0.0, 2.0),
            intensity: Rgb::grey(1e-40),
        },
        Light::Sphere {
            center: Vec3::new(-1.0, 0.5, 1.5),
            radius: 0.25,
            radiance: Rgb::grey(3.0),
        },
    ];
    let imp = TlImportance::new(Vec3::new(0.0, 0.0, 1.0), Vec3::X);
    let tree = LightTree::build(&lights).unwrap();
    let s = tree.sample(&imp, 0.0).expect("two lights contribute");
    assert_ne!(s.light, 1, "{s:?}");
    assert!(s.pmf >= MIN_PMF, "{s:?}");
    assert_eq!(tree.pmf(&imp, 1), 0.0);
    check_vanishing_scene(&lights, &imp, 50, 0xA11);
}

/// Regression: subnormal intensities (energies of 1e-39 down to the smallest subnormal) next
/// to ordinary lights, and scenes made of such lights only.
#[test]
fn subnormal_intensities_never_give_pmf_zero() {
    let tiny = [1e-38, 1e-39, 1e-41, 1e-43, f32::from_bits(1)];
    let mut rng = Rng::new(0x5AB);
    let mut mixed = Vec::new();
    let mut only_tiny = Vec::new();
    for i in 0..40 {
        let position = Vec3::new(
            rng.f32() * 4.0 - 2.0,
            rng.f32() * 4.0 - 2.0,
            rng.f32() * 2.0,
        );
        let intensity = tiny[i % tiny.len()];
        mixed.push(Light::Point {
            position,
            intensity: if i % 3 == 0 {
                (1.0 + rng.f32()).into()
            } else {
                intensity.into()
            },
        });
        only_tiny.push(Light::Point {
            position,
            intensity: intensity.into(),
        });
    }
    let imp = TlImportance::new(Vec3::ZERO, Vec3::Z);
    check_vanishing_scene(&mixed, &imp, 100, 0x5AB1);
    check_vanishing_scene(&only_tiny, &imp, 100, 0x5AB2);
}

/// Regression: a triangle with a vertex offset by 1e-45 from another (area and energy near
/// f32's smallest subnormal) next to ordinary lights.
#[test]
fn tiny_triangle_never_gives_pmf_zero() {
    let mut lights = vec![
        Light::Triangle {
            vertices: [
                Vec3::new(0.0, 0.0, 2.0),
                Vec3::new(1e-45, 0.0, 2.0),
                Vec3::new(0.0, 1.0, 2.0),
            ],
            radiance: Rgb::grey(1.0),
            two_sided: false,
        },
        Light::Triangle {
            vertices: [
                Vec3::new(1e-45, 1e-45, 1.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(0.0, 1e-45, 1.0),
            ],
            radiance: Rgb::grey(5.0),
            two_sided: true,
        },
    ];
    for i in 0..6 {
        lights.push(Light::Sphere {
            center: Vec3::new(i as f32 - 2.5, 1.0, 3.0),
            radius: 0.2,
            radiance: Rgb::grey(1.0),
        });
    }
    let imp = TlImportance::new(Vec3::new(0.0, 0.0, 0.0), Vec3::Z);
    check_vanishing_scene(&lights, &imp, 100, 0x7121);
}

/// Regression: a shading point on a point light at 1e15 sees it with importance E/1e-12 and
/// the other lights, 1e15 away, with E/1e30: their shares underflow f32.
#[test]
fn far_shading_point_on_a_light_never_gives_pmf_zero() {
    let at = Vec3::new(1e15, 0.0, 0.0);
    let mut lights = vec![Light::Point {
        position: at,
        intensity: Rgb::grey(1.0),
    }];
    for i in 0..12 {
        lights.push(Light::Point {
            position: Vec3::new(0.0, i as f32 * 1e13, 0.0),
            intensity: Rgb::grey(1.0 + i as f32),
        });
        lights.push(Light::Point {
            position: Vec3::new(1e15, 1e15, i as f32 * 1e13),
            intensity: Rgb::grey(2.0),
        });
    }
    for receiver in [
        Receiver::Reflective,
        Receiver::Transmissive,
        Receiver::Omnidirectional,
    ] {
        let imp = TlImportance::with_receiver(at, Vec3::new(-1.0, 1.0, 0.5), receiver);
        check_vanishing_scene(&lights, &imp, 20, 0xFA2);
    }
}

/// Regression: pmfs spread over the whole f32 range, so that they underflow through the
/// product of the ratios along a path as well as through single ratios: 16 groups of three
/// point lights, each group 1e-3 as bright as the one before (down to 1e-45).
#[test]
fn vanishing_path_products_are_never_sampled() {
    let mut lights = Vec::new();
    for i in 0..16 {
        for j in 0..3 {
            lights.push(Light::Point {
                position: Vec3::new(i as f32 * 10.0 + j as f32, 0.0, 1.0),
                intensity: Rgb::grey(libm_free_pow10(-3 * i)),
            });
        }
    }
    let imp = TlImportance::with_receiver(
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::ZERO,
        Receiver::Omnidirectional,
    );
    check_vanishing_scene(&lights, &imp, 50, 0xDEE9);
}

/// 10^e for small integer e, in f32 (to the nearest of repeated multiplication).
fn libm_free_pow10(e: i32) -> f32 {
    let mut x = 1.0f64;
    for _ in 0..e.unsigned_abs() {
        x = if e < 0 { x / 10.0 } else { x * 10.0 };
    }
    x as f32
}

/// The batch calls equal the single calls bit for bit — TL, BL (every material) and memoised
/// importances, on random scenes of every light kind (VPLs included), default and compact trees, batches of every length
/// around the number of lanes, u from the edges of [0, 1) as well as inside — and reject
/// slices of different lengths.
#[test]
fn batch_calls_equal_single_calls() {
    use manylights::importance::MemoTable;
    use manylights::internals::sample::BATCH_LANES;
    use manylights::{BlImportance, Material, Memo, ShadingPoint};
    let table = MemoTable::new();
    let mut compared = 0usize;
    for seed in 0..24u64 {
        let n = [1usize, 3, 50, 700, 4000][seed as usize % 5];
        let (lights, half) = if seed % 3 == 2 {
            vpl_scene(seed + 500, n)
        } else {
            styled_scene(seed + 500, n)
        };
        let opts = manylights::BuildOptions {
            compact: seed % 2 == 1,
            ..manylights::BuildOptions::default()
        };
        let tree = LightTree::build_with(&lights, &opts).unwrap();
        let mut rng = Rng::new(seed ^ 0xBA7C);
        let m = [1usize, BATCH_LANES - 1, BATCH_LANES, BATCH_LANES + 1, 67][seed as usize % 5];
        let tl: Vec<TlImportance> = (0..m)
            .map(|_| random_importance(&mut rng, &lights, half))
            .collect();
        let bl: Vec<BlImportance> = tl
            .iter()
            .map(|t| {
                let material = match rng.below(3) {
                    0 => Material::Lambert {
                        albedo: Rgb::grey(0.8),
                    },
                    1 => Material::Ggx {
                        alpha: rng.log_range(0.01, 1.0),
                        specular: 1.0,
                    },
                    _ => Material::Plastic {
                        albedo: Rgb::grey(0.5),
                        specular: 0.5,
                        alpha: rng.log_range(0.01, 1.0),
                    },
                };
                let n = if t.normal() == Vec3::ZERO {
                    Vec3::Z
                } else {
                    t.normal()
                };
                BlImportance::new(&ShadingPoint {
                    position: t.position(),
                    normal: n,
                    wo: n + rng.unit() * 0.9,
                    material,
                })
                .unwrap()
            })
            .collect();
        let us: Vec<f32> = (0..m)
            .map(|j| match j % 7 {
                0 => 0.0,
                1 => manylights::internals::sample::ONE_MINUS_EPSILON,
                _ => rng.f32(),
            })
            .collect();
        let memos: Vec<Memo<'_, TlImportance>> =
            tl.iter().map(|&t| Memo::new(t, &tree, &table)).collect();
        let mut out = vec![None; m];
        let mut pmfs = vec![0.0f32; m];
        macro_rules! check {
            ($imps:expr) => {{
                let imps = $imps;
                tree.sample_batch(imps, &us, &mut out).unwrap();
                for j in 0..m {
                    assert_eq!(
                        out[j],
                        tree.sample(&imps[j], us[j]),
                        "seed {seed} point {j}"
                    );
                }
                // The pmfs of the sampled lights and of arbitrary ones (out of range included).
                let ls: Vec<u32> = (0..m)
                    .map(|j| match out[j] {
                        Some(s) if j % 3 != 0 => s.light,
                        _ => rng.below(n + 2) as u32,
                    })
                    .collect();
                tree.pmf_batch(imps, &ls, &mut pmfs).unwrap();
                for j in 0..m {
                    assert_eq!(
                        pmfs[j].to_bits(),
                        tree.pmf(&imps[j], ls[j]).to_bits(),
                        "seed {seed} point {j} light {}",
                        ls[j]
                    );
                }
                compared += m;
            }};
        }
        check!(&tl[..]);
        check!(&bl[..]);
        check!(&memos[..]);
        // Slices of different lengths are an error naming the argument.
        let e = tree.sample_batch(&tl, &us[..m - 1], &mut out).unwrap_err();
        assert_eq!((e.what, e.expected, e.got), ("us", m, m - 1));
        let e = tree.pmf_batch(&tl, &[0], &mut pmfs[..m]);
        assert!(m == 1 || e.unwrap_err().what == "lights");
    }
    assert!(compared > 1000, "{compared}");
}
