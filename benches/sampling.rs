//! Sampling throughput of the 4-wide tree against the binary scalar baseline (same build, same
//! TL importance, measured in one group so the ratio is read from one run), the batch calls
//! beside the single ones (every sample a new shading point, the importances built inside the
//! timed loop), build time, and split sampling one descent at a time against interleaved
//! (`sample_each`).
//! Scene: the random scene of `mlrender bench` (fixed seed).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use manylights::baseline::BinaryLightTree;
use manylights::{
    LightCut, LightSample, LightTree, Memo, MemoTable, SplitOptions, TlImportance, CUT_CAPACITY,
};
use manylights_testkit as random_scene;
use std::hint::black_box;

const POINTS: usize = 4096;
/// Shading points per batch call.
const BATCH: usize = 256;

fn sampling(c: &mut Criterion) {
    let mut group = c.benchmark_group("sample");
    group.throughput(Throughput::Elements(POINTS as u64));
    let points = random_scene::shading_points(POINTS, 7);
    let us = random_scene::uniforms(POINTS, 7);
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
            let mut out: Vec<Option<LightSample>> = vec![None; BATCH];
            b.iter(|| {
                let mut acc = 0.0f32;
                for (pc, uc) in points.chunks(BATCH).zip(us.chunks(BATCH)) {
                    imps.clear();
                    imps.extend(pc.iter().map(|p| TlImportance::new(p.position, p.normal)));
                    tree.sample_batch(black_box(&imps), black_box(uc), &mut out[..pc.len()])
                        .unwrap();
                    acc += out[..pc.len()].iter().flatten().map(|s| s.pmf).sum::<f32>();
                }
                acc
            })
        });
        let lights_of: Vec<u32> = points
            .iter()
            .zip(&us)
            .map(|(p, &u)| {
                let imp = TlImportance::new(p.position, p.normal);
                tree.sample(&imp, u).map_or(0, |s| s.light)
            })
            .collect();
        group.bench_with_input(BenchmarkId::new("4-wide pmf", n), &n, |b, _| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for (p, &light) in points.iter().zip(&lights_of) {
                    let imp = TlImportance::new(p.position, p.normal);
                    acc += tree.pmf(black_box(&imp), black_box(light));
                }
                acc
            })
        });
        group.bench_with_input(BenchmarkId::new("4-wide pmf batch", n), &n, |b, _| {
            let mut imps = Vec::with_capacity(BATCH);
            let mut out = vec![0.0f32; BATCH];
            b.iter(|| {
                let mut acc = 0.0f32;
                for (pc, lc) in points.chunks(BATCH).zip(lights_of.chunks(BATCH)) {
                    imps.clear();
                    imps.extend(pc.iter().map(|p| TlImportance::new(p.position, p.normal)));
                    tree.pmf_batch(black_box(&imps), black_box(lc), &mut out[..pc.len()])
                        .unwrap();
                    acc += out[..pc.len()].iter().sum::<f32>();
                }
                acc
            })
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
    for n in [1_000usize, 100_000, 1_000_000] {
        let lights = random_scene::lights(n, 7);
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::new("4-wide", n), &lights, |b, lights| {
            b.iter(|| LightTree::build(black_box(lights)).unwrap())
        });
    }
    group.finish();
}

fn cuts(c: &mut Criterion) {
    let mut group = c.benchmark_group("cut");
    group.throughput(Throughput::Elements(POINTS as u64));
    let points = random_scene::shading_points(POINTS, 7);
    let lights = random_scene::lights(100_000, 7);
    let tree = LightTree::build(&lights).unwrap();
    let opts = SplitOptions::default();
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
    // Split sampling at prebuilt cuts: one light per cluster, one descent at a time
    // (`sample_in`) against four interleaved (`sample_each`); same lights, same pmfs.
    let us = random_scene::uniforms(POINTS, 7);
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

criterion_group!(benches, sampling, memo, build, cuts);
criterion_main!(benches);
