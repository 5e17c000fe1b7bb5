//! Unit tests of the module, beside the integration tests (deterministic: fixed seeds).

use super::*;

/// `finish` as the per-cluster test defines it: a division per cluster, the running sums
/// of the clusters kept.
fn reference(cut: &LightCut) -> (u64, f32, [f32; MAX_CUT_SIZE], usize) {
    let scale = cut.scale;
    let all = cut
        .clusters()
        .iter()
        .fold(0.0f32, |acc, c| acc + c.weight * scale);
    let (mut skipped, mut kept) = (0u64, 0.0f32);
    for (i, c) in cut.clusters().iter().enumerate() {
        if (c.weight * scale) / all >= 2.0 * MIN_PMF {
            kept += c.weight * scale;
        } else {
            skipped |= 1 << i;
        }
    }
    let (mut ends, mut acc, mut last) = ([0.0f32; MAX_CUT_SIZE], 0.0f32, 0);
    for (i, c) in cut.clusters().iter().enumerate() {
        if skipped & (1 << i) == 0 {
            acc += c.weight * scale;
            last = i;
        }
        ends[i] = acc;
    }
    (skipped, if skipped == 0 { all } else { kept }, ends, last)
}

/// The one-division shortcut of `finish` decides exactly what the per-cluster test does:
/// weights spread over the whole f32 range, shares at and around `2 · MIN_PMF`, sums that
/// overflow.
#[test]
fn finish_equals_the_per_cluster_test() {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 33) as u32
    };
    let threshold = 2.0 * MIN_PMF;
    for round in 0..20_000 {
        let n = 1 + next() as usize % MAX_CUT_SIZE;
        let mut cut = LightCut::new();
        let mut acc = Accepted::default();
        let base = f32::from_bits(1 + next() % 0x7F00_0000);
        for k in 0..n {
            let u = next() as f32 / u32::MAX as f32;
            let weight = match (round % 4, k % 5) {
                // Any positive finite f32.
                (0, 0) => f32::from_bits(1 + next() % (f32::MAX.to_bits() - 1)),
                (0, 1) => f32::MAX,
                // Shares near 2 · MIN_PMF of the total.
                (0 | 1, 2) => base * threshold * (n as f32) * (0.5 + u),
                (1, 3) => base * threshold * (n as f32),
                // Sums that overflow.
                (2, _) => f32::MAX * (0.25 + u),
                _ => base * (1.0 + u),
            };
            let c = Cluster {
                node: 0,
                slot: 0,
                path: k as u64 + 1,
                weight,
                score: 0.0,
                glossy_score: 0.0,
            };
            acc.push(&mut cut.clusters, c);
        }
        (cut.len, cut.total) = (acc.len, acc.total);
        cut.finish();
        let (skipped, total, ends, last) = reference(&cut);
        assert_eq!(cut.skipped, skipped, "round {round}");
        assert_eq!(cut.sample_total.to_bits(), total.to_bits(), "round {round}");
        assert_eq!(cut.last, last, "round {round}");
        for (i, (a, b)) in cut.ends[..n].iter().zip(&ends).enumerate() {
            assert_eq!(a.to_bits(), b.to_bits(), "round {round}, {i}");
        }
    }
}

/// A seeded generator of numbers in [0, 1).
fn uniforms(seed: u64) -> impl FnMut() -> f32 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Points, spots, spheres, one-sided disks and triangles over a box with a cluster of
/// small lights in one corner, powers spread over ten decades.
fn mixed_tree(n: usize) -> LightTree {
    use crate::colour::Rgb;
    use crate::Light;
    use glam::Vec3;
    let mut u = uniforms(0x5EED);
    let lights: alloc::vec::Vec<Light> = (0..n)
        .map(|i| {
            let scale = if i % 3 == 0 { 0.5 } else { 10.0 };
            let p = Vec3::new(u(), u(), u()) * scale;
            let power = Rgb::grey(10f32.powf(u() * 10.0 - 5.0));
            let d = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5);
            let d = if d.length() > 1e-3 { d } else { Vec3::Z };
            match i % 5 {
                0 => Light::Point {
                    position: p,
                    intensity: power,
                },
                1 => Light::Spot {
                    position: p,
                    direction: d,
                    intensity: power,
                    half_angle: 0.2 + u(),
                    falloff_start: 0.1,
                },
                2 => Light::Sphere {
                    center: p,
                    radius: 0.01 + 0.3 * u(),
                    radiance: power,
                },
                3 => Light::Disk {
                    center: p,
                    normal: d,
                    radius: 0.01 + 0.3 * u(),
                    radiance: power,
                    two_sided: false,
                },
                _ => Light::Triangle {
                    vertices: [p, p + Vec3::X * 0.2 * u(), p + d * 0.3],
                    radiance: power,
                    two_sided: i % 2 == 0,
                },
            }
        })
        .collect();
    LightTree::build_with(&lights, &crate::BuildOptions::default()).unwrap()
}

/// Shading points in and around the box of [`mixed_tree`]: Lambert (black among them, so
/// no defensive term), GGX and plastic, normals and views in every direction.
fn shading_points(n: usize, seed: u64) -> alloc::vec::Vec<crate::ShadingPoint> {
    use crate::colour::Rgb;
    use crate::Material;
    use glam::Vec3;
    let mut u = uniforms(seed);
    (0..n)
        .map(|i| {
            let normal = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5) + Vec3::Z * 1e-3;
            let wo = Vec3::new(u() - 0.5, u() - 0.5, u() - 0.5) + Vec3::X * 1e-3;
            let material = match i % 4 {
                0 => Material::Lambert {
                    albedo: Rgb::grey(if i % 8 == 0 { 0.0 } else { u() }),
                },
                1 => Material::Ggx {
                    alpha: 0.02 + 0.98 * u(),
                    specular: 1.0,
                },
                _ => Material::Plastic {
                    albedo: Rgb::grey(u()),
                    specular: u(),
                    alpha: 0.02 + 0.98 * u(),
                },
            };
            crate::ShadingPoint {
                position: Vec3::new(u(), u(), u()) * 12.0 - Vec3::splat(1.0),
                normal,
                wo,
                material,
            }
        })
        .collect()
}

/// `surely_positive4` names only slots whose importance is positive, and most of them:
/// the BRDF-oriented cut may skip the nodes it rules out.
#[test]
fn surely_positive_slots_are_positive() {
    use crate::importance::{BlImportance, Importance};
    let tree = mixed_tree(3000);
    let (mut sure, mut positive) = (0u32, 0u32);
    for sp in shading_points(200, 7) {
        let imp = BlImportance::new(&sp).unwrap();
        for node in tree.nodes() {
            let w = imp.eval4(node);
            let pos = w.simd_gt(f32x4::ZERO).to_bitmask();
            let s = imp.surely_positive4(node);
            assert_eq!(s & !pos, 0, "{sp:?}: {:?}, sure {s:04b}", w.to_array());
            sure += count4(s);
            positive += count4(pos);
        }
    }
    assert!(sure as f32 >= 0.9 * positive as f32, "{sure} of {positive}");
}

/// The BRDF-oriented cut skips `decide` at nodes whose surely kept slots do not fit, and
/// is the same cut, bit for bit, as the one that decides every node.
#[test]
fn bl_cut_skips_nodes_that_cannot_fit_and_is_unchanged() {
    use crate::importance::BlImportance;
    let tree = mixed_tree(3000);
    let (mut skipped, mut nodes) = (0usize, 0usize);
    for (i, sp) in shading_points(300, 11).iter().enumerate() {
        let imp = BlImportance::new(sp).unwrap();
        let opts = BlCutOptions {
            max_size: [4, 9, 16, 33, 64][i % 5],
            delta: [0.5, 0.05, 0.0][i % 3],
            split_sin: [1.0, 0.9, 0.5][i % 3],
        };
        let mut cut = LightCut::new();
        cut.rebuild_bl(&tree, &imp, &opts);
        // `rebuild_bl`'s decisions, counting the nodes decided.
        let rule = BlSplitRule::new(&opts);
        let calls = core::cell::Cell::new(0usize);
        let decide = |node: &Node4, _: f32| {
            calls.set(calls.get() + 1);
            rule.decide(imp.eval4_for_cut(node))
        };
        let total = |root: &Node4| imp.eval4_for_cut(root).0.to_array().iter().sum();
        // Every node decided (no slot surely kept), then with the slots surely kept.
        let mut full = LightCut::new();
        LightCut::build_with(&mut full, &tree, opts.max_size, decide, |_| 0, total);
        let every = calls.replace(0);
        let mut skipping = LightCut::new();
        let sure = |node: &Node4| imp.surely_positive4(node);
        LightCut::build_with(&mut skipping, &tree, opts.max_size, decide, sure, total);
        skipped += every - calls.get();
        nodes += every;
        for c in [&cut, &skipping] {
            assert_eq!(c.len(), full.len(), "point {i}");
            for (a, b) in c.clusters().iter().zip(full.clusters()) {
                assert_eq!(
                    (
                        a.node,
                        a.slot,
                        a.path,
                        a.weight.to_bits(),
                        a.score.to_bits()
                    ),
                    (
                        b.node,
                        b.slot,
                        b.path,
                        b.weight.to_bits(),
                        b.score.to_bits()
                    ),
                    "point {i}"
                );
                assert_eq!(a.glossy_score.to_bits(), b.glossy_score.to_bits());
            }
            assert_eq!(c.total_weight().to_bits(), full.total_weight().to_bits());
            assert_eq!(c.max_score().to_bits(), full.max_score().to_bits());
        }
    }
    assert!(skipped * 10 >= nodes, "{skipped} of {nodes} nodes skipped");
}
