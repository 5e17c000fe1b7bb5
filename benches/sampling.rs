//! Sampling throughput of the 4-wide tree against the binary scalar baseline (same build, same
//! TL importance, measured in one group so the ratio is read from one run), build time, and
//! split sampling one descent at a time against interleaved (`sample_each`).
//! Scene: the random scene of `mlrender bench` (fixed seed).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use manylights::baseline::BinaryLightTree;
use manylights::{LightCut, LightTree, SplitOptions, TlImportance, CUT_CAPACITY};
use manylights_testkit as random_scene;
use std::hint::black_box;

const POINTS: usize = 4096;

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
        group.bench_with_input(BenchmarkId::new("4-wide pmf", n), &n, |b, _| {
            let queries: Vec<(TlImportance, u32)> = points
                .iter()
                .zip(&us)
                .filter_map(|(p, &u)| {
                    let imp = TlImportance::new(p.position, p.normal);
                    tree.sample(&imp, u).map(|s| (imp, s.light))
                })
                .collect();
            b.iter(|| {
                let mut acc = 0.0f32;
                for (imp, light) in &queries {
                    acc += tree.pmf(black_box(imp), black_box(*light));
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

criterion_group!(benches, sampling, build, cuts);
criterion_main!(benches);
