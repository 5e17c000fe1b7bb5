//! Every direct-lighting technique per shading point: the estimator's set-up at the point
//! (`Estimator::new`: cuts, budget; or, in the group `direct, reset`, one estimator moved to
//! each point by `Estimator::reset`) and one estimate (`Estimator::estimate`) with the core's
//! plastic material and no occluder (`direct::Unoccluded`: every shadow ray passes, so the
//! figures are the library's alone). The yardstick is `tl-mis`, one TL tree sample plus one
//! BSDF sample (what pbrt-v4 and Cycles do at a shading point).
//! Scene: the random scene of `mlmeasure bench` (fixed seed, 10⁵ lights); the host's uniform
//! numbers from a 64-bit LCG restarted at the same seed in every iteration.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use manylights::direct::{Estimator, Params, Technique, Uniforms, Unoccluded};
use manylights::Rgb;
use manylights::{LightSet, Material};
use manylights_testkit as random_scene;
use std::hint::black_box;

const POINTS: usize = 1024;

/// The host's random numbers (the LCG of the `direct` module's example).
struct Lcg(u64);

impl Uniforms for Lcg {
    fn next_f64(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    fn next_f32(&mut self) -> f32 {
        (self.next_f64() as f32).min(1.0 - f32::EPSILON / 2.0)
    }
}

fn direct(c: &mut Criterion) {
    let set = LightSet::build(random_scene::lights(100_000, 13)).unwrap();
    let plastic = Material::Plastic {
        albedo: Rgb::grey(0.5),
        specular: 0.5,
        alpha: 0.2,
    };
    let sps = random_scene::surface_points(POINTS, 13, plastic);
    let params = Params::default();
    let mut group = c.benchmark_group("direct");
    group.sample_size(10);
    group.throughput(Throughput::Elements(POINTS as u64));
    for technique in Technique::ALL {
        group.bench_function(technique.name(), |b| {
            b.iter(|| {
                let mut u = Lcg(13);
                let mut acc = 0.0f64;
                for sp in &sps {
                    let mut est = Estimator::new(&set, black_box(sp), technique, &params).unwrap();
                    acc += est.estimate(&Unoccluded, &mut u).unwrap()[0];
                }
                acc
            })
        });
    }
    group.finish();
    // The same, with one estimator moved from point to point (`Estimator::reset`, the same
    // set-up and estimates without a new estimator's copy): how a host keeping one
    // estimator per thread pays for the set-up.
    let mut group = c.benchmark_group("direct, reset");
    group.sample_size(10);
    group.throughput(Throughput::Elements(POINTS as u64));
    for technique in Technique::ALL {
        group.bench_function(technique.name(), |b| {
            let mut est = Estimator::new(&set, &sps[0], technique, &params).unwrap();
            b.iter(|| {
                let mut u = Lcg(13);
                let mut acc = 0.0f64;
                for sp in &sps {
                    est.reset(black_box(sp)).unwrap();
                    acc += est.estimate(&Unoccluded, &mut u).unwrap()[0];
                }
                acc
            })
        });
    }
    group.finish();
}

/// The wavefront batches against the single calls they equal bit for bit: the per-point
/// set-up and one estimate at 1,024 shading points (`bl-mis` and `tl-split`), a loop of
/// `Estimator::new` and `estimate` against `wavefront::estimate_each`; and 4,096 points on
/// lights, `sample_point` per triple against `wavefront::sample_points`.
fn wavefront(c: &mut Criterion) {
    use manylights::light::sample_point;
    use manylights::wavefront::{estimate_each, sample_points};
    let set = LightSet::build(random_scene::lights(100_000, 13)).unwrap();
    let plastic = Material::Plastic {
        albedo: Rgb::grey(0.5),
        specular: 0.5,
        alpha: 0.2,
    };
    let sps = random_scene::surface_points(POINTS, 13, plastic);
    let params = Params::default();
    let mut group = c.benchmark_group("wavefront");
    group.sample_size(10);
    group.throughput(Throughput::Elements(POINTS as u64));
    for technique in [Technique::BlMis, Technique::TlSplit] {
        group.bench_function(format!("single calls, {technique}"), |b| {
            b.iter(|| {
                let mut u = Lcg(13);
                let mut acc = 0.0f64;
                for sp in &sps {
                    let mut est = Estimator::new(&set, black_box(sp), technique, &params).unwrap();
                    acc += est.estimate(&Unoccluded, &mut u).unwrap()[1];
                }
                acc
            })
        });
        group.bench_function(format!("estimate_each, {technique}"), |b| {
            let mut out = vec![[0.0f64; 3]; sps.len()];
            b.iter(|| {
                let mut u = Lcg(13);
                estimate_each(
                    &set,
                    black_box(&sps),
                    1,
                    technique,
                    &params,
                    &Unoccluded,
                    &mut u,
                    &mut out,
                )
                .unwrap();
                out.iter().map(|e| e[1]).sum::<f64>()
            })
        });
    }
    let n = 4096;
    let which: Vec<u32> = (0..n).map(|i| (i * 7919 % 100_000) as u32).collect();
    let xs: Vec<glam::Vec3> = random_scene::shading_points(n, 9)
        .iter()
        .map(|p| p.position)
        .collect();
    let raw = random_scene::uniforms(2 * n, 9);
    let us: Vec<[f32; 2]> = raw.chunks(2).map(|c| [c[0], c[1]]).collect();
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function("sample_point per triple", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for j in 0..n {
                let l = &set.lights()[which[j] as usize];
                acc += sample_point(l, black_box(xs[j]), us[j]).map_or(0.0, |p| p.pdf);
            }
            acc
        })
    });
    group.bench_function("sample_points", |b| {
        let mut out = vec![None; n];
        b.iter(|| {
            sample_points(set.lights(), &which, black_box(&xs), &us, &mut out).unwrap();
            out.iter().flatten().map(|p| p.pdf).sum::<f32>()
        })
    });
    group.finish();
}

criterion_group!(benches, direct, wavefront);
criterion_main!(benches);
