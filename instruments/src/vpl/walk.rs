//! VPL candidates from random walks from the light (Keller 1997, "Instant Radiosity"): a
//! path leaves the point light in a uniform direction carrying flux Φ/M (Φ = 4πI, M paths per
//! frame); at every diffuse hit y (albedo ρ) it leaves the candidate VPL of intensity ρ·flux/π
//! (what y re-emits, as a one-sided Lambertian point), then continues with probability ρ in a
//! cosine-distributed direction (Russian roulette: the carried flux stays Φ/M).
//!
//! Plain instant radiosity keeps every candidate; with acceptance each candidate goes through
//! the core's [`VplAcceptor`] (importons with visibility by shadow rays) and is kept with its
//! probability, its intensity scaled by 1/p.

use super::gather::visible;
use super::scenes::VplScene;
use glam::Vec3;
use manylights::vpl::AcceptStats;
use manylights::Rgb;
use manylights::{Frame, Vpl, VplAcceptor};
use manylights_render::render::busy_time;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use std::f32::consts::{FRAC_1_PI, PI};

/// Longest walk (bounces); Russian roulette ends nearly all walks long before.
const MAX_BOUNCES: usize = 64;

/// Independent chunks of a frame's paths (each its own random numbers and acceptor copy), so
/// that the result does not depend on the number of threads.
const CHUNKS: usize = 16;

/// A frame's VPLs.
#[derive(Debug, Default)]
pub struct FrameVpls {
    /// The VPLs kept (intensities already scaled by 1/p).
    pub vpls: Vec<Vpl>,
    /// Some of the candidates (the first of each chunk), to estimate the next frame's mean
    /// acceptance probability.
    pub sample: Vec<Vpl>,
    /// Decisions (every candidate counts as accepted with p = 1 without acceptance).
    pub stats: AcceptStats,
    /// Busy seconds (CPU time summed over the threads).
    pub seconds: f64,
}

/// SplitMix64's finaliser (Steele, Lea, Flood 2014): seeds that differ in a few bits (a
/// pixel index, a chunk number) become unrelated ones. `Pcg64Mcg::seed_from_u64` of nearby
/// seeds gives visibly correlated first numbers, which biases an average over such seeds.
pub fn mix(seed: u64) -> u64 {
    let mut z = seed.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A unit vector uniform on the sphere.
fn sphere_dir(rng: &mut Pcg64Mcg) -> Vec3 {
    let z = 1.0 - 2.0 * rng.random::<f32>();
    let phi = 2.0 * PI * rng.random::<f32>();
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// A cosine-distributed unit vector about the unit `n`.
fn cosine_dir(n: Vec3, rng: &mut Pcg64Mcg) -> Vec3 {
    let (u1, u2) = (rng.random::<f32>(), rng.random::<f32>());
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let local = Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt());
    Frame::from_normal(n).map_or(n, |f| f.to_world(local).normalize())
}

/// One walk from the light carrying `flux`; `emit` receives each candidate.
pub fn walk(scene: &VplScene, flux: f32, rng: &mut Pcg64Mcg, mut emit: impl FnMut(Vpl)) {
    let g = &scene.scene.geometry;
    let (mut o, mut d) = (scene.light, sphere_dir(rng));
    for _ in 0..MAX_BOUNCES {
        let Some(hit) = g.nearest(o, d, 1e-4) else {
            break;
        };
        let n = if hit.normal.dot(d) > 0.0 {
            -hit.normal
        } else {
            hit.normal
        };
        let p = o + d * hit.t;
        let p = p + n * (1e-4 * (1.0 + p.abs().max_element()));
        let albedo = hit.material.lobes().0;
        emit(Vpl {
            position: p,
            normal: n,
            intensity: Rgb::grey(albedo * flux * FRAC_1_PI),
        });
        if rng.random::<f32>() >= albedo {
            break;
        }
        o = p;
        d = cosine_dir(n, rng);
    }
}

/// The mean number of candidates per path, from `paths` walks (seeded by `seed`).
pub fn candidates_per_path(scene: &VplScene, paths: usize, seed: u64) -> f64 {
    let mut rng = Pcg64Mcg::seed_from_u64(mix(seed));
    let mut n = 0u64;
    for _ in 0..paths {
        walk(scene, 1.0, &mut rng, |_| n += 1);
    }
    n as f64 / paths.max(1) as f64
}

/// The VPLs of one frame from `paths` walks, through `acceptor` if given (its importons and
/// Φ̃_total as they are; its counts are left alone: the frame's are returned).
pub fn frame_vpls(
    scene: &VplScene,
    paths: usize,
    acceptor: Option<&VplAcceptor>,
    seed: u64,
) -> FrameVpls {
    let flux = 4.0 * PI * scene.intensity / paths.max(1) as f32;
    let g = &scene.scene.geometry;
    let parts: Vec<FrameVpls> = (0..CHUNKS)
        .into_par_iter()
        .map(|c| {
            let (lo, hi) = (c * paths / CHUNKS, (c + 1) * paths / CHUNKS);
            let mut rng = Pcg64Mcg::seed_from_u64(mix(seed ^ mix(c as u64)));
            let mut acc = acceptor.cloned();
            if let Some(a) = &mut acc {
                a.reset_stats();
            }
            let (mut vpls, mut sample, mut stats) =
                (Vec::new(), Vec::new(), AcceptStats::default());
            let seconds = busy_time(|| {
                let mut candidates = Vec::new();
                for _ in lo..hi {
                    candidates.clear();
                    walk(scene, flux, &mut rng, |v| candidates.push(v));
                    for v in &candidates {
                        if sample.len() < 16 {
                            sample.push(*v);
                        }
                        match &mut acc {
                            None => {
                                let e = f64::from(v.energy());
                                stats.candidates += 1;
                                stats.accepted += 1;
                                stats.sum_probability += 1.0;
                                stats.candidate_energy += e;
                                stats.accepted_energy += e;
                                vpls.push(*v);
                            }
                            Some(a) => {
                                let xi = rng.random::<f32>();
                                let mut vis = |x: Vec3, y: Vec3| visible(g, x, y);
                                if let Some(k) = a
                                    .accept_with(v, xi, &mut vis)
                                    .expect("candidates of the walks are valid")
                                {
                                    vpls.push(k.vpl);
                                }
                            }
                        }
                    }
                }
            });
            if let Some(a) = &acc {
                stats = a.stats();
            }
            FrameVpls {
                vpls,
                sample,
                stats,
                seconds,
            }
        })
        .collect();
    let mut out = FrameVpls::default();
    for p in parts {
        out.vpls.extend(p.vpls);
        out.sample.extend(p.sample);
        out.seconds += p.seconds;
        out.stats.merge(&p.stats);
    }
    out
}
