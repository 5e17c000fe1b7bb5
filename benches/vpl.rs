//! VPL acceptance per candidate with the paper's 100 importons (Georgiev & Slusallek 2010,
//! N_C = 100): Φ̃_i with the importons four to an f32x4 (`VplAcceptor::estimate`, which the
//! acceptance decision calls) against its scalar twin, one importon at a time
//! (`Importons::contribution`, the reference the crate's tests hold `contribution4` equal to,
//! lane by lane), and the whole decision (`VplAcceptor::accept`: check, Φ̃_i, p, roulette).
//! Both estimates validate the candidate, as `estimate` does. Importons and candidates: the
//! seeded shading points of `testkit` (diffuse importons, albedo 0.5; candidate intensities
//! uniform in [0.1, 10]).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use manylights::Rgb;
use manylights::{Vpl, VplAcceptor};
use manylights_testkit as random_scene;
use std::hint::black_box;

const CANDIDATES: usize = 4096;
const IMPORTONS: usize = manylights::vpl::DEFAULT_IMPORTONS;

fn vpl(c: &mut Criterion) {
    let mut acc = VplAcceptor::new(640 * 480, 1000).unwrap();
    for p in random_scene::shading_points(IMPORTONS, 17) {
        acc.importons_mut()
            .push_diffuse(p.position, p.normal, 0.5)
            .unwrap();
    }
    // A later frame: Φ̃_total > 0, so that `accept` evaluates the importons.
    acc.update(1e3).unwrap();
    let us = random_scene::uniforms(2 * CANDIDATES, 17);
    let candidates: Vec<Vpl> = random_scene::shading_points(CANDIDATES, 18)
        .iter()
        .zip(&us)
        .map(|(p, &u)| Vpl {
            position: p.position,
            normal: p.normal,
            intensity: Rgb::grey(0.1 + 9.9 * u),
        })
        .collect();
    let xis = &us[CANDIDATES..];
    let mut group = c.benchmark_group("vpl");
    group.throughput(Throughput::Elements(CANDIDATES as u64));
    group.bench_function("estimate scalar, 100 importons", |b| {
        let imp = acc.importons();
        let n = imp.len();
        b.iter(|| {
            let mut sum = 0.0f32;
            for v in &candidates {
                let m = black_box(v).validate().unwrap();
                let mut phi = 0.0f32;
                for j in 0..n {
                    phi +=
                        imp.contribution(j, v.position, m, v.intensity.luminance(), f32::INFINITY);
                }
                sum += phi / n as f32;
            }
            sum
        })
    });
    group.bench_function("estimate 4-wide, 100 importons", |b| {
        b.iter(|| {
            let mut sum = 0.0f32;
            for v in &candidates {
                sum += acc.estimate(black_box(v)).unwrap();
            }
            sum
        })
    });
    group.bench_function("accept 4-wide, 100 importons", |b| {
        let mut acc = acc.clone();
        b.iter(|| {
            let mut kept = 0usize;
            for (v, &xi) in candidates.iter().zip(xis) {
                kept += usize::from(acc.accept(black_box(v), xi).unwrap().is_some());
            }
            kept
        })
    });
    group.finish();
}

criterion_group!(benches, vpl);
criterion_main!(benches);
