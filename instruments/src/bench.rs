//! `mlmeasure bench`: build time, memory and single-threaded sampling throughput of the 4-wide
//! tree against the binary scalar baseline, measured in one run, plus the exactness of the
//! pmfs. The build's peak heap is measured with [`crate::alloc_count`] when that is the global
//! allocator (as in `mlmeasure`).
//!
//! [`run`] returns a typed [`BenchReport`]; [`BenchReport::to_json`] gives the one flat JSON
//! object that `mlmeasure bench --json` prints (every field of the nested groups is a top-level
//! key, named as the field), and [`table`] the human table.

use crate::alloc_count;
use manylights::baseline::BinaryLightTree;
use manylights::cut::CUT_CAPACITY;
use manylights::importance::MemoTable;
use manylights::{
    BlCutOptions, BlImportance, BuildOptions, Light, LightCut, LightTree, Material, Memo,
    ShadingPoint, SplitCutOptions, TlImportance,
};
use manylights_ffi as ffi;
use manylights_testkit::{self as random_scene, BenchPoint};
use serde::{Serialize, Serializer};
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
    let cpu = manylights_render::render::busy_time(|| out = Some(f()));
    let ms = t.elapsed().as_secs_f64() * 1e3;
    // Saturating: another thread of the process may have reset the peak meanwhile.
    let peak = alloc_count::peak().saturating_sub(base);
    let time = BuildTime {
        ms,
        cpu_ms: cpu * 1e3,
        peak: alloc_count::installed().then_some(peak),
    };
    (out.expect("the build ran"), time)
}

/// The CPU seconds each of rayon's threads and the calling thread has run so far; `None`
/// without a thread CPU clock.
fn threads_cpu_seconds() -> Option<(Vec<f64>, f64)> {
    let pool: Option<Vec<f64>> =
        rayon::broadcast(|_| manylights_render::render::thread_cpu_seconds())
            .into_iter()
            .collect();
    Some((pool?, manylights_render::render::thread_cpu_seconds()?))
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
pub const BATCH: usize = 256;

/// Samples per shading point in the Memo comparison.
pub const MEMO_SAMPLES: usize = 8;

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

/// The report of one `mlmeasure bench` run: the run's settings, the builds, the trees' size and
/// shape, and (unless the run was build-only) the sampling passes and the pmf checks.
///
/// Rates are the best of the repeats; a ratio is of those best rates. A figure that is not a
/// finite number (a ratio of two zero rates) is `null` in the JSON and `-` in the table.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// What was measured.
    #[serde(flatten)]
    pub run: RunInfo,
    /// The builds of the 4-wide tree and the binary baseline.
    #[serde(flatten)]
    pub build: BuildFigures,
    /// The size and shape of the trees built.
    #[serde(flatten)]
    pub shape: TreeShape,
    /// The sampling passes and pmf checks; `None` for a build-only run.
    #[serde(flatten)]
    pub sampling: Option<SamplingReport>,
}

impl BenchReport {
    /// The report as the one flat JSON object of `mlmeasure bench --json`: the keys are the
    /// field names of the groups, in serde_json's map order.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("a report of numbers and strings serialises")
    }
}

/// The run's settings.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct RunInfo {
    /// Number of lights.
    pub lights: usize,
    /// The scene, by its command-line name ([`SceneKinds::name`]).
    #[serde(serialize_with = "scene_name")]
    pub kinds: SceneKinds,
    /// Seed of the scene, the points and the uniform numbers.
    pub seed: u64,
    /// Timed repetitions of each build and pass (at least 1).
    pub repeats: usize,
}

fn scene_name<S: Serializer>(kinds: &SceneKinds, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(kinds.name())
}

/// The builds: the fastest wall-clock and thread CPU milliseconds of the repeats, and the
/// largest peak heap per light (`None` without the counting allocator).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct BuildFigures {
    /// [`LightTree::build`], wall-clock ms.
    pub build_ms: f64,
    /// [`LightTree::build`], thread CPU ms.
    pub build_cpu_ms: f64,
    /// [`LightTree::build`], peak heap bytes per light (the tree included).
    pub build_peak_bytes_per_light: Option<f64>,
    /// [`LightTree::build_parallel`] on rayon's pool ([`manylights_testkit::RayonJoin`]), wall-clock ms;
    /// the tree is checked to be the serial build's, byte for byte.
    pub build_parallel_ms: f64,
    /// [`LightTree::build_parallel`], CPU ms of the calling thread plus those of the busiest
    /// of rayon's threads during the build (best of the repeats): the calling thread works
    /// only while the pool waits for it, and waits while the pool works, so this is about
    /// what the parallel build takes when every thread has a core of its own, whatever else
    /// the machine runs. `None` without a thread CPU clock.
    pub build_parallel_cpu_ms: Option<f64>,
    /// Threads of rayon's pool (`RAYON_NUM_THREADS`, else one per core).
    pub build_threads: usize,
    /// [`BinaryLightTree::build`], wall-clock ms.
    pub baseline_build_ms: f64,
    /// [`BinaryLightTree::build`], thread CPU ms.
    pub baseline_build_cpu_ms: f64,
    /// [`BinaryLightTree::build`], peak heap bytes per light (the tree included).
    pub baseline_build_peak_bytes_per_light: Option<f64>,
}

/// The trees' memory and the 4-wide tree's shape ([`LightTree::stats`]).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct TreeShape {
    /// The 4-wide tree's bytes per light.
    pub bytes_per_light: f32,
    /// The binary baseline's bytes per light.
    pub baseline_bytes_per_light: f64,
    /// Nodes of the 4-wide tree.
    pub nodes: u32,
    /// Mean filled slots per node.
    pub mean_fill: f32,
    /// Levels of nodes.
    pub depth: u32,
}

/// The sampling passes over the shading points and the pmf checks.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SamplingReport {
    /// Number of shading points.
    pub points: usize,
    /// One TL sample per point, the 4-wide tree against the baseline.
    #[serde(flatten)]
    pub single: SingleThroughput,
    /// The Rust batch call.
    #[serde(flatten)]
    pub batch: BatchThroughput,
    /// The C ABI's batch call.
    #[serde(flatten)]
    pub ffi: FfiThroughput,
    /// Pmf queries of the samples drawn.
    #[serde(flatten)]
    pub pmf: PmfThroughput,
    /// Eight samples per point, with and without a [`Memo`].
    #[serde(flatten)]
    pub memo: MemoThroughput,
    /// The pmfs' exactness.
    #[serde(flatten)]
    pub exactness: Exactness,
    /// BRDF-oriented sampling through a light cut.
    #[serde(flatten)]
    pub bl: BlThroughput,
    /// Split sampling through a Conty–Kulla cut.
    #[serde(flatten)]
    pub split: SplitThroughput,
}

/// One TL sample per shading point ([`LightTree::sample`], [`BinaryLightTree::sample`]).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SingleThroughput {
    /// The 4-wide tree, Msamples/s.
    pub tl_msamples_per_s: f64,
    /// The binary baseline, Msamples/s.
    pub baseline_msamples_per_s: f64,
    /// `tl_msamples_per_s / baseline_msamples_per_s`.
    pub speedup: f64,
}

/// [`LightTree::sample_batch`], [`BATCH`] shading points a call, the importances built in the
/// loop.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct BatchThroughput {
    /// Msamples/s.
    pub tl_batch_msamples_per_s: f64,
    /// `tl_batch_msamples_per_s / tl_msamples_per_s`.
    pub batch_speedup: f64,
    /// Shading points per call ([`BATCH`]).
    pub batch_size: usize,
    /// [`manylights::internals::sample::BATCH_LANES`].
    pub batch_lanes: usize,
}

/// `ml_tree_sample_tl_batch` over the same chunks, called through its `extern "C"` symbol.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct FfiThroughput {
    /// Msamples/s.
    pub ffi_batch_msamples_per_s: f64,
    /// `ffi_batch_msamples_per_s / tl_batch_msamples_per_s`.
    pub ffi_batch_vs_tl_batch: f64,
}

/// [`LightTree::pmf`] and [`LightTree::pmf_batch`] of every sample drawn.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct PmfThroughput {
    /// One query a call, Mqueries/s.
    pub pmf_mqueries_per_s: f64,
    /// [`BATCH`] queries a call, Mqueries/s.
    pub pmf_batch_mqueries_per_s: f64,
}

/// [`MEMO_SAMPLES`] samples per shading point over the first `points / MEMO_SAMPLES` points.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MemoThroughput {
    /// Without a Memo, Msamples/s.
    pub tl_8_per_point_msamples_per_s: f64,
    /// With a Memo (one [`MemoTable`] reused from point to point), Msamples/s.
    pub tl_8_per_point_memo_msamples_per_s: f64,
    /// `tl_8_per_point_memo_msamples_per_s / tl_8_per_point_msamples_per_s`.
    pub memo_speedup: f64,
}

/// The exactness of the pmfs.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Exactness {
    /// Largest relative difference between a sample's pmf and [`LightTree::pmf`] of its light.
    pub pmf_max_rel_err: f64,
    /// Largest `|Σ pmf - 1|` over every light at the first 100 points with a positive sum;
    /// `None` above 100 000 lights.
    pub pmf_sum_max_err: Option<f64>,
    /// Fraction of the shading points that got a sample.
    pub returned_fraction: f64,
}

/// BRDF-oriented sampling, GGX α = 0.2, ωo uniform over the hemisphere of n: per point the
/// set-up, the light cut, then the budget N = ceil(50 · IB) samples drawn from it.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct BlThroughput {
    /// Cut + budget samples, Msamples/s.
    pub bl_msamples_per_s: f64,
    /// Cut + one sample, Msamples/s.
    pub bl_single_msamples_per_s: f64,
    /// `bl_msamples_per_s / tl_msamples_per_s`.
    pub bl_vs_tl: f64,
    /// Cut builds alone, per second.
    pub cut_builds_per_s: f64,
    /// Mean cut size.
    pub avg_cut_size: f64,
    /// Mean budget N.
    pub avg_bl_budget: f64,
}

/// Split sampling: the Conty–Kulla cut, then one sample per cluster.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SplitThroughput {
    /// Cut + [`LightCut::sample_in`] per cluster, M light samples/s.
    pub split_msamples_per_s: f64,
    /// Cut + [`LightCut::sample_each`], M light samples/s.
    pub split_each_msamples_per_s: f64,
    /// `split_each_msamples_per_s / split_msamples_per_s`.
    pub split_each_speedup: f64,
    /// Cut builds alone, per second.
    pub split_cut_builds_per_s: f64,
    /// Mean cut size.
    pub avg_split_cut_size: f64,
}

/// `n` per point of `m` points, 0 for no points.
fn per_point(n: usize, m: usize) -> f64 {
    n as f64 / m.max(1) as f64
}

/// Millions per second of `n` things done since `t`.
fn mega_per_s(n: usize, t: Instant) -> f64 {
    n as f64 / t.elapsed().as_secs_f64() / 1e6
}

/// Runs the benchmark; returns its report.
pub fn run(cfg: &BenchConfig) -> BenchReport {
    let lights = cfg.kinds.lights(cfg.lights, cfg.seed);
    let repeats = cfg.repeats.max(1);
    let (tree, baseline, build, shape) = measure_builds(&lights, cfg.lights, repeats);
    let run = RunInfo {
        lights: cfg.lights,
        kinds: cfg.kinds,
        seed: cfg.seed,
        repeats,
    };
    let sampling =
        (!cfg.build_only).then(|| measure_sampling(cfg, &lights, &tree, &baseline, repeats));
    BenchReport {
        run,
        build,
        shape,
        sampling,
    }
}

/// Builds the 4-wide tree and the binary baseline `repeats` times each; returns the last
/// trees, the build figures and the trees' size and shape (bytes divided by `n`, the lights
/// asked for, or 1 for none).
fn measure_builds(
    lights: &[Light],
    n: usize,
    repeats: usize,
) -> (LightTree, BinaryLightTree, BuildFigures, TreeShape) {
    let per_light = |bytes: usize| bytes as f64 / n.max(1) as f64;
    let (tree, time) = best_build(repeats, || {
        LightTree::build(lights).expect("the bench scene is valid")
    });
    let threads = rayon::current_num_threads();
    let mut busiest: Option<f64> = None;
    let (parallel, parallel_time) = best_build(repeats, || {
        let before = threads_cpu_seconds();
        let tree = LightTree::build_parallel(
            lights,
            &BuildOptions::default(),
            &manylights_testkit::RayonJoin,
        )
        .expect("the bench scene is valid");
        if let (Some((pool_b, caller_b)), Some((pool_a, caller_a))) =
            (before, threads_cpu_seconds())
        {
            let pool = pool_a
                .iter()
                .zip(&pool_b)
                .map(|(a, b)| a - b)
                .fold(0.0, f64::max);
            let ms = (caller_a - caller_b + pool) * 1e3;
            busiest = Some(busiest.map_or(ms, |best| best.min(ms)));
        }
        tree
    });
    assert!(
        parallel.as_bytes() == tree.as_bytes(),
        "the parallel build differs from the serial one"
    );
    drop(parallel);
    let (baseline, baseline_time) = best_build(repeats, || {
        BinaryLightTree::build(lights).expect("the bench scene is valid")
    });
    let build = BuildFigures {
        build_ms: time.ms,
        build_cpu_ms: time.cpu_ms,
        build_peak_bytes_per_light: time.peak.map(per_light),
        build_parallel_ms: parallel_time.ms,
        build_parallel_cpu_ms: busiest,
        build_threads: threads,
        baseline_build_ms: baseline_time.ms,
        baseline_build_cpu_ms: baseline_time.cpu_ms,
        baseline_build_peak_bytes_per_light: baseline_time.peak.map(per_light),
    };
    let stats = tree.stats();
    let shape = TreeShape {
        bytes_per_light: stats.bytes_per_light,
        baseline_bytes_per_light: per_light(baseline.bytes()),
        nodes: stats.nodes,
        mean_fill: stats.mean_fill,
        depth: stats.depth,
    };
    (tree, baseline, build, shape)
}

/// Every sampling pass and pmf check over `cfg.points` seeded shading points, in a fixed order.
fn measure_sampling(
    cfg: &BenchConfig,
    lights: &[Light],
    tree: &LightTree,
    baseline: &BinaryLightTree,
    repeats: usize,
) -> SamplingReport {
    let points = random_scene::shading_points(cfg.points, cfg.seed);
    let us = random_scene::uniforms(cfg.points, cfg.seed);

    let mut ffi_bench = FfiBench::new(lights, &points);
    let (single, batch, ffi) =
        alternating_passes(tree, baseline, &mut ffi_bench, &points, &us, repeats);
    // The C ABI's batch samples are the Rust core's, bit for bit.
    assert!(
        ffi_bench.matches_core(tree, &us),
        "the C ABI's batch samples differ from the core's"
    );
    ffi_bench.free();

    // The samples once more, kept for the pmf queries.
    let samples: Vec<Option<manylights::SampledLight>> = points
        .iter()
        .zip(&us)
        .map(|(p, &u)| tree.sample(&TlImportance::new(p.position, p.normal), u))
        .collect();
    let returned = samples.iter().filter(|s| s.is_some()).count();
    let (pmf, pmf_max_rel_err) = pmf_passes(tree, &points, &samples, repeats);
    let memo = memo_passes(tree, &points, &us, repeats);
    let split = split_passes(tree, &points, &us, repeats);
    let bl_points = bl_points(&points, cfg.seed);
    let bl = bl_passes(tree, &bl_points, &us, repeats, single.tl_msamples_per_s);
    let exactness = Exactness {
        pmf_max_rel_err,
        pmf_sum_max_err: pmf_sum_max_err(tree, &points, cfg.lights),
        returned_fraction: per_point(returned, cfg.points),
    };
    SamplingReport {
        points: cfg.points,
        single,
        batch,
        ffi,
        pmf,
        memo,
        exactness,
        bl,
        split,
    }
}

/// The C ABI's tree of the bench's lights, its points and its output buffer.
struct FfiBench {
    tree: *mut ffi::ml_tree,
    points: Vec<ffi::ml_tl_point>,
    out: Vec<ffi::ml_sampled_light>,
}

impl FfiBench {
    /// The same lights and points through the C ABI.
    fn new(lights: &[Light], points: &[BenchPoint]) -> FfiBench {
        let descs: Vec<ffi::ml_light> = lights.iter().map(ffi::ml_light::from).collect();
        let mut tree: *mut ffi::ml_tree = std::ptr::null_mut();
        let status = ffi::ml_tree_build(
            descs.as_ptr(),
            descs.len(),
            std::ptr::null(),
            std::ptr::null(),
            &mut tree,
        );
        assert_eq!(status, ffi::ML_OK, "the bench scene is valid");
        let points: Vec<ffi::ml_tl_point> = points
            .iter()
            .map(|p| ffi::ml_tl_point {
                position: p.position.into(),
                normal: p.normal.into(),
                receiver: ffi::ml_receiver::Reflective as u32,
            })
            .collect();
        let out = vec![ffi::ml_sampled_light::default(); points.len()];
        FfiBench { tree, points, out }
    }

    /// Throughput of the C ABI's batch TL sampling (`ml_tree_sample_tl_batch`, called through
    /// its `extern "C"` symbol) over the points, in million samples per second, and the sum of
    /// the pmfs.
    fn pass(&mut self, us: &[f32]) -> (f64, f64) {
        let t = Instant::now();
        for ((p, u), o) in self
            .points
            .chunks(BATCH)
            .zip(us.chunks(BATCH))
            .zip(self.out.chunks_mut(BATCH))
        {
            let status = ffi::ml_tree_sample_tl_batch(
                black_box(self.tree),
                p.as_ptr(),
                u.as_ptr(),
                p.len(),
                o.as_mut_ptr(),
            );
            assert_eq!(status, ffi::ML_OK, "the bench's batch call is valid");
        }
        let s = t.elapsed().as_secs_f64();
        let acc = self.out.iter().map(|o| f64::from(o.pmf)).sum();
        (self.points.len() as f64 / s / 1e6, acc)
    }

    /// Whether the last pass's samples are `tree`'s, bit for bit.
    fn matches_core(&self, tree: &LightTree, us: &[f32]) -> bool {
        self.points
            .iter()
            .zip(us)
            .zip(&self.out)
            .all(|((p, &u), o)| {
                let s = tree.sample(&TlImportance::new(p.position.into(), p.normal.into()), u);
                ffi::ml_sampled_light::from(s) == *o
            })
    }

    fn free(self) {
        assert_eq!(ffi::ml_tree_free(self.tree), ffi::ML_OK);
    }
}

/// One TL sample per point through the C ABI's batch call, the Rust batch call, the 4-wide
/// tree and the baseline, alternated so that all see the same machine state; the best of
/// `repeats` of each.
fn alternating_passes(
    tree: &LightTree,
    baseline: &BinaryLightTree,
    ffi_bench: &mut FfiBench,
    points: &[BenchPoint],
    us: &[f32],
    repeats: usize,
) -> (SingleThroughput, BatchThroughput, FfiThroughput) {
    let mut tl = 0.0f64;
    let mut base = 0.0f64;
    let mut ffi_batch = 0.0f64;
    let mut tl_batch = 0.0f64;
    let mut checksum = 0.0;
    let mut imps: Vec<TlImportance> = Vec::with_capacity(BATCH);
    let mut batch_out: Vec<Option<manylights::SampledLight>> = vec![None; BATCH];
    for _ in 0..repeats {
        // The C ABI's batch call over the same chunks.
        let (r, c) = ffi_bench.pass(us);
        ffi_batch = ffi_batch.max(r);
        checksum += c;
        // The batch call, BATCH shading points at a time, the importances built in the loop.
        let t = Instant::now();
        let acc = random_scene::sample_batches(tree, points, us, &mut imps, &mut batch_out);
        tl_batch = tl_batch.max(mega_per_s(points.len(), t));
        checksum += f64::from(acc);
        let (r, c) = time_pass(points, us, |imp, u| {
            tree.sample(imp, u).map_or(0.0, |s| s.pmf)
        });
        tl = tl.max(r);
        checksum += c;
        let (r, c) = time_pass(points, us, |imp, u| {
            baseline.sample(imp, u).map_or(0.0, |s| s.pmf)
        });
        base = base.max(r);
        checksum += c;
    }
    black_box(checksum);
    (
        SingleThroughput {
            tl_msamples_per_s: tl,
            baseline_msamples_per_s: base,
            speedup: tl / base,
        },
        BatchThroughput {
            tl_batch_msamples_per_s: tl_batch,
            batch_speedup: tl_batch / tl,
            batch_size: BATCH,
            batch_lanes: manylights::internals::sample::BATCH_LANES,
        },
        FfiThroughput {
            ffi_batch_msamples_per_s: ffi_batch,
            ffi_batch_vs_tl_batch: ffi_batch / tl_batch,
        },
    )
}

/// The pmf of every sample's light, through the batch call and one query at a time, the best
/// of `repeats` of each; also the largest relative difference between a sample's pmf and the
/// single query's.
fn pmf_passes(
    tree: &LightTree,
    points: &[BenchPoint],
    samples: &[Option<manylights::SampledLight>],
    repeats: usize,
) -> (PmfThroughput, f64) {
    let mut pmf_rate = 0.0f64;
    let mut pmf_batch_rate = 0.0f64;
    let mut max_rel = 0.0f64;
    let queried: Vec<(usize, u32)> = samples
        .iter()
        .enumerate()
        .filter_map(|(j, s)| s.map(|s| (j, s.light)))
        .collect();
    let mut imps: Vec<TlImportance> = Vec::with_capacity(BATCH);
    let mut batch_pmfs = vec![0.0f32; BATCH];
    for _ in 0..repeats {
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
        pmf_batch_rate = pmf_batch_rate.max(mega_per_s(queried.len(), t));
        let t = Instant::now();
        let mut acc = 0.0f64;
        let mut n = 0usize;
        for (p, s) in points.iter().zip(samples) {
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
        pmf_rate = pmf_rate.max(mega_per_s(n, t));
    }
    (
        PmfThroughput {
            pmf_mqueries_per_s: pmf_rate,
            pmf_batch_mqueries_per_s: pmf_batch_rate,
        },
        max_rel,
    )
}

/// [`MEMO_SAMPLES`] samples per shading point, without and with a Memo (its table reused from
/// point to point, as a renderer keeps one per thread); the best of `repeats` of each.
fn memo_passes(
    tree: &LightTree,
    points: &[BenchPoint],
    us: &[f32],
    repeats: usize,
) -> MemoThroughput {
    let table = MemoTable::new();
    let mut memo_rate = 0.0f64;
    let mut no_memo_rate = 0.0f64;
    let per = MEMO_SAMPLES;
    let memo_points = &points[..points.len() / per];
    for _ in 0..repeats {
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
        no_memo_rate = no_memo_rate.max(mega_per_s(memo_points.len() * per, t));
        let t = Instant::now();
        let mut acc = 0.0f64;
        for (p, uc) in memo_points.iter().zip(us.chunks(per)) {
            let memo = Memo::new(TlImportance::new(p.position, p.normal), tree, &table);
            for &u in uc {
                acc += tree
                    .sample(black_box(&memo), u)
                    .map_or(0.0, |s| f64::from(s.pmf));
            }
        }
        black_box(acc);
        memo_rate = memo_rate.max(mega_per_s(memo_points.len() * per, t));
    }
    MemoThroughput {
        tl_8_per_point_msamples_per_s: no_memo_rate,
        tl_8_per_point_memo_msamples_per_s: memo_rate,
        memo_speedup: memo_rate / no_memo_rate,
    }
}

/// Split sampling per shading point: the Conty–Kulla cut and one sample per cluster through
/// `sample_in` and through `sample_each`, and the cut construction alone; the best of
/// `repeats` of each.
fn split_passes(
    tree: &LightTree,
    points: &[BenchPoint],
    us: &[f32],
    repeats: usize,
) -> SplitThroughput {
    let split_opts = SplitCutOptions::default();
    let mut split_rate = 0.0f64;
    let mut split_each_rate = 0.0f64;
    let mut split_builds = 0.0f64;
    let mut cut_size_sum = 0usize;
    for _ in 0..repeats {
        let t = Instant::now();
        let mut acc = 0.0f64;
        let mut n_samples = 0usize;
        cut_size_sum = 0;
        for (p, &u) in points.iter().zip(us) {
            let imp = TlImportance::new(p.position, p.normal);
            let cut = LightCut::build_split(tree, black_box(&imp), &split_opts);
            cut_size_sum += cut.len();
            for i in 0..cut.len() {
                if let Some(s) = cut.sample_in(tree, &imp, i, black_box(u)) {
                    acc += f64::from(s.pmf);
                    n_samples += 1;
                }
            }
        }
        black_box(acc);
        split_rate = split_rate.max(mega_per_s(n_samples, t));
        // The same samples drawn by `sample_each` (descents interleaved four at a time).
        let t = Instant::now();
        let mut acc = 0.0f64;
        let mut n_samples = 0usize;
        let mut out = [None; CUT_CAPACITY];
        for (p, &u) in points.iter().zip(us) {
            let imp = TlImportance::new(p.position, p.normal);
            let cut = LightCut::build_split(tree, black_box(&imp), &split_opts);
            let u_all = [black_box(u); CUT_CAPACITY];
            cut.sample_each(tree, &imp, &u_all[..cut.len()], &mut out[..cut.len()]);
            for s in out[..cut.len()].iter().flatten() {
                acc += f64::from(s.pmf);
                n_samples += 1;
            }
        }
        black_box(acc);
        split_each_rate = split_each_rate.max(mega_per_s(n_samples, t));
        // Cut construction alone.
        let t = Instant::now();
        let mut sizes = 0usize;
        for p in points {
            let imp = TlImportance::new(p.position, p.normal);
            sizes += LightCut::build_split(tree, black_box(&imp), &split_opts).len();
        }
        black_box(sizes);
        split_builds = split_builds.max(points.len() as f64 / t.elapsed().as_secs_f64());
    }
    SplitThroughput {
        split_msamples_per_s: split_rate,
        split_each_msamples_per_s: split_each_rate,
        split_each_speedup: split_each_rate / split_rate,
        split_cut_builds_per_s: split_builds,
        avg_split_cut_size: per_point(cut_size_sum, points.len()),
    }
}

/// The shading points of the BRDF-oriented passes: `points` with GGX α = 0.2 and ωo uniform
/// over the hemisphere of n (from a second set of points seeded by `seed ^ 0xb1`).
fn bl_points(points: &[BenchPoint], seed: u64) -> Vec<ShadingPoint> {
    points
        .iter()
        .zip(random_scene::shading_points(points.len(), seed ^ 0xb1))
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
        .collect()
}

/// BRDF-oriented sampling per shading point: set-up, the light cut, then the budget
/// N = ceil(50 · IB) samples drawn from it (how the method uses a cut); separately cut + one
/// sample, and the cut construction alone; the best of `repeats` of each. `tl` is the 4-wide
/// TL rate the BL rate is compared with.
fn bl_passes(
    tree: &LightTree,
    bl_points: &[ShadingPoint],
    us: &[f32],
    repeats: usize,
    tl: f64,
) -> BlThroughput {
    let cut_opts = BlCutOptions::default();
    let mut bl_rate = 0.0f64;
    let mut bl_single_rate = 0.0f64;
    let mut bl_builds = 0.0f64;
    let mut bl_cut_size = 0usize;
    let mut bl_budget = 0usize;
    for _ in 0..repeats {
        let t = Instant::now();
        let mut acc = 0.0f64;
        let mut n_samples = 0usize;
        bl_cut_size = 0;
        bl_budget = 0;
        for (sp, &u) in bl_points.iter().zip(us) {
            let imp = BlImportance::new(black_box(sp)).expect("valid shading point");
            let cut = LightCut::build_bl(tree, &imp, &cut_opts);
            bl_cut_size += cut.len();
            let n = manylights::internals::mis::sample_budget(
                cut.max_score(),
                manylights::internals::mis::N_MAX,
            );
            bl_budget += n as usize;
            for j in 0..n {
                let uj = (u + j as f32 * 0.618_034).fract();
                if let Some(s) = cut.sample(tree, &imp, black_box(uj)) {
                    acc += f64::from(s.pmf);
                    n_samples += 1;
                }
            }
        }
        black_box(acc);
        bl_rate = bl_rate.max(mega_per_s(n_samples, t));
        let t = Instant::now();
        let mut acc = 0.0f64;
        for (sp, &u) in bl_points.iter().zip(us) {
            let imp = BlImportance::new(black_box(sp)).expect("valid shading point");
            let cut = LightCut::build_bl(tree, &imp, &cut_opts);
            acc += cut.sample(tree, &imp, u).map_or(0.0, |s| f64::from(s.pmf));
        }
        black_box(acc);
        bl_single_rate = bl_single_rate.max(mega_per_s(bl_points.len(), t));
        let t = Instant::now();
        let mut sizes = 0usize;
        for sp in bl_points {
            let imp = BlImportance::new(black_box(sp)).expect("valid shading point");
            sizes += LightCut::build_bl(tree, &imp, &cut_opts).len();
        }
        black_box(sizes);
        bl_builds = bl_builds.max(bl_points.len() as f64 / t.elapsed().as_secs_f64());
    }
    BlThroughput {
        bl_msamples_per_s: bl_rate,
        bl_single_msamples_per_s: bl_single_rate,
        bl_vs_tl: bl_rate / tl,
        cut_builds_per_s: bl_builds,
        avg_cut_size: per_point(bl_cut_size, bl_points.len()),
        avg_bl_budget: per_point(bl_budget, bl_points.len()),
    }
}

/// The largest `|Σ pmf - 1|` of every one of the `lights` lights at the first 100 points
/// whose sum is positive; `None` above 100 000 lights (too slow).
fn pmf_sum_max_err(tree: &LightTree, points: &[BenchPoint], lights: usize) -> Option<f64> {
    if lights > 100_000 {
        return None;
    }
    let mut worst = 0.0f64;
    for p in points.iter().take(100) {
        let imp = TlImportance::new(p.position, p.normal);
        let sum: f64 = (0..lights as u32)
            .map(|l| f64::from(tree.pmf(&imp, l)))
            .sum();
        if sum > 0.0 {
            worst = worst.max((sum - 1.0).abs());
        }
    }
    Some(worst)
}

/// The table's rows: a label and a figure (NaN for a figure not measured).
fn rows(r: &BenchReport) -> Vec<(&'static str, f64)> {
    let (b, t) = (&r.build, &r.shape);
    let unmeasured = |v: Option<f64>| v.unwrap_or(f64::NAN);
    let mut rows = vec![("lights", r.run.lights as f64)];
    if let Some(s) = &r.sampling {
        rows.push(("shading points", s.points as f64));
    }
    rows.extend([
        ("build (ms, best of the repeats)", b.build_ms),
        ("build, thread CPU time (ms, best)", b.build_cpu_ms),
        (
            "build peak heap (bytes per light)",
            unmeasured(b.build_peak_bytes_per_light),
        ),
        ("parallel build (ms, best)", b.build_parallel_ms),
        (
            "parallel build, CPU time of the caller and the busiest thread (ms, best)",
            unmeasured(b.build_parallel_cpu_ms),
        ),
        ("parallel build threads", b.build_threads as f64),
        ("baseline build (ms)", b.baseline_build_ms),
        (
            "baseline build, thread CPU time (ms)",
            b.baseline_build_cpu_ms,
        ),
        (
            "baseline build peak heap (bytes per light)",
            unmeasured(b.baseline_build_peak_bytes_per_light),
        ),
        ("bytes per light", f64::from(t.bytes_per_light)),
        ("baseline bytes per light", t.baseline_bytes_per_light),
        ("nodes", f64::from(t.nodes)),
        ("mean slots filled", f64::from(t.mean_fill)),
        ("depth", f64::from(t.depth)),
    ]);
    // A build-only report has no sampling rows.
    let Some(s) = &r.sampling else {
        return rows;
    };
    rows.extend([
        ("4-wide TL (Msamples/s)", s.single.tl_msamples_per_s),
        (
            "binary baseline (Msamples/s)",
            s.single.baseline_msamples_per_s,
        ),
        ("speedup", s.single.speedup),
        (
            "4-wide TL, batch of 256 points (Msamples/s)",
            s.batch.tl_batch_msamples_per_s,
        ),
        ("batch / single", s.batch.batch_speedup),
        (
            "C ABI batch TL, ml_tree_sample_tl_batch (Msamples/s)",
            s.ffi.ffi_batch_msamples_per_s,
        ),
        ("C ABI batch / Rust batch", s.ffi.ffi_batch_vs_tl_batch),
        ("pmf queries (M/s)", s.pmf.pmf_mqueries_per_s),
        ("pmf queries, batch (M/s)", s.pmf.pmf_batch_mqueries_per_s),
        (
            "8 samples per point (Msamples/s)",
            s.memo.tl_8_per_point_msamples_per_s,
        ),
        (
            "8 samples per point with a Memo (Msamples/s)",
            s.memo.tl_8_per_point_memo_msamples_per_s,
        ),
        ("Memo / no Memo", s.memo.memo_speedup),
        ("pmf max rel. error", s.exactness.pmf_max_rel_err),
        ("pmf sum max error", unmeasured(s.exactness.pmf_sum_max_err)),
        ("points with a sample", s.exactness.returned_fraction),
        (
            "BL, GGX α=0.2: cut + budget N samples (M samples/s)",
            s.bl.bl_msamples_per_s,
        ),
        (
            "BL: cut + 1 sample (M samples/s)",
            s.bl.bl_single_msamples_per_s,
        ),
        ("BL / TL throughput", s.bl.bl_vs_tl),
        ("BL cut builds (per s)", s.bl.cut_builds_per_s),
        ("mean BL cut size", s.bl.avg_cut_size),
        ("mean BL budget N = ceil(50 IB)", s.bl.avg_bl_budget),
        (
            "split sampling, cut + 1 sample/cluster (M light samples/s)",
            s.split.split_msamples_per_s,
        ),
        (
            "the same with sample_each (M light samples/s)",
            s.split.split_each_msamples_per_s,
        ),
        ("sample_each / sample_in", s.split.split_each_speedup),
        ("split cut builds (per s)", s.split.split_cut_builds_per_s),
        ("mean split cut size", s.split.avg_split_cut_size),
    ]);
    rows
}

/// The report as a human-readable table: the scene, then one row per figure (a build-only
/// report has no sampling rows); a figure not measured or not finite is `-`.
pub fn table(r: &BenchReport) -> String {
    let mut s = String::from("| measure | value |\n|---|---|\n");
    s.push_str(&format!("| scene | {} |\n", r.run.kinds.name()));
    for (name, v) in rows(r) {
        let v = if v.is_finite() {
            format!("{v:.4}")
        } else {
            "-".to_string()
        };
        s.push_str(&format!("| {name} | {v} |\n"));
    }
    s
}
