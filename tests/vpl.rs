//! Probabilistic VPL acceptance (Georgiev & Slusallek 2010) and the VPL light kind: the
//! acceptance is unbiased (mean accepted scaled energy = the candidates' energy), ε ≥ 1 keeps
//! everything, p ∈ (0, 1], a candidate that contributes nothing is kept with probability ε, the
//! first frame keeps everything, the 4-wide contribution equals the scalar one lane by lane,
//! bad input is an error naming the field; the VPL light's bounds, energy and point sampling;
//! two regressions at the end (a kept VPL stays a valid light whatever ε, found by the `vpl`
//! fuzz target; no NaN estimate next to an importon).
//! (The VPL kind's tree properties run with every other kind's in `sampling.rs` and
//! `importance.rs`, over `vpl_scene`.)

mod common;

use common::{Rng, Stats};
use glam::{DVec3, Vec3};
use manylights::error::{LightField, Problem, VplField};
use manylights::internals::light::LightExt;
use manylights::light::{intersect, pdf_direction, pdf_point, sample_point};
use manylights::vpl::{Unoccluded, DEFAULT_EPSILON};
use manylights::Rgb;
use manylights::{Importons, Light, LightTree, Material, TlImportance, Vpl, VplAcceptor, VplError};
use std::f32::consts::PI;

/// Importons on the floor z = 0 of a 4 × 4 square, facing up: `n` of them, every fifth a
/// glossy plastic one (when `glossy`), one in seven a miss.
fn floor_importons(rng: &mut Rng, n: usize, glossy: bool) -> Importons {
    let mut imp = Importons::new();
    for j in 0..n {
        if j % 7 == 6 {
            imp.push_miss();
            continue;
        }
        let p = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), 0.0);
        if glossy && j % 5 == 0 {
            let wo = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 1.0);
            let m = Material::Plastic {
                albedo: Rgb::grey(0.4),
                specular: 0.6,
                alpha: rng.range(0.05, 1.0),
            };
            imp.push(p, Vec3::Z, wo, m).unwrap();
        } else {
            imp.push_diffuse(p, Vec3::Z, rng.range(0.1, 0.9)).unwrap();
        }
    }
    imp
}

/// A candidate above or beside the floor, facing a random way; `dead` ones face away from the
/// floor from above it (no importon can see their lobe).
fn candidate(rng: &mut Rng, dead: bool) -> Vpl {
    let position = Vec3::new(
        rng.range(-4.0, 4.0),
        rng.range(-4.0, 4.0),
        rng.range(0.1, 3.0),
    );
    let normal = if dead {
        Vec3::new(rng.range(-0.2, 0.2), rng.range(-0.2, 0.2), 1.0)
    } else {
        rng.unit()
    };
    Vpl {
        position,
        normal,
        intensity: Rgb::grey(rng.log_range(1e-2, 10.0)),
    }
}

fn acceptor_with(imp: Importons, total: f64, epsilon: f32) -> VplAcceptor {
    let mut a = VplAcceptor::new(64 * 64, 500)
        .unwrap()
        .with_epsilon(epsilon)
        .unwrap();
    *a.importons_mut() = imp;
    a.set_total_luminance(total).unwrap();
    a
}

/// The contribution of `v` to importon `j` in f64 from the importon's geometry (position read
/// back from the store): f·G·I with f the BRDF the importon was built with.
fn reference_contribution(x: Vec3, n: Vec3, f: f64, v: &Vpl) -> f64 {
    let d = v.position.as_dvec3() - x.as_dvec3();
    let d2 = d.length_squared();
    let m = v.normal.as_dvec3().normalize();
    let cx = n.as_dvec3().dot(d).max(0.0) / d2.sqrt();
    let cy = (-m.dot(d)).max(0.0) / d2.sqrt();
    f * cx * cy / d2 * f64::from(v.intensity.luminance())
}

// ---------------------------------------------------------------------------------------------
// 4-wide vs scalar
// ---------------------------------------------------------------------------------------------

#[test]
fn contribution4_equals_scalar_lane_by_lane() {
    let mut rng = Rng::new(0x4C41_4E45);
    for case in 0..40 {
        let n = 1 + rng.below(37);
        let imp = floor_importons(&mut rng, n, case % 2 == 0);
        assert_eq!(imp.len(), n);
        assert_eq!(imp.blocks(), n.div_ceil(4));
        for _ in 0..50 {
            let dead = rng.chance(0.2);
            let v = candidate(&mut rng, dead);
            let m = v.validate().unwrap();
            let g_max = if rng.chance(0.5) {
                f32::INFINITY
            } else {
                rng.log_range(0.01, 10.0)
            };
            for b in 0..imp.blocks() {
                let lanes = imp
                    .contribution4(b, v.position, m, v.intensity.luminance(), g_max)
                    .to_array();
                for (l, &c4) in lanes.iter().enumerate() {
                    let c =
                        imp.contribution(4 * b + l, v.position, m, v.intensity.luminance(), g_max);
                    assert!(
                        c4.to_bits() == c.to_bits(),
                        "case {case}, importon {}: 4-wide {c4} vs scalar {c} ({v:?})",
                        4 * b + l
                    );
                    assert!(c >= 0.0 && c.is_finite(), "{c}");
                }
            }
        }
    }
}

/// The scalar contribution of a diffuse importon is albedo/π · cos · cos / d² · I (f64).
#[test]
fn contribution_matches_the_formula() {
    let mut rng = Rng::new(0xF0);
    for _ in 0..200 {
        let x = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0);
        let albedo = rng.range(0.1, 0.9);
        let mut imp = Importons::new();
        imp.push_diffuse(x, Vec3::Z * 3.0, albedo).unwrap();
        let v = candidate(&mut rng, false);
        let m = v.validate().unwrap();
        let c =
            f64::from(imp.contribution(0, v.position, m, v.intensity.luminance(), f32::INFINITY));
        let r = reference_contribution(x, Vec3::Z, f64::from(albedo) / std::f64::consts::PI, &v);
        assert!((c - r).abs() <= 1e-5 * r + 1e-12, "{c} vs {r}");
        // Clamped: G ≤ g_max.
        let g_max = 0.05;
        let cc = f64::from(imp.contribution(0, v.position, m, v.intensity.luminance(), g_max));
        let bound =
            f64::from(albedo) / std::f64::consts::PI * 0.05 * f64::from(v.intensity.luminance());
        assert!(
            cc <= bound * (1.0 + 1e-6) && cc <= c * (1.0 + 1e-6),
            "{cc} {bound} {c}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Acceptance
// ---------------------------------------------------------------------------------------------

/// Over many trials of the same candidate set, the mean accepted (scaled) energy equals the
/// candidates' energy. Per candidate the accepted energy is E/p with probability p, variance
/// E²(1/p − 1); the tolerance is 5 standard deviations of the mean from that exact variance.
#[test]
fn acceptance_is_unbiased() {
    let mut rng = Rng::new(0x0B1A5);
    let imp = floor_importons(&mut rng, 100, true);
    let candidates: Vec<Vpl> = (0..400).map(|i| candidate(&mut rng, i % 3 == 0)).collect();
    // Φ̃_total chosen so that p spans (ε, 1]: the median candidate's Φ̃_i times P·N.
    let probe = acceptor_with(imp.clone(), 0.0, DEFAULT_EPSILON);
    let mut phis: Vec<f32> = candidates
        .iter()
        .map(|c| probe.estimate(c).unwrap())
        .collect();
    phis.sort_by(f32::total_cmp);
    let total = f64::from(phis[phis.len() * 3 / 4]) * 64.0 * 64.0 * 500.0;
    let mut acc = acceptor_with(imp, total, DEFAULT_EPSILON);
    let ps: Vec<f32> = candidates
        .iter()
        .map(|c| acc.probability(c).unwrap())
        .collect();
    let low = ps.iter().filter(|&&p| p < 0.5).count();
    assert!(low > 100 && low < 390, "p does not spread: {low} below 0.5");
    let energy: f64 = candidates.iter().map(|c| f64::from(c.energy())).sum();
    let var: f64 = candidates
        .iter()
        .zip(&ps)
        .map(|(c, &p)| f64::from(c.energy()).powi(2) * (1.0 / f64::from(p) - 1.0))
        .sum();
    let trials = 4000;
    let mut stats = Stats::default();
    for _ in 0..trials {
        let mut e = 0.0;
        for c in &candidates {
            if let Some(a) = acc.accept(c, rng.f32()).unwrap() {
                e += f64::from(a.vpl.energy());
                assert_eq!(a.vpl.position, c.position);
                assert_eq!(a.vpl.normal, c.normal);
            }
        }
        stats.add(e);
    }
    let se = (var / trials as f64).sqrt();
    let diff = stats.mean() - energy;
    assert!(
        diff.abs() <= 5.0 * se,
        "mean accepted energy {} vs candidates' {energy}: {diff} is more than 5 σ = {}",
        stats.mean(),
        5.0 * se
    );
    // The sample spread agrees with the analytic one (within 10 %: 4,000 trials).
    let sample_sd = stats.se() * (trials as f64).sqrt();
    assert!(
        (sample_sd / var.sqrt() - 1.0).abs() < 0.1,
        "{sample_sd} vs {}",
        var.sqrt()
    );
    // The statistics count every decision.
    let s = acc.stats();
    assert_eq!(s.candidates, trials * 400);
    let (ratio, ratio_sd) = s.energy_ratio();
    assert!(
        (ratio - 1.0).abs() <= 5.0 * ratio_sd,
        "energy ratio {ratio} ± {ratio_sd}"
    );
    let expected_sd = (var * trials as f64).sqrt() / (energy * trials as f64);
    assert!(
        (ratio_sd / expected_sd - 1.0).abs() < 1e-6,
        "{ratio_sd} vs {expected_sd}"
    );
    let mean_p = ps.iter().map(|&p| f64::from(p)).sum::<f64>() / 400.0;
    assert!((s.mean_probability() - mean_p).abs() < 1e-9, "{s:?}");
    // Acceptance rate: a sum of independent Bernoulli(p) over 1.6 M decisions.
    let rate_se = (ps
        .iter()
        .map(|&p| f64::from(p) * (1.0 - f64::from(p)))
        .sum::<f64>()
        * trials as f64)
        .sqrt()
        / s.candidates as f64;
    assert!(
        (s.acceptance_rate() - mean_p).abs() <= 5.0 * rate_se,
        "{s:?}"
    );
}

#[test]
fn epsilon_of_one_or_more_accepts_everything() {
    let mut rng = Rng::new(0xE1);
    let imp = floor_importons(&mut rng, 100, false);
    for eps in [1.0, 1.5, 100.0] {
        let mut acc = acceptor_with(imp.clone(), 1e30, eps);
        for i in 0..500 {
            let c = candidate(&mut rng, i % 2 == 0);
            let a = acc.accept(&c, rng.f32()).unwrap().expect("ε ≥ 1 keeps all");
            assert_eq!(a.probability, 1.0);
            assert_eq!(a.vpl, c);
        }
        assert_eq!(acc.stats().acceptance_rate(), 1.0);
    }
}

#[test]
fn probabilities_are_in_zero_one() {
    let mut rng = Rng::new(0x9);
    for case in 0..30 {
        let n = 1 + rng.below(120);
        let imp = floor_importons(&mut rng, n, case % 2 == 1);
        let total = f64::from(rng.log_range(1e-6, 1e12));
        let eps = rng.log_range(1e-4, 2.0);
        let acc = acceptor_with(imp, total, eps);
        for _ in 0..200 {
            let dead = rng.chance(0.3);
            let c = candidate(&mut rng, dead);
            let p = acc.probability(&c).unwrap();
            assert!(p > 0.0 && p <= 1.0, "p = {p}");
            assert!(p >= eps.min(1.0), "p = {p} below ε = {eps}");
            let mut vis = |_: Vec3, _: Vec3| rng.chance(0.5);
            let pv = acc.probability_with(&c, &mut vis).unwrap();
            assert!(pv > 0.0 && pv <= p, "occlusion raised p: {pv} > {p}");
        }
    }
}

/// A candidate whose lobe no importon sees (or that every importon finds occluded) has Φ̃_i = 0
/// and p = ε exactly: kept iff ξ ≤ ε, on a sweep of ξ and in frequency.
#[test]
fn no_contribution_is_accepted_with_probability_epsilon() {
    let mut rng = Rng::new(0xE0);
    let imp = floor_importons(&mut rng, 100, true);
    let mut acc = acceptor_with(imp, 1e3, DEFAULT_EPSILON);
    let dead = candidate(&mut rng, true);
    assert_eq!(acc.estimate(&dead).unwrap(), 0.0);
    assert_eq!(acc.probability(&dead).unwrap(), DEFAULT_EPSILON);
    let live = Vpl {
        position: Vec3::new(0.0, 0.0, 1.0),
        normal: -Vec3::Z,
        intensity: Rgb::grey(1.0),
    };
    let mut never = |_: Vec3, _: Vec3| false;
    assert_eq!(
        acc.probability_with(&live, &mut never).unwrap(),
        DEFAULT_EPSILON
    );
    assert!(acc.probability(&live).unwrap() > DEFAULT_EPSILON);
    for k in 0..1000 {
        let xi = k as f32 / 1000.0;
        let a = acc.accept(&dead, xi).unwrap();
        assert_eq!(a.is_some(), xi <= DEFAULT_EPSILON, "ξ = {xi}");
        if let Some(a) = a {
            assert_eq!(a.vpl.intensity, dead.intensity / DEFAULT_EPSILON);
        }
    }
    acc.reset_stats();
    let n = 200_000;
    for _ in 0..n {
        acc.accept_with(&live, rng.f32(), &mut never).unwrap();
    }
    let eps = f64::from(DEFAULT_EPSILON);
    let se = (eps * (1.0 - eps) / n as f64).sqrt();
    let rate = acc.stats().acceptance_rate();
    assert!((rate - eps).abs() <= 5.0 * se, "rate {rate} vs ε {eps}");
}

#[test]
fn first_frame_accepts_everything() {
    let mut rng = Rng::new(0xF1);
    let mut acc = VplAcceptor::new(100, 10).unwrap();
    acc.importons_mut()
        .push_diffuse(Vec3::ZERO, Vec3::Z, 0.5)
        .unwrap();
    assert_eq!(acc.total_luminance(), 0.0);
    for i in 0..1000 {
        let c = candidate(&mut rng, i % 2 == 0);
        let xi = if i == 0 {
            1.0 - f32::EPSILON / 2.0
        } else {
            rng.f32()
        };
        let a = acc.accept(&c, xi).unwrap().expect("first frame keeps all");
        assert_eq!((a.probability, a.vpl), (1.0, c));
    }
    // Then the estimate moves to the frames' mean.
    acc.update(10.0).unwrap();
    acc.update(20.0).unwrap();
    assert_eq!(acc.total_luminance(), 15.0);
    assert_eq!(acc.target(), 15.0 / 1000.0);
}

/// The visibility tests stop once p = 1 is certain: p is still that of the full sum.
#[test]
fn early_exit_keeps_p_exact() {
    let mut rng = Rng::new(0xEE);
    let imp = floor_importons(&mut rng, 100, true);
    // Deterministic occlusion: a hash of the importon's position.
    let occluder = |x: Vec3, _: Vec3| (x.x.to_bits() ^ x.y.to_bits()) % 3 != 0;
    let mut saved = 0;
    for total in [1e2, 1e4, 1e6] {
        let acc = acceptor_with(imp.clone(), total, DEFAULT_EPSILON);
        for _ in 0..300 {
            let c = candidate(&mut rng, false);
            let mut calls_full = 0;
            let full = acc
                .estimate_with(&c, &mut |x: Vec3, y: Vec3| {
                    calls_full += 1;
                    occluder(x, y)
                })
                .unwrap();
            let p_full = (full / acc.target() as f32 + DEFAULT_EPSILON).min(1.0);
            let mut calls = 0;
            let p = acc
                .probability_with(&c, &mut |x: Vec3, y: Vec3| {
                    calls += 1;
                    occluder(x, y)
                })
                .unwrap();
            assert_eq!(p, p_full, "{c:?}");
            assert!(calls <= calls_full);
            saved += calls_full - calls;
        }
    }
    assert!(
        saved > 1000,
        "the early exit never happened ({saved} tests saved)"
    );
}

/// Occlusion is asked only for the importons the candidate would reach, with the importon's
/// position first.
#[test]
fn visibility_is_asked_for_reached_importons_only() {
    let mut acc = VplAcceptor::new(16, 4).unwrap();
    let im = acc.importons_mut();
    im.push_diffuse(Vec3::new(0.0, 0.0, 0.0), Vec3::Z, 0.5)
        .unwrap();
    im.push_diffuse(Vec3::new(1.0, 0.0, 0.0), -Vec3::Z, 0.5)
        .unwrap(); // faces away
    im.push_miss();
    im.push_diffuse(Vec3::new(2.0, 0.0, 0.0), Vec3::Z, 0.5)
        .unwrap();
    im.push_diffuse(Vec3::new(3.0, 0.0, 0.0), Vec3::Z, 0.0)
        .unwrap(); // black
    acc.set_total_luminance(1.0).unwrap();
    let c = Vpl {
        position: Vec3::new(1.0, 0.0, 1.0),
        normal: -Vec3::Z,
        intensity: Rgb::grey(1.0),
    };
    let mut asked = Vec::new();
    let mut vis = |x: Vec3, y: Vec3| {
        asked.push((x, y));
        true
    };
    let pv = acc.probability_with(&c, &mut vis).unwrap();
    assert_eq!(
        asked,
        vec![
            (Vec3::ZERO, c.position),
            (Vec3::new(2.0, 0.0, 0.0), c.position)
        ]
    );
    assert_eq!(pv, acc.probability(&c).unwrap());
    assert_eq!(
        acc.probability_with(&c, &mut Unoccluded).unwrap(),
        pv,
        "Unoccluded is no test"
    );
    // Φ̃_i = the mean over N_C = 5 importons (the miss and the black one count).
    let phi = acc.estimate(&c).unwrap();
    let each = 0.5 / PI * (1.0 / 2.0f32.sqrt()).powi(2) / 2.0;
    assert!((phi - 2.0 * each / 5.0).abs() < 1e-6, "{phi}");
}

#[test]
fn bad_input_is_an_error_naming_the_field() {
    let e = |r: Result<VplAcceptor, VplError>| r.unwrap_err();
    assert_eq!(e(VplAcceptor::new(0, 10)).field, VplField::Pixels);
    assert_eq!(e(VplAcceptor::new(10, 0)).field, VplField::Wanted);
    let ok = || VplAcceptor::new(10, 10).unwrap();
    for eps in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let err = e(ok().with_epsilon(eps));
        assert_eq!(err.field, VplField::Epsilon, "{eps}");
        assert!(err.to_string().contains("epsilon"), "{err}");
    }
    assert_eq!(
        e(ok().with_geometry_clamp(0.0)).field,
        VplField::GeometryClamp
    );
    let mut acc = ok();
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(acc.update(bad).unwrap_err().field, VplField::Luminance);
        assert_eq!(
            acc.set_total_luminance(bad).unwrap_err().field,
            VplField::Luminance
        );
    }
    let good = Vpl {
        position: Vec3::ONE,
        normal: Vec3::Z,
        intensity: Rgb::grey(1.0),
    };
    let cases = [
        (
            Vpl {
                position: Vec3::new(f32::NAN, 0.0, 0.0),
                ..good
            },
            VplField::Position,
            Problem::NotFinite,
        ),
        (
            Vpl {
                position: Vec3::new(0.0, 2e15, 0.0),
                ..good
            },
            VplField::Position,
            Problem::OutOfRange,
        ),
        (
            Vpl {
                normal: Vec3::ZERO,
                ..good
            },
            VplField::Normal,
            Problem::ZeroLength,
        ),
        (
            Vpl {
                normal: Vec3::new(0.0, f32::INFINITY, 0.0),
                ..good
            },
            VplField::Normal,
            Problem::NotFinite,
        ),
        (
            Vpl {
                intensity: Rgb::grey(-1.0),
                ..good
            },
            VplField::Intensity,
            Problem::Negative,
        ),
        (
            Vpl {
                intensity: Rgb::grey(f32::INFINITY),
                ..good
            },
            VplField::Intensity,
            Problem::NotFinite,
        ),
    ];
    for (c, field, problem) in cases {
        let err = acc.accept(&c, 0.5).unwrap_err();
        assert_eq!((err.field, err.problem), (field, problem), "{c:?}");
        assert!(err.to_string().contains(field.name()), "{err}");
        assert_eq!(acc.probability(&c).unwrap_err().field, field);
    }
    for xi in [-0.1, 1.0, 1.5, f32::NAN] {
        assert_eq!(acc.accept(&good, xi).unwrap_err().field, VplField::Xi);
    }
    assert_eq!(acc.stats().candidates, 0, "rejected input counts nothing");
    let mut im = Importons::new();
    let err = im
        .push_diffuse(Vec3::new(f32::NAN, 0.0, 0.0), Vec3::Z, 0.5)
        .unwrap_err();
    assert_eq!(err.field, VplField::ImportonPosition);
    let err = im.push_diffuse(Vec3::ZERO, Vec3::ZERO, 0.5).unwrap_err();
    assert_eq!(err.field, VplField::ImportonNormal);
    let err = im.push_diffuse(Vec3::ZERO, Vec3::Z, 1.5).unwrap_err();
    assert_eq!(err.field, VplField::ImportonMaterial);
    let m = Material::Ggx {
        alpha: 0.0,
        specular: 1.0,
    };
    let err = im.push(Vec3::ZERO, Vec3::Z, Vec3::Z, m).unwrap_err();
    assert_eq!(err.field, VplField::ImportonMaterial);
    let m = Material::Lambert {
        albedo: Rgb::grey(0.5),
    };
    let err = im.push(Vec3::ZERO, Vec3::Z, Vec3::ZERO, m).unwrap_err();
    assert_eq!(err.field, VplField::ImportonWo);
    assert!(im.is_empty(), "rejected importons are not stored");
}

// ---------------------------------------------------------------------------------------------
// The VPL light kind
// ---------------------------------------------------------------------------------------------

#[test]
fn vpl_light_bounds_energy_and_validation() {
    let l = Light::Vpl {
        position: Vec3::new(1.0, 2.0, 3.0),
        normal: Vec3::new(0.0, 0.0, -2.0),
        intensity: Rgb::grey(3.0),
    };
    assert!(l.validate(0).is_ok());
    assert!((l.energy() - 3.0 * PI).abs() < 1e-5);
    assert_eq!(l.area(), 0.0);
    let b = l.bounds();
    assert_eq!(b.cone.axis, -Vec3::Z);
    assert_eq!(
        (b.cone.theta_o, b.cone.theta_e),
        (0.0, std::f32::consts::FRAC_PI_2)
    );
    assert_eq!(b.sphere.radius, 0.0);
    assert_eq!(b.sphere.center, Vec3::new(1.0, 2.0, 3.0));
    let bad = [
        (
            Light::Vpl {
                position: Vec3::new(f32::NAN, 0.0, 0.0),
                normal: Vec3::Z,
                intensity: Rgb::grey(1.0),
            },
            LightField::Position,
        ),
        (
            Light::Vpl {
                position: Vec3::ZERO,
                normal: Vec3::ZERO,
                intensity: Rgb::grey(1.0),
            },
            LightField::Normal,
        ),
        (
            Light::Vpl {
                position: Vec3::ZERO,
                normal: Vec3::Z,
                intensity: Rgb::grey(-1.0),
            },
            LightField::Intensity,
        ),
        (
            Light::Vpl {
                position: Vec3::ZERO,
                normal: Vec3::Z,
                intensity: Rgb::grey(1e30),
            },
            LightField::Intensity,
        ),
    ];
    for (l, field) in bad {
        match l.validate(4) {
            Err(manylights::BuildError::InvalidLight {
                index: 4, field: f, ..
            }) => {
                assert_eq!(f, field, "{l:?}")
            }
            other => panic!("{l:?}: {other:?}"),
        }
        assert!(LightTree::build(&[l]).is_err());
    }
}

/// A VPL is a delta light: its position, pdf 1, radiance I·max(0, cos θ)/d²; never hit by a ray.
#[test]
fn vpl_light_point_sampling() {
    let y = Vec3::new(0.0, 0.0, 2.0);
    let l = Light::Vpl {
        position: y,
        normal: Vec3::new(0.3, 0.0, -1.0),
        intensity: Rgb::grey(4.0),
    };
    let m = DVec3::new(0.3, 0.0, -1.0).normalize();
    let mut rng = Rng::new(0x5A);
    for _ in 0..200 {
        let x = rng.in_cube(3.0);
        let Some(s) = sample_point(&l, x, rng.u2()) else {
            panic!("no sample at {x}");
        };
        assert!(s.delta && s.pdf == 1.0 && s.position == y);
        let d = y.as_dvec3() - x.as_dvec3();
        let expected = 4.0 * m.dot(-d / d.length()).max(0.0) / d.length_squared();
        assert!(
            (f64::from(s.radiance.r) - expected).abs() <= 1e-5 * expected + 1e-9,
            "{} vs {expected}",
            s.radiance.r
        );
        assert_eq!(pdf_point(&l, x, y), 1.0);
        assert_eq!(pdf_direction(&l, x, s.direction), 0.0);
        assert!(intersect(&l, x, s.direction).is_none());
    }
    assert!(sample_point(&l, y, [0.5, 0.5]).is_none(), "x at the VPL");
}

/// Accepted VPLs go straight into a tree; at a point in front of them the tree's pmfs sum to
/// 1 and every VPL that reaches the point has a positive pmf.
#[test]
fn accepted_vpls_build_into_a_tree() {
    let mut rng = Rng::new(0x7EE);
    let imp = floor_importons(&mut rng, 100, false);
    let mut acc = acceptor_with(imp, 50.0, DEFAULT_EPSILON);
    let mut lights = Vec::new();
    while lights.len() < 300 {
        let c = Vpl {
            position: Vec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), 2.0),
            normal: Vec3::new(rng.range(-0.2, 0.2), rng.range(-0.2, 0.2), -1.0),
            intensity: Rgb::grey(rng.log_range(0.1, 10.0)),
        };
        if let Some(a) = acc.accept(&c, rng.f32()).unwrap() {
            lights.push(a.vpl.light());
        }
    }
    let tree = LightTree::build(&lights).unwrap();
    assert!(tree.validate().is_ok());
    let at = TlImportance::new(Vec3::new(0.2, -0.1, 0.0), Vec3::Z);
    let sum: f64 = (0..lights.len() as u32)
        .map(|i| f64::from(tree.pmf(&at, i)))
        .sum();
    assert!((sum - 1.0).abs() < 1e-4, "Σ pmf = {sum}");
    for (i, _) in lights.iter().enumerate() {
        assert!(
            tree.pmf(&at, i as u32) > 0.0,
            "VPL {i} reaches but has pmf 0"
        );
    }
    let s = tree.sample(&at, 0.37).unwrap();
    assert_eq!(s.pmf, tree.pmf(&at, s.light));
}

/// Found by the `vpl` fuzz target (`fuzz/regressions/vpl/crash-e6f2…`): with a tiny ε (here
/// the subnormal 3.2e-40) a candidate no importon sees has p = ε, and its kept intensity I/p
/// overflowed to +∞ (for I = 0.79); with ε = 1e-30 it was finite but no valid light (energy
/// above `MAX_LIGHT_ENERGY`), so the tree build rejected the accepted set. p is now at least
/// πI/MAX_LIGHT_ENERGY (plus a rounding margin): the kept VPL is always a valid light. A
/// candidate whose own energy exceeds the limit is rejected, as a `Light::Vpl` is.
#[test]
fn tiny_epsilon_keeps_vpls_valid_lights() {
    let mut imp = Importons::new();
    imp.push_diffuse(Vec3::new(10.0, 0.0, 0.0), Vec3::Z, 0.5)
        .unwrap();
    let unseen = |intensity: f32| Vpl {
        position: Vec3::new(-0.0625, -0.0625, -0.0625),
        normal: -Vec3::Z,
        intensity: intensity.into(),
    };
    let limit = manylights::MAX_LIGHT_ENERGY / PI;
    for epsilon in [
        3.20707e-40,
        f32::from_bits(1),
        1e-30,
        1e-20,
        DEFAULT_EPSILON,
    ] {
        let mut acc = acceptor_with(imp.clone(), 1e6, epsilon);
        for intensity in [0.0, 1e-30, 0.7943282, 1e10, 1e20, 1e23, limit * 0.999_99] {
            let c = unseen(intensity);
            let p = acc.probability(&c).unwrap();
            assert!(
                p >= epsilon && p <= 1.0,
                "ε {epsilon}, I {intensity}: p = {p}"
            );
            let a = acc
                .accept(&c, 0.0)
                .unwrap()
                .expect("ξ = 0 keeps every candidate");
            assert_eq!(a.probability, p);
            assert!(
                a.vpl.intensity.is_finite(),
                "ε {epsilon}, I {intensity}: {a:?}"
            );
            if let Err(e) = LightTree::build(&[a.vpl.light()]) {
                panic!("ε {epsilon}, I {intensity}: {a:?} is no valid light: {e}");
            }
            // At the paper's ε, any intensity far below the limit keeps the paper's p = ε.
            if epsilon == DEFAULT_EPSILON && intensity <= 1e20 {
                assert_eq!(p, epsilon, "I {intensity}");
            }
        }
        let too_bright = unseen(limit * 1.0001);
        let e = acc.probability(&too_bright).unwrap_err();
        assert_eq!(
            (e.field, e.problem),
            (VplField::Intensity, Problem::EnergyTooLarge)
        );
        assert_eq!(
            acc.accept(&too_bright, 0.5).unwrap_err().field,
            VplField::Intensity
        );
    }
}

/// Φ̃_i was NaN for a bright candidate a few nanometres from an importon: f · (G · I) with
/// G · I overflowing to +∞ and f = 0 for a miss (misses sit at the origin) or a glossy lane.
/// The product is now (f · G) · I: Φ̃_i is +∞ where the contribution overflows, never NaN.
#[test]
fn a_candidate_on_an_importon_has_no_nan_estimate() {
    let mut imp = Importons::new();
    imp.push_miss();
    imp.push_diffuse(Vec3::new(5.0, 0.0, 0.0), Vec3::Z, 0.5)
        .unwrap();
    imp.push_diffuse(Vec3::new(0.0, 0.0, 0.0), Vec3::Z, 0.5)
        .unwrap();
    let acc = acceptor_with(imp, 1.0, DEFAULT_EPSILON);
    for intensity in [1e21f32, 3e23] {
        let c = Vpl {
            position: Vec3::new(0.0, 0.0, 3.3e-10),
            normal: -Vec3::Z,
            intensity: intensity.into(),
        };
        let phi = acc.estimate(&c).unwrap();
        assert!(phi == f32::INFINITY, "I {intensity}: Φ̃_i = {phi}");
        assert_eq!(acc.probability(&c).unwrap(), 1.0);
        for j in 0..3 {
            let v = acc
                .importons()
                .contribution(j, c.position, -Vec3::Z, intensity, f32::INFINITY);
            assert!(!v.is_nan(), "importon {j}: {v}");
            let v4 = acc
                .importons()
                .contribution4(0, c.position, -Vec3::Z, intensity, f32::INFINITY)
                .to_array()[j];
            assert_eq!(v.to_bits(), v4.to_bits(), "importon {j}");
        }
    }
}
