//! Seeded random many-light scenes: the scene of `mlmeasure bench` and of the criterion
//! benches, in a crate of its own so that the core's benches build without the renderer.
//!
//! N lights with centres uniform in [-100, 100]³ and power uniform in [0.1, 10]: 40 % points,
//! 20 % spots (random direction, half-angle uniform in [10°, 60°]), 20 % spheres (radius
//! uniform in [0.1, 1]), 20 % one-sided triangles (edges of about 0.1 to 2, random
//! orientation). Each light's intensity or radiance is set so that its power is the drawn one.
//! [`point_lights`] is the points-only variant (same cube, same powers).
//! Shading points are uniform in the same cube with uniformly random normals; [`surface_points`]
//! gives them a material and a view direction in the normal's hemisphere.
//!
//! Beside the scenes, the helpers the tests share: [`SplitMix64`], their deterministic
//! generator; [`TestUniforms`], its numbers behind the core's [`manylights::Uniforms`]; and
//! [`ggx`], the f64 GGX reference of the tests and the SPTD fit; with the feature `rayon`,
//! `RayonJoin`, the build's fork-join on rayon's pool.

pub mod ggx;
mod rng;
mod uniforms;
pub use rng::{splitmix64, SplitMix64};
pub use uniforms::TestUniforms;

/// The tree build's fork-join on rayon's thread pool ([`manylights::Join`]): what
/// [`LightTree::build_parallel`] is given by the tools.
#[cfg(feature = "rayon")]
#[derive(Clone, Copy, Debug, Default)]
pub struct RayonJoin;

#[cfg(feature = "rayon")]
impl manylights::Join for RayonJoin {
    fn join<A, B, RA, RB>(&self, a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA + Send,
        B: FnOnce() -> RB + Send,
        RA: Send,
        RB: Send,
    {
        rayon::join(a, b)
    }
}

use glam::Vec3;
use manylights::Rgb;
use manylights::{Light, LightTree, Material, SampledLight, TlImportance};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f32::consts::PI;
use std::hint::black_box;

/// Half the side of the scene cube.
pub const HALF_EXTENT: f32 = 100.0;

/// A uniformly random unit vector.
pub fn unit_vector(rng: &mut impl Rng) -> Vec3 {
    let z = rng.random_range(-1.0f32..=1.0);
    let phi = rng.random_range(0.0..2.0 * PI);
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

fn in_cube(rng: &mut impl Rng) -> Vec3 {
    Vec3::new(
        rng.random_range(-HALF_EXTENT..HALF_EXTENT),
        rng.random_range(-HALF_EXTENT..HALF_EXTENT),
        rng.random_range(-HALF_EXTENT..HALF_EXTENT),
    )
}

/// The bench scene's `n` lights, from `seed`.
pub fn lights(n: usize, seed: u64) -> Vec<Light> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let c = in_cube(&mut rng);
            let power = rng.random_range(0.1f32..10.0);
            // Interleave the kinds so every prefix of the list has the same mix.
            match i % 10 {
                0..=3 => Light::Point {
                    position: c,
                    intensity: Rgb::grey(power / (4.0 * PI)),
                },
                4 | 5 => {
                    let half_angle = rng.random_range(10.0f32..60.0).to_radians();
                    Light::Spot {
                        position: c,
                        direction: unit_vector(&mut rng),
                        intensity: Rgb::grey(power / (2.0 * PI * (1.0 - half_angle.cos()))),
                        half_angle,
                        falloff_start: half_angle * 0.8,
                    }
                }
                6 | 7 => {
                    let radius = rng.random_range(0.1f32..1.0);
                    Light::Sphere {
                        center: c,
                        radius,
                        radiance: Rgb::grey(power / (PI * 4.0 * PI * radius * radius)),
                    }
                }
                _ => {
                    // A roughly equilateral triangle of edge `size`, randomly oriented.
                    let size = rng.random_range(0.1f32..2.0);
                    let n = unit_vector(&mut rng);
                    let u = n.any_orthonormal_vector();
                    let v = n.cross(u);
                    let r = size / 3f32.sqrt();
                    let phase = rng.random_range(0.0..2.0 * PI);
                    let vertices = [0.0f32, 1.0, 2.0].map(|k| {
                        let a = phase + k * 2.0 * PI / 3.0 + rng.random_range(-0.2f32..0.2);
                        c + (u * a.cos() + v * a.sin()) * r
                    });
                    let t = Light::Triangle {
                        vertices,
                        radiance: Rgb::grey(1.0),
                        two_sided: false,
                    };
                    let area = t.area().max(1e-12);
                    Light::Triangle {
                        vertices,
                        radiance: Rgb::grey(power / (PI * area)),
                        two_sided: false,
                    }
                }
            }
        })
        .collect()
}

/// `n` isotropic point lights uniform in the cube with power uniform in [0.1, 10], from
/// `seed`: the scene whose build has no orientation to bound.
pub fn point_lights(n: usize, seed: u64) -> Vec<Light> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let c = in_cube(&mut rng);
            let power = rng.random_range(0.1f32..10.0);
            Light::Point {
                position: c,
                intensity: Rgb::grey(power / (4.0 * PI)),
            }
        })
        .collect()
}

/// A bench shading point: position and unit normal (what a TL importance is set up from;
/// [`manylights::ShadingPoint`] adds the view direction and material).
#[derive(Clone, Copy, Debug)]
pub struct BenchPoint {
    /// Position.
    pub position: Vec3,
    /// Unit normal.
    pub normal: Vec3,
}

/// `m` shading points uniform in the cube with uniform normals, from `seed`.
pub fn shading_points(m: usize, seed: u64) -> Vec<BenchPoint> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x5eed_0f90_1475);
    (0..m)
        .map(|_| BenchPoint {
            position: in_cube(&mut rng),
            normal: unit_vector(&mut rng),
        })
        .collect()
}

/// `m` uniform numbers in [0, 1), from `seed`.
pub fn uniforms(m: usize, seed: u64) -> Vec<f32> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0xa5a5_1234_5678_9abc);
    (0..m).map(|_| rng.random::<f32>()).collect()
}

/// `m` shading points for the BRDF-aware calls: the positions and normals of
/// [`shading_points`]`(m, seed)`, a view direction ωo uniform in the normal's hemisphere, and
/// `material`.
pub fn surface_points(m: usize, seed: u64, material: Material) -> Vec<manylights::ShadingPoint> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x0b5e_7e00_d1ec_7104);
    shading_points(m, seed)
        .into_iter()
        .map(|p| {
            let w = unit_vector(&mut rng);
            let wo = if w.dot(p.normal) < 0.0 { -w } else { w };
            manylights::ShadingPoint {
                position: p.position,
                normal: p.normal,
                wo,
                material,
            }
        })
        .collect()
}

/// The timed loop of the batch TL sampling benches (`mlmeasure bench`, the criterion `sampling`
/// and `abi` groups): `points` with their uniform numbers through
/// [`LightTree::sample_batch`], `out.len()` points per call, each call's importances built in
/// the loop as a host builds them per shading point (`imps` is the caller's scratch). Returns
/// the sum of the pmfs, for the caller to keep the work from being optimised away.
pub fn sample_batches(
    tree: &LightTree,
    points: &[BenchPoint],
    us: &[f32],
    imps: &mut Vec<TlImportance>,
    out: &mut [Option<SampledLight>],
) -> f32 {
    let chunk = out.len().max(1);
    let mut acc = 0.0f32;
    for (pc, uc) in points.chunks(chunk).zip(us.chunks(chunk)) {
        imps.clear();
        imps.extend(pc.iter().map(|p| TlImportance::new(p.position, p.normal)));
        tree.sample_batch(black_box(&imps[..]), black_box(uc), &mut out[..pc.len()])
            .expect("one uniform number per point");
        acc += out[..pc.len()].iter().flatten().map(|s| s.pmf).sum::<f32>();
    }
    acc
}

/// The timed loop of the batch pmf benches, as [`sample_batches`]: the pmf of `lights[j]` at
/// `points[j]` through [`LightTree::pmf_batch`], `out.len()` queries per call. Returns the sum
/// of the pmfs.
pub fn pmf_batches(
    tree: &LightTree,
    points: &[BenchPoint],
    lights: &[u32],
    imps: &mut Vec<TlImportance>,
    out: &mut [f32],
) -> f32 {
    let chunk = out.len().max(1);
    let mut acc = 0.0f32;
    for (pc, lc) in points.chunks(chunk).zip(lights.chunks(chunk)) {
        imps.clear();
        imps.extend(pc.iter().map(|p| TlImportance::new(p.position, p.normal)));
        tree.pmf_batch(black_box(&imps[..]), black_box(lc), &mut out[..pc.len()])
            .expect("one light per point");
        acc += out[..pc.len()].iter().sum::<f32>();
    }
    acc
}

/// The light [`LightTree::sample`] returns at each point with its uniform number (0 where it
/// returns none): the lights the pmf benches query.
pub fn sampled_lights(tree: &LightTree, points: &[BenchPoint], us: &[f32]) -> Vec<u32> {
    points
        .iter()
        .zip(us)
        .map(|(p, &u)| {
            tree.sample(&TlImportance::new(p.position, p.normal), u)
                .map_or(0, |s| s.light)
        })
        .collect()
}
