//! The measurement behind the triangle strategy (run with `--ignored --nocapture`), and unit
//! checks of the internal pieces.

extern crate std;

use super::triangle::{self, Mode};
use super::*;
use std::println;
use std::time::Instant;

use manylights_testkit::SplitMix64 as Rng;

/// Mean, relative variance per sample and ns per sample of the irradiance estimate at the
/// origin (normal +z) of a unit-radiance triangle, with the given strategy.
fn irradiance(v: &[Vec3; 3], spherical: bool, n: usize) -> (f64, f64, f64) {
    let mut rng = Rng(7);
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    let t0 = Instant::now();
    for _ in 0..n {
        let u = [rng.f32(), rng.f32()];
        let Some(view) = triangle::view(v, Vec3::ZERO, Some(spherical)) else {
            continue;
        };
        let est = view
            .sample(Vec3::ZERO, u.map(f64::from))
            .and_then(|p| view.at_point(1.0.into(), true, Vec3::ZERO, p))
            .map_or(0.0, |lp| {
                f64::from(lp.radiance.r) * f64::from(lp.direction.z.max(0.0)) / f64::from(lp.pdf)
            });
        s += est;
        s2 += est * est;
    }
    let ns = t0.elapsed().as_nanos() as f64 / n as f64;
    let mean = s / n as f64;
    let var = (s2 / n as f64 - mean * mean).max(0.0);
    (mean, var / (mean * mean), ns)
}

#[test]
#[ignore = "measurement: prints the variance of both triangle strategies"]
fn measure_triangle_strategies() {
    let tri = |c: Vec3, e1: Vec3, e2: Vec3| [c, c + e1, c + e2];
    let cases: [(&str, [Vec3; 3]); 9] = [
        (
            "far, tiny",
            tri(Vec3::new(0.3, 0.2, 30.0), Vec3::X * 0.3, Vec3::Y * 0.3),
        ),
        (
            "far, small",
            tri(Vec3::new(0.3, 0.2, 10.0), Vec3::X * 0.5, Vec3::Y * 0.5),
        ),
        ("medium", tri(Vec3::new(0.3, 0.2, 3.0), Vec3::X, Vec3::Y)),
        (
            "near, facing",
            tri(Vec3::new(-0.5, -0.5, 1.0), Vec3::X * 2.0, Vec3::Y * 2.0),
        ),
        (
            "close, large",
            tri(Vec3::new(-1.0, -1.0, 0.1), Vec3::X * 3.0, Vec3::Y * 3.0),
        ),
        (
            "very close",
            tri(Vec3::new(-1.0, -1.0, 0.01), Vec3::X * 3.0, Vec3::Y * 3.0),
        ),
        (
            "vertical wall",
            tri(Vec3::new(0.2, -1.0, 0.0), Vec3::Y * 2.0, Vec3::Z * 2.0),
        ),
        (
            "grazing, low",
            tri(Vec3::new(1.0, -1.0, 0.02), Vec3::X * 2.0, Vec3::Y * 2.0),
        ),
        (
            "grazing, far",
            tri(Vec3::new(5.0, -1.0, 0.3), Vec3::X * 2.0, Vec3::Y * 2.0),
        ),
    ];
    let n = 1 << 20;
    println!(
        "case            Ω (sr)     E          relvar area  relvar sph  ratio   ns area  ns sph"
    );
    for (name, v) in cases {
        let omega = match triangle::view(&v, Vec3::ZERO, Some(true)).unwrap().mode {
            Mode::Spherical { omega, .. } => omega,
            Mode::Area { .. } => 0.0,
        };
        let (ma, va, ta) = irradiance(&v, false, n);
        let (ms, vs, ts) = irradiance(&v, true, n);
        println!(
            "{name:<15} {omega:<10.3e} {ma:<10.4e} {va:<12.4e} {vs:<11.4e} {:<7.3} {ta:<8.1} {ts:.1}   (E sph {ms:.4e})",
            vs / va
        );
    }
}

#[test]
#[ignore = "measurement: precision of spherical sampling for tiny solid angles"]
fn measure_spherical_precision() {
    for k in 1..=8 {
        let s = 10f32.powi(-k);
        let c = Vec3::new(0.3, 0.2, 1.0);
        let v = [c, c + Vec3::X * s, c + Vec3::new(0.3, 1.0, 0.0) * s];
        let view = triangle::view(&v, Vec3::ZERO, Some(true)).unwrap();
        let omega = match view.mode {
            Mode::Spherical { omega, .. } => omega,
            Mode::Area { .. } => 0.0,
        };
        let mut rng = Rng(3);
        let n = 200_000;
        let (mut b1s, mut b2s, mut fails) = (0.0f64, 0.0f64, 0);
        let e1 = V64::from_f32(v[1] - v[0]);
        let e2 = V64::from_f32(v[2] - v[0]);
        for _ in 0..n {
            let u = [f64::from(rng.f32()), f64::from(rng.f32())];
            match view.sample(Vec3::ZERO, u) {
                Some(p) => {
                    // Barycentrics of p in the triangle's plane, by least squares.
                    let d = V64::from_f32(p) - V64::from_f32(v[0]);
                    let (a11, a12, a22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
                    let (r1, r2) = (d.dot(e1), d.dot(e2));
                    let det = a11 * a22 - a12 * a12;
                    b1s += (r1 * a22 - r2 * a12) / det;
                    b2s += (r2 * a11 - r1 * a12) / det;
                }
                None => fails += 1,
            }
        }
        // Uniform in solid angle ≈ uniform in area for a tiny triangle: mean barycentrics 1/3.
        println!(
            "size {s:.0e}: Ω = {omega:.3e}, mean b1 {:.4}, b2 {:.4}, failures {fails}",
            b1s / n as f64,
            b2s / n as f64
        );
    }
}
