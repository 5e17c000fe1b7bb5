//! A small version of `mlrender estimator`'s checks, and an exhaustive reference for the
//! combined MIS + adaptive-allocation estimator on a tiny discrete problem.

use glam::Vec3;
use manylights::mis::{AdaptiveAllocator, CombinedWeights, SequentialWeights};
use manylights::{Light, Material, ShadingPoint};
use manylights_render::estimator::reference::reference;
use manylights_render::estimator::scene::{Config, Plan, Scene};
use manylights_render::estimator::techniques::{
    mixture_term, tl_term, trace, trace_brute, Denominator, LambertMode, Params, Setup, Technique,
};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Mean and standard error of `k` estimates.
fn run(setup: &Setup, t: Technique, k: usize, seed: u64) -> (f64, f64) {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..k {
        let x = setup.estimate(t, &mut rng);
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
            trace(&scene, c.sp.position, d, |l, lp| walked.push((l, *lp)));
            let mut brute = trace_brute(&scene, c.sp.position, d);
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
        material: Material::Lambert { albedo },
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
        radiance: l,
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
        radiance: l,
        two_sided: false,
    };
    let exact_disk =
        f64::from(albedo) * f64::from(l) * f64::from(rd * rd) * (1.0 / f64::from(h * h + rd * rd));
    // The same disk turned away contributes 0.
    let away = Light::Disk {
        center: Vec3::new(0.0, 0.0, h),
        normal: Vec3::Z,
        radius: rd,
        radiance: l,
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
                    power: false,
                    ..params
                },
            ));
        }
        for (i, (t, p)) in cases.into_iter().enumerate() {
            let k = match t {
                Technique::Uniform | Technique::Power | Technique::Tl | Technique::Bl => 200_000,
                Technique::TlSplit => 40_000,
                Technique::MisEqual | Technique::Full => 12_000,
            };
            let setup = Setup::new(&scene, &c.sp, t, &p);
            let (mean, se) = run(&setup, t, k, 1000 * ci as u64 + i as u64);
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

/// A tiny discrete problem: points y with values f(y) and the probabilities with which TL, BL
/// and TB produce them (TB's leftover mass is a miss).
struct Problem {
    f: Vec<f32>,
    p_tl: Vec<f32>,
    p_bl: Vec<f32>,
    p_tb: Vec<f32>,
}

impl Problem {
    fn random(rng: &mut Pcg64Mcg, m: usize) -> Problem {
        let norm = |rng: &mut Pcg64Mcg, zero_chance: f64, mass: f32| {
            let mut v: Vec<f32> = (0..m)
                .map(|_| {
                    if rng.random_bool(zero_chance) {
                        0.0
                    } else {
                        rng.random_range(0.05f32..1.0)
                    }
                })
                .collect();
            if v.iter().all(|&x| x == 0.0) {
                v[0] = 1.0;
            }
            let s: f32 = v.iter().sum();
            v.iter_mut().for_each(|x| *x *= mass / s);
            v
        };
        let p_tl = norm(rng, 0.2, 1.0);
        let p_bl = norm(rng, 0.2, 1.0);
        let hit_mass = rng.random_range(0.1f32..0.9);
        let p_tb = norm(rng, 0.3, hit_mass);
        // f > 0 only where some technique can produce the point; a few zeros (lights that send
        // nothing towards x: TB hits them without counting a hit).
        let f = (0..m)
            .map(|i| {
                let covered = p_tl[i] > 0.0 || p_bl[i] > 0.0 || p_tb[i] > 0.0;
                if covered && !rng.random_bool(0.15) {
                    rng.random_range(0.1f32..10.0)
                } else {
                    0.0
                }
            })
            .collect();
        Problem {
            f,
            p_tl,
            p_bl,
            p_tb,
        }
    }

    fn total(&self) -> f64 {
        self.f.iter().map(|&x| f64::from(x)).sum()
    }

    /// Whether the BRDF-aware mixture with BL (`bl`) or without covers every point that TL does
    /// not (the unbiasedness condition).
    fn covered(&self, bl: bool) -> bool {
        (0..self.f.len()).all(|i| {
            self.f[i] == 0.0
                || self.p_tl[i] > 0.0
                || self.p_tb[i] > 0.0
                || (bl && self.p_bl[i] > 0.0)
        })
    }

    /// E[TL part]: one sample.
    fn tl_expectation(&self, w: CombinedWeights) -> f64 {
        self.expectation(&self.p_tl, |f, tl, bl, tb| tl_term(f, w, tl, bl, tb))
    }

    /// Σ_y pmf(y) · term(f(y), pdf_TL(y), pdf_BL(y), pdf_TB(y)) over the points with pmf > 0
    /// and f > 0: the expectation of one sample drawn with `pmf`.
    fn expectation(&self, pmf: &[f32], term: impl Fn(f32, f32, f32, f32) -> f32) -> f64 {
        (0..self.f.len())
            .filter(|&i| pmf[i] > 0.0 && self.f[i] > 0.0)
            .map(|i| {
                f64::from(pmf[i])
                    * f64::from(term(self.f[i], self.p_tl[i], self.p_bl[i], self.p_tb[i]))
            })
            .sum()
    }

    /// Σ_y pmf(y) · term(y) for one BRDF-aware sample with denominator `den`.
    fn one_sample(&self, pmf: &[f32], w: CombinedWeights, den: Denominator) -> f64 {
        self.expectation(pmf, |f, tl, bl, tb| mixture_term(f, w, tl, bl, tb, den))
    }

    /// Probability that a TB sample counts as a hit (it reaches a point with f > 0).
    fn hit_probability(&self) -> f64 {
        (0..self.f.len())
            .filter(|&i| self.f[i] > 0.0)
            .map(|i| f64::from(self.p_tb[i]))
            .sum()
    }

    /// E[mixture part] of `full`: samples j..n with the allocator in state `alloc`, every
    /// branch of the allocator enumerated. `den_of(p)` gives the denominator used with BL
    /// probability p (the correct one is `(n p, n (1 − p))`).
    fn adaptive_expectation(
        &self,
        w: CombinedWeights,
        alloc: AdaptiveAllocator,
        j: u32,
        n: u32,
        den_of: &impl Fn(f32) -> Denominator,
    ) -> f64 {
        if j == n {
            return 0.0;
        }
        let p = alloc.p_bl();
        let den = den_of(p);
        let (pd, qd) = (f64::from(p), 1.0 - f64::from(p));
        let mut e = 0.0;
        if p > 0.0 {
            e += pd * self.one_sample(&self.p_bl, w, den);
            e += pd * self.adaptive_expectation(w, alloc, j + 1, n, den_of);
        }
        e += qd * self.one_sample(&self.p_tb, w, den);
        let ph = self.hit_probability();
        let (mut hit, mut miss) = (alloc, alloc);
        hit.record_tb(true);
        miss.record_tb(false);
        e += qd * ph * self.adaptive_expectation(w, hit, j + 1, n, den_of);
        e += qd * (1.0 - ph) * self.adaptive_expectation(w, miss, j + 1, n, den_of);
        e
    }

    /// E[whole estimator] of `full` with [`SequentialWeights`]: the BRDF-aware samples j..n
    /// with the allocator in state `alloc` and the weights `sw` holding the p of the samples
    /// before j, every branch enumerated; at the end of a branch, the TL part weighted with
    /// that branch's p_1..p_n. `p_used(p)` is the BL probability passed to the weights for a
    /// sample drawn with probability p (the correct one is p itself).
    fn sequential_expectation(
        &self,
        sw: SequentialWeights,
        alloc: AdaptiveAllocator,
        j: u32,
        p_used: &impl Fn(f32) -> f32,
    ) -> f64 {
        if j == sw.budget() {
            return self.expectation(&self.p_tl, |f, tl, bl, tb| sw.tl_term(f, tl, bl, tb));
        }
        let p = alloc.p_bl();
        let q = p_used(p);
        let one = |pmf: &[f32]| -> f64 {
            self.expectation(pmf, |f, tl, bl, tb| sw.mixture_term(f, q, tl, bl, tb))
        };
        let mut next = sw;
        next.record(q);
        let (pd, qd) = (f64::from(p), 1.0 - f64::from(p));
        let mut e = 0.0;
        if p > 0.0 {
            e += pd * (one(&self.p_bl) + self.sequential_expectation(next, alloc, j + 1, p_used));
        }
        e += qd * one(&self.p_tb);
        let ph = self.hit_probability();
        let (mut hit, mut miss) = (alloc, alloc);
        hit.record_tb(true);
        miss.record_tb(false);
        e += qd * ph * self.sequential_expectation(next, hit, j + 1, p_used);
        e += qd * (1.0 - ph) * self.sequential_expectation(next, miss, j + 1, p_used);
        e
    }

    /// E[mixture part] of `mis-equal`: ⌊n/2⌋ BL and ⌊n/2⌋ TB samples, and for an odd n one
    /// more that is BL or TB with probability 1/2, all with the denominator `n q_ref`.
    fn equal_expectation(&self, w: CombinedWeights, n: u32) -> f64 {
        let den = Denominator {
            a: 0.5 * n as f32,
            b: 0.5 * n as f32,
        };
        let per_pair = self.one_sample(&self.p_bl, w, den) + self.one_sample(&self.p_tb, w, den);
        f64::from(n / 2) * per_pair + if n % 2 == 1 { 0.5 * per_pair } else { 0.0 }
    }
}

/// `count` random five-point problems with a non-zero integral, from `seed`.
fn problems(seed: u64, count: usize) -> Vec<Problem> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let prob = Problem::random(&mut rng, 5);
        if prob.total() != 0.0 {
            out.push(prob);
        }
    }
    out
}

/// The expectation of the combined estimator, every outcome of the allocator's choices and of
/// the samples enumerated, equals the integral; a denominator that ignores the allocator's
/// current p (the mixture at the reference p_ref = 1/2) does not.
#[test]
fn combined_estimator_is_exactly_unbiased_by_enumeration() {
    let mut worst_wrong = 0.0f64;
    for prob in problems(2024, 60) {
        for n in [1u32, 2, 3, 7] {
            let nf = n as f32;
            for bl in [true, false] {
                if !prob.covered(bl) {
                    continue;
                }
                let w = CombinedWeights {
                    n_tl: 1.0,
                    n_mixture: nf,
                    p_ref: if bl { 0.5 } else { 0.0 },
                    power: false,
                };
                for power in [false, true] {
                    let w = CombinedWeights { power, ..w };
                    let e = prob.tl_expectation(w)
                        + prob.adaptive_expectation(w, AdaptiveAllocator::new(bl), 0, n, &|p| {
                            Denominator {
                                a: nf * p,
                                b: nf * (1.0 - p),
                            }
                        });
                    let rel = (e - prob.total()).abs() / prob.total();
                    assert!(
                        rel < 2e-5,
                        "full n={n} bl={bl} power={power}: {e} vs {}",
                        prob.total()
                    );
                }
                if bl {
                    let e = prob.tl_expectation(w) + prob.equal_expectation(w, n);
                    let rel = (e - prob.total()).abs() / prob.total();
                    assert!(rel < 2e-5, "mis-equal n={n}: {e} vs {}", prob.total());
                    // Wrong: sampling adaptively but dividing by the reference mixture.
                    let e = prob.tl_expectation(w)
                        + prob.adaptive_expectation(w, AdaptiveAllocator::new(true), 0, n, &|_| {
                            Denominator {
                                a: nf * 0.5,
                                b: nf * 0.5,
                            }
                        });
                    worst_wrong = worst_wrong.max((e - prob.total()).abs() / prob.total());
                }
            }
        }
    }
    // The enumeration can tell a biased estimator from an unbiased one.
    assert!(worst_wrong > 0.05, "{worst_wrong}");
}

/// `full`'s estimator with [`SequentialWeights`] (each BRDF-aware sample weighted against its
/// own mixture density, TL weighted by the mean of the per-sample weights once every p_j is
/// known): its expectation, every branch of the allocator and every sample enumerated, equals
/// the integral, for both heuristics and with and without BL; weighting the samples with a
/// probability other than the one they were drawn with does not.
#[test]
fn sequential_weights_are_exactly_unbiased_by_enumeration() {
    let mut worst_wrong = 0.0f64;
    for prob in problems(2025, 60) {
        for n in [0u32, 1, 2, 3, 7] {
            for bl in [true, false] {
                // Without BRDF-aware samples TL alone must cover every point.
                let tl_covers = (0..prob.f.len()).all(|i| prob.f[i] == 0.0 || prob.p_tl[i] > 0.0);
                if !prob.covered(bl) || (n == 0 && !tl_covers) {
                    continue;
                }
                for power in [false, true] {
                    let sw = SequentialWeights::new(n, 1.0, power);
                    let e = prob.sequential_expectation(sw, AdaptiveAllocator::new(bl), 0, &|p| p);
                    let rel = (e - prob.total()).abs() / prob.total();
                    assert!(
                        rel < 2e-5,
                        "n={n} bl={bl} power={power}: {e} vs {}",
                        prob.total()
                    );
                    if bl && n > 0 {
                        let e =
                            prob.sequential_expectation(sw, AdaptiveAllocator::new(bl), 0, &|_| {
                                0.5
                            });
                        worst_wrong = worst_wrong.max((e - prob.total()).abs() / prob.total());
                    }
                }
            }
        }
    }
    assert!(worst_wrong > 0.05, "{worst_wrong}");
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
                radiance: 1.0 + (i % 3) as f32,
            }
        })
        .collect();
    let mut rng = Pcg64Mcg::seed_from_u64(9);
    for (mi, (name, material)) in manylights_render::estimator::scene::MATERIALS
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
                trace(
                    &scene,
                    sp.position,
                    frame.to_world(wi).normalize(),
                    |_, lp| {
                        v += f64::from(f * lp.radiance * wi.z / pdf);
                    },
                );
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
