//! The `direct` estimators of the core:
//!
//! 1. every technique is unbiased: its mean over K estimates is within 5 standard errors
//!    (computed from the K estimates) of a closed-form expectation — Lambert receivers and
//!    sphere and disk lights of known irradiance, and glossy receivers against a fine
//!    midpoint quadrature of the BRDF over a sphere light's cap;
//! 2. the combined MIS + adaptive-allocation estimators are exactly unbiased by enumerating
//!    every branch of the allocator on tiny discrete problems;
//! 3. the lower level with a host BSDF (three colour channels) gives the one call's estimate;
//! 4. the light samplers honour their contract (sampled pmf = queried pmf > 0, pmfs sum to 1),
//!    the alias table's frequencies equal its pmfs, `LightTree::trace` finds what testing every
//!    light finds;
//! 5. bad input from the host is an error naming it, never a panic or a NaN.

mod common;

use common::{Rng, Stats};
use glam::Vec3;
use manylights::direct::{
    DirectError, EnergySampler, Estimator, LambertMode, LightSampler, Occluder, Params, Step,
    Technique, TreeSampler, UniformSampler, Uniforms, Unoccluded,
};
use manylights::internals::mis::{AdaptiveAllocator, CombinedWeights, SequentialWeights};
use manylights::internals::trace::trace_all;
use manylights::light_set::AliasTable;
use manylights::Heuristic;
use manylights::Rgb;
use manylights::{BlCutOptions, Brdf, Frame, Light, LightSet, Material, ShadingPoint};
use manylights_testkit::TestUniforms;

/// The one channel of an estimate of a grey scene (every channel must be the same, bit for
/// bit: grey inputs weigh and shade each channel as the scalar estimate was).
fn grey(v: [f64; 3]) -> f64 {
    assert!(
        v[0].to_bits() == v[1].to_bits() && v[1].to_bits() == v[2].to_bits(),
        "a grey scene's channels differ: {v:?}"
    );
    v[0]
}

/// What a TL sample contributes with the fixed weights: `g · w_TL / pdf_TL`.
fn tl_term(g: f32, w: CombinedWeights, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> f32 {
    let (w_tl, _) = w.weights(pdf_tl, pdf_bl, pdf_tb);
    g * w_tl / pdf_tl
}

/// A BRDF-aware sample's denominator `a pdf_BL + b pdf_TB`.
#[derive(Clone, Copy, Debug)]
struct Denominator {
    a: f32,
    b: f32,
}

/// What a BRDF-aware sample contributes with the fixed weights: `g · w_M / (a pdf_BL + b pdf_TB)`.
fn mixture_term(
    g: f32,
    w: CombinedWeights,
    pdf_tl: f32,
    pdf_bl: f32,
    pdf_tb: f32,
    den: Denominator,
) -> f32 {
    let (_, w_m) = w.weights(pdf_tl, pdf_bl, pdf_tb);
    g * w_m / (den.a * pdf_bl + den.b * pdf_tb)
}

// ---------------------------------------------------------------------------------------------
// 1. Unbiasedness against closed forms
// ---------------------------------------------------------------------------------------------

/// A sphere light entirely above the horizon of a Lambert receiver at the origin with normal
/// +z: `E = L π sin²σ cos ω`, reflected radiance `(ρ/π) E`.
fn sphere_exact(albedo: f32, c: Vec3, r: f32, l: f32) -> f64 {
    let d = f64::from(c.length());
    let sin2 = f64::from(r * r) / (d * d);
    f64::from(albedo) * f64::from(l) * sin2 * f64::from(c.z) / d
}

/// A one-sided disk facing the receiver on its axis at height h: `E = L π R²/(h² + R²)`.
fn disk_exact(albedo: f32, h: f32, r: f32, l: f32) -> f64 {
    f64::from(albedo) * f64::from(l) * f64::from(r * r) / f64::from(h * h + r * r)
}

/// Lights above a receiver at the origin (normal +z) whose Lambert integral is known.
fn lambert_scene() -> (Vec<Light>, f64) {
    let albedo = 0.8;
    let mut lights = Vec::new();
    let mut exact = 0.0;
    for (i, &(c, r, l)) in [
        (Vec3::new(1.0, 0.5, 2.0), 0.4f32, 3.0f32),
        (Vec3::new(-2.0, 1.0, 3.0), 0.3, 5.0),
        (Vec3::new(0.5, -3.0, 4.0), 0.8, 1.0),
        (Vec3::new(-0.3, -0.4, 1.2), 0.15, 20.0),
    ]
    .iter()
    .enumerate()
    {
        lights.push(Light::Sphere {
            center: c,
            radius: r,
            radiance: Rgb::grey(l),
        });
        exact += sphere_exact(albedo, c, r, l);
        if i == 1 {
            // A disk on the axis facing the receiver, and the same disk turned away (0).
            let (h, rd, ld) = (1.5f32, 0.7f32, 2.0f32);
            for normal in [-Vec3::Z, Vec3::Z] {
                lights.push(Light::Disk {
                    center: Vec3::new(0.0, 0.0, h),
                    normal,
                    radius: rd,
                    radiance: Rgb::grey(ld),
                    two_sided: false,
                });
            }
            exact += disk_exact(albedo, h, rd, ld);
        }
    }
    // A light below the horizon contributes nothing.
    lights.push(Light::Sphere {
        center: Vec3::new(0.0, 1.0, -2.0),
        radius: 0.5,
        radiance: Rgb::grey(4.0),
    });
    (lights, exact)
}

/// The reflected radiance at the origin (normal +z, view `wo`) from one sphere light for any
/// material, by the midpoint rule over the light's cap in (cos θ, φ) about its centre's
/// direction, in f64 (`n × n` cells).
fn sphere_quadrature(m: &Material, wo: Vec3, c: Vec3, r: f32, l: f32, n: usize) -> f64 {
    let d = f64::from(c.length());
    let w = glam::DVec3::new(f64::from(c.x), f64::from(c.y), f64::from(c.z)) / d;
    let cos_max = (1.0 - f64::from(r * r) / (d * d)).sqrt();
    let t = w.any_orthonormal_vector();
    let b = w.cross(t);
    let mut sum = 0.0;
    for i in 0..n {
        let ct = cos_max + (1.0 - cos_max) * (i as f64 + 0.5) / n as f64;
        let st = (1.0 - ct * ct).max(0.0).sqrt();
        for j in 0..n {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / n as f64;
            let dir = w * ct + (t * phi.cos() + b * phi.sin()) * st;
            if dir.z <= 0.0 {
                continue;
            }
            let wi = Vec3::new(dir.x as f32, dir.y as f32, dir.z as f32);
            sum += f64::from(m.eval(wo, wi)) * dir.z;
        }
    }
    let solid_angle = std::f64::consts::TAU * (1.0 - cos_max);
    sum * f64::from(l) * solid_angle / (n * n) as f64
}

/// Every technique (and `full` in every Lambert mode, and both heuristics) at `sp`: the mean of
/// `k` estimates (scaled by the technique's cost) within 5 standard errors of `exact`.
fn check_unbiased(set: &LightSet, sp: &ShadingPoint, exact: f64, k: usize, seed: u64) -> f64 {
    let base = Params::default();
    let mut cases: Vec<(Technique, Params)> = Technique::ALL.iter().map(|&t| (t, base)).collect();
    for lambert in LambertMode::ALL {
        cases.push((Technique::Full, Params { lambert, ..base }));
    }
    for t in [
        Technique::MisEqual,
        Technique::Full,
        Technique::TlMis,
        Technique::BlMis,
    ] {
        cases.push((
            t,
            Params {
                heuristic: Heuristic::Balance,
                ..base
            },
        ));
    }
    // `bl-mis` with other numbers of light samples (0 is clamped to 1), `full` and
    // `mis-equal` with the library's cut instead of the paper's.
    for k in [0, 1, 3, 7] {
        cases.push((
            Technique::BlMis,
            Params {
                bl_light_samples: k,
                ..base
            },
        ));
    }
    for t in [Technique::MisEqual, Technique::Full] {
        cases.push((
            t,
            Params {
                mixture_cut: BlCutOptions::default(),
                ..base
            },
        ));
    }
    let mut worst = 0.0f64;
    for (i, (t, p)) in cases.into_iter().enumerate() {
        let k = match t {
            Technique::Uniform | Technique::Energy => 4 * k,
            Technique::TlSplit | Technique::MisEqual | Technique::Full => k / 4,
            _ => k,
        };
        let mut est = Estimator::new(set, sp, t, &p).unwrap();
        let mut u = TestUniforms::new(seed + i as u64);
        let mut st = Stats::default();
        for _ in 0..k {
            let v = grey(est.estimate(&Unoccluded, &mut u).unwrap());
            assert!(v.is_finite() && v >= 0.0, "{t}: {v}");
            st.add(v);
        }
        let z = (st.mean() - exact) / st.se().max(1e-12 * exact);
        worst = worst.max(z.abs());
        assert!(
            z.abs() <= 5.0,
            "{t} ({p:?}) at {:?}: mean {} exact {exact} se {}: {z:.2} SE",
            sp.material,
            st.mean(),
            st.se()
        );
    }
    worst
}

#[test]
fn every_technique_is_unbiased_for_lambert_against_closed_forms() {
    let (lights, exact) = lambert_scene();
    let set = LightSet::build(lights).unwrap();
    let sp = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::new(0.3, 0.1, 1.0),
        material: Material::Lambert {
            albedo: Rgb::grey(0.8),
        },
    };
    let worst = check_unbiased(&set, &sp, exact, 40_000, 11);
    eprintln!("lambert: largest deviation {worst:.2} SE");
}

#[test]
fn every_technique_is_unbiased_for_glossy_materials_against_quadrature() {
    let (c, r, l) = (Vec3::new(0.6, 0.2, 1.5), 0.35f32, 4.0f32);
    let wo = Vec3::new(-0.5, -0.15, 0.85).normalize();
    let set = LightSet::build(vec![
        Light::Sphere {
            center: c,
            radius: r,
            radiance: Rgb::grey(l),
        },
        // Behind the receiver: never contributes, but the techniques see it.
        Light::Sphere {
            center: Vec3::new(0.0, 0.0, -2.0),
            radius: 0.3,
            radiance: Rgb::grey(1.0),
        },
    ])
    .unwrap();
    for (mi, material) in [
        Material::Ggx {
            alpha: 0.2,
            specular: 1.0,
        },
        Material::Ggx {
            alpha: 0.6,
            specular: 1.0,
        },
        Material::Plastic {
            albedo: Rgb::grey(0.5),
            specular: 0.5,
            alpha: 0.1,
        },
    ]
    .into_iter()
    .enumerate()
    {
        let exact = sphere_quadrature(&material, wo, c, r, l, 600);
        let sp = ShadingPoint {
            position: Vec3::ZERO,
            normal: Vec3::Z,
            wo,
            material,
        };
        let worst = check_unbiased(&set, &sp, exact, 40_000, 100 * mi as u64);
        eprintln!("{material:?}: exact {exact:.6}, largest deviation {worst:.2} SE");
    }
}

// ---------------------------------------------------------------------------------------------
// 2. Exact unbiasedness of the combined estimators by enumeration
// ---------------------------------------------------------------------------------------------

/// A tiny discrete problem: points y with values f(y) and the probabilities with which TL, BL
/// and TB produce them (TB's leftover mass is a miss).
struct Problem {
    f: Vec<f32>,
    p_tl: Vec<f32>,
    p_bl: Vec<f32>,
    p_tb: Vec<f32>,
}

impl Problem {
    fn random(rng: &mut Rng, m: usize) -> Problem {
        let norm = |rng: &mut Rng, zero_chance: f64, mass: f32| {
            let mut v: Vec<f32> = (0..m)
                .map(|_| {
                    if rng.chance(zero_chance) {
                        0.0
                    } else {
                        rng.range(0.05, 1.0)
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
        let hit_mass = rng.range(0.1, 0.9);
        let p_tb = norm(rng, 0.3, hit_mass);
        // f > 0 only where some technique can produce the point; a few zeros (lights that send
        // nothing towards x: TB hits them without counting a hit).
        let f = (0..m)
            .map(|i| {
                let covered = p_tl[i] > 0.0 || p_bl[i] > 0.0 || p_tb[i] > 0.0;
                if covered && !rng.chance(0.15) {
                    rng.range(0.1, 10.0)
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
    let mut rng = Rng::new(seed);
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
                    heuristic: Heuristic::Balance,
                };
                for heuristic in Heuristic::ALL {
                    let w = CombinedWeights { heuristic, ..w };
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
                        "full n={n} bl={bl} {heuristic:?}: {e} vs {}",
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
                for heuristic in Heuristic::ALL {
                    let sw = SequentialWeights::new(n, 1.0, heuristic);
                    let e = prob.sequential_expectation(sw, AdaptiveAllocator::new(bl), 0, &|p| p);
                    let rel = (e - prob.total()).abs() / prob.total();
                    assert!(
                        rel < 2e-5,
                        "n={n} bl={bl} {heuristic:?}: {e} vs {}",
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

// ---------------------------------------------------------------------------------------------
// 3. The lower level with a host BSDF
// ---------------------------------------------------------------------------------------------

/// A host's own Lambert BSDF in three colour channels (world space, its own sampling).
struct HostLambert {
    albedo: [f32; 3],
    frame: Frame,
}

impl HostLambert {
    fn cos(&self, d: Vec3) -> f32 {
        d.dot(self.frame.normal).max(0.0)
    }
    fn pdf(&self, d: Vec3) -> f32 {
        self.cos(d) / std::f32::consts::PI
    }
    /// Cosine-weighted, by Malley's method.
    fn sample(&self, u: [f32; 2]) -> (Vec3, f32) {
        let r = u[0].sqrt();
        let phi = std::f32::consts::TAU * u[1];
        let local = Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u[0]).max(0.0).sqrt());
        let d = self.frame.to_world(local).normalize();
        (d, self.pdf(d))
    }
}

/// One estimate through the lower level, per channel.
fn host_estimate(est: &mut Estimator, host: &HostLambert, u: &mut TestUniforms) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    est.start();
    loop {
        match est.next(u).unwrap() {
            Step::Done => return sum,
            Step::Light(d) => {
                let cos = host.cos(d.point.direction);
                if cos <= 0.0 || d.point.radiance.is_black() {
                    continue;
                }
                let w = est.weigh(&d, host.pdf(d.point.direction)).unwrap();
                let radiance = d.point.radiance.to_array();
                for (c, s) in sum.iter_mut().enumerate() {
                    let value = host.albedo[c] / std::f32::consts::PI * radiance[c] * cos;
                    *s += f64::from(w.contribution(value));
                }
            }
            Step::Bsdf(b) => {
                let (dir, pdf) = host.sample(b.u);
                let cos = host.cos(dir);
                est.bsdf_hits(
                    &b,
                    dir,
                    pdf,
                    |p| p.reached_before(f32::INFINITY),
                    |h| {
                        let radiance = h.point.radiance.to_array();
                        for (c, s) in sum.iter_mut().enumerate() {
                            let value = host.albedo[c] / std::f32::consts::PI * radiance[c] * cos;
                            *s += f64::from(h.weighted.contribution(value));
                        }
                    },
                )
                .unwrap();
            }
        }
    }
}

#[test]
fn lower_level_with_a_host_bsdf_is_unbiased_per_channel() {
    let (lights, exact) = lambert_scene();
    let set = LightSet::build(lights).unwrap();
    let albedo = [0.8f32, 0.4, 0.2];
    // The core's material stands in for the host's BSDF in the importance (albedo 0.8).
    let sp = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::new(0.3, 0.1, 1.0),
        material: Material::Lambert {
            albedo: Rgb::grey(0.8),
        },
    };
    let host = HostLambert {
        albedo,
        frame: Frame::from_normal(Vec3::Z).unwrap(),
    };
    for (ti, (t, lambert)) in [
        (Technique::TlMis, LambertMode::TlOnly),
        (Technique::BlMis, LambertMode::TlOnly),
        (Technique::Full, LambertMode::BlTb),
        (Technique::Full, LambertMode::TbBudget),
        (Technique::MisEqual, LambertMode::TlOnly),
        (Technique::TlSplit, LambertMode::TlOnly),
    ]
    .into_iter()
    .enumerate()
    {
        let p = Params {
            lambert,
            ..Params::default()
        };
        let mut est = Estimator::new(&set, &sp, t, &p).unwrap();
        let mut u = TestUniforms::new(500 + ti as u64);
        let mut st: [Stats; 3] = Default::default();
        let k = if matches!(t, Technique::TlMis | Technique::BlMis) {
            40_000
        } else {
            10_000
        };
        for _ in 0..k {
            let v = host_estimate(&mut est, &host, &mut u);
            for c in 0..3 {
                st[c].add(v[c]);
            }
        }
        for c in 0..3 {
            let want = exact * f64::from(albedo[c] / 0.8);
            let z = (st[c].mean() - want) / st[c].se();
            assert!(z.abs() <= 5.0, "{t} {lambert:?} channel {c}: {z:.2} SE");
        }
    }
}

/// With the core's own material, the lower level (driven by hand) gives the one call's
/// estimates bit for bit.
#[test]
fn one_call_is_the_lower_level_loop() {
    let (lights, _) = lambert_scene();
    let set = LightSet::build(lights).unwrap();
    let material = Material::Plastic {
        albedo: Rgb::grey(0.5),
        specular: 0.5,
        alpha: 0.1,
    };
    let sp = ShadingPoint {
        position: Vec3::new(0.01, 0.02, 0.0),
        normal: Vec3::Z,
        wo: Vec3::new(0.6, 0.1, 0.5).normalize(),
        material,
    };
    let frame = Frame::from_normal(sp.normal).unwrap();
    let wo = frame.to_local(sp.wo);
    for t in Technique::ALL {
        let mut a = Estimator::new(&set, &sp, t, &Params::default()).unwrap();
        let mut b = a.clone();
        let (mut ua, mut ub) = (TestUniforms::new(9), TestUniforms::new(9));
        for _ in 0..200 {
            let one = a.estimate(&Unoccluded, &mut ua).unwrap();
            let mut sum = [0.0f64; 3];
            b.start();
            loop {
                match b.next(&mut ub).unwrap() {
                    Step::Done => break,
                    Step::Light(d) => {
                        let wi = frame.to_local(d.point.direction);
                        let g = material.eval_rgb(wo, wi) * d.point.radiance * wi.z;
                        if wi.z <= 0.0 || g.max_channel() <= 0.0 {
                            continue;
                        }
                        let w = b.weigh(&d, material.pdf(wo, wi)).unwrap();
                        for (s, c) in sum.iter_mut().zip(g.to_array()) {
                            *s += f64::from(w.contribution(c));
                        }
                    }
                    Step::Bsdf(s) => {
                        let Some((wi, pdf)) = material.sample(wo, s.u) else {
                            continue;
                        };
                        let f = material.eval_rgb(wo, wi);
                        let mut v = [0.0f64; 3];
                        b.bsdf_hits(
                            &s,
                            frame.to_world(wi).normalize(),
                            pdf,
                            |p| p.reached_before(f32::INFINITY),
                            |h| {
                                let g = f * h.point.radiance * wi.z;
                                for (s, c) in v.iter_mut().zip(g.to_array()) {
                                    *s += f64::from(h.weighted.contribution(c));
                                }
                            },
                        )
                        .unwrap();
                        for c in 0..3 {
                            sum[c] += v[c];
                        }
                    }
                }
            }
            assert_eq!(one.map(f64::to_bits), sum.map(f64::to_bits), "{t}");
        }
    }
}

/// An occluder that blocks everything beyond `t_max` from the origin region.
struct Wall(f32);

impl Occluder for Wall {
    fn occluded(&self, _x: Vec3, _d: Vec3, t: f32) -> bool {
        t > self.0
    }
}

#[test]
fn occluded_lights_contribute_nothing() {
    let (lights, _) = lambert_scene();
    let set = LightSet::build(lights).unwrap();
    let sp = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::Z,
        material: Material::Ggx {
            alpha: 0.3,
            specular: 1.0,
        },
    };
    for t in Technique::ALL {
        let mut est = Estimator::new(&set, &sp, t, &Params::default()).unwrap();
        let mut u = TestUniforms::new(3);
        for _ in 0..500 {
            assert_eq!(est.estimate(&Wall(0.01), &mut u).unwrap(), [0.0; 3], "{t}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 4. Samplers, alias table, trace
// ---------------------------------------------------------------------------------------------

fn random_lights(seed: u64, n: usize) -> Vec<Light> {
    let mut rng = Rng::new(seed);
    let spec = common::SceneSpec::default();
    common::random_scene(&mut rng, n, &spec)
}

/// The contract of a [`LightSampler`]: every sample's pmf is positive and equals the queried
/// pmf; the pmfs sum to 1.
fn check_sampler(s: &impl LightSampler, n: u32, rng: &mut Rng, what: &str) {
    let sum: f64 = (0..n).map(|l| f64::from(s.pmf(l))).sum();
    let mut any = false;
    for _ in 0..2000 {
        if let Some(x) = s.sample(rng.f32()) {
            any = true;
            assert!(x.pmf > 0.0 && x.pmf.is_finite(), "{what}: {x:?}");
            assert_eq!(x.pmf, s.pmf(x.light), "{what}: light {}", x.light);
        }
    }
    if any {
        assert!((sum - 1.0).abs() < 1e-4, "{what}: pmfs sum to {sum}");
    }
    assert_eq!(s.pmf(n), 0.0, "{what}: out of range");
}

#[test]
fn samplers_honour_the_light_sampler_contract() {
    let lights = random_lights(5, 300);
    let n = lights.len() as u32;
    let set = LightSet::build(lights.clone()).unwrap();
    let mut rng = Rng::new(6);
    check_sampler(&UniformSampler::new(n), n, &mut rng, "uniform");
    check_sampler(&EnergySampler::new(&set), n, &mut rng, "energy");
    for _ in 0..20 {
        let x = common::random_shading_point(&mut rng, &lights, 5.0);
        let normal = common::random_normal(&mut rng);
        check_sampler(
            &TreeSampler::new(set.tree(), x, normal),
            n,
            &mut rng,
            "tree",
        );
        let sp = ShadingPoint {
            position: x,
            normal,
            wo: (normal + rng.unit() * 0.5).normalize(),
            material: Material::Ggx {
                alpha: 0.2,
                specular: 1.0,
            },
        };
        if let Ok(s) = manylights::direct::CutSampler::new(set.tree(), &sp, &Default::default()) {
            check_sampler(&s, n, &mut rng, "cut");
        }
    }
}

#[test]
fn alias_table_frequencies_are_its_pmfs() {
    let weights = [3.0, 0.0, 1.0, 1e-3, 7.5, 0.0, 2.0, f64::NAN, -1.0, 0.25];
    let table = AliasTable::new(weights);
    let total: f64 = weights.iter().filter(|w| **w > 0.0).sum();
    // A dense grid of u: each entry's frequency is its probability to within 2 cells per slot.
    let m = 1_000_000usize;
    let mut count = vec![0usize; weights.len()];
    for k in 0..m {
        let (i, pmf) = table.sample((k as f64 + 0.5) / m as f64).unwrap();
        assert!(pmf > 0.0);
        assert_eq!(pmf, table.pmf(i));
        count[i as usize] += 1;
    }
    for (i, &w) in weights.iter().enumerate() {
        let p = if w > 0.0 { w / total } else { 0.0 };
        assert_eq!(f64::from(table.pmf(i as u32)), (p as f32) as f64);
        let freq = count[i] as f64 / m as f64;
        let tol = 2.0 * weights.len() as f64 / m as f64;
        assert!((freq - p).abs() <= tol, "entry {i}: {freq} vs {p}");
    }
    assert!(AliasTable::new([0.0, 0.0]).sample(0.5).is_none());
    assert!(AliasTable::new([]).sample(0.5).is_none());
}

#[test]
fn trace_finds_what_testing_every_light_finds() {
    let lights = random_lights(8, 400);
    let set = LightSet::build(lights.clone()).unwrap();
    let mut rng = Rng::new(2);
    let mut hits = 0;
    for _ in 0..3000 {
        let x = common::random_shading_point(&mut rng, &lights, 5.0);
        let d = rng.unit();
        let mut walked = Vec::new();
        set.trace(x, d, |l, lp| walked.push((l, *lp)));
        let mut brute = Vec::new();
        trace_all(&lights, x, d, |l, lp| brute.push((l, *lp)));
        // Lights without energy are in no cluster's bounds: only emitting points must agree.
        walked.retain(|h| !h.1.radiance.is_black());
        brute.retain(|h| !h.1.radiance.is_black());
        walked.sort_by_key(|h| h.0);
        brute.sort_by_key(|h| h.0);
        assert_eq!(walked, brute);
        hits += brute.len();
    }
    assert!(hits > 50, "{hits} hits");
}

// ---------------------------------------------------------------------------------------------
// 5. Bad input
// ---------------------------------------------------------------------------------------------

/// Uniform numbers that are all `v`.
struct Constant(f32, f64);

impl Uniforms for Constant {
    fn next_f32(&mut self) -> f32 {
        self.0
    }
    fn next_f64(&mut self) -> f64 {
        self.1
    }
}

#[test]
fn bad_input_is_an_error_naming_it() {
    let (lights, _) = lambert_scene();
    let set = LightSet::build(lights).unwrap();
    let good = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::Z,
        material: Material::Ggx {
            alpha: 0.3,
            specular: 1.0,
        },
    };
    for bad in [
        ShadingPoint {
            position: Vec3::new(f32::NAN, 0.0, 0.0),
            ..good
        },
        ShadingPoint {
            normal: Vec3::ZERO,
            ..good
        },
        ShadingPoint {
            wo: Vec3::splat(f32::INFINITY),
            ..good
        },
        ShadingPoint {
            material: Material::Ggx {
                alpha: -1.0,
                specular: 1.0,
            },
            ..good
        },
    ] {
        for t in Technique::ALL {
            let e = Estimator::new(&set, &bad, t, &Params::default()).unwrap_err();
            assert!(matches!(e, DirectError::Shading(_)), "{t}: {e:?}");
            assert!(e.to_string().starts_with("shading point: field `"), "{e}");
        }
    }
    for t in Technique::ALL {
        let mut est = Estimator::new(&set, &good, t, &Params::default()).unwrap();
        for (f, d) in [
            (f32::NAN, 0.5),
            (1.0, 0.5),
            (-0.1, 0.5),
            (0.5, 1.0),
            (0.5, f64::NAN),
        ] {
            match est.estimate(&Unoccluded, &mut Constant(f, d)) {
                Err(DirectError::Uniform { .. }) => {}
                Ok(v) => assert!(v.iter().all(|c| c.is_finite() && *c >= 0.0), "{t}: {v:?}"),
                Err(e) => panic!("{t}: {e}"),
            }
        }
        // A technique that draws f32s refuses a bad one.
        if !matches!(t, Technique::Uniform | Technique::Energy) {
            let e = est
                .estimate(&Unoccluded, &mut Constant(1.5, 0.5))
                .unwrap_err();
            assert!(e.to_string().contains("[0, 1)"), "{e}");
        } else {
            assert!(est.estimate(&Unoccluded, &mut Constant(0.5, 2.0)).is_err());
        }
    }
    // The lower level: a bad pdf, direction or hit distance from the host.
    let mut est = Estimator::new(&set, &good, Technique::TlMis, &Params::default()).unwrap();
    let mut u = TestUniforms::new(1);
    est.start();
    let mut saw_light = false;
    loop {
        match est.next(&mut u).unwrap() {
            Step::Done => break,
            Step::Light(d) => {
                saw_light = true;
                for pdf in [f32::NAN, -1.0, f32::INFINITY] {
                    let e = est.weigh(&d, pdf).unwrap_err();
                    assert!(e.to_string().starts_with("bsdf_pdf"), "{e}");
                }
            }
            Step::Bsdf(b) => {
                let cases = [
                    (Vec3::ZERO, 1.0, "direction"),
                    (Vec3::new(f32::NAN, 0.0, 1.0), 1.0, "direction"),
                    (Vec3::Z, f32::NAN, "bsdf_pdf"),
                    (Vec3::Z, -1.0, "bsdf_pdf"),
                ];
                for (d, pdf, what) in cases {
                    let e = est.bsdf_hits(&b, d, pdf, |_| true, |_| {}).unwrap_err();
                    assert!(e.to_string().starts_with(what), "{e}");
                }
                // A blocked ray reaches nothing (a NaN distance neither); a free one is
                // weighted in [0, 1].
                for t in [0.0, f32::NAN] {
                    let reached = est.bsdf_hits(&b, Vec3::Z, 1.0, |p| p.reached_before(t), |_| {});
                    assert!(!reached.unwrap());
                }
                let free = |p: &manylights::LightPoint| p.reached_before(f32::INFINITY);
                est.bsdf_hits(&b, Vec3::new(0.0, 0.0, 3.0), 1.0, free, |h| {
                    assert!((0.0..=1.0).contains(&h.weighted.weight()));
                })
                .unwrap();
            }
        }
    }
    assert!(saw_light);
}

/// A random material of each kind (Lambert, GGX and plastic, rough and sharp).
fn random_material(rng: &mut Rng) -> Material {
    let alpha = [0.03f32, 0.1, 0.3, 0.8][rng.below(4)];
    match rng.below(3) {
        0 => Material::Lambert {
            albedo: Rgb::new(0.2, 0.5, 0.7),
        },
        1 => Material::Ggx {
            alpha,
            specular: 0.9,
        },
        _ => Material::Plastic {
            albedo: Rgb::grey(0.4),
            specular: 0.5,
            alpha,
        },
    }
}

/// `Estimator::reset` is `Estimator::new` at the new point, in place: moved through a chain
/// of shading points (and refused an invalid one on the way), an estimator gives bit for bit
/// the estimates, cuts and budgets of new estimators made at each point, for every technique,
/// with and without a light at infinity.
#[test]
fn reset_is_a_new_estimator_in_place() {
    let mut rng = Rng::new(41);
    let spec = common::SceneSpec::default();
    for with_sun in [false, true] {
        let mut lights = random_lights(17, 150);
        if with_sun {
            lights.push(Light::Distant {
                direction: Vec3::new(0.3, 0.2, 1.0),
                angular_radius: 0.01,
                irradiance: Rgb::new(3.0, 2.5, 2.0),
            });
        }
        let set = LightSet::build(lights.clone()).unwrap();
        let points: Vec<ShadingPoint> = (0..40)
            .map(|_| ShadingPoint {
                position: common::random_shading_point(&mut rng, &lights, spec.half),
                normal: rng.unit(),
                wo: rng.unit(),
                material: random_material(&mut rng),
            })
            .collect();
        let bad = ShadingPoint {
            normal: Vec3::ZERO,
            ..points[0]
        };
        for t in Technique::ALL {
            let params = Params::default();
            let mut moved = Estimator::new(&set, &points[0], t, &params).unwrap();
            for (i, sp) in points.iter().enumerate() {
                if i % 7 == 3 {
                    // Refused: the error `new` gives, and the estimator stays where it was.
                    let want = Estimator::new(&set, &bad, t, &params).err();
                    assert_eq!(moved.reset(&bad).err(), want, "{t}");
                    assert!(want.is_some());
                    let prev = &points[i.saturating_sub(1)];
                    let mut fresh = Estimator::new(&set, prev, t, &params).unwrap();
                    let (mut ua, mut ub) =
                        (TestUniforms::new(i as u64), TestUniforms::new(i as u64));
                    for _ in 0..3 {
                        let a = moved.estimate(&Unoccluded, &mut ua).unwrap();
                        let b = fresh.estimate(&Unoccluded, &mut ub).unwrap();
                        assert_eq!(
                            a.map(f64::to_bits),
                            b.map(f64::to_bits),
                            "{t} after refusal"
                        );
                    }
                }
                moved.reset(sp).unwrap();
                let mut fresh = Estimator::new(&set, sp, t, &params).unwrap();
                assert_eq!(moved.budget(), fresh.budget(), "{t} at {i}");
                assert_eq!(moved.ib().to_bits(), fresh.ib().to_bits(), "{t} at {i}");
                assert_eq!(moved.split_cut().clusters(), fresh.split_cut().clusters());
                assert_eq!(
                    moved.cut_sampler().map(|c| c.cut().clusters().to_vec()),
                    fresh.cut_sampler().map(|c| c.cut().clusters().to_vec()),
                    "{t} at {i}"
                );
                let (mut ua, mut ub) = (
                    TestUniforms::new(100 + i as u64),
                    TestUniforms::new(100 + i as u64),
                );
                for _ in 0..8 {
                    let a = moved.estimate(&Unoccluded, &mut ua).unwrap();
                    let b = fresh.estimate(&Unoccluded, &mut ub).unwrap();
                    assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "{t} at {i}");
                }
            }
        }
    }
}

/// `Estimator::reuse` gives what `new` gives: from an empty slot, from one of the same
/// technique (moved in place) and from one of another technique (replaced); an invalid point
/// leaves the slot as it was.
#[test]
fn reuse_is_new_from_any_slot() {
    let set = LightSet::build(random_lights(23, 80)).unwrap();
    let sp = |x: f32| ShadingPoint {
        position: Vec3::new(x, 0.1, 0.0),
        normal: Vec3::Z,
        wo: Vec3::new(0.3, 0.2, 0.9),
        material: Material::Plastic {
            albedo: Rgb::grey(0.5),
            specular: 0.5,
            alpha: 0.1,
        },
    };
    let params = Params::default();
    let mut slot = None;
    // Each technique at two points in a row: replaced, then moved in place.
    for (i, t) in (0..30).map(|i| (i, Technique::ALL[(i / 2) % Technique::ALL.len()])) {
        let at = sp(i as f32 * 0.1);
        let bad = ShadingPoint {
            wo: Vec3::ZERO,
            ..at
        };
        let before = slot.as_ref().map(|e: &Estimator| e.technique());
        assert!(Estimator::reuse(&mut slot, &set, &bad, t, &params).is_err());
        assert_eq!(slot.as_ref().map(|e| e.technique()), before);
        let a = Estimator::reuse(&mut slot, &set, &at, t, &params).unwrap();
        let mut b = Estimator::new(&set, &at, t, &params).unwrap();
        let (mut ua, mut ub) = (TestUniforms::new(i as u64), TestUniforms::new(i as u64));
        for _ in 0..4 {
            let x = a.estimate(&Unoccluded, &mut ua).unwrap();
            let y = b.estimate(&Unoccluded, &mut ub).unwrap();
            assert_eq!(x.map(f64::to_bits), y.map(f64::to_bits), "{t} at {i}");
        }
    }
}
