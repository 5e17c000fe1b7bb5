//! Sampling throughput of the 4-wide tree against the binary scalar baseline (same build, same
//! TL importance, measured in one group so the ratio is read from one run), the batch calls
//! beside the single ones (every sample a new shading point, the importances built inside the
//! timed loop), BL sampling through a BRDF-oriented cut and split sampling with their per-point
//! set-up, pmf queries single and batch, build time against the binary build, cut construction
//! against one tree descent, and split sampling one descent at a time against interleaved
//! (`sample_each`); the descents alone (`descents`: run in both builds, with and without the
//! feature `prefetch`, to compare the hint with plain loads), and the build split over two threads against the serial build
//! (`build_parallel`).
//! Scene: the random scene of `mlmeasure bench` (fixed seed).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use manylights::baseline::BinaryLightTree;
use manylights::cut::CUT_CAPACITY;
use manylights::importance::MemoTable;
use manylights::Rgb;
use manylights::{
    BlCutOptions, BlImportance, BuildOptions, Join, LightCut, LightTree, Material, Memo,
    SampledLight, SplitCutOptions, TlImportance,
};
use manylights_testkit as random_scene;
use std::hint::black_box;

const POINTS: usize = 4096;
/// Shading points per batch call.
const BATCH: usize = 256;
/// The material of the BRDF-aware benches: both lobes, a glossy one of α = 0.2.
const PLASTIC: Material = Material::Plastic {
    albedo: Rgb::grey(0.5),
    specular: 0.5,
    alpha: 0.2,
};

fn sampling(c: &mut Criterion) {
    let mut group = c.benchmark_group("sample");
    group.sample_size(20);
    group.throughput(Throughput::Elements(POINTS as u64));
    let points = random_scene::shading_points(POINTS, 7);
    let sps = random_scene::surface_points(POINTS, 7, PLASTIC);
    let us = random_scene::uniforms(POINTS, 7);
    let cut_opts = BlCutOptions::default();
    let split_opts = SplitCutOptions::default();
    for n in [1_000usize, 100_000, 1_000_000] {
        let lights = random_scene::lights(n, 7);
        let tree = LightTree::build(&lights).unwrap();
        let binary = BinaryLightTree::build(&lights).unwrap();
        group.bench_with_input(BenchmarkId::new("4-wide", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (p, &u) in points.iter().zip(&us) {
                    let imp = TlImportance::new(p.position, p.normal);
                    acc += tree
                        .sample(black_box(&imp), black_box(u))
                        .map_or(0.0, |s| s.pmf);
                }
                acc
            })
        });
        group.bench_with_input(BenchmarkId::new("binary", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (p, &u) in points.iter().zip(&us) {
                    let imp = TlImportance::new(p.position, p.normal);
                    acc += binary
                        .sample(black_box(&imp), black_box(u))
                        .map_or(0.0, |s| s.pmf);
                }
                acc
            })
        });
        // The batch call, BATCH points at a time (a wavefront's worth).
        group.bench_with_input(BenchmarkId::new("4-wide batch", n), &n, |b, _| {
            let mut imps = Vec::with_capacity(BATCH);
            let mut out: Vec<Option<SampledLight>> = vec![None; BATCH];
            b.iter(|| random_scene::sample_batches(&tree, &points, &us, &mut imps, &mut out))
        });
        // BL through the BRDF-oriented cut: the importance and the cut built at every point
        // (what `bl` does per shading point), then one sample of the cut.
        group.bench_with_input(BenchmarkId::new("BL cut", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (sp, &u) in sps.iter().zip(&us) {
                    let imp = BlImportance::new(black_box(sp)).unwrap();
                    let cut = LightCut::build_bl(&tree, &imp, &cut_opts);
                    acc += cut.sample(&tree, &imp, black_box(u)).map_or(0.0, |s| s.pmf);
                }
                acc
            })
        });
        // Split sampling: the split cut built at every point, then one light in each of its
        // clusters (`sample_each`); an element is a shading point, not a sample.
        group.bench_with_input(BenchmarkId::new("split", n), &n, |b, _| {
            let mut out = [None; CUT_CAPACITY];
            b.iter(|| {
                let mut acc = 0.0f32;
                for (p, &u) in points.iter().zip(&us) {
                    let imp = TlImportance::new(p.position, p.normal);
                    let cut = LightCut::build_split(&tree, black_box(&imp), &split_opts);
                    let u_all = [black_box(u); CUT_CAPACITY];
                    cut.sample_each(&tree, &imp, &u_all[..cut.len()], &mut out[..cut.len()]);
                    acc += out[..cut.len()]
                        .iter()
                        .flatten()
                        .map(|s| s.pmf)
                        .sum::<f32>();
                }
                acc
            })
        });
    }
    group.finish();
}

/// pmf queries at the lights the 4-wide tree samples there: single, batch, and the binary
/// tree's single query.
fn pmf(c: &mut Criterion) {
    let mut group = c.benchmark_group("pmf");
    group.sample_size(20);
    group.throughput(Throughput::Elements(POINTS as u64));
    let points = random_scene::shading_points(POINTS, 7);
    let us = random_scene::uniforms(POINTS, 7);
    for n in [1_000usize, 100_000, 1_000_000] {
        let lights = random_scene::lights(n, 7);
        let tree = LightTree::build(&lights).unwrap();
        let binary = BinaryLightTree::build(&lights).unwrap();
        let lights_of = random_scene::sampled_lights(&tree, &points, &us);
        group.bench_with_input(BenchmarkId::new("4-wide", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (p, &light) in points.iter().zip(&lights_of) {
                    let imp = TlImportance::new(p.position, p.normal);
                    acc += tree.pmf(black_box(&imp), black_box(light));
                }
                acc
            })
        });
        group.bench_with_input(BenchmarkId::new("binary", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (p, &light) in points.iter().zip(&lights_of) {
                    let imp = TlImportance::new(p.position, p.normal);
                    acc += binary.pmf(black_box(&imp), black_box(light));
                }
                acc
            })
        });
        group.bench_with_input(BenchmarkId::new("4-wide batch", n), &n, |b, _| {
            let mut imps = Vec::with_capacity(BATCH);
            let mut out = vec![0.0f32; BATCH];
            b.iter(|| random_scene::pmf_batches(&tree, &points, &lights_of, &mut imps, &mut out))
        });
    }
    group.finish();
}

/// Eight samples per shading point, with and without a [`Memo`] (its table reused from point
/// to point, as a renderer keeps one per thread).
fn memo(c: &mut Criterion) {
    const PER_POINT: usize = 8;
    let mut group = c.benchmark_group("memo");
    let points = random_scene::shading_points(POINTS / PER_POINT, 8);
    let us = random_scene::uniforms(POINTS, 8);
    group.throughput(Throughput::Elements(POINTS as u64));
    for n in [100_000usize, 1_000_000] {
        let lights = random_scene::lights(n, 7);
        let tree = LightTree::build(&lights).unwrap();
        let table = MemoTable::new();
        group.bench_with_input(BenchmarkId::new("8 per point", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (p, uc) in points.iter().zip(us.chunks(PER_POINT)) {
                    let imp = TlImportance::new(p.position, p.normal);
                    for &u in uc {
                        acc += tree.sample(black_box(&imp), u).map_or(0.0, |s| s.pmf);
                    }
                }
                acc
            })
        });
        group.bench_with_input(BenchmarkId::new("8 per point, memo", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (p, uc) in points.iter().zip(us.chunks(PER_POINT)) {
                    let memo = Memo::new(TlImportance::new(p.position, p.normal), &tree, &table);
                    for &u in uc {
                        acc += tree.sample(black_box(&memo), u).map_or(0.0, |s| s.pmf);
                    }
                }
                acc
            })
        });
    }
    group.finish();
}

fn build(c: &mut Criterion) {
    let mut group = c.benchmark_group("build");
    group.sample_size(10);
    for n in [10_000usize, 100_000, 1_000_000] {
        let lights = random_scene::lights(n, 7);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::new("4-wide", n), &lights, |b, lights| {
            b.iter(|| LightTree::build(black_box(lights)).unwrap())
        });
        group.bench_with_input(BenchmarkId::new("binary", n), &lights, |b, lights| {
            b.iter(|| BinaryLightTree::build(black_box(lights)).unwrap())
        });
    }
    group.finish();
}

/// Cut construction per shading point (the importance's set-up included): the split cut (TL
/// importance) and the BRDF-oriented cut (BL importance) for three materials, against the
/// yardstick of one single-sample TL descent at the same points.
fn cuts(c: &mut Criterion) {
    let mut group = c.benchmark_group("cut");
    group.sample_size(20);
    group.throughput(Throughput::Elements(POINTS as u64));
    let points = random_scene::shading_points(POINTS, 7);
    let lights = random_scene::lights(100_000, 7);
    let tree = LightTree::build(&lights).unwrap();
    let opts = SplitCutOptions::default();
    let us = random_scene::uniforms(POINTS, 7);
    group.bench_function("TL descent, N=100000", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for (p, &u) in points.iter().zip(&us) {
                let imp = TlImportance::new(p.position, p.normal);
                acc += tree
                    .sample(black_box(&imp), black_box(u))
                    .map_or(0.0, |s| s.pmf);
            }
            acc
        })
    });
    group.bench_function("split build, N=100000", |b| {
        b.iter(|| {
            let mut size = 0;
            for p in &points {
                let imp = TlImportance::new(p.position, p.normal);
                size += LightCut::build_split(&tree, black_box(&imp), &opts).len();
            }
            size
        })
    });
    let cut_opts = BlCutOptions::default();
    for (name, material) in [
        (
            "Lambert",
            Material::Lambert {
                albedo: Rgb::grey(0.5),
            },
        ),
        (
            "GGX 0.2",
            Material::Ggx {
                alpha: 0.2,
                specular: 1.0,
            },
        ),
        ("plastic 0.2", PLASTIC),
    ] {
        let sps = random_scene::surface_points(POINTS, 7, material);
        group.bench_function(format!("BL build, N=100000, {name}"), |b| {
            b.iter(|| {
                let mut size = 0;
                for sp in &sps {
                    let imp = BlImportance::new(black_box(sp)).unwrap();
                    size += LightCut::build_bl(&tree, &imp, &cut_opts).len();
                }
                size
            })
        });
    }
    // Split sampling at prebuilt cuts: one light per cluster, one descent at a time
    // (`sample_in`) against four interleaved (`sample_each`); same lights, same pmfs.
    let prepared: Vec<(TlImportance, LightCut)> = points
        .iter()
        .map(|p| {
            let imp = TlImportance::new(p.position, p.normal);
            (imp, LightCut::build_split(&tree, &imp, &opts))
        })
        .collect();
    group.bench_function("split sample_in, N=100000", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for ((imp, cut), &u) in prepared.iter().zip(&us) {
                for i in 0..cut.len() {
                    acc += cut
                        .sample_in(&tree, imp, i, black_box(u))
                        .map_or(0.0, |s| s.pmf);
                }
            }
            acc
        })
    });
    group.bench_function("split sample_each, N=100000", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            let mut out = [None; CUT_CAPACITY];
            for ((imp, cut), &u) in prepared.iter().zip(&us) {
                let u_all = [black_box(u); CUT_CAPACITY];
                cut.sample_each(&tree, imp, &u_all[..cut.len()], &mut out[..cut.len()]);
                acc += out[..cut.len()]
                    .iter()
                    .flatten()
                    .map(|s| s.pmf)
                    .sum::<f32>();
            }
            acc
        })
    });
    group.finish();
}

/// The descents at 10⁵ and 10⁶ lights, one sample, a batch of samples and a batch of pmfs per
/// shading point. Their prefetch hint is measured against plain loads by running this group
/// in both builds against a saved baseline:
/// `cargo bench --bench sampling -- descents --save-baseline prefetch`, then
/// `cargo bench --no-default-features --bench sampling -- descents --baseline prefetch`.
fn descents(c: &mut Criterion) {
    let mut group = c.benchmark_group("descents");
    group.sample_size(20);
    group.throughput(Throughput::Elements(POINTS as u64));
    let points = random_scene::shading_points(POINTS, 7);
    let us = random_scene::uniforms(POINTS, 7);
    let imps: Vec<TlImportance> = points
        .iter()
        .map(|p| TlImportance::new(p.position, p.normal))
        .collect();
    for n in [100_000usize, 1_000_000] {
        let lights = random_scene::lights(n, 7);
        let tree = LightTree::build(&lights).unwrap();
        let lights_of = random_scene::sampled_lights(&tree, &points, &us);
        group.bench_with_input(BenchmarkId::new("sample", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (imp, &u) in imps.iter().zip(&us) {
                    let s = tree.sample(black_box(imp), black_box(u));
                    acc += s.map_or(0.0, |s| s.pmf);
                }
                acc
            })
        });
        let mut out = vec![None; BATCH];
        group.bench_with_input(BenchmarkId::new("sample_batch", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (ic, uc) in imps.chunks(BATCH).zip(us.chunks(BATCH)) {
                    let out = &mut out[..ic.len()];
                    tree.sample_batch(black_box(ic), uc, out).unwrap();
                    acc += out.iter().flatten().map(|s| s.pmf).sum::<f32>();
                }
                acc
            })
        });
        let mut out = vec![0.0f32; BATCH];
        group.bench_with_input(BenchmarkId::new("pmf_batch", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (ic, lc) in imps.chunks(BATCH).zip(lights_of.chunks(BATCH)) {
                    let out = &mut out[..ic.len()];
                    tree.pmf_batch(black_box(ic), lc, out).unwrap();
                    acc += out.iter().sum::<f32>();
                }
                acc
            })
        });
    }
    group.finish();
}

/// A fork-join on scoped threads: `b` on a thread of its own while `a` runs on the caller's
/// (the build splits only subtrees of 2^14 lights or more, so few threads are started).
struct ScopedThreads;

impl Join for ScopedThreads {
    fn join<A, B, RA, RB>(&self, a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA + Send,
        B: FnOnce() -> RB + Send,
        RA: Send,
        RB: Send,
    {
        std::thread::scope(|s| {
            let hb = s.spawn(b);
            let ra = a();
            (ra, hb.join().unwrap())
        })
    }
}

/// The build split over threads ([`LightTree::build_parallel`]) against the serial build; an
/// element is a light.
fn build_parallel(c: &mut Criterion) {
    let mut group = c.benchmark_group("build_parallel");
    group.sample_size(10);
    for n in [100_000usize, 1_000_000] {
        let lights = random_scene::lights(n, 7);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::new("serial", n), &lights, |b, lights| {
            b.iter(|| LightTree::build(black_box(lights)).unwrap())
        });
        group.bench_with_input(BenchmarkId::new("threads", n), &lights, |b, lights| {
            b.iter(|| {
                LightTree::build_parallel(
                    black_box(lights),
                    &BuildOptions::default(),
                    &ScopedThreads,
                )
                .unwrap()
            })
        });
    }
    group.finish();
}

criterion_group!(
    benches,
    sampling,
    pmf,
    memo,
    build,
    cuts,
    descents,
    build_parallel
);
criterion_main!(benches);
