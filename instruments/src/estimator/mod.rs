//! `mlmeasure estimator`: are the estimators unbiased, and what do they cost at equal time?
//!
//! Direct illumination **without visibility** on synthetic configurations ([`scene`]): 1,000
//! small sphere and disk lights around 64 shading points, materials Lambert, GGX α ∈ {0.05,
//! 0.2, 0.6} and plastic (by default point i gets material i mod 5: 64 configurations). The
//! exact value of each configuration comes from an independent computation ([`mod@reference`]:
//! every light integrated on its own, own samplers, to a relative standard error below 1e-3,
//! the total to below 1e-4). Each technique of [`manylights::direct`] then produces K independent
//! estimates per configuration (default 100,000). The full run takes about 5 minutes of two
//! cores (10 minutes when the machine is shared); `--quick` (10 configurations, 4,000
//! estimates) a few seconds.
//!
//! Per technique and configuration:
//! - `mean`, the per-estimate variance `var` (unbiased sample variance), the standard error
//!   `se = sqrt(var/K)`;
//! - `bias_sigma = (mean − exact) / sqrt(se² + se_ref²)`, with `se_ref` the reference's
//!   standard error (it is included so that a reference error is not reported as a bias; it is
//!   typically 1–2 orders of magnitude below `se`);
//! - `time`: nanoseconds per estimate **including the per-shading-point set-up** (importances,
//!   cuts: a renderer builds them at every shading point), measured single-threaded in a
//!   separate pass after the statistics (which run in parallel over configurations and
//!   techniques, with the set-up built once). Each technique runs for at least `time_ms` per
//!   round, rounds interleave the techniques, and the fastest of 3 rounds is kept.
//! - `max_share`: the largest single estimate over the sum of all estimates (a heavy-tail
//!   diagnostic: when it is large the sample variance, hence `se`, is unreliable).
//!
//! `max_bias_sigma` is the largest |bias_sigma| over all `bias_pairs` (configuration,
//! technique) pairs. With hundreds of pairs a large maximum comes by chance, so it is reported
//! against its null distribution — every technique unbiased and every z an independent
//! N(0, 1), whose maximum of K absolute values has `P(max ≤ z) = (2Φ(z) − 1)^K`
//! ([`max_abs_normal_cdf`]): the observed maximum's quantile under it
//! (`max_bias_sigma_null_quantile`; above 0.99 is evidence of a bias or of an underestimated
//! standard error), the null maximum's median, 95 % and 99 % quantiles, the probability that
//! it stays ≤ 4, the rms of all z's (1 under the null) and the count above 3 against its
//! expectation. (The techniques of a configuration share its reference, so their z's are
//! correlated through `se_ref`; it is small against `se`, and the null ignores it.)
//!
//! Equal-time variance ratio of technique A against `tl-split` at a configuration:
//! `(var·time)_A / (var·time)_tl-split`. `var_ratio_full_vs_tl_glossy` is its **geometric
//! mean** over the GGX α ≤ 0.2 configurations, `var_ratio_full_vs_tl_diffuse` over the
//! Lambert ones; arithmetic means and medians are reported next to them.
//!
//! What "equal time" means here: there is no visibility, so a light sample costs no shadow
//! ray while a TB sample's ray is traced against the lights' bounding spheres. In a renderer
//! both pay for a ray, which favours the BRDF-aware techniques more than this instrument does.

pub mod reference;
pub mod scene;

use manylights::direct::{Estimator, LambertMode, Params, Technique, Unoccluded};
use manylights_render::uniforms::RngUniforms;
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use reference::Reference;
use scene::{Config, Plan, Scene, MATERIALS};
use serde_json::{json, Map, Value};
use std::hint::black_box;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

/// What to run.
#[derive(Clone, Copy, Debug)]
pub struct EstimatorConfig {
    /// Seed of the scene, the reference and the estimates.
    pub seed: u64,
    /// Estimates per technique and configuration.
    pub estimates: usize,
    /// Number of lights.
    pub lights: usize,
    /// Number of shading points.
    pub points: usize,
    /// How points and materials are combined.
    pub plan: Plan,
    /// Relative standard error each light's reference integral must reach.
    pub ref_target: f64,
    /// Relative standard error the reference's total must reach.
    pub ref_total_target: f64,
    /// Minimum duration of one timing round per technique and configuration.
    pub time_ms: f64,
    /// Cut and budget parameters.
    pub params: Params,
}

impl EstimatorConfig {
    /// The full run: 1,000 lights, 64 points cycling through the materials, 100,000 estimates.
    pub fn full(seed: u64) -> EstimatorConfig {
        EstimatorConfig {
            seed,
            estimates: 100_000,
            lights: 1000,
            points: 64,
            plan: Plan::Cycle,
            ref_target: 1e-3,
            ref_total_target: 1e-4,
            time_ms: 5.0,
            params: Params::default(),
        }
    }

    /// The smoke run of `--quick`: 10 points (two per material), 4,000 estimates.
    pub fn quick(seed: u64) -> EstimatorConfig {
        EstimatorConfig {
            estimates: 4000,
            points: 10,
            time_ms: 2.0,
            ..EstimatorConfig::full(seed)
        }
    }
}

/// One technique at one configuration.
#[derive(Clone, Copy, Debug, Default)]
pub struct TechResult {
    /// Mean of the estimates.
    pub mean: f64,
    /// Per-estimate variance.
    pub var: f64,
    /// Standard error of the mean.
    pub se: f64,
    /// `(mean − exact) / sqrt(se² + se_ref²)`.
    pub bias_sigma: f64,
    /// Nanoseconds per estimate, single-threaded, set-up included.
    pub time_ns: f64,
    /// Largest estimate over the sum of the estimates.
    pub max_share: f64,
}

/// One configuration's results.
#[derive(Clone, Debug)]
pub struct ConfigResult {
    /// The configuration.
    pub config: Config,
    /// Its exact value.
    pub reference: Reference,
    /// Split cut size.
    pub split_len: usize,
    /// BL cut size.
    pub bl_cut_len: usize,
    /// IB(x).
    pub ib: f32,
    /// The BRDF-aware budget N.
    pub n_mix: u32,
    /// Per technique, in [`Technique::ALL`] order.
    pub results: [TechResult; Technique::ALL.len()],
    /// At Lambert points (when `full` runs with another [`LambertMode`]): `full` with
    /// [`LambertMode::TbOne`] (TL split + one BRDF sample), for comparison.
    pub full_tb_one: Option<TechResult>,
}

impl ConfigResult {
    /// The result of `t`.
    pub fn get(&self, t: Technique) -> &TechResult {
        &self.results[Technique::ALL.iter().position(|&x| x == t).unwrap()]
    }

    /// `(var·time)_t / (var·time)_tl-split`.
    pub fn equal_time_ratio(&self, t: Technique) -> f64 {
        let a = self.get(t);
        let b = self.get(Technique::TlSplit);
        (a.var * a.time_ns) / (b.var * b.time_ns)
    }
}

/// Running mean and variance (Welford), plus the largest value.
#[derive(Clone, Copy, Debug, Default)]
struct Moments {
    n: u64,
    mean: f64,
    m2: f64,
    sum: f64,
    max: f64,
}

impl Moments {
    fn push(&mut self, x: f64) {
        self.n += 1;
        let d = x - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (x - self.mean);
        self.sum += x;
        self.max = self.max.max(x.abs());
    }

    fn var(&self) -> f64 {
        if self.n > 1 {
            self.m2 / (self.n - 1) as f64
        } else {
            0.0
        }
    }
}

/// A stream of the estimates of technique `t` at configuration `c`, independent of the others.
fn rng_for(seed: u64, config: usize, t: usize, stream: u64) -> Pcg64Mcg {
    let s = seed
        .wrapping_mul(0x9e37_79b9_7f4a_7c15)
        .wrapping_add((config as u64) << 20)
        .wrapping_add((t as u64) << 8)
        .wrapping_add(stream);
    Pcg64Mcg::seed_from_u64(s)
}

/// The bias z of a mean with standard error `se` against an exact value that has its own
/// standard error `se_ref`: `(mean − exact)/sqrt(se² + se_ref²)`; 0 when both errors are 0
/// and the values agree, ±∞ when they are 0 and the values differ.
pub fn bias_sigma(mean: f64, se: f64, exact: f64, se_ref: f64) -> f64 {
    let s = (se * se + se_ref * se_ref).sqrt();
    let d = mean - exact;
    if s > 0.0 {
        d / s
    } else if d == 0.0 {
        0.0
    } else {
        f64::INFINITY.copysign(d)
    }
}

/// `P(|Z| ≤ z)` for a standard normal `Z`: `2Φ(z) − 1 = 1 − erfc(z/√2)` (0 for `z ≤ 0`).
fn abs_normal_cdf(z: f64) -> f64 {
    if z > 0.0 {
        1.0 - libm::erfc(z / std::f64::consts::SQRT_2)
    } else {
        0.0
    }
}

/// `P(max of k independent |N(0,1)| ≤ z) = (2Φ(z) − 1)^k`: where the largest of `k` bias z's
/// falls in its distribution when every technique is unbiased and every standard error
/// right (computed as `exp(k · ln(1 − erfc(z/√2)))`, which keeps its precision in the tail).
pub fn max_abs_normal_cdf(z: f64, k: usize) -> f64 {
    if z.is_nan() {
        return f64::NAN;
    }
    if z <= 0.0 {
        return if k == 0 { 1.0 } else { 0.0 };
    }
    (k as f64 * (-libm::erfc(z / std::f64::consts::SQRT_2)).ln_1p()).exp()
}

/// `1 −` [`max_abs_normal_cdf`]`(z, k)`, the probability that the largest of `k`
/// independent `|N(0,1)|` exceeds `z` (computed as `−expm1(k · ln(1 − erfc(z/√2)))`, exact
/// far in the tail).
pub fn max_abs_normal_sf(z: f64, k: usize) -> f64 {
    if z.is_nan() {
        return f64::NAN;
    }
    if z <= 0.0 {
        return if k == 0 { 0.0 } else { 1.0 };
    }
    -(k as f64 * (-libm::erfc(z / std::f64::consts::SQRT_2)).ln_1p()).exp_m1()
}

/// The `p` quantile of the largest of `k` independent `|N(0,1)|`: the z with
/// [`max_abs_normal_cdf`]`(z, k) = p` (by bisection, to 1e-9; NaN unless 0 < p < 1 and
/// k ≥ 1).
pub fn max_abs_normal_quantile(p: f64, k: usize) -> f64 {
    if !(p > 0.0 && p < 1.0) || k == 0 {
        return f64::NAN;
    }
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    while hi - lo > 1e-9 {
        let mid = 0.5 * (lo + hi);
        if max_abs_normal_cdf(mid, k) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The largest bias z among `k` pairs against its null distribution (every technique
/// unbiased, every z an independent N(0, 1)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaxBias {
    /// The largest |z|.
    pub max: f64,
    /// The number of (configuration, technique) pairs it is the largest of.
    pub pairs: usize,
    /// `P(max of pairs |N(0,1)| ≤ max)`: its quantile under the null.
    pub null_quantile: f64,
    /// `P(max of pairs |N(0,1)| ≥ max)`: its p-value under the null.
    pub null_p_value: f64,
    /// The median and the 95 % and 99 % quantiles of the null's maximum.
    pub null_median: f64,
    /// See `null_median`.
    pub null_p95: f64,
    /// See `null_median`.
    pub null_p99: f64,
    /// `P(max of pairs |N(0,1)| ≤ 4)`: how often a 4 σ limit holds by chance alone.
    pub null_below_4: f64,
    /// The root mean square of the z's (1 under the null).
    pub rms: f64,
    /// How many |z| exceed 3, and how many the null expects (`pairs · P(|Z| > 3)`).
    pub above_3: usize,
    /// See `above_3`.
    pub above_3_expected: f64,
}

impl MaxBias {
    /// The summary of the bias z's `z` (NaN-free; infinite z's count as the largest).
    pub fn of(z: &[f64]) -> MaxBias {
        let k = z.len();
        let max = z.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        MaxBias {
            max,
            pairs: k,
            null_quantile: max_abs_normal_cdf(max, k),
            null_p_value: max_abs_normal_sf(max, k),
            null_median: max_abs_normal_quantile(0.5, k),
            null_p95: max_abs_normal_quantile(0.95, k),
            null_p99: max_abs_normal_quantile(0.99, k),
            null_below_4: max_abs_normal_cdf(4.0, k),
            rms: (z.iter().map(|x| x * x).sum::<f64>() / k.max(1) as f64).sqrt(),
            above_3: z.iter().filter(|x| x.abs() > 3.0).count(),
            above_3_expected: k as f64 * (1.0 - abs_normal_cdf(3.0)),
        }
    }
}

/// Geometric mean, arithmetic mean and median of positive values (NaN when empty).
fn summarise(v: &[f64]) -> (f64, f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let n = v.len() as f64;
    let geo = (v.iter().map(|x| x.ln()).sum::<f64>() / n).exp();
    let mean = v.iter().sum::<f64>() / n;
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let med = if s.len() % 2 == 1 {
        s[s.len() / 2]
    } else {
        0.5 * (s[s.len() / 2 - 1] + s[s.len() / 2])
    };
    (geo, mean, med)
}

fn progress(label: &str, done: &AtomicUsize, total: usize) {
    let d = done.fetch_add(1, Ordering::Relaxed) + 1;
    let step = (total / 10).max(1);
    if d % step == 0 || d == total {
        eprintln!("  {label}: {d}/{total}");
    }
}

/// Runs the instrument; returns the per-configuration results and the JSON report.
pub fn run(cfg: &EstimatorConfig) -> (Vec<ConfigResult>, Value) {
    let start = Instant::now();
    let scene = Scene::new(cfg.lights, cfg.points, cfg.plan, cfg.seed);
    let n_cfg = scene.configs.len();
    eprintln!(
        "estimator: {} lights, {} configurations, {} estimates per technique",
        cfg.lights, n_cfg, cfg.estimates
    );

    // 1. The exact values.
    let t_ref = Instant::now();
    let done = AtomicUsize::new(0);
    let refs: Vec<Reference> = scene
        .configs
        .par_iter()
        .enumerate()
        .map(|(i, c)| {
            let r = reference::reference(
                &scene,
                &c.sp,
                cfg.ref_target,
                cfg.ref_total_target,
                cfg.seed ^ (0xfeed_0000 + i as u64),
            );
            progress("reference", &done, n_cfg);
            r
        })
        .collect();
    let ref_s = t_ref.elapsed().as_secs_f64();

    // The jobs: every (configuration, technique) pair, slot = index in Technique::ALL; and,
    // unless `full` already runs that way, `full` with one TB sample at the Lambert points
    // (slot EXTRA), reported next to the main figures.
    const EXTRA: usize = Technique::ALL.len();
    let tb_one = Params {
        lambert: LambertMode::TbOne,
        ..cfg.params
    };
    let with_extra = cfg.params.lambert != LambertMode::TbOne;
    let mut jobs: Vec<(usize, usize)> = Vec::new();
    for ci in 0..n_cfg {
        for ti in 0..Technique::ALL.len() {
            jobs.push((ci, ti));
        }
        if with_extra && scene.configs[ci].is_diffuse() {
            jobs.push((ci, EXTRA));
        }
    }
    let job_of = |ti: usize| -> (Technique, &Params) {
        if ti == EXTRA {
            (Technique::Full, &tb_one)
        } else {
            (Technique::ALL[ti], &cfg.params)
        }
    };

    // 2. The estimates, all jobs in parallel.
    let t_stats = Instant::now();
    let done = AtomicUsize::new(0);
    let stats: Vec<Moments> = jobs
        .par_iter()
        .map(|&(ci, ti)| {
            let (t, params) = job_of(ti);
            let mut est = Estimator::new(&scene.set, &scene.configs[ci].sp, t, params)
                .expect("valid shading point");
            let mut rng = rng_for(cfg.seed, ci, ti, 0);
            let mut m = Moments::default();
            for _ in 0..cfg.estimates {
                let v = est.estimate(&Unoccluded, &mut RngUniforms(&mut rng));
                // The scene is grey: every channel is the same estimate.
                m.push(v.expect("uniform numbers in [0, 1)")[0]);
            }
            progress("estimates", &done, jobs.len());
            m
        })
        .collect();
    let stats_s = t_stats.elapsed().as_secs_f64();

    // 3. Time per estimate, single-threaded, set-up included: per configuration, 3 rounds
    // over its jobs; the fastest round is kept. As a renderer sets up at every new shading
    // point: one estimator per round, set up again (`reset`) before every estimate.
    let t_time = Instant::now();
    let min_round = Duration::from_secs_f64(cfg.time_ms * 1e-3);
    let mut times = vec![f64::INFINITY; jobs.len()];
    let mut first = 0;
    while first < jobs.len() {
        let ci = jobs[first].0;
        let last = first + jobs[first..].iter().take_while(|j| j.0 == ci).count();
        let sp = &scene.configs[ci].sp;
        for round in 0..3 {
            for (slot, &(_, ti)) in times[first..last].iter_mut().zip(&jobs[first..last]) {
                let (t, params) = job_of(ti);
                let mut rng = rng_for(cfg.seed, ci, ti, 1 + round);
                let t0 = Instant::now();
                let mut count = 0u64;
                let mut acc = 0.0f64;
                let mut est = Estimator::new(&scene.set, black_box(sp), t, params)
                    .expect("valid shading point");
                loop {
                    est.reset(black_box(sp)).expect("valid shading point");
                    let v = est.estimate(&Unoccluded, &mut RngUniforms(&mut rng));
                    acc += v.expect("uniform numbers in [0, 1)")[0];
                    count += 1;
                    if count % 4 == 0 && t0.elapsed() >= min_round {
                        break;
                    }
                }
                black_box(acc);
                *slot = slot.min(t0.elapsed().as_secs_f64() * 1e9 / count as f64);
            }
        }
        first = last;
    }
    let time_s = t_time.elapsed().as_secs_f64();

    // 4. Assemble.
    let result_of = |job: usize, r: &Reference| -> TechResult {
        let m = &stats[job];
        let var = m.var();
        let se = (var / m.n as f64).sqrt();
        TechResult {
            mean: m.mean,
            var,
            se,
            bias_sigma: bias_sigma(m.mean, se, r.value, r.std_err),
            time_ns: times[job],
            max_share: if m.sum > 0.0 { m.max / m.sum } else { 0.0 },
        }
    };
    let results: Vec<ConfigResult> = scene
        .configs
        .iter()
        .enumerate()
        .map(|(ci, c)| {
            let r = refs[ci];
            let setup = Estimator::new(&scene.set, &c.sp, Technique::Full, &cfg.params)
                .expect("valid shading point");
            let mut results = [TechResult::default(); Technique::ALL.len()];
            let mut full_tb_one = None;
            for (job, &(_, ti)) in jobs.iter().enumerate().filter(|(_, j)| j.0 == ci) {
                if ti == EXTRA {
                    full_tb_one = Some(result_of(job, &r));
                } else {
                    results[ti] = result_of(job, &r);
                }
            }
            ConfigResult {
                config: *c,
                reference: r,
                split_len: setup.split_cut().len(),
                bl_cut_len: setup.cut_sampler().map_or(0, |b| b.cut().len()),
                ib: setup.ib(),
                n_mix: setup.budget(),
                results,
                full_tb_one,
            }
        })
        .collect();
    let report = report(cfg, &results, ref_s, stats_s, time_s, start.elapsed());
    (results, report)
}

/// Equal-time ratios of `t` against tl-split over the configurations selected by `pick`.
fn ratios(rs: &[ConfigResult], t: Technique, pick: impl Fn(&ConfigResult) -> bool) -> Vec<f64> {
    rs.iter()
        .filter(|r| pick(r))
        .map(|r| r.equal_time_ratio(t))
        .collect()
}

fn report(
    cfg: &EstimatorConfig,
    rs: &[ConfigResult],
    ref_s: f64,
    stats_s: f64,
    time_s: f64,
    total: Duration,
) -> Value {
    let all_z: Vec<f64> = rs
        .iter()
        .flat_map(|r| r.results.iter().map(|t| t.bias_sigma))
        .collect();
    let mb = MaxBias::of(&all_z);
    let max_bias = mb.max;
    let max_at = rs
        .iter()
        .enumerate()
        .flat_map(|(ci, r)| {
            r.results
                .iter()
                .enumerate()
                .map(move |(ti, t)| (t.bias_sigma.abs(), ci, ti))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map_or(Value::Null, |(_, ci, ti)| {
            json!({
                "config": ci,
                "point": rs[ci].config.point,
                "material": rs[ci].config.material_name(),
                "technique": Technique::ALL[ti].name(),
                "bias_sigma": rs[ci].results[ti].bias_sigma,
            })
        });
    let json_num = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    let glossy = |r: &ConfigResult| r.config.is_glossy();
    let diffuse = |r: &ConfigResult| r.config.is_diffuse();
    let (g_geo, g_mean, g_med) = summarise(&ratios(rs, Technique::Full, glossy));
    let (d_geo, d_mean, d_med) = summarise(&ratios(rs, Technique::Full, diffuse));

    let mut per_tech = Map::new();
    for (ti, &t) in Technique::ALL.iter().enumerate() {
        let b: Vec<f64> = rs.iter().map(|r| r.results[ti].bias_sigma).collect();
        let max_abs = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mean_abs = b.iter().map(|x| x.abs()).sum::<f64>() / b.len().max(1) as f64;
        let above3 = b.iter().filter(|x| x.abs() > 3.0).count();
        let rms = (b.iter().map(|x| x * x).sum::<f64>() / b.len().max(1) as f64).sqrt();
        let mean_signed = b.iter().sum::<f64>() / b.len().max(1) as f64;
        let time_us =
            rs.iter().map(|r| r.results[ti].time_ns).sum::<f64>() / rs.len().max(1) as f64 * 1e-3;
        let rel_var: Vec<f64> = rs
            .iter()
            .filter(|r| r.reference.value > 0.0)
            .map(|r| r.results[ti].var / (r.reference.value * r.reference.value))
            .collect();
        let max_share = rs
            .iter()
            .map(|r| r.results[ti].max_share)
            .fold(0.0f64, f64::max);
        let mut by_mat = Map::new();
        for (mi, (name, _)) in MATERIALS.iter().enumerate() {
            let v = ratios(rs, t, |r| r.config.material == mi);
            let (geo, _, _) = summarise(&v);
            by_mat.insert(name.to_string(), json!(geo));
        }
        per_tech.insert(
            t.name().to_string(),
            json!({
                "max_bias_sigma": max_abs,
                "mean_abs_bias_sigma": mean_abs,
                "rms_bias_sigma": rms,
                "mean_signed_bias_sigma": mean_signed,
                "configs_above_3_sigma": above3,
                "time_us_per_estimate": time_us,
                "rel_var_geomean": summarise(&rel_var).0,
                "max_share": max_share,
                "equal_time_vs_tl_split_geomean": Value::Object(by_mat),
            }),
        );
    }
    let tb1: Vec<(f64, f64)> = rs
        .iter()
        .filter_map(|r| {
            r.full_tb_one.map(|t| {
                let b = r.get(Technique::TlSplit);
                ((t.var * t.time_ns) / (b.var * b.time_ns), t.bias_sigma)
            })
        })
        .collect();
    let tb1_ratios: Vec<f64> = tb1.iter().map(|x| x.0).collect();
    let (t1_geo, t1_mean, t1_med) = summarise(&tb1_ratios);
    let lambert_tb_one = if tb1.is_empty() {
        Value::Null
    } else {
        json!({
            "what": "full with LambertMode::TbOne (TL split + 1 TB sample) at the Lambert configurations",
            "var_ratio_vs_tl_diffuse": t1_geo,
            "var_ratio_vs_tl_diffuse_mean": t1_mean,
            "var_ratio_vs_tl_diffuse_median": t1_med,
            "max_bias_sigma": tb1.iter().fold(0.0f64, |m, x| m.max(x.1.abs())),
            "time_us_per_estimate": rs.iter().filter_map(|r| r.full_tb_one.map(|t| t.time_ns)).sum::<f64>() / tb1.len() as f64 * 1e-3,
        })
    };
    let mut full_by_mat = Map::new();
    for (mi, (name, _)) in MATERIALS.iter().enumerate() {
        let (geo, _, _) = summarise(&ratios(rs, Technique::Full, |r| r.config.material == mi));
        full_by_mat.insert(name.to_string(), json!(geo));
    }
    let worst_light = rs
        .iter()
        .map(|r| r.reference.worst_light_rel_se)
        .fold(0.0f64, f64::max);
    let worst_config = rs
        .iter()
        .map(|r| r.reference.std_err / r.reference.value)
        .fold(0.0f64, f64::max);
    let unconverged: usize = rs.iter().map(|r| r.reference.unconverged).sum();
    let mut by_mat = Map::new();
    for (mi, (name, _)) in MATERIALS.iter().enumerate() {
        let sel: Vec<&ConfigResult> = rs.iter().filter(|r| r.config.material == mi).collect();
        let k = sel.len().max(1) as f64;
        by_mat.insert(
            name.to_string(),
            json!({
                "configs": sel.len(),
                "mean_split_cut": sel.iter().map(|r| r.split_len as f64).sum::<f64>() / k,
                "mean_bl_cut": sel.iter().map(|r| r.bl_cut_len as f64).sum::<f64>() / k,
                "mean_n": sel.iter().map(|r| f64::from(r.n_mix)).sum::<f64>() / k,
            }),
        );
    }
    let bias = json!({
        "bias_sigma_denominator": "sqrt(se_mean^2 + se_ref^2)",
        "bias_pairs": mb.pairs,
        "max_bias_sigma_at": max_at,
        "max_bias_sigma_null_quantile": json_num(mb.null_quantile),
        "max_bias_sigma_null_p_value": json_num(mb.null_p_value),
        "max_bias_sigma_null_median": json_num(mb.null_median),
        "max_bias_sigma_null_p95": json_num(mb.null_p95),
        "max_bias_sigma_null_p99": json_num(mb.null_p99),
        "max_bias_sigma_null_below_4": json_num(mb.null_below_4),
        "rms_bias_sigma": json_num(mb.rms),
        "pairs_above_3_sigma": mb.above_3,
        "pairs_above_3_sigma_expected": mb.above_3_expected,
    });
    let mut out = json!({
        "configs": rs.len(),
        "lights": cfg.lights,
        "points": cfg.points,
        "plan": match cfg.plan { Plan::Cycle => "point i: material i mod 5", Plan::All => "every point x every material" },
        "estimates": cfg.estimates,
        "seed": cfg.seed,
        "max_bias_sigma": max_bias,
        "var_ratio_full_vs_tl_glossy": g_geo,
        "var_ratio_full_vs_tl_glossy_mean": g_mean,
        "var_ratio_full_vs_tl_glossy_median": g_med,
        "var_ratio_full_vs_tl_diffuse": d_geo,
        "var_ratio_full_vs_tl_diffuse_mean": d_mean,
        "var_ratio_full_vs_tl_diffuse_median": d_med,
        "var_ratio_full_vs_tl_by_material": Value::Object(full_by_mat),
        "lambert_tb_one": lambert_tb_one,
        "var_ratio_aggregate": "geometric mean of (var*time)_full/(var*time)_tl-split per configuration",
        "glossy_configs": rs.iter().filter(|r| r.config.is_glossy()).count(),
        "diffuse_configs": rs.iter().filter(|r| r.config.is_diffuse()).count(),
        "reference_worst_light_rel_se": worst_light,
        "reference_worst_config_rel_se": worst_config,
        "reference_unconverged_lights": unconverged,
        "split_threshold": cfg.params.split_cut.threshold,
        "split_max_size": cfg.params.split_cut.max_size,
        "cut_delta": cfg.params.bl_cut.delta,
        "cut_max_size": cfg.params.bl_cut.max_size,
        "cut_split_sin": cfg.params.bl_cut.split_sin,
        "bl_light_samples": cfg.params.bl_light_samples,
        "mixture_cut": {
            "delta": cfg.params.mixture_cut.delta,
            "max_size": cfg.params.mixture_cut.max_size,
            "split_sin": cfg.params.mixture_cut.split_sin,
        },
        "n_max": cfg.params.n_max,
        "lambert_mode": format!("{:?}", cfg.params.lambert),
        "power_heuristic": cfg.params.heuristic == manylights::Heuristic::Power,
        "materials": Value::Object(by_mat),
        "techniques": Value::Object(per_tech),
        "reference_s": ref_s,
        "estimates_s": stats_s,
        "timing_s": time_s,
        "runtime_s": total.as_secs_f64(),
    });
    if let (Some(o), Value::Object(b)) = (out.as_object_mut(), bias) {
        o.extend(b);
    }
    out
}

/// The human-readable tables: per technique and material, then the worst configurations.
pub fn table(rs: &[ConfigResult], report: &Value, verbose: bool) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "{} configurations, {} lights, {} estimates per technique; reference: worst light rel. SE {:.2e}, worst configuration rel. SE {:.2e}\n\n",
        report["configs"], report["lights"], report["estimates"],
        report["reference_worst_light_rel_se"].as_f64().unwrap_or(f64::NAN),
        report["reference_worst_config_rel_se"].as_f64().unwrap_or(f64::NAN),
    ));
    s.push_str("| material | technique | max abs bias (SE) | rms bias (SE) | rel. variance (geo) | time/estimate (µs) | equal-time var vs tl-split (geo) |\n");
    s.push_str("|---|---|---|---|---|---|---|\n");
    for (mi, (name, _)) in MATERIALS.iter().enumerate() {
        let sel: Vec<&ConfigResult> = rs.iter().filter(|r| r.config.material == mi).collect();
        if sel.is_empty() {
            continue;
        }
        for (ti, &t) in Technique::ALL.iter().enumerate() {
            let b: Vec<f64> = sel.iter().map(|r| r.results[ti].bias_sigma).collect();
            let max_abs = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let rms = (b.iter().map(|x| x * x).sum::<f64>() / b.len() as f64).sqrt();
            let rel_var: Vec<f64> = sel
                .iter()
                .map(|r| r.results[ti].var / (r.reference.value * r.reference.value))
                .collect();
            let time =
                sel.iter().map(|r| r.results[ti].time_ns).sum::<f64>() / sel.len() as f64 * 1e-3;
            let ratio: Vec<f64> = sel.iter().map(|r| r.equal_time_ratio(t)).collect();
            s.push_str(&format!(
                "| {name} | {} | {max_abs:.2} | {rms:.2} | {:.3e} | {time:.2} | {:.3} |\n",
                t.name(),
                summarise(&rel_var).0,
                summarise(&ratio).0
            ));
        }
    }
    s.push_str(&format!(
        "\nmax |bias| = {:.2} SE; full vs tl-split at equal time (geometric mean): glossy (GGX α ≤ 0.2) {:.3}, diffuse {:.3}\n",
        report["max_bias_sigma"].as_f64().unwrap_or(f64::NAN),
        report["var_ratio_full_vs_tl_glossy"].as_f64().unwrap_or(f64::NAN),
        report["var_ratio_full_vs_tl_diffuse"].as_f64().unwrap_or(f64::NAN),
    ));
    let f = |k: &str| report[k].as_f64().unwrap_or(f64::NAN);
    s.push_str(&format!(
        "largest |bias| against its null distribution (seed {}; z = (mean − exact)/sqrt(se² + se_ref²), {} pairs taken as independent N(0, 1)): P(max ≤ {:.2}) = {:.4} (p-value {:.2e}); the null's maximum has median {:.2}, 95 % {:.2}, 99 % {:.2}, and stays ≤ 4 with probability {:.3}; rms z {:.3}; {} pairs above 3 SE ({:.2} expected)\n",
        report["seed"],
        report["bias_pairs"],
        f("max_bias_sigma"),
        f("max_bias_sigma_null_quantile"),
        f("max_bias_sigma_null_p_value"),
        f("max_bias_sigma_null_median"),
        f("max_bias_sigma_null_p95"),
        f("max_bias_sigma_null_p99"),
        f("max_bias_sigma_null_below_4"),
        f("rms_bias_sigma"),
        report["pairs_above_3_sigma"],
        f("pairs_above_3_sigma_expected"),
    ));
    if let Some(v) = report["lambert_tb_one"]["var_ratio_vs_tl_diffuse"].as_f64() {
        s.push_str(&format!(
            "full with one TB sample at Lambert points (--lambert tb-one): diffuse {v:.3}, max |bias| {:.2} SE, {:.2} µs/estimate\n",
            report["lambert_tb_one"]["max_bias_sigma"].as_f64().unwrap_or(f64::NAN),
            report["lambert_tb_one"]["time_us_per_estimate"].as_f64().unwrap_or(f64::NAN),
        ));
    }
    // The largest deviations.
    let mut worst: Vec<(f64, usize, usize)> = rs
        .iter()
        .enumerate()
        .flat_map(|(ci, r)| {
            r.results
                .iter()
                .enumerate()
                .map(move |(ti, t)| (t.bias_sigma.abs(), ci, ti))
        })
        .collect();
    worst.sort_by(|a, b| b.0.total_cmp(&a.0));
    s.push_str("\nlargest deviations:\n| config | point | material | technique | bias (SE) | mean | exact | rel. SE | max share |\n|---|---|---|---|---|---|---|---|---|\n");
    let shown = if verbose { worst.len() } else { 8 };
    for &(_, ci, ti) in worst.iter().take(shown) {
        let r = &rs[ci];
        let t = &r.results[ti];
        s.push_str(&format!(
            "| {ci} | {} | {} | {} | {:+.2} | {:.6e} | {:.6e} | {:.2e} | {:.2e} |\n",
            r.config.point,
            r.config.material_name(),
            Technique::ALL[ti].name(),
            t.bias_sigma,
            t.mean,
            r.reference.value,
            t.se / r.reference.value,
            t.max_share
        ));
    }
    if verbose {
        s.push_str("\nper configuration:\n| config | material | exact | split cut | BL cut | IB | N | full/tl-split (equal time) |\n|---|---|---|---|---|---|---|---|\n");
        for (ci, r) in rs.iter().enumerate() {
            s.push_str(&format!(
                "| {ci} | {} | {:.5e} | {} | {} | {:.3} | {} | {:.3} |\n",
                r.config.material_name(),
                r.reference.value,
                r.split_len,
                r.bl_cut_len,
                r.ib,
                r.n_mix,
                r.equal_time_ratio(Technique::Full)
            ));
        }
    }
    s
}

/// The command-line arguments of `mlmeasure estimator`.
#[derive(clap::Args, Clone, Debug)]
pub struct EstimatorArgs {
    /// Seed of the scene, the reference and the estimates.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Estimates per technique and configuration (default 100,000; 4,000 with --quick).
    #[arg(long, value_name = "K")]
    pub estimates: Option<usize>,
    /// A fast smoke run: 10 shading points, 4,000 estimates.
    #[arg(long)]
    pub quick: bool,
    /// Number of shading points (default 64; 10 with --quick).
    #[arg(long)]
    pub points: Option<usize>,
    /// Number of lights.
    #[arg(long, default_value_t = 1000)]
    pub lights: usize,
    /// Evaluate every point with every material (5× the configurations) instead of point i
    /// with material i mod 5.
    #[arg(long)]
    pub all_materials: bool,
    /// The estimators' parameters.
    #[command(flatten)]
    pub params: manylights_render::params::ParamArgs,
    /// Print every configuration and every deviation.
    #[arg(long)]
    pub verbose: bool,
    /// Print one JSON object as the last line of stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `mlmeasure estimator` with `args`; returns the process exit code.
pub fn run_cli(args: &EstimatorArgs) -> i32 {
    let mut cfg = if args.quick {
        EstimatorConfig::quick(args.seed)
    } else {
        EstimatorConfig::full(args.seed)
    };
    if let Some(k) = args.estimates {
        cfg.estimates = k.max(2);
    }
    if let Some(p) = args.points {
        cfg.points = p.max(1);
    }
    cfg.lights = args.lights.max(1);
    if args.all_materials {
        cfg.plan = Plan::All;
    }
    cfg.params = args.params.params();
    let (rs, report) = run(&cfg);
    println!("{}", table(&rs, &report, args.verbose));
    if args.json {
        println!("{report}");
    }
    0
}
