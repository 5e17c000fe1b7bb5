//! Seeded scenes of every light kind and layout, made with integer and correctly rounded
//! arithmetic only (no library trigonometry), so that they are the same on every platform;
//! and hashes of what a build makes of them.

#![allow(dead_code)]

use glam::Vec3;
use manylights::baseline::BinaryLightTree;
use manylights::tree::Slot;
use manylights::Rgb;
use manylights::{BuildOptions, Light, LightTree};
use manylights_testkit::SplitMix64;

/// The scenes' generator: testkit's SplitMix64 from a raw state, with the draws of `below`
/// and `direction` these scenes were recorded with.
struct Rng(SplitMix64);

impl Rng {
    /// Uniform in [0, n) as the next 64 bits modulo `n`.
    fn below(&mut self, n: u64) -> u64 {
        self.0.next_u64() % n
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        self.0.range(lo, hi)
    }

    fn in_cube(&mut self, half: f32) -> Vec3 {
        self.0.in_cube(half)
    }

    /// A direction, not unit length (the build normalises), sometimes along an axis.
    fn direction(&mut self) -> Vec3 {
        if self.below(8) == 0 {
            return [Vec3::X, -Vec3::Y, Vec3::Z][self.below(3) as usize] * 3.0;
        }
        loop {
            let d = self.in_cube(1.0);
            if d.length_squared() > 1e-4 {
                return d;
            }
        }
    }
}

/// `n` lights from `seed` laid out by `style`: 0 in a cube, 1 in clusters, 2 on a line, 3 on
/// a plane, 4 at a few points shared by many lights. Every kind appears (one- and two-sided
/// area lights, spots wider than a hemisphere, degenerate triangles), with energies over eight
/// decades and a few lights of zero energy.
pub fn scene(seed: u64, n: usize, style: u32) -> Vec<Light> {
    let mut rng = Rng(SplitMix64(seed ^ 0x6f6c_6465_6e5f_7465));
    let centres: Vec<Vec3> = (0..16).map(|_| rng.in_cube(1000.0)).collect();
    (0..n)
        .map(|i| {
            let c = match style {
                0 => rng.in_cube(100.0),
                1 => centres[rng.below(16) as usize] + rng.in_cube(2.0),
                2 => Vec3::new(rng.range(-50.0, 50.0), 1.0, -2.0),
                3 => Vec3::new(rng.range(-50.0, 50.0), rng.range(-50.0, 50.0), 3.0),
                _ => Vec3::splat((i % 5) as f32),
            };
            let power = if rng.below(40) == 0 {
                0.0
            } else {
                rng.range(0.1, 10.0) * [1e-4, 1e-2, 1.0, 1e2, 1e4][rng.below(5) as usize]
            };
            match rng.below(9) {
                0 => Light::Point {
                    position: c,
                    intensity: Rgb::grey(power),
                },
                1 => {
                    let half_angle = rng.range(0.01, 3.1);
                    Light::Spot {
                        position: c,
                        direction: rng.direction(),
                        intensity: Rgb::grey(power),
                        half_angle,
                        falloff_start: half_angle * 0.5,
                    }
                }
                2 => Light::Sphere {
                    center: c,
                    radius: rng.range(0.01, 3.0),
                    radiance: Rgb::grey(power),
                },
                3 | 4 => Light::Disk {
                    center: c,
                    normal: rng.direction(),
                    radius: rng.range(0.01, 3.0),
                    radiance: Rgb::grey(power),
                    two_sided: rng.below(2) == 0,
                },
                5 | 6 => {
                    let s = rng.range(0.01, 4.0);
                    let vertices = if rng.below(30) == 0 {
                        [c, c + Vec3::X, c + Vec3::X * 2.0]
                    } else {
                        [c, c + rng.direction() * s, c + rng.direction() * s]
                    };
                    Light::Triangle {
                        vertices,
                        radiance: Rgb::grey(power),
                        two_sided: rng.below(3) == 0,
                    }
                }
                _ => Light::Vpl {
                    position: c,
                    normal: rng.direction(),
                    intensity: Rgb::grey(power),
                },
            }
        })
        .collect()
}

/// FNV-1a (64 bits) of 32-bit words, byte order independent.
fn fnv(words: impl IntoIterator<Item = u32>) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for w in words {
        for b in w.to_le_bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}

/// FNV-1a (64 bits) of bytes.
fn fnv_bytes(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for &b in bytes {
        h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Hashes of the binary tree (every node of [`BinaryLightTree`]: bounds, energy, child); of
/// the 4-wide tree's contents, whatever their storage (its nodes, each node's variance, the
/// light of every light slot in tree order and every light's path), built with the default
/// options and with [`BuildOptions::compact`]; and of the default tree's byte form
/// ([`LightTree::as_bytes`]), of `lights`.
pub fn hashes(lights: &[Light]) -> [u64; 4] {
    let binary = BinaryLightTree::build(lights).expect("valid scene");
    let words: &[u32] = bytemuck::cast_slice(binary.nodes());
    let tree = LightTree::build(lights).expect("valid scene");
    let compact = LightTree::build_with(
        lights,
        &BuildOptions {
            compact: true,
            ..BuildOptions::default()
        },
    )
    .expect("valid scene");
    [
        fnv(words.iter().copied()),
        content_hash(&tree),
        content_hash(&compact),
        fnv_bytes(&tree.as_bytes()),
    ]
}

/// FNV-1a of a 4-wide tree's contents through its public accessors: the nodes' words, each
/// node's variance, each slot's light (tree order) and each light's path.
fn content_hash(tree: &LightTree) -> u64 {
    let nodes: &[u32] = bytemuck::cast_slice(tree.nodes());
    let variances = (0..tree.nodes().len() as u32).map(|n| tree.energy_rel_variance(n).to_bits());
    let slot_lights = tree.nodes().iter().flat_map(|node| {
        (0..4).filter_map(move |k| match tree.slot(node, k) {
            Slot::Light(l) => Some(l),
            _ => None,
        })
    });
    let paths = (0..tree.light_count()).flat_map(|l| {
        let p = tree.path(l);
        [p as u32, (p >> 32) as u32]
    });
    fnv(nodes
        .iter()
        .copied()
        .chain(variances)
        .chain(slot_lights)
        .chain(paths))
}

/// The scenes hashed: (seed, lights, style).
pub const CASES: [(u64, usize, u32); 24] = [
    (1, 1, 0),
    (2, 2, 0),
    (3, 3, 1),
    (4, 4, 0),
    (5, 5, 4),
    (6, 6, 2),
    (7, 9, 3),
    (8, 17, 0),
    (9, 33, 1),
    (10, 100, 0),
    (11, 100, 4),
    (12, 300, 2),
    (13, 300, 3),
    (14, 1000, 0),
    (15, 1000, 1),
    (16, 1000, 4),
    (17, 3000, 2),
    (18, 3000, 3),
    (19, 5000, 0),
    (20, 5000, 1),
    (21, 20000, 0),
    (22, 20000, 1),
    (23, 20000, 4),
    (24, 20000, 3),
];
