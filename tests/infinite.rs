//! Distant and environment lights, and colour:
//!
//! 1. the root choice keeps every pmf exact: for random scenes of local lights with distant
//!    lights (angular radius 0, a sun's 0.27°, wide) and an environment, at random points and
//!    normals, with TL and BL importances, the tree's cut sampler and pbrt-v4's fixed
//!    probabilities: a sampled light's pmf is its queried pmf bit for bit, the pmfs of all lights
//!    sum to 1, a light at infinity that can contribute has a positive pmf, and the batch calls
//!    are the single ones;
//! 2. they are stored in the tree and its bytes: a round trip gives the same tree, corrupt
//!    entries are rejected, bad descriptors are errors naming the light and field;
//! 3. every technique is unbiased with them, in colour, against closed forms (a uniform sky
//!    over a Lambert plane reflects ρL; a sun reflects (ρ/π) E cos θ) and quadratures (a sun
//!    and a gradient sky over glossy materials), through the one call with the built-in skies
//!    and through the lower level with a host environment;
//! 4. BL weighs a sun by the BRDF: a glossy lobe facing away from it leaves it the defensive
//!    share only, and a surface facing away from it gives it pmf 0.

mod common;

use common::{Rng, SceneSpec, Stats};
use glam::{DVec3, Vec3};
use manylights::direct::{
    CutSampler, Estimator, LightSampler, Params, PinfSampler, Step, Technique, TreeSampler,
    Unoccluded,
};
use manylights::error::{LightField, Problem};
use manylights::importance::Receiver;
use manylights::light::{Environment, EnvironmentSample, GradientSky, UniformSky};
use manylights::light_set::InfiniteKind;
use manylights::{
    BlCutOptions, BlImportance, BuildError, BuildOptions, FormatError, Importance, Light, LightSet,
    LightTree, Material, Rgb, Serial, ShadingPoint, TlImportance, ValidationError,
};
use manylights_testkit::TestUniforms;

/// The sun's angular radius, 0.27°.
const SUN: f32 = 0.27 * std::f32::consts::PI / 180.0;

fn distant(direction: Vec3, angular_radius: f32, irradiance: Rgb) -> Light {
    Light::Distant {
        direction,
        angular_radius,
        irradiance,
    }
}

/// Local lights of a random scene with one to three distant lights (angular radius 0, the
/// sun's, or up to 0.4) and, most of the time, an environment (some bounds 0), at random
/// places in the list.
fn infinite_scene(rng: &mut Rng, n_local: usize) -> Vec<Light> {
    let spec = SceneSpec {
        half: 20.0,
        ..SceneSpec::default()
    };
    let mut lights = common::random_scene(rng, n_local, &spec);
    let mut extra = Vec::new();
    for k in 0..1 + rng.below(3) {
        let gamma = match k % 3 {
            0 => 0.0,
            1 => SUN,
            _ => 0.4 * rng.f32(),
        };
        let e = Rgb::new(
            rng.log_range(0.1, 10.0),
            rng.log_range(0.1, 10.0),
            rng.f32(),
        );
        extra.push(distant(rng.unit() * rng.log_range(0.5, 2.0), gamma, e));
    }
    if rng.chance(0.8) {
        let mut irradiance = [0.0f32; 6];
        for e in &mut irradiance {
            *e = if rng.chance(0.2) {
                0.0
            } else {
                rng.log_range(0.01, 5.0)
            };
        }
        extra.push(Light::Environment { irradiance });
    }
    for l in extra {
        let at = rng.below(lights.len() + 1);
        lights.insert(at, l);
    }
    lights
}

/// A random shading point (position, normal and ωo on the normal's side) with a random
/// material.
fn random_sp(rng: &mut Rng) -> ShadingPoint {
    let n = rng.unit();
    let mut wo = rng.unit();
    if wo.dot(n) < 0.0 {
        wo = -wo;
    }
    let material = match rng.below(3) {
        0 => Material::Lambert {
            albedo: Rgb::new(rng.f32(), rng.f32(), rng.f32()),
        },
        1 => Material::Ggx {
            alpha: rng.range(0.01, 1.0),
            specular: rng.range(0.1, 1.0),
        },
        _ => Material::Plastic {
            albedo: Rgb::new(rng.f32(), rng.f32(), rng.f32()),
            specular: rng.f32(),
            alpha: rng.range(0.01, 1.0),
        },
    };
    ShadingPoint {
        position: rng.in_cube(30.0),
        normal: n,
        wo,
        material,
    }
}

/// A light sampler's contract at one point: sampled pmf = queried pmf (bit for bit) > 0, and
/// the queried pmfs of all lights sum to 1 when something is sampled.
fn check_sampler(name: &str, s: &dyn LightSampler, n: u32, rng: &mut Rng) {
    let mut any = false;
    for u in common::u_values(rng, 24) {
        if let Some(x) = s.sample(u) {
            any = true;
            assert!(x.pmf > 0.0 && x.pmf <= 1.0, "{name}: {x:?}");
            assert_eq!(x.pmf.to_bits(), s.pmf(x.light).to_bits(), "{name}: {x:?}");
        }
    }
    let sum: f64 = (0..n).map(|l| f64::from(s.pmf(l))).sum();
    if any {
        assert!((sum - 1.0).abs() <= 1e-4, "{name}: pmfs sum to {sum}");
    } else {
        assert_eq!(sum, 0.0, "{name}: nothing sampled but pmfs sum to {sum}");
    }
    assert_eq!(s.pmf(n), 0.0, "{name}: a light out of range");
}

#[test]
fn pmfs_stay_exact_with_lights_at_infinity() {
    let mut rng = Rng::new(0x1f_1417e);
    for scene in 0..24 {
        let n_local = [0, 1, 5, 40, 300][scene % 5];
        check_infinite_scene(&mut rng, n_local, 12);
    }
}

proptest::proptest! {
    #![proptest_config(common::proptest_config(48, 0x696e_6669_6e69))]

    /// The same contract over scenes drawn by proptest: 0 to 400 local lights, one to three
    /// distant lights and most of the time an environment.
    #[test]
    fn root_choice_contract_holds_for_random_scenes(n_local in 0usize..400, seed in proptest::prelude::any::<u64>()) {
        check_infinite_scene(&mut Rng::new(seed), n_local, 6);
    }
}

/// Property 1 of the module documentation on one random scene of `n_local` local lights, at
/// `points` random shading points.
fn check_infinite_scene(rng: &mut Rng, n_local: usize, points: usize) {
    {
        let lights = infinite_scene(rng, n_local);
        // The tree level takes the environment's light anywhere in the list.
        let tree = &LightTree::build(&lights).unwrap();
        tree.validate_lights(&lights).unwrap();
        let n = lights.len() as u32;
        for _ in 0..points {
            let sp = random_sp(rng);
            let receiver = [
                Receiver::Reflective,
                Receiver::Transmissive,
                Receiver::Omnidirectional,
            ][rng.below(3)];
            let tl = TlImportance::with_receiver(sp.position, sp.normal, receiver);
            check_sampler("tl", &TreeSampler::with_importance(tree, tl), n, rng);
            let bl = BlImportance::new(&sp).unwrap();
            // BL through the tree itself (the ABI's ml_tree_sample_bl) and through its cut.
            let mut any = false;
            for u in common::u_values(rng, 16) {
                if let Some(s) = tree.sample(&bl, u) {
                    any = true;
                    assert_eq!(s.pmf.to_bits(), tree.pmf(&bl, s.light).to_bits());
                }
            }
            let sum: f64 = (0..n).map(|l| f64::from(tree.pmf(&bl, l))).sum();
            assert!(!any || (sum - 1.0).abs() <= 1e-4, "bl: {sum}");
            let cut = CutSampler::with_importance(tree, bl, &BlCutOptions::default());
            check_sampler("bl cut", &cut, n, rng);
            // pbrt-v4's sampler returns no light when its tree is chosen and has nothing to
            // offer there, so its pmfs then sum to n/(n + 1) only: checked where the tree's
            // root weight is positive, sample against query everywhere.
            let pinf = PinfSampler::with_importance(tree, tl);
            if tree.root_weight(&tl) > 0.0 || tree.nodes().is_empty() {
                check_sampler("pinf", &pinf, n, rng);
            } else {
                for u in common::u_values(rng, 8) {
                    if let Some(x) = pinf.sample(u) {
                        assert_eq!(x.pmf.to_bits(), pinf.pmf(x.light).to_bits());
                    }
                }
            }
            // Conservative: a light at infinity that can contribute has a positive pmf.
            for e in tree.infinite_lights() {
                let l = &lights[e.light as usize];
                let contributes = match *l {
                    Light::Distant {
                        direction,
                        angular_radius,
                        irradiance,
                    } => {
                        let c = f64::from(direction.normalize().dot(sp.normal.normalize()));
                        let horizon = -f64::from(angular_radius).sin() + 1e-4;
                        irradiance.luminance() > 0.0
                            && (receiver != Receiver::Reflective || c > horizon)
                    }
                    Light::Environment { .. } => {
                        e.environment_bound(sp.normal.normalize(), receiver) > 0.0
                    }
                    _ => unreachable!(),
                };
                if contributes {
                    assert!(
                        tl.eval_infinite(e) > 0.0,
                        "{l:?} at {sp:?} ({receiver:?}) has TL importance 0"
                    );
                    let pmf = tree.pmf(&tl, e.light);
                    assert!(pmf > 0.0, "{l:?} at {sp:?}: pmf 0");
                }
            }
        }
        // The batch calls are the single ones.
        let imps: Vec<TlImportance> = (0..40)
            .map(|_| TlImportance::new(rng.in_cube(30.0), rng.unit()))
            .collect();
        let us: Vec<f32> = (0..40).map(|_| rng.f32()).collect();
        let mut out = vec![None; 40];
        tree.sample_batch(&imps, &us, &mut out).unwrap();
        let ls: Vec<u32> = (0..40).map(|_| rng.below(n as usize) as u32).collect();
        let mut pmfs = vec![0.0; 40];
        tree.pmf_batch(&imps, &ls, &mut pmfs).unwrap();
        for j in 0..40 {
            assert_eq!(out[j], tree.sample(&imps[j], us[j]));
            assert_eq!(pmfs[j].to_bits(), tree.pmf(&imps[j], ls[j]).to_bits());
        }
    }
}

/// The root weighs the tree's root importance against the lights at infinity: sampling
/// frequencies follow the pmfs (a χ² test over the root's choices).
#[test]
fn root_choice_frequencies_follow_the_pmfs() {
    let lights = vec![
        Light::Point {
            position: Vec3::new(0.0, 0.0, 2.0),
            intensity: Rgb::grey(1.0),
        },
        distant(Vec3::new(0.3, 0.0, 1.0), SUN, Rgb::new(2.0, 1.5, 1.0)),
    ];
    let sky = UniformSky {
        radiance: Rgb::new(0.1, 0.2, 0.4),
    };
    let set = with_sky(lights, sky);
    let tl = TlImportance::new(Vec3::ZERO, Vec3::Z);
    let p: Vec<f64> = (0..3).map(|l| f64::from(set.tree().pmf(&tl, l))).collect();
    assert!(p.iter().all(|&x| x > 0.01), "{p:?}");
    let k = 200_000;
    let mut rng = Rng::new(5);
    let mut count = [0u64; 3];
    for _ in 0..k {
        let s = set.tree().sample(&tl, rng.f32()).unwrap();
        count[s.light as usize] += 1;
    }
    let expected: Vec<f64> = p.iter().map(|x| x * k as f64).collect();
    let (chi2, dof) = common::chi2_statistic(&count, &expected);
    assert!(
        chi2 <= common::chi2_critical(dof, 5.0),
        "χ² {chi2} ({count:?} vs {expected:?})"
    );
    // The point light's TL importance 4π·1/4 against the sun's 4π·E_Y·cos θ and the sky's 4π·πL_Y.
    let (sun_y, sky_y) = (
        Rgb::new(2.0, 1.5, 1.0).luminance(),
        Rgb::new(0.1, 0.2, 0.4).luminance(),
    );
    // cos(θ − γ) for the sun's cap; the tree's bounds are quantised (energies rounded up by
    // at most 2⁻¹¹), hence the tolerance.
    let theta = 0.3f64.atan() - f64::from(SUN);
    let w = [
        0.25,
        f64::from(sun_y) * theta.cos(),
        std::f64::consts::PI * f64::from(sky_y),
    ];
    let total: f64 = w.iter().sum();
    for i in 0..3 {
        let want = w[i] / total;
        assert!((p[i] - want).abs() < 2e-3 * want, "{i}: {} vs {want}", p[i]);
    }
}

#[test]
fn lights_at_infinity_round_trip_through_bytes() {
    let mut rng = Rng::new(77);
    let lights = infinite_scene(&mut rng, 200);
    let tree = LightTree::build(&lights).unwrap();
    assert!(!tree.infinite_lights().is_empty());
    let bytes = tree.as_bytes();
    let back = LightTree::from_bytes(&bytes).unwrap();
    assert_eq!(back, tree);
    back.validate_lights(&lights).unwrap();
    // Every truncation of the section, and trailing bytes, are rejected.
    for cut in 1..=(8 + 64 * tree.infinite_lights().len()) {
        assert_eq!(
            LightTree::from_bytes(&bytes[..bytes.len() - cut]),
            Err(FormatError::Truncated),
            "cut {cut}"
        );
    }
    // Corrupt entries: a bad kind, a light index of the node tree or out of range, a NaN.
    let entry0 = bytes.len() - 64 * tree.infinite_lights().len();
    for (offset, value) in [(4usize, 9u32), (0, 1u32 << 30), (8, f32::NAN.to_bits())] {
        let mut bad = bytes.clone();
        bad[entry0 + offset..entry0 + offset + 4].copy_from_slice(&value.to_ne_bytes());
        // Resealed, so that the structural checks behind the checksum see the entry.
        let bad =
            manylights::internals::tree::seal(&bad[manylights::internals::tree::HEADER_BYTES..]);
        assert!(
            matches!(
                LightTree::from_bytes(&bad),
                Err(FormatError::Invalid(ValidationError::BadInfinite { .. }))
            ),
            "offset {offset}"
        );
    }
    let local = (0..lights.len())
        .find(|&i| !lights[i].is_infinite() && tree.path(i as u32) != 0)
        .unwrap();
    let mut bad = bytes.clone();
    bad[entry0..entry0 + 4].copy_from_slice(&(local as u32).to_ne_bytes());
    assert!(LightTree::from_bytes(&bad).is_err());
    let bad = manylights::internals::tree::seal(&bad[manylights::internals::tree::HEADER_BYTES..]);
    assert!(LightTree::from_bytes(&bad).is_err());
    // A tree checked against other lights.
    let mut other = lights.clone();
    let i = tree.infinite_lights()[0].light as usize;
    other[i] = distant(Vec3::X, 0.1, Rgb::grey(3.0));
    assert!(tree.validate_lights(&other).is_err());
}

#[test]
fn bad_lights_at_infinity_are_errors_naming_them() {
    let cases = [
        (
            distant(Vec3::ZERO, 0.0, Rgb::grey(1.0)),
            LightField::Direction,
            Problem::ZeroLength,
        ),
        (
            distant(Vec3::Z, -0.1, Rgb::grey(1.0)),
            LightField::AngularRadius,
            Problem::OutOfRange,
        ),
        (
            distant(Vec3::Z, 2.0, Rgb::grey(1.0)),
            LightField::AngularRadius,
            Problem::OutOfRange,
        ),
        (
            distant(Vec3::Z, f32::NAN, Rgb::grey(1.0)),
            LightField::AngularRadius,
            Problem::NotFinite,
        ),
        (
            distant(Vec3::Z, 0.0, Rgb::new(1.0, -1.0, 0.0)),
            LightField::Irradiance,
            Problem::Negative,
        ),
        (
            distant(Vec3::Z, 0.0, Rgb::grey(1e30)),
            LightField::Irradiance,
            Problem::EnergyTooLarge,
        ),
        (
            Light::Environment {
                irradiance: [1.0, 1.0, f32::INFINITY, 1.0, 1.0, 1.0],
            },
            LightField::Irradiance,
            Problem::NotFinite,
        ),
    ];
    for (l, field, problem) in cases {
        let lights = vec![
            Light::Point {
                position: Vec3::ZERO,
                intensity: Rgb::grey(1.0),
            },
            l,
        ];
        match LightTree::build(&lights) {
            Err(BuildError::InvalidLight {
                index: 1,
                field: f,
                problem: p,
                ..
            }) => assert_eq!((f, p), (field, problem), "{l:?}"),
            other => panic!("{l:?}: {other:?}"),
        }
    }
    let sky = Light::Environment {
        irradiance: UniformSky {
            radiance: Rgb::grey(1.0),
        }
        .irradiance_bounds(),
    };
    assert_eq!(
        LightTree::build(&[sky, sky]),
        Err(BuildError::SecondEnvironment { index: 1 })
    );
    let many =
        vec![distant(Vec3::Z, 0.0, Rgb::grey(1.0)); manylights::light::MAX_INFINITE_LIGHTS + 1];
    assert!(matches!(
        LightTree::build(&many),
        Err(BuildError::TooManyInfiniteLights { .. })
    ));
    let e = LightTree::build(&[distant(Vec3::Z, 3.0, Rgb::grey(1.0))]).unwrap_err();
    assert!(format!("{e}").contains("angular_radius"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Unbiasedness, in colour
// ---------------------------------------------------------------------------------------------

/// The light set of `lights` and the environment `sky` (its last light).
fn with_sky(lights: Vec<Light>, sky: impl Environment + Send + Sync + 'static) -> LightSet {
    LightSet::build_with_environment(lights, sky, &BuildOptions::default(), &Serial).unwrap()
}

/// Every technique through the one call: each channel's mean of `k` estimates within 5
/// standard errors of `exact`.
fn check_unbiased(set: &LightSet, sp: &ShadingPoint, exact: [f64; 3], k: usize, seed: u64) {
    for (i, &t) in Technique::ALL.iter().enumerate() {
        let k = match t {
            Technique::Uniform | Technique::Energy => 3 * k,
            Technique::TlSplit | Technique::MisEqual | Technique::Full => k / 3,
            _ => k,
        };
        let mut est = Estimator::new(set, sp, t, &Params::default()).unwrap();
        let mut u = TestUniforms::new(seed + i as u64);
        let mut st: [Stats; 3] = Default::default();
        for _ in 0..k {
            let v = est.estimate(&Unoccluded, &mut u).unwrap();
            for c in 0..3 {
                st[c].add(v[c]);
            }
        }
        for c in 0..3 {
            let z = (st[c].mean() - exact[c]) / st[c].se().max(1e-9 * exact[c]);
            assert!(
                z.abs() <= 5.0,
                "{t}, channel {c}, at {:?}: mean {} exact {} se {}: {z:.2} SE",
                sp.material,
                st[c].mean(),
                exact[c],
                st[c].se()
            );
        }
    }
}

/// A Lambert plane at the origin (normal +z) under a uniform sky of radiance L (reflects ρL),
/// a sun of irradiance E at θ from the normal (reflects (ρ/π) E cos θ, its cap entirely above
/// the horizon), a delta sun, and a sphere light (ρ L (r/d)² cos θ).
#[test]
fn every_technique_is_unbiased_under_a_sky_and_suns_in_colour() {
    let albedo = Rgb::new(0.8, 0.5, 0.3);
    let sky = UniformSky {
        radiance: Rgb::new(0.2, 0.3, 0.5),
    };
    let (sun_dir, sun_e) = (Vec3::new(0.4, 0.2, 1.0), Rgb::new(3.0, 2.5, 1.5));
    let (low_dir, low_e) = (Vec3::new(-1.0, 0.3, 0.5), Rgb::new(0.5, 0.4, 0.3));
    let (c, r, l) = (Vec3::new(0.5, -0.3, 2.0), 0.3f32, Rgb::new(4.0, 2.0, 1.0));
    let lights = vec![
        distant(sun_dir, SUN, sun_e),
        Light::Sphere {
            center: c,
            radius: r,
            radiance: l,
        },
        distant(low_dir, 0.0, low_e),
        // Below the horizon: contributes nothing.
        distant(-Vec3::Z, 0.1, Rgb::grey(5.0)),
    ];
    let cos = |d: Vec3| f64::from(d.normalize().z);
    let d = f64::from(c.length());
    let exact = [0, 1, 2].map(|k| {
        let a = f64::from(albedo.to_array()[k]);
        let pi = std::f64::consts::PI;
        a * f64::from(sky.radiance.to_array()[k])
            + a / pi * f64::from(sun_e.to_array()[k]) * cos(sun_dir)
            + a / pi * f64::from(low_e.to_array()[k]) * cos(low_dir)
            + a * f64::from(l.to_array()[k]) * f64::from(r * r) / (d * d) * f64::from(c.z) / d
    });
    let set = with_sky(lights, sky);
    let sp = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::new(0.3, 0.1, 1.0),
        material: Material::Lambert { albedo },
    };
    check_unbiased(&set, &sp, exact, 30_000, 101);
}

/// `∫ f(ωo, ω) L(ω) cos θ dω` at the origin (normal +z) by the midpoint rule in (cos θ, φ)
/// over the upper hemisphere (`n × 4n` cells), per channel, in f64.
fn hemisphere_quadrature(m: &Material, wo: Vec3, l: &dyn Fn(DVec3) -> Rgb, n: usize) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for i in 0..n {
        let ct = (i as f64 + 0.5) / n as f64;
        let st = (1.0 - ct * ct).sqrt();
        for j in 0..4 * n {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / (4 * n) as f64;
            let dir = DVec3::new(st * phi.cos(), st * phi.sin(), ct);
            let wi = dir.as_vec3();
            let f = m.eval_rgb(wo, wi).to_array();
            let li = l(dir).to_array();
            for c in 0..3 {
                sum[c] += f64::from(f[c]) * f64::from(li[c]) * ct;
            }
        }
    }
    let cell = std::f64::consts::TAU / (4 * n * n) as f64;
    sum.map(|s| s * cell)
}

/// A sun's contribution `∫_cap f L cos dω` (L = E / (π sin²γ)) by the midpoint rule over its
/// cap in (cos θ, φ) about its direction.
fn sun_quadrature(m: &Material, wo: Vec3, d: Vec3, gamma: f32, e: Rgb, n: usize) -> [f64; 3] {
    let w = d.as_dvec3().normalize();
    let g = f64::from(gamma);
    let (t, b) = w.any_orthonormal_pair();
    let omc = 1.0 - g.cos();
    let l = 1.0 / (std::f64::consts::PI * g.sin() * g.sin());
    let mut sum = [0.0f64; 3];
    for i in 0..n {
        let ct = 1.0 - omc * (i as f64 + 0.5) / n as f64;
        let st = (1.0 - ct * ct).max(0.0).sqrt();
        for j in 0..n {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / n as f64;
            let dir = w * ct + (t * phi.cos() + b * phi.sin()) * st;
            if dir.z <= 0.0 {
                continue;
            }
            let f = m.eval_rgb(wo, dir.as_vec3()).to_array();
            for c in 0..3 {
                sum[c] += f64::from(f[c]) * dir.z;
            }
        }
    }
    let solid = std::f64::consts::TAU * omc / (n * n) as f64;
    let e = e.to_array();
    [0, 1, 2].map(|c| sum[c] * solid * l * f64::from(e[c]))
}

/// Glossy materials under a gradient sky and a 3° sun (quadratures), through the one call.
#[test]
fn every_technique_is_unbiased_for_glossy_materials_under_sun_and_sky() {
    let sky = GradientSky {
        up: Vec3::Z,
        zenith: Rgb::new(0.1, 0.2, 0.5),
        horizon: Rgb::new(0.5, 0.5, 0.6),
        ground: Rgb::new(0.1, 0.08, 0.05),
    };
    let (sun_dir, gamma, sun_e) = (Vec3::new(-0.5, -0.2, 0.8), 0.05f32, Rgb::new(2.0, 1.8, 1.2));
    let set = with_sky(vec![distant(sun_dir, gamma, sun_e)], sky);
    let wo = Vec3::new(0.5, 0.2, 0.8).normalize();
    for (mi, material) in [
        Material::Plastic {
            albedo: Rgb::new(0.5, 0.3, 0.2),
            specular: 0.5,
            alpha: 0.15,
        },
        Material::Ggx {
            alpha: 0.4,
            specular: 1.0,
        },
    ]
    .into_iter()
    .enumerate()
    {
        let sky_l = |d: DVec3| {
            let (r, _) = sky.eval(d.as_vec3());
            r
        };
        let a = hemisphere_quadrature(&material, wo, &sky_l, 400);
        let b = sun_quadrature(&material, wo, sun_dir, gamma, sun_e, 300);
        let exact = [0, 1, 2].map(|c| a[c] + b[c]);
        let sp = ShadingPoint {
            position: Vec3::ZERO,
            normal: Vec3::Z,
            wo,
            material,
        };
        check_unbiased(&set, &sp, exact, 30_000, 200 + 20 * mi as u64);
    }
}

/// Surfaces tilted against the sky's up (a wall, a slope, an overhang facing the ground), as
/// most of a scene's surfaces are: a gradient sky (with and without a ground colour), a sun
/// with a wide cap across the surface's horizon, a low sun, and two sphere lights, one of them
/// across the horizon. Lambert and glossy, through the one call; the reference is quadrature
/// over the hemisphere (the sky) and over each cap clipped at the horizon (suns and spheres).
/// The shading frame is fixed (normal +z); the sky's up is what tilts.
#[test]
fn every_technique_is_unbiased_on_surfaces_tilted_against_the_sky() {
    let ups = [
        Vec3::X,                    // a wall
        Vec3::new(-0.5, 0.4, 0.7),  // a slope
        Vec3::new(0.3, -0.2, -0.9), // an overhang: the sky mostly below the horizon
    ];
    let spheres = [
        (Vec3::new(0.8, 0.6, 1.5), 0.25f32, Rgb::new(3.0, 2.0, 1.0)),
        // Across the horizon: its centre 0.05 above the plane, radius 0.2.
        (Vec3::new(-1.2, 0.4, 0.05), 0.2, Rgb::new(1.0, 2.0, 4.0)),
    ];
    // The wide sun crosses the horizon (its centre 0.04 rad above it, radius 0.1).
    let (wide_dir, wide_r, wide_e) = (Vec3::new(0.0, -1.0, 0.04), 0.1f32, Rgb::new(1.5, 1.2, 0.8));
    let (low_dir, low_e) = (Vec3::new(0.7, 0.2, 0.3), Rgb::new(2.0, 1.4, 0.9));
    for (ui, &up) in ups.iter().enumerate() {
        let sky = GradientSky {
            up: up.normalize(),
            zenith: Rgb::new(0.08, 0.14, 0.36),
            horizon: Rgb::new(0.44, 0.32, 0.26),
            ground: if ui == 1 {
                Rgb::ZERO
            } else {
                Rgb::new(0.1, 0.08, 0.05)
            },
        };
        let mut lights: Vec<Light> = spheres
            .iter()
            .map(|&(center, radius, radiance)| Light::Sphere {
                center,
                radius,
                radiance,
            })
            .collect();
        lights.push(distant(wide_dir, wide_r, wide_e));
        lights.push(distant(low_dir, SUN, low_e));
        let set = with_sky(lights, sky);
        let wo = Vec3::new(0.4, -0.3, 0.6).normalize();
        for (mi, material) in [
            Material::Lambert {
                albedo: Rgb::new(0.7, 0.5, 0.3),
            },
            Material::Plastic {
                albedo: Rgb::new(0.5, 0.3, 0.2),
                specular: 0.5,
                alpha: 0.15,
            },
        ]
        .into_iter()
        .enumerate()
        {
            let sky_l = |d: DVec3| sky.eval(d.as_vec3()).0;
            let mut exact = hemisphere_quadrature(&material, wo, &sky_l, 300);
            // A sphere of radiance L is the cap of sin γ = r/d with E = π L sin²γ.
            let caps = spheres
                .iter()
                .map(|&(c, r, l)| {
                    let g = (r / c.length()).asin();
                    (c, g, l * (std::f32::consts::PI * g.sin() * g.sin()))
                })
                .chain([(wide_dir, wide_r, wide_e), (low_dir, SUN, low_e)]);
            for (d, g, e) in caps {
                let part = sun_quadrature(&material, wo, d, g, e, 120);
                for c in 0..3 {
                    exact[c] += part[c];
                }
            }
            let sp = ShadingPoint {
                position: Vec3::ZERO,
                normal: Vec3::Z,
                wo,
                material,
            };
            check_unbiased(&set, &sp, exact, 30_000, 300 + 20 * ui as u64 + mi as u64);
        }
    }
}

/// The lower level with an environment and the host's own Lambert BSDF in colour: the
/// environment's samples come as light steps (at distance +∞), the escaping BSDF rays reach it
/// with its radiance and pdf.
#[test]
fn lower_level_with_a_host_environment_is_unbiased() {
    let sky = GradientSky {
        up: Vec3::Z,
        zenith: Rgb::new(0.2, 0.3, 0.6),
        horizon: Rgb::new(0.6, 0.6, 0.6),
        ground: Rgb::ZERO,
    };
    let (sun_dir, sun_e) = (Vec3::new(0.3, 0.5, 0.7), Rgb::new(2.0, 1.5, 1.0));
    let set = with_sky(
        vec![
            distant(sun_dir, SUN, sun_e),
            Light::Point {
                position: Vec3::new(0.0, 0.5, 1.5),
                intensity: Rgb::new(1.0, 0.5, 0.2),
            },
        ],
        sky,
    );
    let env = set.environment_light().expect("an environment");
    assert_eq!(env, 2, "the environment is the last light");
    let albedo = [0.7f32, 0.5, 0.3];
    let lambert = Material::Lambert {
        albedo: Rgb::from_array(albedo),
    };
    let wo = Vec3::new(0.1, 0.2, 1.0).normalize();
    let sky_l = |d: DVec3| sky.eval(d.as_vec3()).0;
    let s = hemisphere_quadrature(&lambert, wo, &sky_l, 400);
    let cos_sun = f64::from(sun_dir.normalize().z);
    let p = Vec3::new(0.0, 0.5, 1.5);
    let (d2, cos_p) = (f64::from(p.length_squared()), f64::from(p.normalize().z));
    let pi = std::f64::consts::PI;
    let exact = [0, 1, 2].map(|c| {
        let a = f64::from(albedo[c]);
        s[c] + a / pi * f64::from(sun_e.to_array()[c]) * cos_sun
            + a / pi * f64::from([1.0f32, 0.5, 0.2][c]) * cos_p / d2
    });
    let sp = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo,
        material: lambert,
    };
    for (ti, t) in [
        Technique::TlMis,
        Technique::BlMis,
        Technique::TlMisPinf,
        Technique::Full,
        Technique::TlSplit,
        Technique::Tl,
    ]
    .into_iter()
    .enumerate()
    {
        let mut est = Estimator::new(&set, &sp, t, &Params::default()).unwrap();
        let mut u = TestUniforms::new(900 + ti as u64);
        let k = 30_000;
        let mut st: [Stats; 3] = Default::default();
        let mut env_steps = 0;
        for _ in 0..k {
            let mut sum = [0.0f64; 3];
            est.start();
            loop {
                let d = match est.next(&mut u).unwrap() {
                    Step::Done => break,
                    Step::Light(d) => d,
                    Step::Bsdf(b) => {
                        // Cosine sampling of the host's Lambert.
                        let r = b.u[0].sqrt();
                        let phi = std::f32::consts::TAU * b.u[1];
                        let z = (1.0 - b.u[0]).max(0.0).sqrt();
                        let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                        let (env_l, env_pdf) = sky.eval(dir);
                        est.bsdf_hits(
                            &b,
                            dir,
                            z / std::f32::consts::PI,
                            |p| p.reached_before(f32::INFINITY),
                            |h| {
                                if h.light == env {
                                    // The environment's own radiance and pdf along the ray.
                                    assert_eq!((h.point.radiance, h.point.pdf), (env_l, env_pdf));
                                }
                                for c in 0..3 {
                                    let l = h.point.radiance.to_array()[c];
                                    let v = albedo[c] / std::f32::consts::PI * l * z;
                                    sum[c] += f64::from(h.weighted.contribution(v));
                                }
                            },
                        )
                        .unwrap();
                        continue;
                    }
                };
                if d.light == env {
                    env_steps += 1;
                    assert_eq!(d.point.distance, f32::INFINITY);
                    // The sky's sample, its direction renormalised (to an ulp).
                    let (l, pdf) = sky.eval(d.point.direction);
                    assert!((d.point.pdf - pdf).abs() <= 1e-5 * pdf, "{d:?}");
                    for (a, b) in d.point.radiance.to_array().into_iter().zip(l.to_array()) {
                        assert!((a - b).abs() <= 1e-5 * b.max(1.0), "{d:?}");
                    }
                }
                let cos = d.point.direction.z;
                if cos <= 0.0 {
                    continue;
                }
                let w = est.weigh(&d, cos / std::f32::consts::PI).unwrap();
                for c in 0..3 {
                    let v = albedo[c] / std::f32::consts::PI * d.point.radiance.to_array()[c] * cos;
                    sum[c] += f64::from(w.contribution(v));
                }
            }
            for c in 0..3 {
                st[c].add(sum[c]);
            }
        }
        assert!(env_steps > 0, "{t}: the environment was never sampled");
        for c in 0..3 {
            let z = (st[c].mean() - exact[c]) / st[c].se();
            assert!(
                z.abs() <= 5.0,
                "{t} channel {c}: mean {} exact {}: {z:.2} SE",
                st[c].mean(),
                exact[c]
            );
        }
        // The one call takes the set's environment too.
        assert!(est.estimate(&Unoccluded, &mut u).is_ok());
    }
}

// ---------------------------------------------------------------------------------------------
// BL weighs the sun by the BRDF
// ---------------------------------------------------------------------------------------------

#[test]
fn bl_gives_a_sun_behind_a_glossy_lobe_only_its_defensive_share() {
    // A sun up to the left, a lamp up to the right (in the mirror direction of the view that
    // looks away from the sun).
    let sun = distant(Vec3::new(-0.6, 0.0, 0.8), SUN, Rgb::grey(1.0));
    let set = LightSet::build(vec![
        sun,
        Light::Point {
            position: Vec3::new(1.8, 0.0, 2.4),
            intensity: Rgb::grey(1.0),
        },
    ])
    .unwrap();
    let tree = set.tree();
    let e = &tree.infinite_lights()[0];
    assert_eq!(e.kind(), Some(InfiniteKind::Distant));
    let glossy = |wo: Vec3| ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo,
        material: Material::Ggx {
            alpha: 0.05,
            specular: 1.0,
        },
    };
    // The mirror direction of ωo = (0.6, 0, 0.8) is the sun's: BL gives it nearly everything.
    let facing = BlImportance::new(&glossy(Vec3::new(0.6, 0.0, 0.8))).unwrap();
    // ωo = (−0.6, 0, 0.8) mirrors away from it: the defensive share only.
    let away = BlImportance::new(&glossy(Vec3::new(-0.6, 0.0, 0.8))).unwrap();
    let tl = TlImportance::new(Vec3::ZERO, Vec3::Z);
    let (p_face, p_away, p_tl) = (tree.pmf(&facing, 0), tree.pmf(&away, 0), tree.pmf(&tl, 0));
    assert!(p_tl > 0.8, "{p_tl}");
    assert!(p_face > 0.99, "{p_face}");
    assert!(
        p_away < 0.05 * p_tl && p_away > 0.0,
        "{p_away} vs TL {p_tl}"
    );
    let b = away.eval_infinite_with_integral(e);
    assert!(b.cap_integral < 1e-6, "{b:?}");
    // A surface facing away from the sun gives it pmf 0, in every importance.
    let down = ShadingPoint {
        normal: -Vec3::Z,
        wo: -Vec3::Z,
        ..glossy(Vec3::Z)
    };
    let bl_down = BlImportance::new(&down).unwrap();
    assert_eq!(tree.pmf(&bl_down, 0), 0.0);
    assert_eq!(tree.pmf(&TlImportance::new(Vec3::ZERO, -Vec3::Z), 0), 0.0);
    // pbrt-v4's fixed probability gives it 1/2 there.
    let pinf = PinfSampler::with_importance(tree, TlImportance::new(Vec3::ZERO, -Vec3::Z));
    assert_eq!(pinf.pmf(0), 0.5);
}

/// A host sky whose `eval` gives a bad radiance (NaN, negative, infinite) in one channel is an
/// error of the one call, as a bad radiance from its `sample` is, for the techniques that take
/// a BSDF sample at every Lambert point (the one-sample MIS ones); a good one is not.
#[test]
fn a_sky_whose_eval_gives_a_bad_radiance_is_an_error() {
    struct BadEval(Rgb);
    impl Environment for BadEval {
        fn sample(&self, _u: [f32; 2]) -> Option<EnvironmentSample> {
            None
        }
        fn eval(&self, _direction: Vec3) -> (Rgb, f32) {
            (self.0, 0.25)
        }
        fn irradiance_bounds(&self) -> [f32; 6] {
            [1.0; 6]
        }
    }
    let sets = [f32::NAN, -1.0, f32::INFINITY, 1.0]
        .map(|v| with_sky(Vec::new(), BadEval(Rgb::new(1.0, v, 1.0))));
    let sp = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::Z,
        material: Material::Lambert {
            albedo: Rgb::grey(0.8),
        },
    };
    for technique in [Technique::TlMis, Technique::BlMis, Technique::TlMisPinf] {
        for (set, bad) in sets.iter().zip([f32::NAN, -1.0, f32::INFINITY]) {
            let mut e = Estimator::new(set, &sp, technique, &Params::default()).unwrap();
            let mut u = TestUniforms::new(7);
            let got = e.estimate(&Unoccluded, &mut u);
            assert!(
                matches!(got, Err(manylights::DirectError::EnvironmentRadiance { value })
                    if value.to_bits() == bad.to_bits()),
                "{technique:?} with {bad}: {got:?}"
            );
        }
        let mut e = Estimator::new(&sets[3], &sp, technique, &Params::default()).unwrap();
        let mut u = TestUniforms::new(7);
        let good = e.estimate(&Unoccluded, &mut u);
        assert!(good.is_ok(), "{technique:?}: {good:?}");
    }
}

/// A tree whose entry of a light at infinity was edited and resealed (a valid tree by itself)
/// does not load with the lights it no longer matches: the entry is compared with them.
#[test]
fn a_resealed_sun_entry_does_not_load_with_its_lights() {
    let lights = vec![
        distant(Vec3::new(0.3, 0.1, 1.0), SUN, Rgb::grey(2.0)),
        Light::Point {
            position: Vec3::new(0.0, 0.0, 2.0),
            intensity: Rgb::grey(1.0),
        },
    ];
    let set = LightSet::build(lights.clone()).unwrap();
    let bytes = set.tree().as_bytes();
    assert!(LightSet::from_bytes(&bytes, lights.clone()).is_ok());
    // The payload ends with the one 64-byte entry; its irradiance's luminance is at byte 28.
    let mut payload = bytes[manylights::internals::tree::HEADER_BYTES..].to_vec();
    let at = payload.len() - 64 + 28;
    let e = f32::from_ne_bytes(payload[at..at + 4].try_into().unwrap());
    assert_eq!(e, 2.0);
    payload[at..at + 4].copy_from_slice(&(16.0f32).to_ne_bytes());
    let resealed = manylights::internals::tree::seal(&payload);
    assert!(
        LightTree::from_bytes(&resealed).is_ok(),
        "a valid tree by itself"
    );
    assert_eq!(
        LightSet::from_bytes(&resealed, lights.clone()).err(),
        Some(FormatError::Invalid(ValidationError::BadInfinite {
            entry: 0
        }))
    );
    assert_eq!(
        LightTree::from_bytes_with_lights(&resealed, &lights).err(),
        Some(FormatError::Invalid(ValidationError::BadInfinite {
            entry: 0
        }))
    );
}

// ---------------------------------------------------------------------------------------------
// The environment given once, to the light set
// ---------------------------------------------------------------------------------------------

/// A light set takes the environment from the host, never as a light of its list: the light
/// is refused by name (index), the environment's light is appended after the lights with its
/// bounds (validated as a light's fields are), and the bytes load back only with an
/// environment of the same bounds.
#[test]
fn the_environment_enters_a_light_set_once_with_its_bounds() {
    let sky = UniformSky {
        radiance: Rgb::new(0.2, 0.3, 0.5),
    };
    let local = vec![
        Light::Point {
            position: Vec3::new(0.0, 0.0, 2.0),
            intensity: Rgb::grey(1.0),
        },
        distant(Vec3::new(0.2, 0.1, 1.0), SUN, Rgb::grey(2.0)),
    ];
    let mut with_light = local.clone();
    with_light.insert(
        1,
        Light::Environment {
            irradiance: sky.irradiance_bounds(),
        },
    );
    assert_eq!(
        LightSet::build(with_light.clone()).err(),
        Some(BuildError::EnvironmentLight { index: 1 })
    );
    let e = LightSet::build(with_light).unwrap_err().to_string();
    assert!(e.contains("light 1") && e.contains("kind"), "{e}");
    let set = with_sky(local.clone(), sky);
    assert_eq!(set.environment_light(), Some(2));
    assert_eq!(set.lights().len(), 3);
    assert_eq!(
        set.lights()[2],
        Light::Environment {
            irradiance: sky.irradiance_bounds()
        }
    );
    assert!(set.environment().is_some());
    // Bad bounds name the environment's light, one past the list.
    struct Bounds([f32; 6]);
    impl Environment for Bounds {
        fn sample(&self, _u: [f32; 2]) -> Option<EnvironmentSample> {
            None
        }
        fn eval(&self, _d: Vec3) -> (Rgb, f32) {
            (Rgb::ZERO, 0.0)
        }
        fn irradiance_bounds(&self) -> [f32; 6] {
            self.0
        }
    }
    let bad = LightSet::build_with_environment(
        local.clone(),
        Bounds([1.0, 1.0, -1.0, 1.0, 1.0, 1.0]),
        &BuildOptions::default(),
        &Serial,
    );
    assert!(
        matches!(
            bad,
            Err(BuildError::InvalidLight {
                index: 2,
                field: LightField::Irradiance,
                problem: Problem::Negative,
                ..
            })
        ),
        "{bad:?}"
    );
    // The bytes: with the environment they load and estimate bit for bit; without it (or
    // with other bounds) they do not.
    let bytes = set.tree().as_bytes();
    let loaded = LightSet::from_bytes_with_environment(&bytes, local.clone(), sky).unwrap();
    assert!(LightSet::from_bytes(&bytes, local.clone()).is_err());
    let brighter = UniformSky {
        radiance: Rgb::grey(4.0),
    };
    assert!(LightSet::from_bytes_with_environment(&bytes, local.clone(), brighter).is_err());
    let sp = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::new(0.2, 0.1, 1.0),
        material: Material::Plastic {
            albedo: Rgb::new(0.6, 0.5, 0.4),
            specular: 0.4,
            alpha: 0.2,
        },
    };
    for t in Technique::ALL {
        let mut a = Estimator::new(&set, &sp, t, &Params::default()).unwrap();
        let mut b = Estimator::new(&loaded, &sp, t, &Params::default()).unwrap();
        let (mut ua, mut ub) = (TestUniforms::new(3), TestUniforms::new(3));
        for _ in 0..50 {
            let (x, y) = (
                a.estimate(&Unoccluded, &mut ua).unwrap(),
                b.estimate(&Unoccluded, &mut ub).unwrap(),
            );
            assert_eq!(x.map(f64::to_bits), y.map(f64::to_bits), "{t}");
        }
    }
}

/// Points on the environment through the light set are the environment's samples (as a point
/// at infinity), and their pdf is its `eval`'s; a bad sample is an error, no sample is none.
#[test]
fn points_on_the_environment_come_from_the_sets_environment() {
    let sky = GradientSky {
        up: Vec3::Z,
        zenith: Rgb::new(0.1, 0.2, 0.5),
        horizon: Rgb::new(0.5, 0.5, 0.6),
        ground: Rgb::new(0.1, 0.08, 0.05),
    };
    let set = with_sky(vec![distant(Vec3::Z, SUN, Rgb::grey(1.0))], sky);
    let env = set.environment_light().unwrap();
    let x = Vec3::new(1.0, 2.0, 3.0);
    let mut rng = Rng::new(11);
    for _ in 0..200 {
        let u = [rng.f32(), rng.f32()];
        let p = set
            .sample_point(env, x, u)
            .unwrap()
            .expect("the sky samples every u");
        let s = sky.sample(u).unwrap();
        // The sample's direction, renormalised.
        let d = s.direction / s.direction.length();
        assert_eq!((p.direction, p.position), (d, d));
        assert_eq!(
            (p.radiance, p.pdf, p.distance),
            (s.radiance, s.pdf, f32::INFINITY)
        );
        assert!(!p.delta);
        assert_eq!(set.pdf_point(env, x, p.direction).unwrap(), sky.eval(d).1);
    }
    // A distant light's points are the light's own.
    let u = [0.3, 0.7];
    assert_eq!(
        set.sample_point(0, x, u).unwrap(),
        manylights::light::sample_point(&set.lights()[0], x, u)
    );
    assert_eq!(set.sample_point(9, x, u).unwrap(), None);
    struct Bad(f32);
    impl Environment for Bad {
        fn sample(&self, _u: [f32; 2]) -> Option<EnvironmentSample> {
            (self.0 != 0.0).then_some(EnvironmentSample {
                direction: Vec3::Z,
                radiance: Rgb::grey(1.0),
                pdf: self.0,
            })
        }
        fn eval(&self, _d: Vec3) -> (Rgb, f32) {
            (Rgb::grey(1.0), self.0)
        }
        fn irradiance_bounds(&self) -> [f32; 6] {
            [1.0; 6]
        }
    }
    let none = with_sky(Vec::new(), Bad(0.0));
    assert_eq!(none.sample_point(0, x, u).unwrap(), None);
    let nan = with_sky(Vec::new(), Bad(f32::NAN));
    assert!(matches!(
        nan.sample_point(0, x, u),
        Err(manylights::DirectError::EnvironmentPdf { .. })
    ));
    assert!(nan.pdf_point(0, x, Vec3::Z).is_err());
}

/// A wavefront batch on a set with an environment: bit for bit the single calls, and a
/// uniform sky over a Lambert plane reflects ρL on average.
#[test]
fn a_wavefront_batch_takes_the_sets_environment() {
    let sky = UniformSky {
        radiance: Rgb::new(0.5, 1.0, 2.0),
    };
    let set = with_sky(Vec::new(), sky);
    let albedo = Rgb::new(0.8, 0.5, 0.25);
    let points: Vec<ShadingPoint> = (0..64)
        .map(|i| ShadingPoint {
            position: Vec3::new(i as f32, 0.0, 0.0),
            normal: Vec3::Z,
            wo: Vec3::new(0.1 * (i % 5) as f32, 0.0, 1.0),
            material: Material::Lambert { albedo },
        })
        .collect();
    let per = 64;
    let params = Params::default();
    for t in [Technique::BlMis, Technique::TlMis, Technique::Tl] {
        let mut out = vec![[0.0f64; 3]; points.len() * per];
        let mut u = TestUniforms::new(21);
        manylights::wavefront::estimate_each(
            &set,
            &points,
            per,
            t,
            &params,
            &Unoccluded,
            &mut u,
            &mut out,
        )
        .unwrap();
        let mut u = TestUniforms::new(21);
        let mut st: [Stats; 3] = Default::default();
        for (j, sp) in points.iter().enumerate() {
            let mut e = Estimator::new(&set, sp, t, &params).unwrap();
            for i in 0..per {
                let v = e.estimate(&Unoccluded, &mut u).unwrap();
                assert_eq!(
                    v.map(f64::to_bits),
                    out[j * per + i].map(f64::to_bits),
                    "{t}"
                );
                for (s, x) in st.iter_mut().zip(v) {
                    s.add(x);
                }
            }
        }
        let exact = [0, 1, 2]
            .map(|c| f64::from(albedo.to_array()[c]) * f64::from(sky.radiance.to_array()[c]));
        for (c, (s, exact)) in st.iter().zip(exact).enumerate() {
            let z = (s.mean() - exact) / s.se().max(1e-12);
            assert!(
                z.abs() <= 5.0,
                "{t} channel {c}: {} vs {exact}: {z:.2} SE",
                s.mean()
            );
        }
    }
}
