//! `mlmeasure sptd-accuracy`: how well the fitted GGX SPTD ([`SptdGgx`]) predicts the
//! cosine-weighted BRDF integral over random caps (docs/formulas.md, section 8).
//!
//! Two strata, reported separately:
//!
//! - *overall* (random caps): `√α` uniform in [0.1, 1], θo uniform in [0°, 85°], cap half-angle
//!   σ log-uniform in [1e-3, 1.2] rad, cap axis uniform on the sphere (so caps straddle and
//!   fall below the horizon);
//! - *grazing*: `√α` uniform in [0.1, 0.7], θo uniform in [70°, 89°], small caps away from the
//!   mirror direction `r = 2 cos θo n − ωo`: the axis `k α` off `r` (k uniform in [1, 4]) in a
//!   direction uniform around it, σ = `s α` with s log-uniform in [0.01, 0.5]; a cap wholly
//!   below the horizon is drawn again. One case in four is then moved onto the horizon: its
//!   axis keeps its azimuth and gets an elevation uniform in `(−σ, σ)`, so the cap straddles
//!   it. At these views the GGX lobe is a narrow ridge along the plane of incidence whose
//!   tails fall off far faster across it than along it.
//!
//! Ground truth: `∫_C f cos dω` by MIS (balance heuristic) of uniform-in-cap
//! and GGX VNDF sampling, `grid²` stratified pairs (default 256²), in f64; an estimate whose
//! standard error (an unstratified upper bound) exceeds 3 % is redone on a 4× finer grid, up to
//! twice, and the remaining standard errors are reported. The directional albedo comes from 256² stratified
//! VNDF samples; the same MIS estimator over the whole hemisphere must reproduce it, and so
//! must the SPTD's hemisphere, both are reported.
//!
//! Definitions:
//! - a case *counts* for relative errors when its truth is meaningfully positive: the
//!   cap-averaged `f cos`, `T/|C|`, exceeds 1e-6 of the hemisphere average `ρ/2π`;
//! - relative error `|S − T| / T`; `spearman` is the rank correlation of S and T over the cases
//!   where either is positive (ties get average ranks);
//! - `false_zero`: `T > 1e-6 ρ` but `S = 0`; `false_nonzero`: the cap lies entirely below the
//!   horizon (`axis·n ≤ −sin σ`, so the exact integral is 0) but `S > 0`;
//! - `ratio_min`, `ratio_max`: the extremes of `S/T` over the cases that count, and
//!   `outside_3x` how many of them fall outside `[1/3, 3]`;
//! - `straddling`: cases whose cap crosses the horizon (`|axis·n| < sin σ`).
//!
//! The JSON keys of the overall stratum have no prefix, those of the grazing one `grazing_`.

use glam::DVec3;
use manylights::internals::sptd::SptdGgx;
use manylights_testkit::ggx::{cap_integral, wo_local, Cap64, Ggx};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use serde_json::json;
use std::f64::consts::PI;
use std::time::Instant;

/// What to measure.
#[derive(Clone, Copy, Debug)]
pub struct AccuracyConfig {
    /// Number of random cases.
    pub cases: usize,
    /// Seed of the cases and of the ground truth.
    pub seed: u64,
    /// Ground truth from `grid²` MIS pairs.
    pub grid: usize,
    /// Number of grazing cases.
    pub grazing_cases: usize,
}

/// One case and its results.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    /// Roughness α.
    pub alpha: f64,
    /// View angle θo (radians).
    pub theta_o: f64,
    /// Cap half-angle σ.
    pub sigma: f64,
    /// Cap axis (local frame, n = +z).
    pub axis: DVec3,
    /// The SPTD's value.
    pub sptd: f64,
    /// Ground truth.
    pub truth: f64,
    /// Its standard error.
    pub std_err: f64,
    /// Directional albedo ρ.
    pub albedo: f64,
    /// The SPTD's whole hemisphere.
    pub sptd_hemisphere: f64,
    /// The MIS estimator over the whole hemisphere.
    pub truth_hemisphere: f64,
}

impl Case {
    /// Whether the truth is meaningfully positive (see the module docs).
    pub fn counts(&self) -> bool {
        let area = Cap64::new(self.axis, self.sigma).area();
        self.truth / area > 1e-6 * self.albedo / (2.0 * PI)
    }

    /// `|S − T| / T`.
    pub fn rel_err(&self) -> f64 {
        (self.sptd - self.truth).abs() / self.truth
    }

    /// Whether the cap crosses the horizon.
    pub fn straddles(&self) -> bool {
        self.axis.z.abs() < self.sigma.sin()
    }
}

fn draw(rng: &mut Pcg64Mcg) -> (f64, f64, f64, DVec3) {
    let u: f64 = rng.random_range(0.1..=1.0);
    let theta_o = rng.random_range(0.0..=85f64.to_radians());
    let sigma = (1e-3f64.ln() + (1.2f64.ln() - 1e-3f64.ln()) * rng.random::<f64>()).exp();
    let z: f64 = rng.random_range(-1.0..=1.0);
    let phi: f64 = rng.random_range(0.0..2.0 * PI);
    let s = (1.0 - z * z).max(0.0).sqrt();
    (
        u * u,
        theta_o,
        sigma,
        DVec3::new(s * phi.cos(), s * phi.sin(), z),
    )
}

/// A grazing case (see the module docs): `(α, θo, σ, axis)`, the cap not wholly below the
/// horizon.
fn draw_grazing(rng: &mut Pcg64Mcg) -> (f64, f64, f64, DVec3) {
    loop {
        let u: f64 = rng.random_range(0.1..=0.7);
        let alpha = u * u;
        let theta_o = rng.random_range(70f64.to_radians()..=89f64.to_radians());
        let k: f64 = rng.random_range(1.0..=4.0);
        let psi: f64 = rng.random_range(0.0..2.0 * PI);
        let s = (0.01f64.ln() + (0.5f64.ln() - 0.01f64.ln()) * rng.random::<f64>()).exp();
        let sigma = s * alpha;
        // The mirror direction and two unit vectors orthogonal to it.
        let (st, ct) = theta_o.sin_cos();
        let r = DVec3::new(-st, 0.0, ct);
        let e1 = DVec3::new(ct, 0.0, st);
        let d = k * alpha;
        let axis = (r * d.cos() + (e1 * psi.cos() + DVec3::Y * psi.sin()) * d.sin()).normalize();
        let straddle = rng.random_range(0..4) == 0;
        let lift: f64 = rng.random_range(-1.0..1.0);
        let axis = if straddle {
            let h = DVec3::new(axis.x, axis.y, 0.0).normalize();
            let (se, ce) = (lift * sigma).sin_cos();
            h * ce + DVec3::Z * se
        } else {
            axis
        };
        if axis.z > -sigma.sin() {
            return (alpha, theta_o, sigma, axis);
        }
    }
}

fn eval_case(alpha: f64, theta_o: f64, sigma: f64, axis: DVec3, seed: u64, grid: usize) -> Case {
    let ggx = Ggx::new(alpha);
    let wo = wo_local(theta_o);
    let sp = SptdGgx::new(alpha as f32, theta_o.cos() as f32);
    let sptd = f64::from(sp.integral(axis.as_vec3(), sigma.sin() as f32));
    let cap = Cap64::new(axis, sigma);
    let mut t = cap_integral(&ggx, wo, &cap, grid, seed);
    // Refine the few estimates above 3 % standard error (slivers at the horizon): 4× finer grids.
    let mut g = grid;
    while t.value > 0.0 && t.std_err > 0.03 * t.value && g < 16 * grid {
        g *= 4;
        t = cap_integral(&ggx, wo, &cap, g, seed ^ g as u64);
    }
    let (albedo, _) = ggx.albedo(wo, 256);
    let hemi = cap_integral(&ggx, wo, &Cap64::new(DVec3::Z, PI / 2.0), 64, seed ^ 1);
    Case {
        alpha,
        theta_o,
        sigma,
        axis,
        sptd,
        truth: t.value,
        std_err: t.std_err,
        albedo,
        sptd_hemisphere: f64::from(sp.albedo()),
        truth_hemisphere: hemi.value,
    }
}

/// Draws and evaluates the overall stratum's cases (in parallel; the result does not depend
/// on threads).
pub fn cases(cfg: &AccuracyConfig) -> Vec<Case> {
    drawn_cases(cfg.seed, cfg.cases, cfg.grid, draw)
}

/// Draws and evaluates the grazing stratum's cases (in parallel; the result does not depend
/// on threads).
pub fn grazing_cases(cfg: &AccuracyConfig) -> Vec<Case> {
    drawn_cases(
        cfg.seed ^ 0x6772_617a_696e_6721,
        cfg.grazing_cases,
        cfg.grid,
        draw_grazing,
    )
}

/// `n` cases drawn by `draw` from a generator seeded with `seed`, each with a seed of its own
/// for its ground truth, then evaluated in parallel.
fn drawn_cases(
    seed: u64,
    n: usize,
    grid: usize,
    draw: fn(&mut Pcg64Mcg) -> (f64, f64, f64, DVec3),
) -> Vec<Case> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let drawn: Vec<_> = (0..n)
        .map(|_| (draw(&mut rng), rng.random::<u64>()))
        .collect();
    drawn
        .into_par_iter()
        .map(|((a, t, s, ax), seed)| eval_case(a, t, s, ax, seed, grid))
        .collect()
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let x = q * (sorted.len() - 1) as f64;
    let i = x.floor() as usize;
    let f = x - i as f64;
    if i + 1 < sorted.len() {
        sorted[i] * (1.0 - f) + sorted[i + 1] * f
    } else {
        sorted[i]
    }
}

fn ranks(v: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut r = vec![0.0; v.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && v[idx[j + 1]] == v[idx[i]] {
            j += 1;
        }
        let avg = 0.5 * (i + j) as f64 + 1.0;
        for &k in &idx[i..=j] {
            r[k] = avg;
        }
        i = j + 1;
    }
    r
}

/// Spearman's rank correlation (Pearson correlation of average ranks).
pub fn spearman(a: &[f64], b: &[f64]) -> f64 {
    let (ra, rb) = (ranks(a), ranks(b));
    let n = ra.len() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let (ma, mb) = (ra.iter().sum::<f64>() / n, rb.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in ra.iter().zip(&rb) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

fn median_where(cases: &[Case], f: impl Fn(&Case) -> bool) -> (f64, usize) {
    let mut e: Vec<f64> = cases
        .iter()
        .filter(|c| c.counts() && f(c))
        .map(Case::rel_err)
        .collect();
    e.sort_by(f64::total_cmp);
    (quantile(&e, 0.5), e.len())
}

/// The figures of one stratum, as JSON keys with `prefix`.
fn stratum(cases: &[Case], prefix: &str) -> serde_json::Map<String, serde_json::Value> {
    let mut errs: Vec<f64> = cases
        .iter()
        .filter(|c| c.counts())
        .map(Case::rel_err)
        .collect();
    errs.sort_by(f64::total_cmp);
    let ratios: Vec<f64> = cases
        .iter()
        .filter(|c| c.counts())
        .map(|c| c.sptd / c.truth)
        .collect();
    let positive: Vec<&Case> = cases
        .iter()
        .filter(|c| c.truth > 0.0 || c.sptd > 0.0)
        .collect();
    let s: Vec<f64> = positive.iter().map(|c| c.sptd).collect();
    let t: Vec<f64> = positive.iter().map(|c| c.truth).collect();
    let false_zero = cases
        .iter()
        .filter(|c| c.truth > 1e-6 * c.albedo && c.sptd == 0.0)
        .count();
    let false_nonzero = cases
        .iter()
        .filter(|c| c.axis.z <= -c.sigma.sin() && c.sptd > 0.0)
        .count();
    let over = |x: f64| errs.iter().filter(|&&e| e > x).count();
    let value = json!({
        "cases": cases.len(),
        "counted": errs.len(),
        "median_rel_err": quantile(&errs, 0.5),
        "p90_rel_err": quantile(&errs, 0.9),
        "spearman": spearman(&s, &t),
        "spearman_cases": positive.len(),
        "rel_err_over_0_5": over(0.5),
        "rel_err_over_1": over(1.0),
        "ratio_min": ratios.iter().copied().fold(f64::INFINITY, f64::min),
        "ratio_max": ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        "outside_3x": ratios.iter().filter(|&&r| !(1.0 / 3.0..=3.0).contains(&r)).count(),
        "false_zero": false_zero,
        "false_nonzero": false_nonzero,
        "straddling": cases.iter().filter(|c| c.straddles()).count(),
    });
    let serde_json::Value::Object(map) = value else {
        unreachable!("json! of an object")
    };
    map.into_iter()
        .map(|(k, v)| (format!("{prefix}{k}"), v))
        .collect()
}

/// The report of a run: JSON with the keys of the issue plus details, the overall stratum's
/// without a prefix, the grazing one's with `grazing_`.
pub fn report(
    cases: &[Case],
    grazing: &[Case],
    cfg: &AccuracyConfig,
    seconds: f64,
) -> serde_json::Value {
    let deg = |d: f64| d.to_radians();
    let (m45, n45) = median_where(cases, |c| c.theta_o < deg(45.0));
    let (m70, n70) = median_where(cases, |c| c.theta_o >= deg(45.0) && c.theta_o < deg(70.0));
    let (m85, n85) = median_where(cases, |c| c.theta_o >= deg(70.0));
    let all: Vec<&Case> = cases.iter().chain(grazing).collect();
    let se_rel: Vec<f64> = all
        .iter()
        .filter(|c| c.counts())
        .map(|c| c.std_err / c.truth)
        .collect();
    let over_3 = se_rel.iter().filter(|&&x| x > 0.03).count();
    let mut se_sorted = se_rel.clone();
    se_sorted.sort_by(f64::total_cmp);
    let hemi_truth = all
        .iter()
        .map(|c| (c.truth_hemisphere / c.albedo - 1.0).abs())
        .fold(0.0, f64::max);
    let hemi_sptd = all
        .iter()
        .map(|c| (c.sptd_hemisphere / c.albedo - 1.0).abs())
        .fold(0.0, f64::max);
    let mut map = stratum(cases, "");
    map.extend(stratum(grazing, "grazing_"));
    let serde_json::Value::Object(rest) = json!({
        "median_rel_err_below_45": m45,
        "median_rel_err_45_70": m70,
        "median_rel_err_above_70": m85,
        "counted_below_45": n45,
        "counted_45_70": n70,
        "counted_above_70": n85,
        "truth_median_rel_std_err": quantile(&se_sorted, 0.5),
        "truth_max_rel_std_err": se_sorted.last().copied().unwrap_or(0.0),
        "truth_rel_std_err_over_3pct": over_3,
        "max_hemisphere_truth_vs_albedo": hemi_truth,
        "max_hemisphere_sptd_vs_albedo": hemi_sptd,
        "seed": cfg.seed,
        "mis_pairs": cfg.grid * cfg.grid,
        "seconds": seconds,
    }) else {
        unreachable!("json! of an object")
    };
    map.extend(rest);
    serde_json::Value::Object(map)
}

/// The cases of a run, both strata.
#[derive(Clone, Debug)]
pub struct Cases {
    /// The overall stratum (random caps).
    pub overall: Vec<Case>,
    /// The grazing stratum.
    pub grazing: Vec<Case>,
}

/// Runs everything: the cases of both strata and the report.
pub fn run(cfg: &AccuracyConfig) -> (Cases, serde_json::Value) {
    let t = Instant::now();
    let cs = Cases {
        overall: cases(cfg),
        grazing: grazing_cases(cfg),
    };
    let r = report(&cs.overall, &cs.grazing, cfg, t.elapsed().as_secs_f64());
    (cs, r)
}

/// The worst `n` counted cases of a stratum, one line each.
fn worst_lines(cases: &[Case], n: usize) -> String {
    let mut worst: Vec<&Case> = cases.iter().filter(|c| c.counts()).collect();
    worst.sort_by(|a, b| {
        let (ra, rb) = ((a.sptd / a.truth).ln().abs(), (b.sptd / b.truth).ln().abs());
        rb.total_cmp(&ra)
    });
    let mut out = String::from(
        "                alpha  theta_o  sigma      axis.z    truth        sptd         S/T\n",
    );
    for c in worst.iter().take(n) {
        out.push_str(&format!(
            "                {:.3}  {:5.1}°   {:.3e}  {:+.3}    {:.4e}   {:.4e}   {:.3}\n",
            c.alpha,
            c.theta_o.to_degrees(),
            c.sigma,
            c.axis.z,
            c.truth,
            c.sptd,
            c.sptd / c.truth
        ));
    }
    out
}

/// The human-readable summary, with the ten worst counted cases of each stratum (the furthest
/// from the truth by ratio, either way).
pub fn table(cases: &Cases, r: &serde_json::Value) -> String {
    let g = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
    let mut out = format!(
        "SPTD GGX accuracy, {} MIS pairs per case\n\
         overall: {} random caps ({} with meaningful truth, {} across the horizon)\n\
         relative error       median {:.3}   p90 {:.3}   (>0.5: {}, >1: {})\n\
         S/T                  min {:.3}   max {:.3}   outside [1/3, 3]: {}\n\
         by view angle        <45° {:.3} ({})   45–70° {:.3} ({})   >70° {:.3} ({})\n\
         rank correlation     spearman {:.4} over {} cases\n\
         zeros                false_zero {}   false_nonzero {}\n\
         grazing: {} small caps 1–4 α off the mirror direction, θo 70–89° ({} with meaningful \
         truth, {} across the horizon)\n\
         relative error       median {:.3}   p90 {:.3}   (>0.5: {}, >1: {})\n\
         S/T                  min {:.3}   max {:.3}   outside [1/3, 3]: {}\n\
         rank correlation     spearman {:.4} over {} cases\n\
         zeros                false_zero {}   false_nonzero {}\n\
         ground truth         median rel. std. err {:.4}, max {:.4} ({} over 3 %)\n\
         hemisphere vs albedo truth {:.4}, SPTD {:.4} (max rel. diff)\n\
         time                 {:.1} s\n",
        r["mis_pairs"],
        r["cases"],
        r["counted"],
        r["straddling"],
        g("median_rel_err"),
        g("p90_rel_err"),
        r["rel_err_over_0_5"],
        r["rel_err_over_1"],
        g("ratio_min"),
        g("ratio_max"),
        r["outside_3x"],
        g("median_rel_err_below_45"),
        r["counted_below_45"],
        g("median_rel_err_45_70"),
        r["counted_45_70"],
        g("median_rel_err_above_70"),
        r["counted_above_70"],
        g("spearman"),
        r["spearman_cases"],
        r["false_zero"],
        r["false_nonzero"],
        r["grazing_cases"],
        r["grazing_counted"],
        r["grazing_straddling"],
        g("grazing_median_rel_err"),
        g("grazing_p90_rel_err"),
        r["grazing_rel_err_over_0_5"],
        r["grazing_rel_err_over_1"],
        g("grazing_ratio_min"),
        g("grazing_ratio_max"),
        r["grazing_outside_3x"],
        g("grazing_spearman"),
        r["grazing_spearman_cases"],
        r["grazing_false_zero"],
        r["grazing_false_nonzero"],
        g("truth_median_rel_std_err"),
        g("truth_max_rel_std_err"),
        r["truth_rel_std_err_over_3pct"],
        g("max_hemisphere_truth_vs_albedo"),
        g("max_hemisphere_sptd_vs_albedo"),
        g("seconds"),
    );
    out.push_str("worst overall cases:\n");
    out.push_str(&worst_lines(&cases.overall, 10));
    out.push_str("worst grazing cases:\n");
    out.push_str(&worst_lines(&cases.grazing, 10));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spearman_of_monotone_and_tied_data() {
        let a = [1.0, 2.0, 3.0, 4.0];
        assert!((spearman(&a, &[10.0, 20.0, 30.0, 40.0]) - 1.0).abs() < 1e-12);
        assert!((spearman(&a, &[4.0, 3.0, 2.0, 1.0]) + 1.0).abs() < 1e-12);
        assert_eq!(ranks(&[0.0, 0.0, 1.0]), vec![1.5, 1.5, 3.0]);
    }
}
