//! `mlrender bench`: build time, memory and single-threaded sampling throughput of the 4-wide
//! tree against the binary scalar baseline, measured in one run, plus the exactness of the
//! pmfs. The build's peak heap is measured with [`crate::alloc_count`] when that is the global
//! allocator (as in `mlrender`).

use crate::alloc_count;
use manylights::baseline::BinaryLightTree;
use manylights::{
    BlCutOptions, BlImportance, Light, LightCut, LightTree, Material, Memo, MemoTable,
    ShadingPoint, SplitCutOptions, TlImportance, CUT_CAPACITY,
};
use manylights_ffi as ffi;
use manylights_testkit::{self as random_scene, BenchPoint};
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

/// Shading points per batch call (a wavefront's worth).
const BATCH: usize = 256;

/// Samples per shading point in the Memo comparison.
const MEMO_SAMPLES: usize = 8;

/// Throughput of one pass over the shading points, in million samples per second.
fn time_pass(
    points: &[BenchPoint],
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

/// Throughput of the C ABI's batch TL sampling (`ml_tree_sample_tl_batch`, called through its
/// `extern "C"` symbol) over the points, in million samples per second.
fn time_ffi_batch(
    tree: *const ffi::ml_tree,
    points: &[ffi::ml_tl_point],
    us: &[f32],
    out: &mut [ffi::ml_light_sample],
) -> (f64, f64) {
    let t = Instant::now();
    for ((p, u), o) in points
        .chunks(BATCH)
        .zip(us.chunks(BATCH))
        .zip(out.chunks_mut(BATCH))
    {
        let status = ffi::ml_tree_sample_tl_batch(
            black_box(tree),
            p.as_ptr(),
            u.as_ptr(),
            p.len(),
            o.as_mut_ptr(),
        );
        assert_eq!(status, ffi::ML_OK, "the bench's batch call is valid");
    }
    let s = t.elapsed().as_secs_f64();
    let acc = out.iter().map(|o| f64::from(o.pmf)).sum();
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

    // The same lights and points through the C ABI.
    let descs: Vec<ffi::ml_light> = lights.iter().map(ffi::ml_light::from).collect();
    let mut ffi_tree: *mut ffi::ml_tree = std::ptr::null_mut();
    let status = ffi::ml_tree_build(descs.as_ptr(), descs.len(), std::ptr::null(), &mut ffi_tree);
    assert_eq!(status, ffi::ML_OK, "the bench scene is valid");
    let ffi_points: Vec<ffi::ml_tl_point> = points
        .iter()
        .map(|p| ffi::ml_tl_point {
            position: p.position.into(),
            normal: p.normal.into(),
        })
        .collect();
    let mut ffi_out = vec![ffi::ml_light_sample::default(); points.len()];

    // Alternate the samplers so that all see the same machine state; keep the best of each.
    let mut tl = 0.0f64;
    let mut base = 0.0f64;
    let mut ffi_batch = 0.0f64;
    let mut tl_batch = 0.0f64;
    let mut checksum = 0.0;
    let mut imps: Vec<TlImportance> = Vec::with_capacity(BATCH);
    let mut batch_out: Vec<Option<manylights::LightSample>> = vec![None; BATCH];
    for _ in 0..cfg.repeats.max(1) {
        // The C ABI's batch call over the same chunks.
        let (r, c) = time_ffi_batch(ffi_tree, &ffi_points, &us, &mut ffi_out);
        ffi_batch = ffi_batch.max(r);
        checksum += c;
        // The batch call, BATCH shading points at a time, the importances built in the loop.
        let t = Instant::now();
        let acc = random_scene::sample_batches(&tree, &points, &us, &mut imps, &mut batch_out);
        tl_batch = tl_batch.max(points.len() as f64 / t.elapsed().as_secs_f64() / 1e6);
        checksum += f64::from(acc);
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
    // The C ABI's batch samples are the Rust core's, bit for bit.
    let ffi_equal = ffi_points
        .iter()
        .zip(&us)
        .zip(&ffi_out)
        .all(|((p, &u), o)| {
            let s = tree.sample(&TlImportance::new(p.position.into(), p.normal.into()), u);
            ffi::ml_light_sample::from(s) == *o
        });
    assert!(
        ffi_equal,
        "the C ABI's batch samples differ from the core's"
    );
    assert_eq!(ffi::ml_tree_free(ffi_tree), ffi::ML_OK);

    // The samples once more, kept for the pmf queries.
    let samples: Vec<Option<manylights::LightSample>> = points
        .iter()
        .zip(&us)
        .map(|(p, &u)| tree.sample(&TlImportance::new(p.position, p.normal), u))
        .collect();
    let returned = samples.iter().filter(|s| s.is_some()).count();
    let mut pmf_rate = 0.0f64;
    let mut pmf_batch_rate = 0.0f64;
    let mut max_rel = 0.0f64;
    let queried: Vec<(usize, u32)> = samples
        .iter()
        .enumerate()
        .filter_map(|(j, s)| s.map(|s| (j, s.light)))
        .collect();
    let mut batch_pmfs = vec![0.0f32; BATCH];
    for _ in 0..cfg.repeats.max(1) {
        // The same queries through the batch call.
        let t = Instant::now();
        let mut acc = 0.0f64;
        let mut lights_of = Vec::with_capacity(BATCH);
        for chunk in queried.chunks(BATCH) {
            imps.clear();
            lights_of.clear();
            for &(j, l) in chunk {
                imps.push(TlImportance::new(points[j].position, points[j].normal));
                lights_of.push(l);
            }
            tree.pmf_batch(
                black_box(&imps),
                black_box(&lights_of),
                &mut batch_pmfs[..chunk.len()],
            )
            .expect("one light per point");
            acc += batch_pmfs[..chunk.len()]
                .iter()
                .map(|&q| f64::from(q))
                .sum::<f64>();
        }
        black_box(acc);
        pmf_batch_rate = pmf_batch_rate.max(queried.len() as f64 / t.elapsed().as_secs_f64() / 1e6);
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

    // Eight samples per shading point, with and without a Memo (its table reused from point to
    // point, as a renderer keeps one per thread).
    let table = MemoTable::new();
    let mut memo_rate = 0.0f64;
    let mut no_memo_rate = 0.0f64;
    let per = MEMO_SAMPLES;
    let memo_points = &points[..points.len() / per];
    for _ in 0..cfg.repeats.max(1) {
        let t = Instant::now();
        let mut acc = 0.0f64;
        for (p, uc) in memo_points.iter().zip(us.chunks(per)) {
            let imp = TlImportance::new(p.position, p.normal);
            for &u in uc {
                acc += tree
                    .sample(black_box(&imp), u)
                    .map_or(0.0, |s| f64::from(s.pmf));
            }
        }
        black_box(acc);
        no_memo_rate =
            no_memo_rate.max((memo_points.len() * per) as f64 / t.elapsed().as_secs_f64() / 1e6);
        let t = Instant::now();
        let mut acc = 0.0f64;
        for (p, uc) in memo_points.iter().zip(us.chunks(per)) {
            let memo = Memo::new(TlImportance::new(p.position, p.normal), &tree, &table);
            for &u in uc {
                acc += tree
                    .sample(black_box(&memo), u)
                    .map_or(0.0, |s| f64::from(s.pmf));
            }
        }
        black_box(acc);
        memo_rate =
            memo_rate.max((memo_points.len() * per) as f64 / t.elapsed().as_secs_f64() / 1e6);
    }

    // Split sampling: build the Conty–Kulla cut, then one sample per cluster.
    let split_opts = SplitCutOptions::default();
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
    let bl_points: Vec<ShadingPoint> = points
        .iter()
        .zip(random_scene::shading_points(points.len(), cfg.seed ^ 0xb1))
        .map(|(p, q)| {
            let wo = if q.normal.dot(p.normal) < 0.0 {
                -q.normal
            } else {
                q.normal
            };
            ShadingPoint {
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
    let cut_opts = BlCutOptions::default();
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
            let cut = LightCut::build_bl(&tree, &imp, &cut_opts);
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
            let cut = LightCut::build_bl(&tree, &imp, &cut_opts);
            acc += cut.sample(&tree, &imp, u).map_or(0.0, |s| f64::from(s.pmf));
        }
        black_box(acc);
        bl_single_rate =
            bl_single_rate.max(bl_points.len() as f64 / t.elapsed().as_secs_f64() / 1e6);
        let t = Instant::now();
        let mut sizes = 0usize;
        for sp in &bl_points {
            let imp = BlImportance::new(black_box(sp)).expect("valid shading point");
            sizes += LightCut::build_bl(&tree, &imp, &cut_opts).len();
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
        "tl_batch_msamples_per_s": tl_batch,
        "batch_speedup": tl_batch / tl,
        "batch_size": BATCH,
        "batch_lanes": manylights::BATCH_LANES,
        "ffi_batch_msamples_per_s": ffi_batch,
        "ffi_batch_vs_tl_batch": ffi_batch / tl_batch,
        "pmf_mqueries_per_s": pmf_rate,
        "pmf_batch_mqueries_per_s": pmf_batch_rate,
        "tl_8_per_point_msamples_per_s": no_memo_rate,
        "tl_8_per_point_memo_msamples_per_s": memo_rate,
        "memo_speedup": memo_rate / no_memo_rate,
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
        (
            "4-wide TL, batch of 256 points (Msamples/s)",
            "tl_batch_msamples_per_s",
        ),
        ("batch / single", "batch_speedup"),
        (
            "C ABI batch TL, ml_tree_sample_tl_batch (Msamples/s)",
            "ffi_batch_msamples_per_s",
        ),
        ("C ABI batch / Rust batch", "ffi_batch_vs_tl_batch"),
        ("pmf queries (M/s)", "pmf_mqueries_per_s"),
        ("pmf queries, batch (M/s)", "pmf_batch_mqueries_per_s"),
        (
            "8 samples per point (Msamples/s)",
            "tl_8_per_point_msamples_per_s",
        ),
        (
            "8 samples per point with a Memo (Msamples/s)",
            "tl_8_per_point_memo_msamples_per_s",
        ),
        ("Memo / no Memo", "memo_speedup"),
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
