//! A small version of `mlmeasure estimator`'s checks: every technique of the core's `direct`
//! module against an independent numerical reference on random scenes.

use glam::Vec3;
use manylights::direct::{Estimator, LambertMode, Params, Technique, Unoccluded};
use manylights::internals::trace::trace_all;
use manylights::Rgb;
use manylights::{Light, Material, ShadingPoint};
use manylights_instruments::estimator::reference::reference;
use manylights_instruments::estimator::scene::{Config, Plan, Scene};
use manylights_render::uniforms::RngUniforms;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Mean and standard error of `k` estimates.
fn run(est: &mut Estimator, k: usize, seed: u64) -> (f64, f64) {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..k {
        // Grey scenes: every channel is the same estimate.
        let x = est
            .estimate(&Unoccluded, &mut RngUniforms(&mut rng))
            .unwrap()[0];
        s += x;
        s2 += x * x;
    }
    let n = k as f64;
    let mean = s / n;
    let var = (s2 / n - mean * mean).max(0.0) * n / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
fn tree_walk_finds_the_same_lights_as_brute_force() {
    let scene = Scene::new(300, 8, Plan::Cycle, 7);
    let mut rng = Pcg64Mcg::seed_from_u64(3);
    let mut hits = 0usize;
    for c in &scene.configs {
        for _ in 0..400 {
            let z: f32 = rng.random_range(-1.0..1.0);
            let phi: f32 = rng.random_range(0.0..std::f32::consts::TAU);
            let s = (1.0 - z * z).sqrt();
            let d = Vec3::new(s * phi.cos(), s * phi.sin(), z);
            let mut walked = Vec::new();
            scene
                .set
                .trace(c.sp.position, d, |l, lp| walked.push((l, *lp)));
            let mut brute = Vec::new();
            trace_all(scene.set.lights(), c.sp.position, d, |l, lp| {
                brute.push((l, *lp))
            });
            walked.sort_by_key(|h| h.0);
            brute.sort_by_key(|h| h.0);
            assert_eq!(walked, brute);
            hits += brute.len();
        }
    }
    // The scene's lights cover a few percent of the sphere: some rays must hit.
    assert!(hits > 20, "{hits} hits");
}

#[test]
fn reference_matches_closed_forms() {
    let albedo = 0.8f32;
    let sp = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::new(0.3, 0.1, 1.0),
        material: Material::Lambert {
            albedo: albedo.into(),
        },
    };
    let config = Config {
        point: 0,
        material: 0,
        sp,
    };
    // A sphere entirely above the horizon: (ρ/π) L π sin²σ cos ω.
    let (c, r, l) = (Vec3::new(1.0, 0.5, 2.0), 0.4f32, 3.0f32);
    let sphere = Light::Sphere {
        center: c,
        radius: r,
        radiance: Rgb::grey(l),
    };
    let d = f64::from(c.length());
    let sin2 = f64::from(r * r) / (d * d);
    let exact = f64::from(albedo) * f64::from(l) * sin2 * f64::from(c.z) / d;
    // A disk facing the point on its axis at height h: (ρ/π) L π R² / (h² + R²).
    let (h, rd) = (1.5f32, 0.7f32);
    let disk = Light::Disk {
        center: Vec3::new(0.0, 0.0, h),
        normal: -Vec3::Z,
        radius: rd,
        radiance: Rgb::grey(l),
        two_sided: false,
    };
    let exact_disk =
        f64::from(albedo) * f64::from(l) * f64::from(rd * rd) * (1.0 / f64::from(h * h + rd * rd));
    // The same disk turned away contributes 0.
    let away = Light::Disk {
        center: Vec3::new(0.0, 0.0, h),
        normal: Vec3::Z,
        radius: rd,
        radiance: Rgb::grey(l),
        two_sided: false,
    };
    for (lights, exact) in [
        (vec![sphere], exact),
        (vec![disk], exact_disk),
        (vec![sphere, disk, away], exact + exact_disk),
    ] {
        let scene = Scene::with_lights(lights, vec![config]);
        let r = reference(&scene, &sp, 1e-3, 1e-4, 5);
        assert!(r.std_err <= 1e-4 * r.value, "{r:?}");
        assert!(
            (r.value - exact).abs() <= 5.0 * r.std_err + 1e-6 * exact,
            "{} vs {exact} (se {})",
            r.value,
            r.std_err
        );
    }
}

/// Every technique's mean is within 5 standard errors of the exact value, on 5 configurations
/// (one per material) of a 100-light scene.
#[test]
fn every_technique_is_unbiased_on_a_small_scene() {
    let scene = Scene::new(100, 5, Plan::Cycle, 11);
    let params = Params::default();
    let mut worst = 0.0f64;
    for (ci, c) in scene.configs.iter().enumerate() {
        let exact = reference(&scene, &c.sp, 1e-3, 1e-4, 100 + ci as u64);
        assert!(exact.value > 0.0);
        let mut cases: Vec<(Technique, Params)> =
            Technique::ALL.iter().map(|&t| (t, params)).collect();
        if c.is_diffuse() {
            for mode in [LambertMode::TbOne, LambertMode::TbBudget, LambertMode::BlTb] {
                cases.push((
                    Technique::Full,
                    Params {
                        lambert: mode,
                        ..params
                    },
                ));
            }
        }
        for t in [Technique::MisEqual, Technique::Full] {
            cases.push((
                t,
                Params {
                    heuristic: manylights::Heuristic::Balance,
                    ..params
                },
            ));
        }
        for (i, (t, p)) in cases.into_iter().enumerate() {
            let k = match t {
                Technique::Uniform | Technique::Energy | Technique::Tl | Technique::Bl => 200_000,
                Technique::TlMis | Technique::BlMis | Technique::TlMisPinf => 100_000,
                Technique::TlSplit => 40_000,
                Technique::MisEqual | Technique::Full => 12_000,
                _ => unimplemented!("a technique this test does not know"),
            };
            let mut est = Estimator::new(&scene.set, &c.sp, t, &p).unwrap();
            let (mean, se) = run(&mut est, k, 1000 * ci as u64 + i as u64);
            let sigma = (se * se + exact.std_err * exact.std_err).sqrt();
            let z = (mean - exact.value) / sigma;
            worst = worst.max(z.abs());
            assert!(
                z.abs() <= 5.0,
                "{} {} ({p:?}): mean {mean} exact {} se {se}: {z:.2} SE",
                c.material_name(),
                t.name(),
                exact.value
            );
        }
    }
    eprintln!("largest deviation: {worst:.2} SE");
}

/// BRDF sampling alone (every light its ray reaches, divided by the material's pdf) against
/// the reference, for every material, where lights cover much of the hemisphere so that its
/// variance is small.
#[test]
fn brdf_sampling_alone_is_unbiased() {
    use manylights::{Brdf, Frame};
    let lights: Vec<Light> = (0..40)
        .map(|i| {
            let z = 1.0 - (i as f32 + 0.5) / 40.0 * 1.6;
            let phi = i as f32 * 2.399_963;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let dir = Vec3::new(s * phi.cos(), s * phi.sin(), z);
            Light::Sphere {
                center: dir * 2.0,
                radius: 0.45,
                radiance: Rgb::grey(1.0 + (i % 3) as f32),
            }
        })
        .collect();
    let mut rng = Pcg64Mcg::seed_from_u64(9);
    for (mi, (name, material)) in manylights_instruments::estimator::scene::MATERIALS
        .iter()
        .enumerate()
    {
        let sp = ShadingPoint {
            position: Vec3::new(0.05, -0.02, 0.01),
            normal: Vec3::new(0.1, 0.05, 1.0).normalize(),
            wo: Vec3::new(0.5, 0.2, 0.8).normalize(),
            material: *material,
        };
        let config = Config {
            point: 0,
            material: mi,
            sp,
        };
        let scene = Scene::with_lights(lights.clone(), vec![config]);
        let exact = reference(&scene, &sp, 1e-3, 1e-5, 77);
        let frame = Frame::from_normal(sp.normal).unwrap();
        let wo = frame.to_local(sp.wo);
        let k = 400_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..k {
            let mut v = 0.0f64;
            if let Some((wi, pdf)) = material.sample(wo, [rng.random(), rng.random()]) {
                let f = material.eval(wo, wi);
                scene
                    .set
                    .trace(sp.position, frame.to_world(wi).normalize(), |_, lp| {
                        v += f64::from(f * lp.radiance.r * wi.z / pdf);
                    });
            }
            s += v;
            s2 += v * v;
        }
        let n = k as f64;
        let mean = s / n;
        let se = ((s2 / n - mean * mean) / (n - 1.0)).sqrt();
        let z = (mean - exact.value) / (se * se + exact.std_err * exact.std_err).sqrt();
        eprintln!(
            "{name}: TB {mean:.6} exact {:.6} rel.SE {:.1e} -> {z:+.2} SE",
            exact.value,
            se / exact.value
        );
        assert!(z.abs() <= 5.0, "{name}: {z:.2} SE");
    }
}

/// The null distribution of the largest of K bias z's: known values of `(2Φ(z) − 1)^K`, its
/// quantiles inverting it, and the z of one pair with the reference's error in the
/// denominator.
#[test]
fn largest_bias_against_its_null_distribution() {
    use manylights_instruments::estimator::{
        bias_sigma, max_abs_normal_cdf, max_abs_normal_quantile, max_abs_normal_sf, MaxBias,
    };
    // z = (mean − exact) / sqrt(se² + se_ref²): 0.1 / sqrt(0.03² + 0.04²) = 2.
    assert!((bias_sigma(1.1, 0.03, 1.0, 0.04) - 2.0).abs() < 1e-12);
    assert!((bias_sigma(0.9, 0.03, 1.0, 0.04) + 2.0).abs() < 1e-12);
    assert_eq!(bias_sigma(1.0, 0.0, 1.0, 0.0), 0.0);
    assert_eq!(bias_sigma(1.5, 0.0, 1.0, 0.0), f64::INFINITY);
    // One pair: P(|Z| ≤ 1.959964) = 0.95, P(|Z| ≤ 3) = 0.99730.
    assert!((max_abs_normal_cdf(1.959_964, 1) - 0.95).abs() < 1e-6);
    assert!((max_abs_normal_cdf(3.0, 1) - 0.997_300_2).abs() < 1e-7);
    // 576 pairs: P(max ≤ 4) = (1 − 6.334e-5)^576 = 0.9642.
    let p4 = (1.0f64 - 6.334_248_4e-5).powi(576);
    assert!((max_abs_normal_cdf(4.0, 576) - p4).abs() < 1e-6);
    assert!((max_abs_normal_sf(4.0, 576) - (1.0 - p4)).abs() < 1e-6);
    // Far in the tail the p-value keeps its digits: P(max > 8) over 576 ≈ 576 × 1.24e-15.
    let tail = max_abs_normal_sf(8.0, 576);
    assert!(
        (tail / (576.0 * 1.244_192e-15) - 1.0).abs() < 1e-3,
        "{tail}"
    );
    for k in [1, 90, 576] {
        for p in [0.05, 0.5, 0.95, 0.99] {
            let z = max_abs_normal_quantile(p, k);
            assert!((max_abs_normal_cdf(z, k) - p).abs() < 1e-7, "{k} {p}");
        }
    }
    assert!(max_abs_normal_quantile(1.0, 5).is_nan());
    let mb = MaxBias::of(&[0.5, -4.34, 1.0, 3.5]);
    assert_eq!((mb.max, mb.pairs, mb.above_3), (4.34, 4, 2));
    assert!((mb.rms - ((0.25 + 4.34 * 4.34 + 1.0 + 12.25) / 4.0f64).sqrt()).abs() < 1e-12);
    assert!((mb.null_quantile + mb.null_p_value - 1.0).abs() < 1e-12);
    assert!((mb.above_3_expected - 4.0 * 2.699_796e-3).abs() < 1e-8);

    // Under the null the observed maximum's quantile is uniform: over 2,000 runs of 576
    // standard normal z's, the fraction below the median is 1/2 within 5 binomial standard
    // deviations, and the fraction above the 95 % quantile 5 % within 5.
    let mut rng = Pcg64Mcg::seed_from_u64(576);
    let runs = 2000;
    let (mut below_half, mut above_95) = (0usize, 0usize);
    for _ in 0..runs {
        let z: Vec<f64> = (0..576)
            .map(|_| {
                let u: f64 = 1.0 - rng.random::<f64>();
                let v: f64 = rng.random();
                (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
            })
            .collect();
        let q = MaxBias::of(&z).null_quantile;
        below_half += usize::from(q < 0.5);
        above_95 += usize::from(q > 0.95);
    }
    let n = runs as f64;
    let tol = |p: f64| 5.0 * (p * (1.0 - p) / n).sqrt();
    assert!(
        (below_half as f64 / n - 0.5).abs() <= tol(0.5),
        "{below_half}"
    );
    assert!(
        (above_95 as f64 / n - 0.05).abs() <= tol(0.05),
        "{above_95}"
    );
}

/// `estimator::run` on a tiny configuration: the JSON has the bias keys, consistent with its
/// per-configuration results.
#[test]
fn estimator_json_keys() {
    use manylights_instruments::estimator::{self, EstimatorConfig};
    let cfg = EstimatorConfig {
        estimates: 300,
        lights: 40,
        points: 5,
        ref_target: 1e-2,
        ref_total_target: 1e-3,
        time_ms: 0.05,
        ..EstimatorConfig::quick(4)
    };
    let (rs, j) = estimator::run(&cfg);
    let pairs = rs.len() * Technique::ALL.len();
    assert_eq!(j["seed"], 4);
    assert_eq!(j["bias_pairs"].as_u64(), Some(pairs as u64));
    let z: Vec<f64> = rs
        .iter()
        .flat_map(|r| r.results.iter().map(|t| t.bias_sigma))
        .collect();
    let max = z.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert_eq!(j["max_bias_sigma"].as_f64(), Some(max));
    let at = &j["max_bias_sigma_at"];
    let (ci, name) = (
        at["config"].as_u64().unwrap() as usize,
        at["technique"].as_str().unwrap(),
    );
    let ti = Technique::ALL
        .iter()
        .position(|t| t.name() == name)
        .unwrap();
    assert_eq!(rs[ci].results[ti].bias_sigma.abs(), max);
    for key in [
        "max_bias_sigma_null_quantile",
        "max_bias_sigma_null_p_value",
        "max_bias_sigma_null_below_4",
    ] {
        assert!(
            j[key].as_f64().is_some_and(|p| (0.0..=1.0).contains(&p)),
            "{key}: {}",
            j[key]
        );
    }
    let (m, p95, p99) = (
        j["max_bias_sigma_null_median"].as_f64().unwrap(),
        j["max_bias_sigma_null_p95"].as_f64().unwrap(),
        j["max_bias_sigma_null_p99"].as_f64().unwrap(),
    );
    assert!(0.0 < m && m < p95 && p95 < p99);
    assert!(j["rms_bias_sigma"].as_f64().is_some_and(|r| r >= 0.0));
    assert_eq!(
        j["pairs_above_3_sigma"].as_u64(),
        Some(z.iter().filter(|x| x.abs() > 3.0).count() as u64)
    );
    assert!(j["pairs_above_3_sigma_expected"].as_f64().unwrap() > 0.0);
    assert_eq!(j["bias_sigma_denominator"], "sqrt(se_mean^2 + se_ref^2)");
    let table = estimator::table(&rs, &j, false);
    assert!(table.contains("null distribution"), "{table}");
}
