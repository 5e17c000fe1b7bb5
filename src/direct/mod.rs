//! Direct illumination at a shading point: every technique as one library call, over a
//! lower level for hosts with their own BSDFs, spectra or ray casts.
//!
//! A host builds a [`LightSet`](crate::LightSet) once per scene, then at each shading point an
//! [`Estimator`] for one [`Technique`] (its per-point set-up: cuts, budget) — a new one, or
//! better one kept per thread and moved to the point by [`Estimator::reset`], the same set-up
//! without the copy of its state — and asks it for estimates of the reflected radiance
//! `∫ f(ωo, ωi) L(ωi) cos θi dωi` from the lights:
//!
//! - **One call** ([`Estimator::estimate`]): with the core's [`Material`](crate::Material)s and a
//!   host [`Occluder`] (shadow rays), uniform numbers from the host's [`Uniforms`].
//! - **The lower level** ([`Estimator::start`], [`Estimator::next`]): the estimator yields
//!   [`Step::Light`] — a light point for the host to shade and test, weighed with the host's
//!   BSDF pdf by [`Estimator::weigh`] — and [`Step::Bsdf`] — two uniform numbers for the host
//!   to sample its BSDF with; the host reports the direction, its pdf and what its ray hit to
//!   [`Estimator::bsdf_hits`], which returns the lights reached with their weights. The
//!   adaptive allocation (Liu et al. 2019, Algorithm 1) learns from those reports. The one
//!   call is this loop with the core's materials (see "What is exact" below).
//! - **Learned visibility** ([`VisibilityCache`], optional): an estimator made by
//!   [`Estimator::with_visibility`] scales its BRDF-oriented cut's cluster weights by the share
//!   of shadow rays that got through at nearby points, as the cache counted them up to its
//!   last [`commit`](VisibilityCache::commit); the one call records its shadow rays, the lower
//!   level with [`Estimator::record`]. The pmfs stay exact, so every technique stays unbiased.
//!
//! ```
//! use glam::Vec3;
//! use manylights::direct::{Estimator, Params, Technique, Uniforms, Unoccluded};
//! use manylights::{Light, LightSet, Material, Rgb, ShadingPoint};
//!
//! /// The host's random numbers (any generator; here a 64-bit LCG).
//! struct Lcg(u64);
//! impl Uniforms for Lcg {
//!     fn next_f64(&mut self) -> f64 {
//!         self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
//!         (self.0 >> 11) as f64 / (1u64 << 53) as f64
//!     }
//!     fn next_f32(&mut self) -> f32 {
//!         (self.next_f64() as f32).min(1.0 - f32::EPSILON / 2.0)
//!     }
//! }
//!
//! let set = LightSet::build(vec![
//!     Light::Sphere {
//!         center: Vec3::new(0.0, 0.0, 2.0),
//!         radius: 0.5,
//!         radiance: Rgb::new(3.0, 2.5, 2.0),
//!     },
//!     Light::Point { position: Vec3::new(1.0, 0.0, 1.0), intensity: Rgb::grey(2.0) },
//! ])?;
//! let sp = ShadingPoint {
//!     position: Vec3::ZERO,
//!     normal: Vec3::Z,
//!     wo: Vec3::new(0.0, 0.6, 0.8),
//!     material: Material::Plastic { albedo: Rgb::new(0.6, 0.5, 0.4), specular: 0.5, alpha: 0.2 },
//! };
//! let mut est = Estimator::new(&set, &sp, Technique::DEFAULT, &Params::default())?;
//! let rgb = est.estimate(&Unoccluded, &mut Lcg(7))?; // one estimate, host visibility
//! assert!(rgb.iter().all(|c| c.is_finite() && *c >= 0.0));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Every contribution is `value · weight / pdf` ([`Weighted::contribution`], or `value ·`
//! [`Weighted::factor`] for each channel of a spectral value of any sign), with `value = f · L
//! · cos θi` evaluated by whoever owns the BSDF; an estimate is the sum over the steps.
//!
//! Many shading points at once (a wavefront host): [`crate::wavefront::estimate_each`], bit
//! for bit the per-point set-up and estimates one after the other.
//!
//! # Techniques
//!
//! - `uniform`, `power`: one light uniformly or ∝ energy ([`UniformSampler`],
//!   [`EnergySampler`]: an alias table), a point on it.
//! - `tl`: one light by tree descent with the Conty–Kulla importance ([`TreeSampler`]).
//! - `tl-split`: Conty & Kulla's split sampling: one light in each cluster of the split cut
//!   ([`LightCut::build_split`](crate::LightCut::build_split)), summed.
//! - `bl`: one light from the BRDF-oriented cut of Liu et al. 2019 ([`CutSampler`]).
//! - `tl-mis`: one `tl` light sample plus one BSDF sample, combined by the power heuristic
//!   (β = 2): what pbrt-v4 and Blender Cycles do at a shading point.
//! - `bl-mis`: k `bl` light samples from the one cut ([`Params::bl_light_samples`], 2 by
//!   default) plus one BSDF sample, combined by the power heuristic with the sample counts:
//!   the BRDF-oriented cut's light choice, with the BSDF sample covering what a light sample
//!   of a glossy lobe misses. Sample i of k takes its first uniform number in
//!   `[i/k, (i+1)/k)`, so the k samples stratify the cut's choice; each contributes
//!   `g w_L / (k p_L)` with `w_L = (k p_L)² / ((k p_L)² + p_B²)`, a BSDF hit `g w_B / p_B`
//!   with `w_B = p_B² / ((k p_L)² + p_B²)`. Unbiased as any multi-sample MIS with weights
//!   summing to 1 (Veach 1997, section 9.2; the stratified samples keep the expectation of
//!   k independent ones): the weights are fixed functions of the point, and the BSDF
//!   sample reaches every light point the light samples cannot give (point and spot lights
//!   are the light samples' alone, with weight 1). The cut is the per-point set-up every
//!   sample shares, which is why more than one light sample pays
//!   (docs/measurements.md).
//! - `mis-equal`: `tl-split` plus `N = brdf_budget(cut, n_max)` BRDF-aware samples (none at
//!   Lambert points): ⌊N/2⌋ BL, ⌊N/2⌋ BSDF (TB) and, for an odd N, one more that is BL or TB
//!   with probability 1/2. A BRDF-aware sample y contributes `g(y) w_M(y) / (N q_ref(y))`,
//!   `q_ref = (pdf_BL + pdf_TB)/2`, the expected number of BRDF-aware samples landing at y per
//!   unit measure, so the sum is unbiased wherever `q_ref` covers `g·w_M`
//!   (`CombinedWeights` with `p_ref = 1/2`).
//! - `full`, the method of Liu et al. 2019: `tl-split` plus N BRDF-aware samples chosen by
//!   `AdaptiveAllocator` (Algorithm 1) and weighted by
//!   `SequentialWeights`: sample j contributes
//!   `g W_j / q_j` with `q_j = p_j pdf_BL + (1 − p_j) pdf_TB`, p_j the allocator's probability
//!   before the sample. Each choice takes a fresh uniform number; the allocator warps it and
//!   the warped number drives the chosen technique's first dimension — it is never fed to the
//!   next choice, since a BSDF sample's hit depends on it and the next choice would no longer
//!   have probability p_{j+1} given the counts. The TL samples are drawn first but weighted
//!   (and yielded) after the last BRDF-aware sample, once every p_j is known. At Lambert-only
//!   points see [`LambertMode`].
//!
//! The default for a renderer is [`Technique::DEFAULT`], `bl-mis`: where every estimate is a
//! new shading point (as in a renderer: each camera sample and path vertex), a technique's
//! per-point set-up and its number of shadow rays count as much as its variance, and two
//! BRDF-oriented light samples plus one BSDF sample cost a small fraction of split sampling's
//! dozens of light samples and shadow rays while keeping both the BRDF-oriented choice of
//! light and the BSDF sample's coverage of glossy lobes. `full` remains the method of Liu et
//! al. 2019 for hosts that take many samples at one shading point.
//!
//! Densities, for MIS: TL's of a light point y on light l is `split.pmf_in(l) · pdf_point(y)`,
//! BL's `cut.pmf(l) · pdf_point(y)` (`k` times it for the k light samples of `bl-mis`
//! together), TB's the BSDF's solid-angle pdf. Point and spot lights
//! cannot be reached by a BSDF ray, so their TB density is 0 in every weight. A BSDF ray
//! reaches the lights through the tree's bounding spheres ([`LightTree::trace`]); lights do not
//! block each other. The TB "hit" the allocator counts: the ray reached at least one light with
//! non-zero radiance in front of the first surface.
//!
//! # What is exact
//!
//! From the same uniform numbers the lower level yields the one call's steps: the same lights,
//! points, pmfs, weights and BSDF uniform numbers. The one call evaluates its material in the
//! shading frame of [`Frame::from_normal`](crate::Frame::from_normal): `wi =
//! frame.to_local(point.direction)` for a light step (f in colour by `Material::eval_rgb`, the
//! BSDF pdf and cos θi = `wi.z`), and for a BSDF step the local direction of
//! `Material::sample`, its pdf and value (`Material::eval_rgb` of it), sent as
//! `frame.to_world(wi).normalize()`. A host that evaluates the core's material the same way
//! gets the one call's terms bit for bit, and the C ABI's `ml_brdf_eval` / `ml_brdf_pdf` of a
//! light step's direction and `ml_brdf_sample`'s draw are exactly those. What is not exact: the
//! host's own arithmetic (its cos θi, its products with the weight, its sum) rounds otherwise,
//! a few units in the last place of f32 per term; and the pdf of a sampled direction
//! recomputed from its world-space form (`ml_brdf_pdf` of a draw's `wi`) is that of a
//! direction moved by the frame's round trip, which for a sharp GGX lobe is a visible relative
//! difference: pass the draw's own pdf, as the one call does.
//!
//! # Host BSDFs
//!
//! A host with its own BSDF gives the estimators a stand-in [`Material`](crate::Material) for
//! the BRDF-aware parts: the BL importance and cut (which lights to choose), IB(x) and with it
//! `mis-equal`'s and `full`'s budget N, and `full`'s allocation. The weights use the host's
//! own pdfs for its BSDF samples and the library's pmfs for its light samples, consistently,
//! so the stand-in changes the variance only, never the expectation (for a host BSDF that
//! reflects into the normal's hemisphere, where the library's lobes are positive). A close
//! stand-in keeps the variance low:
//!
//! - a Phong lobe of exponent n about the mirror direction: GGX with α = 1/√(2n + 1); a
//!   Blinn–Phong lobe of exponent e about the half vector: α = √(2/(e + 2)) (Walter et al. 2007,
//!   section 5.2, the Beckmann–Phong correspondence, which serves for GGX as well);
//! - RGB albedos and specular colours: one scalar each, their luminance (0.2126 R + 0.7152 G +
//!   0.0722 B) or their largest channel, in [0, 1];
//! - a diffuse-plus-glossy BSDF: `Plastic` with the two weights.
//!
//! A Lambert stand-in has no glossy lobe, so `mis-equal` and `full` take no BSDF samples there
//! (N = 0; `full` per [`LambertMode`]): right for a diffuse host BSDF, a loss of the BSDF
//! samples' coverage for a glossy one (still unbiased: the split samples cover every light).
//! When the host's BSDF gives no direction for a [`Step::Bsdf`]'s numbers it skips
//! [`Estimator::bsdf_hits`], as the one call does: the sample contributes nothing and `full`
//! counts it as a ray that reached no light.
//!
//! # Bad input
//!
//! Nothing here panics or allocates. An invalid shading point is a [`DirectError::Shading`]
//! naming its field; a uniform number outside [0, 1) (or NaN), a NaN or negative BSDF pdf, a
//! non-finite or zero direction and a NaN hit distance are errors naming the argument. An
//! estimate is always finite and non-negative.
//!
//! [`LightTree::trace`]: crate::LightTree::trace

mod estimator;
mod sampler;
pub mod visibility;

pub use estimator::{BsdfDraw, Estimator, LightDraw, LightHit, Step, Weighted};
pub use sampler::{
    CutSampler, EnergySampler, LightSampler, PinfSampler, TreeSampler, UniformSampler,
};

pub use crate::error::DirectError;
pub use visibility::{
    VisibilityCache, VisibilityError, VisibilityField, VisibilityOptions, VisibilityStats,
    MAX_VISIBILITY_CELLS, MAX_VISIBILITY_COUNTERS, MAX_VISIBILITY_SLOTS,
};

use crate::cut::{BlCutOptions, SplitCutOptions};
use crate::mis::{Heuristic, N_MAX};
use core::fmt;
use glam::Vec3;

/// A direct-lighting technique.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Technique {
    /// One light uniformly.
    Uniform,
    /// One light ∝ energy (its flux; for a light at infinity, its power over the scene).
    Energy,
    /// Tree descent with TL importance, one sample.
    Tl,
    /// Split sampling, one sample per cluster.
    TlSplit,
    /// BRDF-oriented cut, one sample.
    Bl,
    /// TL split + BL/TB in equal numbers.
    MisEqual,
    /// TL split + BL/TB adaptively (Liu et al. 2019).
    Full,
    /// One TL tree sample + one BSDF sample, power heuristic (pbrt-v4, Cycles).
    TlMis,
    /// [`Params::bl_light_samples`] samples of one BRDF-oriented cut + one BSDF sample, power
    /// heuristic with the counts.
    BlMis,
    /// `tl-mis` with pbrt-v4's handling of distant and environment lights: with n of them,
    /// each picked with the fixed probability `1 / (n + 1)` whatever the point, the node tree
    /// otherwise — `1 / n` each when the tree holds no local light ([`PinfSampler`]): the
    /// yardstick of weighing them per shading point.
    TlMisPinf,
}

impl Technique {
    /// Every technique.
    pub const ALL: [Technique; 10] = [
        Technique::Uniform,
        Technique::Energy,
        Technique::Tl,
        Technique::TlSplit,
        Technique::Bl,
        Technique::MisEqual,
        Technique::Full,
        Technique::TlMis,
        Technique::BlMis,
        Technique::TlMisPinf,
    ];

    /// The technique a renderer should use when it has no reason to choose another: `bl-mis`,
    /// two samples of the BRDF-oriented cut and one BSDF sample (see the module documentation;
    /// docs/measurements.md has the measurements it was chosen from).
    pub const DEFAULT: Technique = Technique::BlMis;

    /// The technique of a name (as [`Technique::name`] gives it).
    #[must_use]
    pub fn from_name(name: &str) -> Option<Technique> {
        Technique::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The technique's name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Technique::Uniform => "uniform",
            Technique::Energy => "energy",
            Technique::Tl => "tl",
            Technique::TlSplit => "tl-split",
            Technique::Bl => "bl",
            Technique::MisEqual => "mis-equal",
            Technique::Full => "full",
            Technique::TlMis => "tl-mis",
            Technique::BlMis => "bl-mis",
            Technique::TlMisPinf => "tl-mis-pinf",
        }
    }

    /// Whether the technique takes BSDF samples ([`Step::Bsdf`]) at some shading points.
    #[must_use]
    pub fn samples_bsdf(self) -> bool {
        matches!(
            self,
            Technique::MisEqual
                | Technique::Full
                | Technique::TlMis
                | Technique::BlMis
                | Technique::TlMisPinf
        )
    }
}

impl fmt::Display for Technique {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What `full` does at a Lambert-only shading point.
///
/// For a constant BRDF the BRDF-oriented importance is the TL one with exact cap integrals
/// (Liu et al. 2019, end of section 4.2), so BL adds nothing and only TL and TB remain. Next to
/// a small sphere light a few radii from a wall TL samples the light's cap uniformly and is
/// nearly exact, and a cosine-distributed BRDF sample only adds variance and a ray;
/// docs/measurements.md has the measurements behind the default.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
#[non_exhaustive]
pub enum LambertMode {
    /// TL split alone (the default): the Lambert share of IB(x) asks for no BRDF-aware
    /// samples (the MIS budget).
    #[default]
    TlOnly,
    /// TL split + N = `sample_budget(IB(x))` TB samples (Liu et al.: TL + TB only; the budget
    /// as at any other point).
    TbBudget,
    /// TL split + 1 TB sample (no BL cut is built: IB is not needed).
    TbOne,
    /// As at glossy points: TL split + N samples allocated adaptively between BL and TB.
    BlTb,
}

impl LambertMode {
    /// Every mode.
    pub const ALL: [LambertMode; 4] = [
        LambertMode::TlOnly,
        LambertMode::TbBudget,
        LambertMode::TbOne,
        LambertMode::BlTb,
    ];

    /// The mode's name (`tl-only`, `tb-budget`, `tb-one`, `bl-tb`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            LambertMode::TlOnly => "tl-only",
            LambertMode::TbBudget => "tb-budget",
            LambertMode::TbOne => "tb-one",
            LambertMode::BlTb => "bl-tb",
        }
    }

    /// The mode of a name (as [`LambertMode::name`] gives it).
    #[must_use]
    pub fn from_name(name: &str) -> Option<LambertMode> {
        LambertMode::ALL.into_iter().find(|m| m.name() == name)
    }
}

/// Most light samples of one `bl-mis` estimate ([`Params::bl_light_samples`]).
pub const MAX_LIGHT_SAMPLES: u32 = 64;

/// Everything a host configures: the cuts, the budget and the weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// The split-sampling cut (`tl-split`, `mis-equal`, `full`).
    pub split_cut: SplitCutOptions,
    /// The BRDF-oriented cut of `bl` and `bl-mis` (the library's defaults,
    /// [`BlCutOptions::default`]).
    pub bl_cut: BlCutOptions,
    /// The BRDF-oriented cut of `mis-equal` and `full`, whose IB(x) also sets their budget
    /// (Liu et al. 2019's by default, [`BlCutOptions::PAPER`]).
    pub mixture_cut: BlCutOptions,
    /// Light samples per estimate of `bl-mis`, all from its one cut (clamped to
    /// 1..=[`MAX_LIGHT_SAMPLES`]; default 2): stratified over the cut's choice and weighed
    /// against its one BSDF sample with the sample counts.
    pub bl_light_samples: u32,
    /// Nmax of the BRDF-aware budget `N = ceil(Nmax · IB(x))` (clamped to
    /// 1..=[`MAX_BUDGET`](crate::mis::MAX_BUDGET)).
    pub n_max: u32,
    /// `full` at Lambert-only points.
    pub lambert: LambertMode,
    /// The MIS heuristic between the techniques (the power heuristic, β = 2, by default).
    pub heuristic: Heuristic,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            split_cut: SplitCutOptions::default(),
            bl_cut: BlCutOptions::default(),
            mixture_cut: BlCutOptions::PAPER,
            bl_light_samples: 2,
            n_max: N_MAX,
            lambert: LambertMode::TlOnly,
            heuristic: Heuristic::Power,
        }
    }
}

/// The host's uniform numbers (the core has no random number generator). Any sequence works;
/// the estimator asks for them one at a time, in an order fixed by the technique and the
/// outcomes so far.
pub trait Uniforms {
    /// The next number, uniform in [0, 1).
    fn next_f32(&mut self) -> f32;
    /// The next number, uniform in [0, 1) with more bits: for choosing among more lights than
    /// an f32 can tell apart (`uniform`, `power`).
    fn next_f64(&mut self) -> f64;
}

/// The host's visibility: geometry that blocks light.
///
/// A light sample counts only if the segment from the shading point to the light point is
/// free; a BSDF ray reaches only the lights in front of the first surface, each tested with a
/// shadow ray to the point it reaches (so most BSDF rays, which reach no light, cost no ray
/// cast). Lights do not block each other.
pub trait Occluder {
    /// Whether a surface lies on the ray from `x` along the unit `d` before distance `t`.
    fn occluded(&self, x: Vec3, d: Vec3, t: f32) -> bool;
}

/// No geometry: nothing is occluded.
#[derive(Clone, Copy, Debug, Default)]
pub struct Unoccluded;

impl Occluder for Unoccluded {
    #[inline]
    fn occluded(&self, _x: Vec3, _d: Vec3, _t: f32) -> bool {
        false
    }
}

impl<O: Occluder + ?Sized> Occluder for &O {
    #[inline]
    fn occluded(&self, x: Vec3, d: Vec3, t: f32) -> bool {
        (**self).occluded(x, d, t)
    }
}
