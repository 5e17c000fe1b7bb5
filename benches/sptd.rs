//! SPTD evaluation: scalar vs 4-wide, four caps per call (the BRDF-oriented cut's construction
//! is in the `cut` group of `benches/sampling.rs`).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use manylights::importance::f32x4;
use manylights::internals::sptd::SptdGgx;
use manylights_testkit as random_scene;
use std::hint::black_box;

const CAPS: usize = 4096;

fn sptd(c: &mut Criterion) {
    let ggx = SptdGgx::oriented(0.2, Vec3::Z, Vec3::new(0.5, 0.1, 0.8));
    let dirs: Vec<Vec3> = random_scene::shading_points(CAPS, 3)
        .iter()
        .map(|p| p.normal)
        .collect();
    let sines: Vec<f32> = random_scene::uniforms(CAPS, 3)
        .iter()
        .map(|u| (u * u * 0.9).max(1e-4))
        .collect();
    let mut group = c.benchmark_group("sptd");
    group.throughput(Throughput::Elements(CAPS as u64));
    group.bench_function("scalar", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for (d, &s) in dirs.iter().zip(&sines) {
                acc += ggx.integral(black_box(*d), black_box(s));
            }
            acc
        })
    });
    group.bench_function("4-wide", |b| {
        b.iter(|| {
            let mut acc = f32x4::ZERO;
            for (d, s) in dirs.chunks_exact(4).zip(sines.chunks_exact(4)) {
                let ax = f32x4::new([d[0].x, d[1].x, d[2].x, d[3].x]);
                let ay = f32x4::new([d[0].y, d[1].y, d[2].y, d[3].y]);
                let az = f32x4::new([d[0].z, d[1].z, d[2].z, d[3].z]);
                let sn = f32x4::new([s[0], s[1], s[2], s[3]]);
                acc += ggx.integral4(black_box(ax), ay, az, black_box(sn));
            }
            acc
        })
    });
    group.finish();
}

criterion_group!(benches, sptd);
criterion_main!(benches);
