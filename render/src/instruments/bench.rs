//! `mlrender bench`: build time, memory and single-threaded sampling throughput of the 4-wide
//! tree against the binary scalar baseline, measured in one run, plus the exactness of the
//! pmfs. The build's peak heap is measured with [`crate::alloc_count`] when that is the global
//! allocator (as in `mlrender`).

use crate::alloc_count;
use manylights::baseline::BinaryLightTree;
use manylights::{
    BlImportance, CutOptions, Light, LightCut, LightTree, Material, ShadingPoint as Sp,
    SplitOptions, TlImportance, CUT_CAPACITY,
};
use manylights_testkit::{self as random_scene, ShadingPoint};
use serde_json::json;
use std::hint::black_box;
use std::time::Instant;

/// Which seeded scene to measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SceneKinds {
    /// The mixed scene of points, spots, spheres and triangles ([`random_scene::lights`]).
    Mixed,
    /// Point lights only ([`random_scene::point_lights`]).
    Point,
}

impl SceneKinds {
    /// The scene's `n` lights from `seed`.
    pub fn lights(self, n: usize, seed: u64) -> Vec<Light> {
        match self {
            SceneKinds::Mixed => random_scene::lights(n, seed),
            SceneKinds::Point => random_scene::point_lights(n, seed),
        }
    }

    /// The name used on the command line and in the report.
    pub fn name(self) -> &'static str {
        match self {
            SceneKinds::Mixed => "mixed",
            SceneKinds::Point => "point",
        }
    }
}

/// What to measure.
#[derive(Clone, Copy, Debug)]
pub struct BenchConfig {
    /// Number of lights.
    pub lights: usize,
    /// Number of shading points (one sample each).
    pub points: usize,
    /// Seed of the scene, the points and the uniform numbers.
    pub seed: u64,
    /// Timed repetitions of each build and sampling loop; the fastest is kept.
    pub repeats: usize,
    /// The scene.
    pub kinds: SceneKinds,
    /// Measure the builds only (time, peak heap, size and shape), no sampling.
    pub build_only: bool,
}

/// A timed build: wall-clock and thread CPU milliseconds (the CPU time is what the build got
/// of a shared machine), and the peak bytes allocated during it (the result included), or
/// `None` without the counting allocator.
struct BuildTime {
    ms: f64,
    cpu_ms: f64,
    peak: Option<usize>,
}

fn timed_build<T>(f: impl FnOnce() -> T) -> (T, BuildTime) {
    let base = alloc_count::reset_peak();
    let t = Instant::now();
    let mut out = None;
    let cpu = crate::render::busy_time(|| out = Some(f()));
    let ms = t.elapsed().as_secs_f64() * 1e3;
    let peak = alloc_count::peak() - base;
    let time = BuildTime {
        ms,
        cpu_ms: cpu * 1e3,
        peak: alloc_count::installed().then_some(peak),
    };
    (out.expect("the build ran"), time)
}

/// The best of `repeats` builds (the previous result is dropped before each): the fastest
/// wall-clock and CPU times, and the largest peak heap of all of them.
fn best_build<T>(repeats: usize, mut f: impl FnMut() -> T) -> (T, BuildTime) {
    let (mut out, mut best) = timed_build(&mut f);
    for _ in 1..repeats.max(1) {
        drop(out);
        let (o, t) = timed_build(&mut f);
        out = o;
        best.ms = best.ms.min(t.ms);
        best.cpu_ms = best.cpu_ms.min(t.cpu_ms);
        best.peak = best.peak.max(t.peak);
    }
    (out, best)
}

/// Throughput of one pass over the shading points, in million samples per second.
fn time_pass(
    points: &[ShadingPoint],
    us: &[f32],
    mut f: impl FnMut(&TlImportance, f32) -> f32,
) -> (f64, f64) {
    let t = Instant::now();
    let mut acc = 0.0f64;
    for (p, &u) in points.iter().zip(us) {
        let imp = TlImportance::new(p.position, p.normal);
        acc += f64::from(f(black_box(&imp), black_box(u)));
    }
    let s = t.elapsed().as_secs_f64();
    (points.len() as f64 / s / 1e6, acc)
}

/// Runs the benchmark; returns the JSON report (also the source of the human table).
pub fn run(cfg: &BenchConfig) -> serde_json::Value {
    let lights = cfg.kinds.lights(cfg.lights, cfg.seed);
    let per_light = |bytes: Option<usize>| bytes.map(|b| b as f64 / cfg.lights.max(1) as f64);

    let (tree, build) = best_build(cfg.repeats, || {
        LightTree::build(&lights).expect("the bench scene is valid")
    });
    let (baseline, baseline_build) = best_build(cfg.repeats, || {
        BinaryLightTree::build(&lights).expect("the bench scene is valid")
    });
    let stats = tree.stats();
    let build_report = json!({
        "lights": cfg.lights,
        "kinds": cfg.kinds.name(),
        "seed": cfg.seed,
        "repeats": cfg.repeats.max(1),
        "build_ms": build.ms,
        "build_cpu_ms": build.cpu_ms,
        "build_peak_bytes_per_light": per_light(build.peak),
        "baseline_build_ms": baseline_build.ms,
        "baseline_build_cpu_ms": baseline_build.cpu_ms,
        "baseline_build_peak_bytes_per_light": per_light(baseline_build.peak),
        "bytes_per_light": stats.bytes_per_light,
        "baseline_bytes_per_light": baseline.bytes() as f64 / cfg.lights.max(1) as f64,
        "nodes": stats.nodes,
        "mean_fill": stats.mean_fill,
        "depth": stats.depth,
    });
    if cfg.build_only {
        return build_report;
    }
    let points = random_scene::shading_points(cfg.points, cfg.seed);
    let us = random_scene::uniforms(cfg.points, cfg.seed);

    // Alternate the two samplers so that both see the same machine state; keep the best.
    let mut tl = 0.0f64;
    let mut base = 0.0f64;
    let mut checksum = 0.0;
    for _ in 0..cfg.repeats.max(1) {
        let (r, c) = time_pass(&points, &us, |imp, u| {
            tree.sample(imp, u).map_or(0.0, |s| s.pmf)
        });
        tl = tl.max(r);
        checksum += c;
        let (r, c) = time_pass(&points, &us, |imp, u| {
            baseline.sample(imp, u).map_or(0.0, |s| s.pmf)
        });
        base = base.max(r);
        checksum += c;
    }
    black_box(checksum);

    // The samples once more, kept for the pmf queries.
    let samples: Vec<Option<manylights::LightSample>> = points
        .iter()
        .zip(&us)
        .map(|(p, &u)| tree.sample(&TlImportance::new(p.position, p.normal), u))
        .collect();
    let returned = samples.iter().filter(|s| s.is_some()).count();
    let mut pmf_rate = 0.0f64;
    let mut max_rel = 0.0f64;
    for _ in 0..cfg.repeats.max(1) {
        let t = Instant::now();
        let mut acc = 0.0f64;
        let mut n = 0usize;
        for (p, s) in points.iter().zip(&samples) {
            if let Some(s) = s {
                let imp = TlImportance::new(p.position, p.normal);
                let q = tree.pmf(black_box(&imp), black_box(s.light));
                acc += f64::from(q);
                n += 1;
                let rel =
                    (f64::from(q) - f64::from(s.pmf)).abs() / f64::from(q).max(f64::MIN_POSITIVE);
                max_rel = max_rel.max(rel);
            }
        }
        black_box(acc);
        pmf_rate = pmf_rate.max(n as f64 / t.elapsed().as_secs_f64() / 1e6);
    }

    // Split sampling: build the Conty–Kulla cut, then one sample per cluster.
    let split_opts = SplitOptions::default();
    let mut split_rate = 0.0f64;
    let mut split_each_rate = 0.0f64;
    let mut split_builds = 0.0f64;
    let mut cut_size_sum = 0usize;
    for _ in 0..cfg.repeats.max(1) {
        let t = Instant::now();
        let mut acc = 0.0f64;
        let mut n_samples = 0usize;
        cut_size_sum = 0;
        for (p, &u) in points.iter().zip(&us) {
            let imp = TlImportance::new(p.position, p.normal);
            let cut = LightCut::build_split(&tree, black_box(&imp), &split_opts);
            cut_size_sum += cut.len();
            for i in 0..cut.len() {
                if let Some(s) = cut.sample_in(&tree, &imp, i, black_box(u)) {
                    acc += f64::from(s.pmf);
                    n_samples += 1;
                }
            }
        }
        black_box(acc);
        split_rate = split_rate.max(n_samples as f64 / t.elapsed().as_secs_f64() / 1e6);
        // The same samples drawn by `sample_each` (descents interleaved four at a time).
        let t = Instant::now();
        let mut acc = 0.0f64;
        let mut n_samples = 0usize;
        let mut out = [None; CUT_CAPACITY];
        for (p, &u) in points.iter().zip(&us) {
            let imp = TlImportance::new(p.position, p.normal);
            let cut = LightCut::build_split(&tree, black_box(&imp), &split_opts);
            let u_all = [black_box(u); CUT_CAPACITY];
            cut.sample_each(&tree, &imp, &u_all[..cut.len()], &mut out[..cut.len()]);
            for s in out[..cut.len()].iter().flatten() {
                acc += f64::from(s.pmf);
                n_samples += 1;
            }
        }
        black_box(acc);
        split_each_rate = split_each_rate.max(n_samples as f64 / t.elapsed().as_secs_f64() / 1e6);
        // Cut construction alone.
        let t = Instant::now();
        let mut sizes = 0usize;
        for p in &points {
            let imp = TlImportance::new(p.position, p.normal);
            sizes += LightCut::build_split(&tree, black_box(&imp), &split_opts).len();
        }
        black_box(sizes);
        split_builds = split_builds.max(points.len() as f64 / t.elapsed().as_secs_f64());
    }

    // BRDF-oriented sampling: GGX α = 0.2, ωo uniform over the hemisphere of n. Per shading
    // point: set-up, the light cut, then the budget N = ceil(50 · IB) samples drawn from it
    // (how the method uses a cut), and separately cut + one sample.
    let bl_points: Vec<Sp> = points
        .iter()
        .zip(random_scene::shading_points(points.len(), cfg.seed ^ 0xb1))
        .map(|(p, q)| {
            let wo = if q.normal.dot(p.normal) < 0.0 {
                -q.normal
            } else {
                q.normal
            };
            Sp {
                position: p.position,
                normal: p.normal,
                wo: (wo + p.normal * 1e-3).normalize(),
                material: Material::Ggx {
                    alpha: 0.2,
                    specular: 1.0,
                },
            }
        })
        .collect();
    let cut_opts = CutOptions::default();
    let mut bl_rate = 0.0f64;
    let mut bl_single_rate = 0.0f64;
    let mut bl_builds = 0.0f64;
    let mut bl_cut_size = 0usize;
    let mut bl_budget = 0usize;
    for _ in 0..cfg.repeats.max(1) {
        let t = Instant::now();
        let mut acc = 0.0f64;
        let mut n_samples = 0usize;
        bl_cut_size = 0;
        bl_budget = 0;
        for (sp, &u) in bl_points.iter().zip(&us) {
            let imp = BlImportance::new(black_box(sp)).expect("valid shading point");
            let cut = LightCut::build(&tree, &imp, &cut_opts);
            bl_cut_size += cut.len();
            let n = manylights::mis::sample_budget(cut.max_score(), manylights::mis::N_MAX);
            bl_budget += n as usize;
            for j in 0..n {
                let uj = (u + j as f32 * 0.618_034).fract();
                if let Some(s) = cut.sample(&tree, &imp, black_box(uj)) {
                    acc += f64::from(s.pmf);
                    n_samples += 1;
                }
            }
        }
        black_box(acc);
        bl_rate = bl_rate.max(n_samples as f64 / t.elapsed().as_secs_f64() / 1e6);
        let t = Instant::now();
        let mut acc = 0.0f64;
        for (sp, &u) in bl_points.iter().zip(&us) {
            let imp = BlImportance::new(black_box(sp)).expect("valid shading point");
            let cut = LightCut::build(&tree, &imp, &cut_opts);
            acc += cut.sample(&tree, &imp, u).map_or(0.0, |s| f64::from(s.pmf));
        }
        black_box(acc);
        bl_single_rate =
            bl_single_rate.max(bl_points.len() as f64 / t.elapsed().as_secs_f64() / 1e6);
        let t = Instant::now();
        let mut sizes = 0usize;
        for sp in &bl_points {
            let imp = BlImportance::new(black_box(sp)).expect("valid shading point");
            sizes += LightCut::build(&tree, &imp, &cut_opts).len();
        }
        black_box(sizes);
        bl_builds = bl_builds.max(bl_points.len() as f64 / t.elapsed().as_secs_f64());
    }

    // Sum of every light's pmf at 100 shading points.
    let pmf_sum_max_err = if cfg.lights <= 100_000 {
        let mut worst = 0.0f64;
        for p in points.iter().take(100) {
            let imp = TlImportance::new(p.position, p.normal);
            let sum: f64 = (0..cfg.lights as u32)
                .map(|l| f64::from(tree.pmf(&imp, l)))
                .sum();
            if sum > 0.0 {
                worst = worst.max((sum - 1.0).abs());
            }
        }
        Some(worst)
    } else {
        None
    };

    let mut report = build_report;
    let sampling = json!({
        "points": cfg.points,
        "tl_msamples_per_s": tl,
        "baseline_msamples_per_s": base,
        "speedup": tl / base,
        "pmf_mqueries_per_s": pmf_rate,
        "pmf_max_rel_err": max_rel,
        "pmf_sum_max_err": pmf_sum_max_err,
        "returned_fraction": returned as f64 / cfg.points.max(1) as f64,
        "bl_msamples_per_s": bl_rate,
        "bl_single_msamples_per_s": bl_single_rate,
        "bl_vs_tl": bl_rate / tl,
        "cut_builds_per_s": bl_builds,
        "avg_cut_size": bl_cut_size as f64 / cfg.points.max(1) as f64,
        "avg_bl_budget": bl_budget as f64 / cfg.points.max(1) as f64,
        "split_msamples_per_s": split_rate,
        "split_each_msamples_per_s": split_each_rate,
        "split_each_speedup": split_each_rate / split_rate,
        "split_cut_builds_per_s": split_builds,
        "avg_split_cut_size": cut_size_sum as f64 / cfg.points.max(1) as f64,
    });
    if let (Some(r), Some(s)) = (report.as_object_mut(), sampling.as_object()) {
        r.extend(s.iter().map(|(k, v)| (k.clone(), v.clone())));
    }
    report
}

/// The report as a human-readable table.
pub fn table(r: &serde_json::Value) -> String {
    let f = |k: &str| r[k].as_f64().map_or("-".to_string(), |v| format!("{v:.4}"));
    let rows = [
        ("lights", "lights"),
        ("shading points", "points"),
        ("build (ms, best of the repeats)", "build_ms"),
        ("build, thread CPU time (ms, best)", "build_cpu_ms"),
        (
            "build peak heap (bytes per light)",
            "build_peak_bytes_per_light",
        ),
        ("baseline build (ms)", "baseline_build_ms"),
        (
            "baseline build, thread CPU time (ms)",
            "baseline_build_cpu_ms",
        ),
        (
            "baseline build peak heap (bytes per light)",
            "baseline_build_peak_bytes_per_light",
        ),
        ("bytes per light", "bytes_per_light"),
        ("baseline bytes per light", "baseline_bytes_per_light"),
        ("nodes", "nodes"),
        ("mean slots filled", "mean_fill"),
        ("depth", "depth"),
        ("4-wide TL (Msamples/s)", "tl_msamples_per_s"),
        ("binary baseline (Msamples/s)", "baseline_msamples_per_s"),
        ("speedup", "speedup"),
        ("pmf queries (M/s)", "pmf_mqueries_per_s"),
        ("pmf max rel. error", "pmf_max_rel_err"),
        ("pmf sum max error", "pmf_sum_max_err"),
        ("points with a sample", "returned_fraction"),
        (
            "BL, GGX α=0.2: cut + budget N samples (M samples/s)",
            "bl_msamples_per_s",
        ),
        (
            "BL: cut + 1 sample (M samples/s)",
            "bl_single_msamples_per_s",
        ),
        ("BL / TL throughput", "bl_vs_tl"),
        ("BL cut builds (per s)", "cut_builds_per_s"),
        ("mean BL cut size", "avg_cut_size"),
        ("mean BL budget N = ceil(50 IB)", "avg_bl_budget"),
        (
            "split sampling, cut + 1 sample/cluster (M light samples/s)",
            "split_msamples_per_s",
        ),
        (
            "the same with sample_each (M light samples/s)",
            "split_each_msamples_per_s",
        ),
        ("sample_each / sample_in", "split_each_speedup"),
        ("split cut builds (per s)", "split_cut_builds_per_s"),
        ("mean split cut size", "avg_split_cut_size"),
    ];
    let mut s = String::from("| measure | value |\n|---|---|\n");
    if let Some(k) = r["kinds"].as_str() {
        s.push_str(&format!("| scene | {k} |\n"));
    }
    // A build-only report has no sampling rows.
    for (name, key) in rows.into_iter().filter(|(_, k)| r.get(k).is_some()) {
        s.push_str(&format!("| {name} | {} |\n", f(key)));
    }
    s
}
