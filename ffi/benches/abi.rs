//! The C ABI's batch calls against the Rust ones they wrap, in one group so the ratio reads
//! from one run: `ml_tree_sample_tl_batch` against `LightTree::sample_batch` and
//! `ml_tree_pmf_tl_batch` against `LightTree::pmf_batch`, on the same lights, points and
//! uniform numbers, 256 points per call (a wavefront's worth, as `mlrender bench`). The C
//! functions are called through their `extern "C"` symbols: their argument checks and the
//! conversions to and from the C structs are in the figure; the Rust side builds its
//! importances inside the timed loop, as the C side does.
//! Scene: the random scene of `mlrender bench` (fixed seed, 10⁵ lights).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use manylights::{LightSample, LightTree};
use manylights_ffi as ffi;
use manylights_testkit as random_scene;
use std::hint::black_box;

const POINTS: usize = 4096;
/// Shading points per batch call.
const BATCH: usize = 256;
const LIGHTS: usize = 100_000;

fn abi(c: &mut Criterion) {
    let lights = random_scene::lights(LIGHTS, 7);
    let tree = LightTree::build(&lights).unwrap();
    let descs: Vec<ffi::ml_light> = lights.iter().map(ffi::ml_light::from).collect();
    let mut handle: *mut ffi::ml_tree = std::ptr::null_mut();
    let status = ffi::ml_tree_build(descs.as_ptr(), descs.len(), std::ptr::null(), &mut handle);
    assert_eq!(status, ffi::ML_OK, "the bench scene is valid");

    let points = random_scene::shading_points(POINTS, 7);
    let us = random_scene::uniforms(POINTS, 7);
    let c_points: Vec<ffi::ml_tl_point> = points
        .iter()
        .map(|p| ffi::ml_tl_point {
            position: p.position.into(),
            normal: p.normal.into(),
        })
        .collect();
    let lights_of = random_scene::sampled_lights(&tree, &points, &us);

    let mut group = c.benchmark_group("abi");
    group.throughput(Throughput::Elements(POINTS as u64));
    group.bench_function("Rust sample_batch, N=100000", |b| {
        let mut imps = Vec::with_capacity(BATCH);
        let mut out: Vec<Option<LightSample>> = vec![None; BATCH];
        b.iter(|| random_scene::sample_batches(&tree, &points, &us, &mut imps, &mut out))
    });
    group.bench_function("C ml_tree_sample_tl_batch, N=100000", |b| {
        let mut out = vec![ffi::ml_light_sample::NONE; BATCH];
        b.iter(|| {
            let mut acc = 0.0f32;
            for (pc, uc) in c_points.chunks(BATCH).zip(us.chunks(BATCH)) {
                let status = ffi::ml_tree_sample_tl_batch(
                    black_box(handle),
                    black_box(pc.as_ptr()),
                    black_box(uc.as_ptr()),
                    pc.len(),
                    out.as_mut_ptr(),
                );
                assert_eq!(status, ffi::ML_OK);
                acc += out[..pc.len()].iter().map(|s| s.pmf).sum::<f32>();
            }
            acc
        })
    });
    group.bench_function("Rust pmf_batch, N=100000", |b| {
        let mut imps = Vec::with_capacity(BATCH);
        let mut out = vec![0.0f32; BATCH];
        b.iter(|| random_scene::pmf_batches(&tree, &points, &lights_of, &mut imps, &mut out))
    });
    group.bench_function("C ml_tree_pmf_tl_batch, N=100000", |b| {
        let mut out = vec![0.0f32; BATCH];
        b.iter(|| {
            let mut acc = 0.0f32;
            for (pc, lc) in c_points.chunks(BATCH).zip(lights_of.chunks(BATCH)) {
                let status = ffi::ml_tree_pmf_tl_batch(
                    black_box(handle),
                    black_box(pc.as_ptr()),
                    black_box(lc.as_ptr()),
                    pc.len(),
                    out.as_mut_ptr(),
                );
                assert_eq!(status, ffi::ML_OK);
                acc += out[..pc.len()].iter().sum::<f32>();
            }
            acc
        })
    });
    group.finish();
    assert_eq!(ffi::ml_tree_free(handle), ffi::ML_OK);
}

criterion_group!(benches, abi);
criterion_main!(benches);
