//! The C ABI's batch calls against the Rust ones they wrap, in one group so the ratio reads
//! from one run: `ml_tree_sample_tl_batch` against `LightTree::sample_batch` and
//! `ml_tree_pmf_tl_batch` against `LightTree::pmf_batch`, on the same lights, points and
//! uniform numbers, 256 points per call (a wavefront's worth, as `mlmeasure bench`). The C
//! functions are called through their `extern "C"` symbols: their argument checks and the
//! conversions to and from the C structs are in the figure; the Rust side builds its
//! importances inside the timed loop, as the C side does.
//! Scene: the random scene of `mlmeasure bench` (fixed seed, 10⁵ lights).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use manylights::{LightTree, SampledLight};
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
    let status = ffi::ml_tree_build(
        descs.as_ptr(),
        descs.len(),
        std::ptr::null(),
        std::ptr::null(),
        &mut handle,
    );
    assert_eq!(status, ffi::ML_OK, "the bench scene is valid");

    let points = random_scene::shading_points(POINTS, 7);
    let us = random_scene::uniforms(POINTS, 7);
    let c_points: Vec<ffi::ml_tl_point> = points
        .iter()
        .map(|p| ffi::ml_tl_point {
            position: p.position.into(),
            normal: p.normal.into(),
            receiver: ffi::ml_receiver::Reflective as u32,
        })
        .collect();
    let lights_of = random_scene::sampled_lights(&tree, &points, &us);

    let mut group = c.benchmark_group("abi");
    group.throughput(Throughput::Elements(POINTS as u64));
    group.bench_function("Rust sample_batch, N=100000", |b| {
        let mut imps = Vec::with_capacity(BATCH);
        let mut out: Vec<Option<SampledLight>> = vec![None; BATCH];
        b.iter(|| random_scene::sample_batches(&tree, &points, &us, &mut imps, &mut out))
    });
    group.bench_function("C ml_tree_sample_tl_batch, N=100000", |b| {
        let mut out = vec![ffi::ml_sampled_light::default(); BATCH];
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

/// The host's uniform numbers for the C calls (a 64-bit LCG).
unsafe extern "C" fn lcg_f64(user: *mut std::ffi::c_void) -> f64 {
    let s = &mut *(user as *mut u64);
    *s = s
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*s >> 11) as f64 / (1u64 << 53) as f64
}

unsafe extern "C" fn lcg_f32(user: *mut std::ffi::c_void) -> f32 {
    (lcg_f64(user) as f32).min(1.0 - f32::EPSILON / 2.0)
}

/// The wavefront batches against the single calls they equal bit for bit: one-call estimates
/// (`bl-mis`, the default, and `tl-split`) at 1,024 shading points, one call per point
/// (`ml_direct_estimate`) against one call for all (`ml_direct_estimate_batch`); and 4,096
/// points on lights, `ml_light_sample_point` per triple against
/// `ml_light_sample_point_batch`. Scene: `mlmeasure bench`'s (10⁵ lights).
fn wavefront(c: &mut Criterion) {
    let lights = random_scene::lights(LIGHTS, 7);
    let descs: Vec<ffi::ml_light> = lights.iter().map(ffi::ml_light::from).collect();
    let mut handle: *mut ffi::ml_tree = std::ptr::null_mut();
    let status = ffi::ml_tree_build(
        descs.as_ptr(),
        descs.len(),
        std::ptr::null(),
        std::ptr::null(),
        &mut handle,
    );
    assert_eq!(status, ffi::ML_OK, "the bench scene is valid");
    let plastic = manylights::Material::Plastic {
        albedo: manylights::Rgb::grey(0.5),
        specular: 0.5,
        alpha: 0.2,
    };
    let sps: Vec<ffi::ml_shading_point> = random_scene::surface_points(1024, 7, plastic)
        .iter()
        .map(|p| ffi::ml_shading_point {
            position: p.position.into(),
            normal: p.normal.into(),
            wo: p.wo.into(),
            material: ffi::ml_material {
                kind: ffi::ml_material_kind::Plastic as u32,
                albedo: ffi::ml_rgb {
                    r: 0.5,
                    g: 0.5,
                    b: 0.5,
                },
                specular: 0.5,
                alpha: 0.2,
            },
        })
        .collect();
    let mut group = c.benchmark_group("wavefront");
    group.sample_size(10);
    group.throughput(Throughput::Elements(sps.len() as u64));
    for (name, t) in [
        ("bl-mis", ffi::ml_technique::BlMis),
        ("tl-split", ffi::ml_technique::TlSplit),
    ] {
        group.bench_function(format!("C ml_direct_estimate per point, {name}"), |b| {
            b.iter(|| {
                let mut state = 13u64;
                let u = ffi::ml_uniforms {
                    next_f32: Some(lcg_f32),
                    next_f64: Some(lcg_f64),
                    user_data: &mut state as *mut u64 as *mut std::ffi::c_void,
                };
                let mut acc = 0.0;
                for sp in &sps {
                    let mut e = ffi::ml_rgb64::default();
                    let s = ffi::ml_direct_estimate(
                        black_box(handle),
                        sp,
                        t as u32,
                        std::ptr::null(),
                        std::ptr::null(),
                        &u,
                        &mut e,
                    );
                    assert_eq!(s, ffi::ML_OK);
                    acc += e.g;
                }
                acc
            })
        });
        group.bench_function(format!("C ml_direct_estimate_batch, {name}"), |b| {
            let mut out = vec![ffi::ml_rgb64::default(); sps.len()];
            b.iter(|| {
                let mut state = 13u64;
                let u = ffi::ml_uniforms {
                    next_f32: Some(lcg_f32),
                    next_f64: Some(lcg_f64),
                    user_data: &mut state as *mut u64 as *mut std::ffi::c_void,
                };
                let s = ffi::ml_direct_estimate_batch(
                    black_box(handle),
                    sps.as_ptr(),
                    sps.len(),
                    1,
                    t as u32,
                    std::ptr::null(),
                    std::ptr::null(),
                    &u,
                    out.as_mut_ptr(),
                );
                assert_eq!(s, ffi::ML_OK);
                out.iter().map(|e| e.g).sum::<f64>()
            })
        });
    }
    let n = 4096;
    let which: Vec<u32> = (0..n).map(|i| (i * 7919 % LIGHTS) as u32).collect();
    let xs: Vec<ffi::ml_vec3> = random_scene::shading_points(n, 9)
        .iter()
        .map(|p| p.position.into())
        .collect();
    let us = random_scene::uniforms(2 * n, 9);
    let (u0s, u1s) = us.split_at(n);
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function("C ml_light_sample_point per triple", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for j in 0..n {
                let mut p = ffi::ml_light_point::default();
                let s = ffi::ml_light_sample_point(
                    black_box(handle),
                    which[j],
                    xs[j],
                    u0s[j],
                    u1s[j],
                    &mut p,
                );
                assert_eq!(s, ffi::ML_OK);
                acc += p.pdf;
            }
            acc
        })
    });
    group.bench_function("C ml_light_sample_point_batch", |b| {
        let mut out = vec![ffi::ml_light_point::default(); n];
        b.iter(|| {
            let s = ffi::ml_light_sample_point_batch(
                black_box(handle),
                which.as_ptr(),
                xs.as_ptr(),
                u0s.as_ptr(),
                u1s.as_ptr(),
                n,
                out.as_mut_ptr(),
            );
            assert_eq!(s, ffi::ML_OK);
            out.iter().map(|p| p.pdf).sum::<f32>()
        })
    });
    group.finish();
    assert_eq!(ffi::ml_tree_free(handle), ffi::ML_OK);
}

criterion_group!(benches, abi, wavefront);
criterion_main!(benches);
