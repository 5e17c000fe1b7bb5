//! Unit tests of the module, beside the integration tests (deterministic: fixed seeds).

use super::*;

#[test]
fn pick_never_takes_zero_slots() {
    let cases = [
        [0.0, 1.0, 0.0, 2.0],
        [3.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1e-30],
        [1e-30, 1e30, 0.0, 0.0],
    ];
    for w in cases {
        let sum = w[0] + w[1] + w[2] + w[3];
        for u in [0.0, 1e-9, 0.25, 0.5, 0.999, ONE_MINUS_EPSILON] {
            let (k, wk, u2) = pick(f32x4::from(w), sum, u);
            assert_eq!(wk, w[k]);
            assert!(w[k] > 0.0, "w={w:?} u={u} picked {k}");
            assert!((0.0..1.0).contains(&u2), "w={w:?} u={u}: u'={u2}");
        }
    }
}

#[test]
fn pick_warps_uniformly() {
    let w = [1.0, 2.0, 0.0, 1.0];
    let w = f32x4::from(w);
    let (k, _, u2) = pick(w, 4.0, 0.5);
    assert_eq!(k, 1);
    assert!((u2 - 0.5).abs() < 1e-6);
    let (k, _, u2) = pick(w, 4.0, 0.875);
    assert_eq!(k, 3);
    assert!((u2 - 0.5).abs() < 1e-6);
}

#[test]
fn admit_drops_vanishing_slots() {
    let m = MIN_PMF;
    // Nothing to drop: unchanged.
    let w = [1.0, 2.0, 0.0, 3.0];
    assert_eq!(admit(w, 6.0, 1.0, m), (w, 6.0));
    // A share below MIN_PMF, and a negative weight, get 0; the rest renormalise.
    let w = [1.0, 1e-40, -2.0, 1.0];
    assert_eq!(
        admit(w, w[0] + w[1] + w[2] + w[3], 1.0, m),
        ([1.0, 0.0, 0.0, 1.0], 2.0)
    );
    // The path probability counts: at reach 1e-30 a share of 1e-10 is too small.
    let w = [1.0, 1e-10, 0.0, 0.0];
    assert_eq!(admit(w, 1.0, 1e-30, m), ([1.0, 0.0, 0.0, 0.0], 1.0));
    // No slot passes: the largest alone, with probability 1.
    let w = [1.0, 3.0, 3.0, 2.0];
    assert_eq!(admit(w, 9.0, 2.0 * m, m), ([0.0, 3.0, 0.0, 0.0], 3.0));
}

#[test]
fn admit4_agrees_with_admit() {
    let m = MIN_PMF;
    let values = [
        0.0,
        -0.0,
        1.0,
        3.0,
        1e-40,
        1e-30,
        1e-10,
        f32::MIN_POSITIVE,
        -2.0,
        f32::NAN,
        f32::INFINITY,
        1e30,
    ];
    for &a in &values {
        for &b in &values {
            for &c in &values {
                for &d in &values {
                    let w = [a, b, c, d];
                    let sum = a + b + c + d;
                    if !(sum > 0.0 && sum < f32::INFINITY) {
                        continue;
                    }
                    for reach in [1.0, 1e-20, 1e-30, 2.0 * m] {
                        let (x, s) = admit(w, sum, reach, m);
                        let (y, t) = admit4(f32x4::from(w), sum, reach, m);
                        let y = y.to_array();
                        assert_eq!(x.map(f32::to_bits), y.map(f32::to_bits), "{w:?}");
                        assert_eq!(s.to_bits(), t.to_bits(), "{w:?}");
                    }
                }
            }
        }
    }
}

#[test]
fn admit4_agrees_with_admit_at_the_boundary() {
    // Random weights, at reaches around where the smallest share meets MIN_PMF.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        f32::from_bits(0x0080_0000 + (state >> 40) as u32 * 127)
    };
    for _ in 0..100_000 {
        let w = [next(), next(), next(), next()];
        let sum = w[0] + w[1] + w[2] + w[3];
        if !positive_finite(sum) {
            continue;
        }
        let min = w[0].min(w[1]).min(w[2]).min(w[3]);
        let edge = MIN_PMF / (min / sum);
        for reach in [
            edge,
            edge * (1.0 + f32::EPSILON),
            edge * (1.0 - f32::EPSILON),
        ] {
            let reach = reach.min(1.0);
            let (x, s) = admit(w, sum, reach, MIN_PMF);
            let (y, t) = admit4(f32x4::from(w), sum, reach, MIN_PMF);
            let y = y.to_array();
            assert_eq!(x.map(f32::to_bits), y.map(f32::to_bits), "{w:?} {reach}");
            assert_eq!(s.to_bits(), t.to_bits(), "{w:?} {reach}");
        }
    }
}

#[test]
fn positive_finite_is_the_comparisons() {
    for bits in (0..=u32::MAX)
        .step_by(997)
        .chain([0, 1, 0x7F7F_FFFF, 0x7F80_0000])
    {
        let x = f32::from_bits(bits);
        assert_eq!(
            positive_finite(x),
            x > 0.0 && x < f32::INFINITY,
            "{bits:#x}"
        );
    }
}

#[test]
fn sanitize_clamps() {
    assert_eq!(sanitize(f32::NAN), 0.0);
    assert_eq!(sanitize(-1.0), 0.0);
    assert_eq!(sanitize(1.0), ONE_MINUS_EPSILON);
    const { assert!(ONE_MINUS_EPSILON < 1.0) };
}

/// Both walk widths of `pmf_batch` return `pmf`'s bits: the sampled lights, lights no
/// descent picks, a light of zero energy and indices out of range, at points inside and
/// outside the lights' cube (the scene is small, so `pmf_batch` itself takes the narrow
/// width; the wide one is called directly).
#[test]
fn pmf_batch_widths_match_pmf() {
    use crate::colour::Rgb;
    use crate::importance::TlImportance;
    use crate::light::Light;
    use alloc::vec;
    use alloc::vec::Vec;
    use glam::Vec3;
    use manylights_testkit::SplitMix64 as Rng;
    let mut rng = Rng(0x70f_b47c);
    let mut lights = Vec::new();
    for i in 0..3000 {
        let p = Vec3::new(rng.signed(50.0), rng.signed(50.0), rng.signed(50.0));
        let d = Vec3::new(rng.signed(1.0), rng.signed(1.0), rng.signed(1.0));
        lights.push(match i % 3 {
            0 => Light::Point {
                position: p,
                intensity: Rgb::grey(0.1 + 10.0 * rng.f32()),
            },
            1 => Light::Spot {
                position: p,
                direction: d,
                intensity: Rgb::grey(0.1 + 10.0 * rng.f32()),
                half_angle: 0.2 + 1.2 * rng.f32(),
                falloff_start: 0.1,
            },
            _ => Light::Sphere {
                center: p,
                radius: 0.1 + rng.f32(),
                radiance: Rgb::grey(0.1 + rng.f32()),
            },
        });
    }
    lights[17] = Light::Point {
        position: Vec3::ZERO,
        intensity: Rgb::grey(0.0),
    };
    let tree = LightTree::build(&lights).unwrap();
    let m = 700;
    let imps: Vec<TlImportance> = (0..m)
        .map(|_| {
            let h = if rng.f32() < 0.2 { 500.0 } else { 60.0 };
            let p = Vec3::new(rng.signed(h), rng.signed(h), rng.signed(h));
            let n = Vec3::new(rng.signed(1.0), rng.signed(1.0), rng.signed(1.0));
            TlImportance::new(p, n)
        })
        .collect();
    let ls: Vec<u32> = (0..m)
        .map(|j| match j % 5 {
            0 => 17,
            1 => 3000 + (j as u32 % 3),
            2 => rng.next_u32() % 3000,
            _ => tree.sample(&imps[j], rng.f32()).map_or(0, |s| s.light),
        })
        .collect();
    let mut positive = 0;
    // Each width with and without the paths' prefetch (which a tree this small does not
    // get from `pmf_batch`; the lights out of range are prefetched too).
    for hint in [false, true] {
        let mut narrow = vec![f32::NAN; m];
        let mut wide = vec![f32::NAN; m];
        tree.pmf_batch_lanes::<_, PMF_BATCH_LANES>(&imps, &ls, &mut narrow, hint);
        tree.pmf_batch_lanes::<_, PMF_BATCH_LANES_WIDE>(&imps, &ls, &mut wide, hint);
        positive = 0;
        for j in 0..m {
            let want = tree.pmf(&imps[j], ls[j]).to_bits();
            assert_eq!(narrow[j].to_bits(), want, "point {j} light {}", ls[j]);
            assert_eq!(wide[j].to_bits(), want, "point {j} light {}", ls[j]);
            positive += usize::from(wide[j] > 0.0);
        }
    }
    // Three queries in five are of lights that can be sampled (321 of the 700 pmfs are
    // positive with this seed), so the comparison is not of zeros alone.
    assert!(positive > m / 3, "{positive} of {m} pmfs positive");
}
