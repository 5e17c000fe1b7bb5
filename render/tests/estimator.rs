//! A small version of `mlrender estimator`'s checks: every technique of the core's `direct`
//! module against an independent numerical reference on random scenes.

use glam::Vec3;
use manylights::direct::{Estimator, LambertMode, Params, Technique, Unoccluded};
use manylights::trace::trace_all;
use manylights::Rgb;
use manylights::{Light, Material, ShadingPoint};
use manylights_render::instruments::estimator::reference::reference;
use manylights_render::instruments::estimator::scene::{Config, Plan, Scene};
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
                Technique::Uniform | Technique::Power | Technique::Tl | Technique::Bl => 200_000,
                Technique::TlMis | Technique::BlMis | Technique::TlMisPinf => 100_000,
                Technique::TlSplit => 40_000,
                Technique::MisEqual | Technique::Full => 12_000,
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
    for (mi, (name, material)) in manylights_render::instruments::estimator::scene::MATERIALS
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
