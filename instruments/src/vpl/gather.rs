//! Gathering the VPLs at the pixels: every VPL with a shadow ray (`all`, classic instant
//! radiosity), or a few VPLs per pixel drawn from a light tree of them (`tree`).
//!
//! A VPL at y (unit normal m, intensity I) adds to the pixel whose camera ray hits x (unit
//! normal n facing the camera, albedo a)
//!
//! ```text
//! (a/π) · I · min(G, g_max) · V(x, y),     G = max(0, n·ω) · max(0, −m·ω) / |y − x|²,  ω = (y − x)/|y − x|
//! ```
//!
//! The clamp g_max (the scene's) is the usual one of instant radiosity: without it G grows as
//! 1/d² near a VPL and a VPL close to a visible surface paints a bright blotch; with it the
//! estimate loses the energy of the clamped part (a bias that every variant and the reference
//! share, since they all gather through this one function).

use glam::Vec3;
use manylights::cut::{CUT_CAPACITY, MAX_CUT_SIZE};
use manylights::Occluder;
use manylights::{Light, LightCut, LightTree, SampledLight, SplitCutOptions, TlImportance, Vpl};
use manylights_render::render::primary;
use manylights_render::scene::{Geometry, RenderScene};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f32::consts::FRAC_1_PI;

/// What a pixel's camera ray hit: position (offset off the surface), unit normal facing the
/// camera, BRDF value albedo/π.
#[derive(Clone, Copy, Debug)]
pub struct PixelHit {
    /// Position.
    pub position: Vec3,
    /// Unit normal, on the camera's side.
    pub normal: Vec3,
    /// Diffuse albedo.
    pub albedo: f32,
}

/// The camera hits of every pixel, row-major (`None` where the ray leaves the scene).
pub fn pixel_hits(scene: &RenderScene, w: usize, h: usize) -> Vec<Option<PixelHit>> {
    (0..w * h)
        .map(|i| {
            primary(scene, i % w, i / w, w, h).map(|sp| PixelHit {
                position: sp.position,
                normal: sp.normal,
                albedo: sp.material.lobes().0,
            })
        })
        .collect()
}

/// Whether the segment from `x` to `y` is free.
#[inline]
pub fn visible(geometry: &Geometry, x: Vec3, y: Vec3) -> bool {
    let d = y - x;
    let t = d.length();
    t > 0.0 && !geometry.occluded(x, d / t, t)
}

/// A VPL ready for the gathers: position, unit normal, intensity.
#[derive(Clone, Copy, Debug)]
pub struct Gathered {
    /// Position.
    pub position: Vec3,
    /// Unit normal.
    pub normal: Vec3,
    /// Intensity.
    pub intensity: f32,
}

impl From<&Vpl> for Gathered {
    fn from(v: &Vpl) -> Gathered {
        Gathered {
            position: v.position,
            normal: v.normal.normalize(),
            intensity: v.intensity.luminance(),
        }
    }
}

/// The unoccluded contribution of `v` at the hit (see the module documentation).
#[inline]
pub fn unoccluded(hit: &PixelHit, v: &Gathered, g_max: f32) -> f32 {
    let d = v.position - hit.position;
    let d2 = d.length_squared();
    if d2 <= 0.0 {
        return 0.0;
    }
    let inv = 1.0 / d2.sqrt();
    let cos_x = hit.normal.dot(d) * inv;
    let cos_y = -v.normal.dot(d) * inv;
    if cos_x <= 0.0 || cos_y <= 0.0 {
        return 0.0;
    }
    let g = (cos_x * cos_y / d2).min(g_max);
    hit.albedo * FRAC_1_PI * v.intensity * g
}

/// The contribution with visibility.
#[inline]
pub fn contribution(geometry: &Geometry, hit: &PixelHit, v: &Gathered, g_max: f32) -> f32 {
    let c = unoccluded(hit, v, g_max);
    if c > 0.0 && visible(geometry, hit.position, v.position) {
        c
    } else {
        0.0
    }
}

/// `all`: the pixel's value from every VPL.
pub fn gather_all(geometry: &Geometry, hit: &PixelHit, vpls: &[Gathered], g_max: f32) -> f32 {
    vpls.iter()
        .map(|v| contribution(geometry, hit, v, g_max))
        .sum()
}

/// How the `tree` gather draws its VPLs at a pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TreeSampling {
    /// `spp` independent draws from the whole tree by TL importance (`LightTree::sample`).
    Tl,
    /// Split sampling: a cut of at most `spp` clusters by Conty & Kulla's variance heuristic
    /// (`LightCut::build_split`), one draw in each (`LightCut::sample_each`), summed.
    Split,
}

impl TreeSampling {
    /// Its command-line name.
    pub fn name(self) -> &'static str {
        match self {
            TreeSampling::Tl => "tl",
            TreeSampling::Split => "split",
        }
    }

    /// From its name.
    pub fn from_name(s: &str) -> Option<TreeSampling> {
        match s {
            "tl" => Some(TreeSampling::Tl),
            "split" => Some(TreeSampling::Split),
            _ => None,
        }
    }
}

/// The accepted VPLs of one frame in a light tree.
pub struct VplTree {
    tree: Option<LightTree>,
    vpls: Vec<Gathered>,
}

impl VplTree {
    /// Builds the tree (`None` inside when there is no VPL of positive intensity).
    pub fn build(vpls: &[Gathered]) -> VplTree {
        let lights: Vec<Light> = vpls
            .iter()
            .map(|v| Light::Vpl {
                position: v.position,
                normal: v.normal,
                intensity: v.intensity.into(),
            })
            .collect();
        let tree = if vpls.iter().any(|v| v.intensity > 0.0) {
            Some(LightTree::build(&lights).expect("VPLs from finite walks are valid lights"))
        } else {
            None
        };
        VplTree {
            tree,
            vpls: vpls.to_vec(),
        }
    }

    fn estimate(&self, geometry: &Geometry, hit: &PixelHit, s: SampledLight, g_max: f32) -> f32 {
        let v = &self.vpls[s.light as usize];
        contribution(geometry, hit, v, g_max) / s.pmf
    }

    /// `tree`: an unbiased estimate of [`gather_all`] at the hit from `spp` draws (`Tl`) or
    /// a cut of at most `spp` clusters (`Split`), and the number of VPLs drawn; `seed` (mixed
    /// first: any seeds will do) makes the uniform numbers.
    pub fn gather(
        &self,
        geometry: &Geometry,
        hit: &PixelHit,
        spp: usize,
        sampling: TreeSampling,
        g_max: f32,
        seed: u64,
    ) -> (f32, usize) {
        let Some(tree) = &self.tree else {
            return (0.0, 0);
        };
        let mut rng = Pcg64Mcg::seed_from_u64(super::walk::mix(seed));
        let imp = TlImportance::new(hit.position, hit.normal);
        match sampling {
            TreeSampling::Tl => {
                let mut sum = 0.0;
                for _ in 0..spp {
                    if let Some(s) = tree.sample(&imp, rng.random::<f32>()) {
                        sum += self.estimate(geometry, hit, s, g_max);
                    }
                }
                (sum / spp as f32, spp)
            }
            TreeSampling::Split => {
                let opts = SplitCutOptions {
                    max_size: spp.clamp(1, MAX_CUT_SIZE),
                    ..SplitCutOptions::default()
                };
                let cut = LightCut::build_split(tree, &imp, &opts);
                let n = cut.len();
                let mut u = [0f32; CUT_CAPACITY];
                for v in &mut u[..n] {
                    *v = rng.random::<f32>();
                }
                let mut out = [None; CUT_CAPACITY];
                cut.sample_each(tree, &imp, &u[..n], &mut out[..n]);
                let sum = out[..n]
                    .iter()
                    .flatten()
                    .map(|&s| self.estimate(geometry, hit, s, g_max))
                    .sum();
                (sum, n)
            }
        }
    }
}
