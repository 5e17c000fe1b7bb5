//! The per-shading-point estimator: set-up, the step machine of the lower level, and the one
//! call built on it.

use super::sampler::{
    CutSampler, LightSampler, PinfSampler, PowerSampler, TreeSampler, UniformSampler,
};
use super::sky::Environment;
use super::{DirectError, LambertMode, Occluder, Params, Technique, Uniforms, MAX_LIGHT_SAMPLES};
use crate::brdf::{Brdf, Frame};
use crate::colour::Rgb;
use crate::cut::{BlCutOptions, LightCut, CUT_CAPACITY};
use crate::error::Problem;
use crate::importance::{BlImportance, Importance, TlImportance};
use crate::infinite::{InfiniteKind, MAX_INFINITE_LIGHTS};
use crate::light::Light;
use crate::light_sample::{intersect, sample_point, LightPoint};
use crate::light_set::LightSet;
use crate::material::{Material, ShadingError, ShadingField, ShadingPoint};
use crate::math;
use crate::mis::{
    brdf_budget, sample_budget, AdaptiveAllocator, CombinedWeights, Factors, Mixture,
    SequentialWeights,
};
use crate::sample::ONE_MINUS_EPSILON;
use glam::Vec3;

/// A sample's weight and density: it contributes `value · weight / pdf`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weighted {
    f: Factors,
}

impl Weighted {
    /// Contributes nothing.
    const ZERO: Weighted = Weighted {
        f: Factors {
            num: 0.0,
            den: 1.0,
            pdf: 1.0,
        },
    };

    /// Weight 1, density `pdf`.
    #[inline]
    fn plain(pdf: f32) -> Weighted {
        Weighted::checked(Factors {
            num: 1.0,
            den: pdf,
            pdf,
        })
    }

    /// `num / den` with density `pdf`; nothing unless `den` and `pdf` are positive and finite.
    #[inline]
    fn checked(f: Factors) -> Weighted {
        let ok = f.den > 0.0 && f.den < f32::INFINITY && f.pdf > 0.0 && f.pdf < f32::INFINITY;
        if ok && f.num >= 0.0 && f.num < f32::INFINITY {
            Weighted { f }
        } else {
            Weighted::ZERO
        }
    }

    /// The MIS weight, in [0, 1].
    #[inline]
    pub fn weight(&self) -> f32 {
        (self.f.num * self.f.pdf / self.f.den).clamp(0.0, 1.0)
    }

    /// The density the weight is relative to (in the measure of its value: solid angle, or 1
    /// for point, spot and VPL lights): for a light sample, its technique's density (pmf ·
    /// point pdf, times k for the k light samples of `bl-mis`; for a BRDF-aware sample of
    /// `mis-equal` or `full`, the mixture's density);
    /// for a BSDF hit ([`LightHit`]), the BSDF's pdf for `tl-mis` and `bl-mis`, and the
    /// combined density of the BRDF-aware mixture (BL and BSDF, as the technique mixes them)
    /// for `mis-equal` and `full`. The contribution is `value · weight / pdf` in every case.
    #[inline]
    pub fn pdf(&self) -> f32 {
        self.f.pdf
    }

    /// The factor a sample's value is multiplied by, `weight / pdf` (finite, ≥ 0): what a host
    /// applies to each channel of a spectral or RGB value (negative values included, which
    /// [`Weighted::contribution`] clamps to 0). `value · factor()` equals
    /// `contribution(value)` for positive values up to one rounding (the one call computes
    /// `value · num / den`, with weight = num·pdf/den); the C ABI's `ml_weighted.scale` is
    /// this factor, bit for bit.
    #[inline]
    pub fn factor(&self) -> f32 {
        let v = self.f.num / self.f.den;
        if v < f32::INFINITY {
            v
        } else {
            0.0
        }
    }

    /// [`Weighted::contribution`] of each channel of `value`.
    #[inline]
    pub fn contribution_rgb(&self, value: Rgb) -> Rgb {
        value.map(|c| self.contribution(c))
    }

    /// What a sample of `value` (`f · L · cos θi`, or one channel of it) contributes:
    /// `value · weight / pdf`, evaluated as the one-call estimator does; 0 for a value that is
    /// not positive, and never NaN or infinite. For values of any sign use
    /// [`Weighted::factor`].
    #[inline]
    pub fn contribution(&self, value: f32) -> f32 {
        if value.is_nan() || value <= 0.0 {
            return 0.0;
        }
        let v = value * self.f.num / self.f.den;
        if v < f32::INFINITY {
            v
        } else {
            0.0
        }
    }
}

/// What a light sample is, for its weight.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Role {
    /// A technique without MIS: weight 1.
    Plain,
    /// A sample of split sampling.
    Split,
    /// A BL sample of the BRDF-aware mixture, drawn with BL probability `p`; `pmf_bl` is BL's
    /// probability of the light (its density is `pmf_bl` times the point's).
    MixtureBl { p: f32, pmf_bl: f32 },
    /// A light sample of `tl-mis` or `bl-mis`, weighted against one BSDF sample.
    OneMis,
}

/// A light point for the host to shade: evaluate `f · L · cos θi` towards
/// `point.direction` (with `point.radiance` as L), test visibility up to `point.distance`, and
/// weigh it with [`Estimator::weigh`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightDraw {
    /// The light's index in the light set.
    pub light: u32,
    /// The probability of having chosen the light.
    pub pmf: f32,
    /// The point on it, its direction, distance, radiance and solid-angle density.
    pub point: LightPoint,
    /// Whether [`Estimator::weigh`] uses the host's BSDF pdf of the direction (otherwise any
    /// value may be passed, 0 say).
    pub needs_bsdf_pdf: bool,
    role: Role,
}

/// A sample of the host's environment to take: sample its map with `u` (a direction, the
/// radiance along it and the pdf), hand them to [`Estimator::environment_point`] — which
/// turns this step into a [`LightDraw`] — then shade, test and weigh that as any light point
/// (its `distance` is +∞).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvironmentDraw {
    /// The environment light's index in the light set.
    pub light: u32,
    /// The probability of having chosen it.
    pub pmf: f32,
    /// The two uniform numbers (in [0, 1)) for sampling the map.
    pub u: [f32; 2],
    role: Role,
}

/// A BSDF sample for the host to take: sample its BSDF with `u`, cast the ray, and report the
/// direction, its pdf and the first surface's distance to [`Estimator::bsdf_hits`]. A host
/// whose BSDF gives no direction for `u` (below the surface, a zero pdf) skips the report, as
/// the one call does: the sample contributes nothing, and for `full` it counts as a ray that
/// reached no light (the next [`Estimator::next`] records it so).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfDraw {
    /// The two uniform numbers (in [0, 1)) for sampling the BSDF.
    pub u: [f32; 2],
    /// For a mixture sample, its BL probability; `None` for `tl-mis` and `bl-mis`.
    p: Option<f32>,
}

/// A light a BSDF ray reached: the host shades it (`f · L · cos θi` with its own `f`, L =
/// `point.radiance`) and adds `weighted.contribution(value)` (or `value ·
/// weighted.factor()` per channel). `weighted.pdf()` is the BSDF's pdf only for `tl-mis` and
/// `bl-mis`; for `mis-equal` and `full` it is the combined density of the mixed samples (see
/// [`Weighted::pdf`]). A ray that escapes (no surface) reaches the distant lights whose cones
/// hold its direction (`point.distance` = +∞) and the environment, whose `point.radiance` is
/// black and `point.pdf` the host's pdf of the direction: the radiance is the host's to
/// evaluate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightHit {
    /// The light's index in the light set.
    pub light: u32,
    /// The point the ray reached on it.
    pub point: LightPoint,
    /// Its weight and the density the weight is relative to.
    pub weighted: Weighted,
}

/// One step of an estimate (see the [module documentation](super)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// A light point to shade.
    Light(LightDraw),
    /// A sample of the host's environment to take.
    Environment(EnvironmentDraw),
    /// A BSDF sample to take.
    Bsdf(BsdfDraw),
    /// The estimate is complete.
    Done,
}

/// Where an estimate is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Nothing drawn yet.
    Start,
    /// Yielding the TL split samples; then the mixture (`mis-equal`) or the end.
    TlFirst,
    /// The BRDF-aware samples.
    Mixture,
    /// Yielding the TL split samples after the mixture (`full`).
    TlLast,
    /// The next light sample of `bl-mis` (its `j`-th), when it takes more than one.
    OneMisLight,
    /// The BSDF sample of `tl-mis` or `bl-mis` is next.
    OneMisBsdf,
    /// Finished.
    Done,
}

/// Per-light pmfs remembered at one shading point (direct-mapped): an estimate queries the
/// same few lights again and again, and the pmfs are fixed functions of the light there.
/// (It caches whole pmfs of lights; [`crate::Memo`] caches node importances of a descent.)
/// A slot holds a pmf only where its bit is set in the table's mask, so that forgetting them
/// all at a new point is clearing two words.
#[derive(Clone, Debug)]
struct PmfCache {
    tl: PmfTable,
    bl: PmfTable,
}

/// One table of a [`PmfCache`]: the slots, and the mask of those that hold a pmf.
#[derive(Clone, Debug)]
struct PmfTable {
    slots: [(u32, f32); CACHE_SLOTS],
    filled: u64,
}

/// Slots of each cache table (at most 64: one bit each in [`PmfTable::filled`]).
const CACHE_SLOTS: usize = 64;

impl PmfCache {
    const EMPTY: PmfCache = PmfCache {
        tl: PmfTable {
            slots: [(u32::MAX, 0.0); CACHE_SLOTS],
            filled: 0,
        },
        bl: PmfTable {
            slots: [(u32::MAX, 0.0); CACHE_SLOTS],
            filled: 0,
        },
    };

    /// Forgets every pmf (what [`PmfCache::EMPTY`] holds).
    #[inline]
    fn clear(&mut self) {
        self.tl.filled = 0;
        self.bl.filled = 0;
    }

    #[inline]
    fn get(table: &mut PmfTable, light: u32, f: impl FnOnce() -> f32) -> f32 {
        let i = light as usize % CACHE_SLOTS;
        let bit = 1u64 << i;
        let slot = &mut table.slots[i];
        if table.filled & bit == 0 || slot.0 != light {
            *slot = (light, f());
            table.filled |= bit;
        }
        slot.1
    }
}

/// Split samples of one estimate: one per cluster of the cut and one per light at infinity.
const SPLIT_CAPACITY: usize = CUT_CAPACITY + MAX_INFINITE_LIGHTS;

/// The state of one estimate.
#[derive(Clone, Debug)]
struct Run {
    phase: Phase,
    /// The split samples drawn: light, pmf within its cluster, the point's uniform numbers
    /// (the cut's clusters, then the lights at infinity).
    tl: [(u32, f32, [f32; 2]); SPLIT_CAPACITY],
    tl_len: usize,
    tl_next: usize,
    /// The next BRDF-aware sample's index (`mis-equal`, `full`), or the next light sample's
    /// (`bl-mis`).
    j: u32,
    alloc: AdaptiveAllocator,
    /// The BL probabilities recorded so far (`full`).
    sw: SequentialWeights,
    /// A BSDF sample of the mixture was yielded and not yet reported (its BL probability).
    pending_tb: Option<f32>,
}

impl Run {
    /// A run in `phase` with nothing drawn yet, its allocator and sequential weights given
    /// (what [`Estimator::start`] and a new set-up begin from; the split samples beyond
    /// `tl_len = 0` are never read).
    #[inline]
    fn begin(&mut self, phase: Phase, alloc: AdaptiveAllocator, sw: SequentialWeights) {
        self.phase = phase;
        self.tl_len = 0;
        self.tl_next = 0;
        self.j = 0;
        self.alloc = alloc;
        self.sw = sw;
        self.pending_tb = None;
    }
}

/// Direct illumination at one shading point with one technique (see the
/// [module documentation](super)). Set up once per shading point; any number of estimates.
#[derive(Clone, Debug)]
pub struct Estimator<'a> {
    set: &'a LightSet,
    technique: Technique,
    /// The parameters it was made with ([`Estimator::reset`] keeps them).
    params: Params,
    x: Vec3,
    frame: Frame,
    /// ωo in the local frame.
    wo: Vec3,
    material: Material,
    tl: TreeSampler<'a>,
    split: LightCut,
    bl: Option<CutSampler<'a>>,
    pinf: Option<PinfSampler<'a>>,
    n_mix: u32,
    /// BL takes part in `full`'s mixture.
    bl_in_full: bool,
    pmfs: PmfCache,
    run: Run,
}

/// The BRDF-oriented cut `technique` builds: `bl_cut` for `bl` and `bl-mis`, `mixture_cut`
/// for `mis-equal` and `full`.
#[inline]
fn bl_cut_options(technique: Technique, params: &Params) -> &BlCutOptions {
    match technique {
        Technique::MisEqual | Technique::Full => &params.mixture_cut,
        _ => &params.bl_cut,
    }
}

/// The number of light samples of a `bl-mis` estimate (1 for every other technique with one
/// light sample and one BSDF sample).
#[inline]
fn one_mis_light_samples(technique: Technique, params: &Params) -> u32 {
    if technique == Technique::BlMis {
        params.bl_light_samples.clamp(1, MAX_LIGHT_SAMPLES)
    } else {
        1
    }
}

/// Checks a host's uniform number.
#[inline]
fn unit(u: f32) -> Result<f32, DirectError> {
    if (0.0..1.0).contains(&u) {
        Ok(u)
    } else {
        Err(DirectError::Uniform {
            value: f64::from(u),
        })
    }
}

#[inline]
fn next1(u: &mut (impl Uniforms + ?Sized)) -> Result<f32, DirectError> {
    unit(u.next_f32())
}

/// Checks a host's 53-bit uniform number.
#[inline]
fn next64(u: &mut (impl Uniforms + ?Sized)) -> Result<f64, DirectError> {
    let v = u.next_f64();
    if (0.0..1.0).contains(&v) {
        Ok(v)
    } else {
        Err(DirectError::Uniform { value: v })
    }
}

#[inline]
fn next2(u: &mut (impl Uniforms + ?Sized)) -> Result<[f32; 2], DirectError> {
    Ok([next1(u)?, next1(u)?])
}

/// What a technique needs at one shading point, decided and validated before anything is
/// built: shared by [`Estimator::new`] and [`Estimator::reset`].
struct Plan {
    frame: Frame,
    wo: Vec3,
    tl: TlImportance,
    /// Where the technique builds a BL cut, the unit normal and ωo of its importance
    /// ([`BlImportance::directions`]): what is left of its set-up cannot fail.
    bl: Option<(Vec3, Vec3)>,
    needs_split: bool,
    diffuse: bool,
}

impl Plan {
    /// Validates `sp` and decides what `technique` builds there.
    fn new(sp: &ShadingPoint, technique: Technique, params: &Params) -> Result<Plan, DirectError> {
        sp.validate()?;
        let frame = Frame::from_normal(sp.normal).ok_or_else(|| ShadingError {
            field: ShadingField::Normal,
            problem: Problem::ZeroLength,
            value: math::length(sp.normal),
        })?;
        let needs_split = matches!(
            technique,
            Technique::TlSplit | Technique::MisEqual | Technique::Full
        );
        let diffuse = sp.material.is_diffuse_only();
        // Lambert points where `full` needs no IB(x): no BL cut is built.
        let no_ib = diffuse && matches!(params.lambert, LambertMode::TlOnly | LambertMode::TbOne);
        let needs_bl = match technique {
            Technique::Bl | Technique::BlMis => true,
            Technique::MisEqual => !diffuse,
            Technique::Full => !no_ib,
            _ => false,
        };
        let bl = if needs_bl {
            Some(BlImportance::directions(sp)?)
        } else {
            None
        };
        Ok(Plan {
            frame,
            wo: frame.to_local(math::normalize(sp.wo)),
            tl: TlImportance::new(sp.position, frame.normal),
            bl,
            needs_split,
            diffuse,
        })
    }

    /// The number of BRDF-aware samples N (`mis-equal` and `full`; 0 otherwise), given the BL
    /// sampler where one was built.
    fn budget(&self, technique: Technique, params: &Params, bl: Option<&CutSampler>) -> u32 {
        match (technique, bl) {
            (Technique::Full, _) if self.diffuse => match params.lambert {
                LambertMode::TlOnly => 0,
                LambertMode::TbOne => 1,
                LambertMode::TbBudget | LambertMode::BlTb => {
                    sample_budget(bl.map_or(0.0, |b| b.cut().max_score()), params.n_max)
                }
            },
            (Technique::MisEqual | Technique::Full, Some(b)) => brdf_budget(b.cut(), params.n_max),
            _ => 0,
        }
    }

    /// Whether BL takes part in `full`'s mixture.
    fn bl_in_full(&self, params: &Params) -> bool {
        !self.diffuse || params.lambert == LambertMode::BlTb
    }
}

impl<'a> Estimator<'a> {
    /// What `technique` needs at `sp` (only that: the split cut for the split techniques, the
    /// BRDF-oriented cut where BL or the budget needs it).
    ///
    /// The estimator holds its cuts in place (several kilobytes): a host that sets one up at
    /// every shading point of a thread can keep one estimator per thread and move it to each
    /// new point with [`Estimator::reset`], which gives the same estimator without copying it.
    pub fn new(
        set: &'a LightSet,
        sp: &ShadingPoint,
        technique: Technique,
        params: &Params,
    ) -> Result<Estimator<'a>, DirectError> {
        let plan = Plan::new(sp, technique, params)?;
        let tree = set.tree();
        let tl = TreeSampler::with_importance(tree, plan.tl);
        let split = if plan.needs_split {
            LightCut::build_split(tree, tl.importance(), &params.split_cut)
        } else {
            LightCut::new()
        };
        let cut = bl_cut_options(technique, params);
        let bl = plan.bl.map(|(n, wo)| {
            let imp = BlImportance::with_directions(sp, n, wo);
            CutSampler::with_importance(tree, imp, cut)
        });
        let n_mix = plan.budget(technique, params, bl.as_ref());
        let pinf = (technique == Technique::TlMisPinf)
            .then(|| PinfSampler::with_importance(tree, *tl.importance()));
        Ok(Estimator {
            set,
            technique,
            params: *params,
            x: sp.position,
            frame: plan.frame,
            wo: plan.wo,
            material: sp.material,
            tl,
            split,
            bl,
            pinf,
            n_mix,
            bl_in_full: plan.bl_in_full(params),
            pmfs: PmfCache::EMPTY,
            run: Run {
                phase: Phase::Done,
                tl: [(0, 0.0, [0.0; 2]); SPLIT_CAPACITY],
                tl_len: 0,
                tl_next: 0,
                j: 0,
                alloc: AdaptiveAllocator::new(false),
                sw: SequentialWeights::new(0, 1.0, params.heuristic),
                pending_tb: None,
            },
        })
    }

    /// Moves the estimator to the shading point `sp`, with the same light set, technique and
    /// parameters: afterwards it is what [`Estimator::new`] would have returned at `sp`, and
    /// gives bit for bit the same estimates, but it is set up in place, without the copy of
    /// the whole estimator that returning a new one costs. The current estimate is
    /// forgotten (call [`Estimator::start`] before the lower level's steps, as after
    /// `new`). An invalid `sp` is the error `new` would give, and leaves the estimator
    /// unchanged.
    pub fn reset(&mut self, sp: &ShadingPoint) -> Result<(), DirectError> {
        let params = self.params;
        let plan = Plan::new(sp, self.technique, &params)?;
        let tree = self.set.tree();
        self.tl = TreeSampler::with_importance(tree, plan.tl);
        // A technique without split sampling keeps the empty cut `new` gave it.
        if plan.needs_split {
            let tl = *self.tl.importance();
            self.split.rebuild_split(tree, &tl, &params.split_cut);
        }
        let cut = bl_cut_options(self.technique, &params);
        match (&mut self.bl, plan.bl) {
            (Some(b), Some((n, wo))) => b.reset_with_directions(sp, n, wo, cut),
            (bl, dirs) => {
                *bl = dirs.map(|(n, wo)| {
                    let imp = BlImportance::with_directions(sp, n, wo);
                    CutSampler::with_importance(tree, imp, cut)
                })
            }
        }
        self.n_mix = plan.budget(self.technique, &params, self.bl.as_ref());
        if self.technique == Technique::TlMisPinf {
            self.pinf = Some(PinfSampler::with_importance(tree, *self.tl.importance()));
        }
        self.x = sp.position;
        self.frame = plan.frame;
        self.wo = plan.wo;
        self.material = sp.material;
        self.bl_in_full = plan.bl_in_full(&params);
        self.pmfs.clear();
        self.run.begin(
            Phase::Done,
            AdaptiveAllocator::new(false),
            SequentialWeights::new(0, 1.0, params.heuristic),
        );
        Ok(())
    }

    /// The estimator at `sp` from a per-thread `slot`: the one in it moved there by
    /// [`Estimator::reset`] when it was made for `set`, `technique` and `params`, else a new
    /// one put in it. Either way what [`Estimator::new`] gives at `sp`. On error (an invalid
    /// `sp`, `new`'s error) the slot keeps what it held.
    pub fn reuse<'s>(
        slot: &'s mut Option<Estimator<'a>>,
        set: &'a LightSet,
        sp: &ShadingPoint,
        technique: Technique,
        params: &Params,
    ) -> Result<&'s mut Estimator<'a>, DirectError> {
        let same = slot.as_ref().is_some_and(|e| {
            core::ptr::eq(e.set, set) && e.technique == technique && e.params == *params
        });
        match slot {
            Some(e) if same => e.reset(sp)?,
            _ => return Ok(slot.insert(Estimator::new(set, sp, technique, params)?)),
        }
        // Reset in place; `same` held, so the slot holds it.
        match slot {
            Some(e) => Ok(e),
            None => Ok(slot.insert(Estimator::new(set, sp, technique, params)?)),
        }
    }

    /// The parameters.
    #[inline]
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The technique.
    #[inline]
    pub fn technique(&self) -> Technique {
        self.technique
    }

    /// The split cut (empty for techniques without split sampling).
    #[inline]
    pub fn split_cut(&self) -> &LightCut {
        &self.split
    }

    /// The BRDF-oriented sampler, where the technique built one.
    #[inline]
    pub fn cut_sampler(&self) -> Option<&CutSampler<'a>> {
        self.bl.as_ref()
    }

    /// The tree sampler with TL importance at this point.
    #[inline]
    pub fn tree_sampler(&self) -> &TreeSampler<'a> {
        &self.tl
    }

    /// IB(x): the largest BRDF integral over the BRDF-oriented cut (0 without one).
    #[inline]
    pub fn ib(&self) -> f32 {
        self.bl.as_ref().map_or(0.0, |b| b.cut().max_score())
    }

    /// The number of BRDF-aware samples N of `mis-equal` and `full` (0 otherwise).
    #[inline]
    pub fn budget(&self) -> u32 {
        self.n_mix
    }

    /// Whether BL takes part in the BRDF-aware mixture.
    #[inline]
    fn bl_on(&self) -> bool {
        self.bl.is_some() && (self.technique != Technique::Full || self.bl_in_full)
    }

    /// The fixed weights of `mis-equal`.
    #[inline]
    fn combined(&self) -> CombinedWeights {
        CombinedWeights {
            n_tl: 1.0,
            n_mixture: self.n_mix as f32,
            p_ref: if self.bl.is_some() { 0.5 } else { 0.0 },
            heuristic: self.params.heuristic,
        }
    }

    /// The pmf of `light` within its cluster of the split cut (0 if in none), remembered; a
    /// light at infinity is a cluster of its own (1 where its TL importance is positive).
    #[inline]
    fn pmf_tl(&mut self, light: u32) -> f32 {
        let (split, tl) = (&self.split, &self.tl);
        PmfCache::get(&mut self.pmfs.tl, light, || {
            let tree = tl.tree();
            if let Some(i) = tree.infinite_entry(light) {
                let e = &tree.infinite_lights()[i];
                return if tl.importance().eval_infinite(e) > 0.0 {
                    1.0
                } else {
                    0.0
                };
            }
            split
                .pmf_in(tree, tl.importance(), light)
                .map_or(0.0, |(_, p)| p)
        })
    }

    /// The pmf of `light` through the BRDF-oriented cut (0 without one), remembered.
    #[inline]
    fn pmf_bl(&mut self, light: u32) -> f32 {
        let Some(bl) = &self.bl else {
            return 0.0;
        };
        PmfCache::get(&mut self.pmfs.bl, light, || bl.pmf(light))
    }

    /// Starts a new estimate (forgetting the current one).
    pub fn start(&mut self) {
        let budget = if matches!(self.technique, Technique::MisEqual | Technique::Full) {
            self.n_mix
        } else {
            0
        };
        self.run.begin(
            Phase::Start,
            AdaptiveAllocator::new(self.bl.is_some() && self.bl_in_full),
            SequentialWeights::new(budget, 1.0, self.params.heuristic),
        );
    }

    /// Whether a light sample of `role` is weighed with the BSDF's pdf of its direction.
    #[inline]
    fn needs_bsdf_pdf(&self, role: Role, delta: bool) -> bool {
        !delta
            && match role {
                Role::Plain => false,
                Role::Split => self.n_mix > 0 && self.technique != Technique::TlSplit,
                Role::MixtureBl { .. } | Role::OneMis => true,
            }
    }

    /// A light sample of `light` chosen with probability `pmf`, its point from `uv`: a light
    /// point, or for the environment a sample of the host's map to take.
    #[inline]
    fn draw(&self, light: u32, pmf: f32, uv: [f32; 2], role: Role) -> Option<Step> {
        let l = self.set.lights().get(light as usize)?;
        if let Light::Environment { .. } = l {
            return Some(Step::Environment(EnvironmentDraw {
                light,
                pmf,
                u: uv,
                role,
            }));
        }
        let point = sample_point(l, self.x, uv)?;
        Some(Step::Light(LightDraw {
            light,
            pmf,
            point,
            needs_bsdf_pdf: self.needs_bsdf_pdf(role, point.delta),
            role,
        }))
    }

    /// Turns an environment step into the light point the host sampled from its map:
    /// `direction` (world space, any positive length), the `radiance` along it and its
    /// solid-angle `pdf` (> 0). Shade, test (to `distance` = +∞) and weigh it as any light
    /// point.
    pub fn environment_point(
        &self,
        draw: &EnvironmentDraw,
        direction: Vec3,
        radiance: Rgb,
        pdf: f32,
    ) -> Result<LightDraw, DirectError> {
        let l2 = direction.length_squared();
        if !(l2 > 0.0 && l2 < f32::INFINITY && direction.is_finite()) {
            return Err(DirectError::Direction { length_squared: l2 });
        }
        if !(pdf > 0.0 && pdf < f32::INFINITY) {
            return Err(DirectError::EnvironmentPdf { value: pdf });
        }
        for c in radiance.to_array() {
            if !(0.0..f32::INFINITY).contains(&c) {
                return Err(DirectError::EnvironmentRadiance { value: c });
            }
        }
        let d = direction / crate::math::sqrt(l2);
        Ok(LightDraw {
            light: draw.light,
            pmf: draw.pmf,
            point: LightPoint {
                position: d,
                normal: Vec3::ZERO,
                direction: d,
                distance: f32::INFINITY,
                pdf,
                delta: false,
                radiance,
            },
            needs_bsdf_pdf: self.needs_bsdf_pdf(draw.role, false),
            role: draw.role,
        })
    }

    /// Draws the split samples' lights: all uniform numbers first, then the descents together.
    fn draw_split(&mut self, u: &mut (impl Uniforms + ?Sized)) -> Result<(), DirectError> {
        let m = self.split.len();
        let mut us = [0f32; CUT_CAPACITY];
        let mut uvs = [[0f32; 2]; CUT_CAPACITY];
        for i in 0..m {
            us[i] = next1(u)?;
            uvs[i] = next2(u)?;
        }
        let mut chosen = [None; CUT_CAPACITY];
        self.split.sample_each(
            self.tl.tree(),
            self.tl.importance(),
            &us[..m],
            &mut chosen[..m],
        );
        let mut n = 0;
        for i in 0..m {
            if let Some(s) = chosen[i] {
                self.run.tl[n] = (s.light, s.pmf, uvs[i]);
                n += 1;
            }
        }
        // Each light at infinity is a cluster of its own, sampled where it may contribute.
        let tree = self.tl.tree();
        for e in tree.infinite_lights() {
            if self.tl.importance().eval_infinite(e) > 0.0 {
                self.run.tl[n] = (e.light, 1.0, next2(u)?);
                n += 1;
            }
        }
        self.run.tl_len = n;
        self.run.tl_next = 0;
        Ok(())
    }

    /// The next split sample with a point, if any is left.
    fn next_split(&mut self) -> Option<Step> {
        while self.run.tl_next < self.run.tl_len {
            let (light, pmf, uv) = self.run.tl[self.run.tl_next];
            self.run.tl_next += 1;
            if let Some(d) = self.draw(light, pmf, uv, Role::Split) {
                return Some(d);
            }
        }
        None
    }

    /// Settles a BSDF sample of the mixture that was never reported: its ray reached nothing.
    #[inline]
    fn settle_pending(&mut self) {
        if let Some(p) = self.run.pending_tb.take() {
            self.run.alloc.record_tb(false);
            self.run.sw.record(p);
        }
    }

    /// The next step of the estimate begun by [`Estimator::start`], drawing uniform numbers
    /// from `u` as needed. After [`Step::Done`] it keeps returning `Done`.
    pub fn next(&mut self, u: &mut (impl Uniforms + ?Sized)) -> Result<Step, DirectError> {
        self.settle_pending();
        loop {
            match self.run.phase {
                Phase::Done => return Ok(Step::Done),
                Phase::Start => {
                    self.run.phase = Phase::Done;
                    match self.technique {
                        Technique::Uniform => {
                            let s = UniformSampler::new(self.set.len() as u32);
                            let v = next64(u)?;
                            if let Some(s) = s.sample_f64(v) {
                                return Ok(self.single(s.light, s.pmf, next2(u)?));
                            }
                        }
                        Technique::Power => {
                            let v = next64(u)?;
                            if let Some(s) = PowerSampler::new(self.set).sample_f64(v) {
                                return Ok(self.single(s.light, s.pmf, next2(u)?));
                            }
                        }
                        Technique::Tl => {
                            if let Some(s) = self.tl.sample(next1(u)?) {
                                return Ok(self.single(s.light, s.pmf, next2(u)?));
                            }
                        }
                        Technique::Bl => {
                            let v = next1(u)?;
                            if let Some(s) = self.bl.as_ref().and_then(|b| b.sample(v)) {
                                return Ok(self.single(s.light, s.pmf, next2(u)?));
                            }
                        }
                        Technique::TlMis | Technique::BlMis | Technique::TlMisPinf => {
                            self.run.j = 0;
                            self.run.phase = Phase::OneMisLight;
                        }
                        Technique::TlSplit | Technique::MisEqual => {
                            self.draw_split(u)?;
                            self.run.phase = Phase::TlFirst;
                        }
                        Technique::Full => {
                            self.draw_split(u)?;
                            self.run.phase = if self.n_mix == 0 {
                                Phase::TlFirst
                            } else {
                                Phase::Mixture
                            };
                        }
                    }
                }
                Phase::OneMisLight => {
                    // Sample i of k takes its uniform number in [i/k, (i+1)/k): the k samples
                    // stratify the light choice (k = 1: the number itself).
                    let k = one_mis_light_samples(self.technique, &self.params);
                    let i = self.run.j;
                    self.run.j += 1;
                    if self.run.j >= k {
                        self.run.phase = Phase::OneMisBsdf;
                    }
                    let v = next1(u)?;
                    let uv = next2(u)?;
                    let v = if k == 1 {
                        v
                    } else {
                        ((i as f32 + v) / k as f32).min(ONE_MINUS_EPSILON)
                    };
                    let s = match self.technique {
                        Technique::TlMis => self.tl.sample(v),
                        Technique::TlMisPinf => self.pinf.as_ref().and_then(|p| p.sample(v)),
                        _ => self.bl.as_ref().and_then(|b| b.sample(v)),
                    };
                    if let Some(s) = s {
                        if let Some(d) = self.draw(s.light, s.pmf, uv, Role::OneMis) {
                            return Ok(d);
                        }
                    }
                }
                Phase::OneMisBsdf => {
                    self.run.phase = Phase::Done;
                    return Ok(Step::Bsdf(BsdfDraw {
                        u: next2(u)?,
                        p: None,
                    }));
                }
                Phase::TlFirst => {
                    if let Some(d) = self.next_split() {
                        return Ok(d);
                    }
                    let mixture = self.technique == Technique::MisEqual
                        && self.n_mix > 0
                        && self.bl.is_some();
                    self.run.phase = if mixture { Phase::Mixture } else { Phase::Done };
                }
                Phase::TlLast => {
                    if let Some(d) = self.next_split() {
                        return Ok(d);
                    }
                    self.run.phase = Phase::Done;
                }
                Phase::Mixture => {
                    if self.run.j >= self.n_mix {
                        self.run.phase = if self.technique == Technique::Full {
                            Phase::TlLast
                        } else {
                            Phase::Done
                        };
                        continue;
                    }
                    if let Some(step) = self.mixture_step(u)? {
                        return Ok(step);
                    }
                }
            }
        }
    }

    /// The only light sample of `uniform`, `power`, `tl` and `bl`, if it has a point.
    #[inline]
    fn single(&mut self, light: u32, pmf: f32, uv: [f32; 2]) -> Step {
        self.draw(light, pmf, uv, Role::Plain).unwrap_or(Step::Done)
    }

    /// The j-th BRDF-aware sample: a BL light sample, a BSDF sample, or nothing (a BL sample
    /// without a light or point).
    fn mixture_step(
        &mut self,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<Option<Step>, DirectError> {
        let j = self.run.j;
        self.run.j += 1;
        let (technique, warped, p) = if self.technique == Technique::Full {
            let (t, w, p) = self.run.alloc.choose(next1(u)?);
            (t, w, p)
        } else {
            // ⌊N/2⌋ BL, ⌊N/2⌋ TB, and for an odd N one more, BL or TB with probability 1/2.
            let half = self.n_mix / 2;
            let v = next1(u)?;
            if j < half {
                (Mixture::Bl, v, 0.5)
            } else if j < 2 * half {
                (Mixture::Tb, v, 0.5)
            } else if v < 0.5 {
                (Mixture::Bl, 2.0 * v, 0.5)
            } else {
                (Mixture::Tb, (2.0 * v - 1.0).min(ONE_MINUS_EPSILON), 0.5)
            }
        };
        match technique {
            Mixture::Bl => {
                let uv = next2(u)?;
                if self.technique == Technique::Full {
                    self.run.sw.record(p);
                }
                let Some(s) = self.bl.as_ref().and_then(|b| b.sample(warped)) else {
                    return Ok(None);
                };
                let role = Role::MixtureBl { p, pmf_bl: s.pmf };
                Ok(self.draw(s.light, s.pmf, uv, role))
            }
            Mixture::Tb => {
                let v = next1(u)?;
                if self.technique == Technique::Full {
                    self.run.pending_tb = Some(p);
                }
                Ok(Some(Step::Bsdf(BsdfDraw {
                    u: [warped, v],
                    p: Some(p),
                })))
            }
        }
    }

    /// The weight and density of a light sample, given the host's BSDF pdf of its direction
    /// (used only where `draw.needs_bsdf_pdf`). Weigh a sample only if it contributes (its
    /// value is positive and it is visible); a sample weighed in the wrong estimate gets the
    /// weights of the current one.
    pub fn weigh(&mut self, draw: &LightDraw, bsdf_pdf: f32) -> Result<Weighted, DirectError> {
        if !(0.0..f32::INFINITY).contains(&bsdf_pdf) {
            return Err(DirectError::BsdfPdf { value: bsdf_pdf });
        }
        // A BSDF ray never reaches a point or spot light.
        let pdf_tb = if draw.needs_bsdf_pdf { bsdf_pdf } else { 0.0 };
        let pdf = draw.pmf * draw.point.pdf;
        let pp = draw.point.pdf;
        Ok(match draw.role {
            Role::Plain => Weighted::plain(pdf),
            Role::OneMis => {
                // k light samples: each contributes 1/k of its estimate, weighed against the
                // one BSDF sample with the counts (k, 1); their density together is k·pdf.
                let k = one_mis_light_samples(self.technique, &self.params) as f32;
                let a = pdf * k;
                if pdf_tb > 0.0 {
                    let w = crate::mis::power(k, pdf, &[(1.0, pdf_tb)]);
                    Weighted::checked(Factors {
                        num: w,
                        den: a,
                        pdf: a,
                    })
                } else {
                    Weighted::plain(a)
                }
            }
            Role::Split => match self.technique {
                Technique::MisEqual => {
                    let pdf_bl = if self.n_mix > 0 && self.bl_on() {
                        self.pmf_bl(draw.light) * pp
                    } else {
                        0.0
                    };
                    let (w_tl, _) = self.combined().weights(pdf, pdf_bl, pdf_tb);
                    Weighted::checked(Factors {
                        num: w_tl,
                        den: pdf,
                        pdf,
                    })
                }
                Technique::Full if self.n_mix > 0 => {
                    let pdf_bl = if self.bl_on() {
                        self.pmf_bl(draw.light) * pp
                    } else {
                        0.0
                    };
                    let w = self.run.sw.tl_weight(pdf, pdf_bl, pdf_tb);
                    Weighted::checked(Factors {
                        num: w,
                        den: pdf,
                        pdf,
                    })
                }
                _ => Weighted::plain(pdf),
            },
            Role::MixtureBl { p, pmf_bl } => {
                let pdf_bl = pmf_bl * pp;
                let pdf_tl = self.pmf_tl(draw.light) * pp;
                self.mixture_weight(p, pdf_tl, pdf_bl, pdf_tb)
            }
        })
    }

    /// The weight of a point reached by a BRDF-aware sample of BL probability `p`.
    #[inline]
    fn mixture_weight(&self, p: f32, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> Weighted {
        if self.technique == Technique::Full {
            // The term depends on the budget and the sample's own p only.
            let terms = SequentialWeights::new(self.n_mix, 1.0, self.params.heuristic);
            match terms.mixture_factors(p, pdf_tl, pdf_bl, pdf_tb) {
                Some(f) => Weighted::checked(f),
                None => Weighted::ZERO,
            }
        } else {
            let (_, w_m) = self.combined().weights(pdf_tl, pdf_bl, pdf_tb);
            let half = 0.5 * self.n_mix as f32;
            let den = half * pdf_bl + half * pdf_tb;
            Weighted::checked(Factors {
                num: w_m,
                den,
                pdf: den,
            })
        }
    }

    /// Reports a BSDF sample: the host sampled `direction` (world space, any positive length)
    /// with density `bsdf_pdf`, and its ray's first surface is at `hit_distance` (+∞ for none).
    /// Calls `each` for every light reached in front of it with non-zero radiance, with its
    /// weight — a ray that escapes also reaches the distant lights whose cones hold its
    /// direction. Returns whether any was reached (what the adaptive allocation learns). For a
    /// light set with an environment light, [`Estimator::bsdf_hits_env`] (this gives
    /// [`DirectError::NeedsEnvironment`]).
    pub fn bsdf_hits(
        &mut self,
        draw: &BsdfDraw,
        direction: Vec3,
        bsdf_pdf: f32,
        hit_distance: f32,
        each: impl FnMut(LightHit),
    ) -> Result<bool, DirectError> {
        self.needs_no_environment()?;
        self.bsdf_hits_env(draw, direction, bsdf_pdf, hit_distance, 0.0, each)
    }

    /// [`Estimator::bsdf_hits`] for any light set: an escaping ray (`hit_distance` = +∞) also
    /// reaches the environment, weighed with `environment_pdf`, the host's pdf of sampling
    /// `direction` from its map (≥ 0, finite; ignored without an environment light or when
    /// the ray does not escape). The environment's hit has a black `point.radiance`: the host
    /// shades it with its own radiance along `direction`.
    pub fn bsdf_hits_env(
        &mut self,
        draw: &BsdfDraw,
        direction: Vec3,
        bsdf_pdf: f32,
        hit_distance: f32,
        environment_pdf: f32,
        each: impl FnMut(LightHit),
    ) -> Result<bool, DirectError> {
        if hit_distance.is_nan() || hit_distance < 0.0 {
            return Err(DirectError::HitDistance {
                value: hit_distance,
            });
        }
        // Points at infinity are reached only by a ray that escapes.
        let escapes = hit_distance == f32::INFINITY;
        self.bsdf_hits_with_env(
            draw,
            direction,
            bsdf_pdf,
            environment_pdf,
            |lp| lp.distance < hit_distance || escapes,
            each,
        )
    }

    /// [`Estimator::bsdf_hits`] with visibility decided per light point by `visible` (a
    /// shadow ray to the point, say; to `distance` = +∞ for a distant light). For a light set
    /// with an environment light, [`Estimator::bsdf_hits_with_env`] (this gives
    /// [`DirectError::NeedsEnvironment`]).
    pub fn bsdf_hits_with(
        &mut self,
        draw: &BsdfDraw,
        direction: Vec3,
        bsdf_pdf: f32,
        visible: impl FnMut(&LightPoint) -> bool,
        each: impl FnMut(LightHit),
    ) -> Result<bool, DirectError> {
        self.needs_no_environment()?;
        self.bsdf_hits_with_env(draw, direction, bsdf_pdf, 0.0, visible, each)
    }

    /// [`Estimator::bsdf_hits_with`] for any light set: the environment is reached where
    /// `visible` passes its point at infinity along `direction`, and weighed with
    /// `environment_pdf` (as [`Estimator::bsdf_hits_env`]).
    pub fn bsdf_hits_with_env(
        &mut self,
        draw: &BsdfDraw,
        direction: Vec3,
        bsdf_pdf: f32,
        environment_pdf: f32,
        mut visible: impl FnMut(&LightPoint) -> bool,
        mut each: impl FnMut(LightHit),
    ) -> Result<bool, DirectError> {
        let l2 = direction.length_squared();
        if !(l2 > 0.0 && l2 < f32::INFINITY && direction.is_finite()) {
            return Err(DirectError::Direction { length_squared: l2 });
        }
        if !(0.0..f32::INFINITY).contains(&bsdf_pdf) {
            return Err(DirectError::BsdfPdf { value: bsdf_pdf });
        }
        if !(0.0..f32::INFINITY).contains(&environment_pdf) {
            return Err(DirectError::EnvironmentPdf {
                value: environment_pdf,
            });
        }
        // A direction already of unit length (to f32 rounding) is taken as it is.
        let dir = if (l2 - 1.0).abs() <= 4.0 * f32::EPSILON {
            direction
        } else {
            direction / crate::math::sqrt(l2)
        };
        let mixture = draw.p;
        // This sample's outcome is recorded here, not when the next step settles it.
        let pending = if mixture.is_some() {
            self.run.pending_tb.take()
        } else {
            None
        };
        let mut hit = false;
        let set = self.set;
        let x = self.x;
        set.trace(x, dir, |light, lp| {
            if lp.radiance.is_black() || !visible(lp) {
                return;
            }
            hit = true;
            let weighted = self.hit_weight(mixture, light, lp.pdf, bsdf_pdf);
            each(LightHit {
                light,
                point: *lp,
                weighted,
            });
        });
        // The lights at infinity along the ray.
        for e in set.tree().infinite_lights() {
            let lp = match e.kind() {
                Some(InfiniteKind::Distant) => set
                    .lights()
                    .get(e.light as usize)
                    .and_then(|l| intersect(l, x, dir)),
                Some(InfiniteKind::Environment) => Some(LightPoint {
                    position: dir,
                    normal: Vec3::ZERO,
                    direction: dir,
                    distance: f32::INFINITY,
                    pdf: environment_pdf,
                    delta: false,
                    radiance: Rgb::ZERO,
                }),
                None => None,
            };
            let Some(lp) = lp else {
                continue;
            };
            let environment = e.kind() == Some(InfiniteKind::Environment);
            if (!environment && lp.radiance.is_black()) || !visible(&lp) {
                continue;
            }
            hit = true;
            let weighted = self.hit_weight(mixture, e.light, lp.pdf, bsdf_pdf);
            each(LightHit {
                light: e.light,
                point: lp,
                weighted,
            });
        }
        if let Some(p) = pending {
            self.run.alloc.record_tb(hit);
            self.run.sw.record(p);
        }
        Ok(hit)
    }

    /// [`DirectError::NeedsEnvironment`] for a light set with an environment light.
    #[inline]
    fn needs_no_environment(&self) -> Result<(), DirectError> {
        match self.set.environment() {
            Some(_) => Err(DirectError::NeedsEnvironment),
            None => Ok(()),
        }
    }

    /// The weight of a BSDF sample (of mixture probability `mixture`, `None` for the BSDF
    /// sample of a two-sample technique) that reached `light` at a point of light-sampling
    /// density `point_pdf`, the BSDF's density being `bsdf_pdf`.
    #[inline]
    fn hit_weight(
        &mut self,
        mixture: Option<f32>,
        light: u32,
        point_pdf: f32,
        bsdf_pdf: f32,
    ) -> Weighted {
        match mixture {
            Some(p) => {
                let pdf_tl = self.pmf_tl(light) * point_pdf;
                let pdf_bl = if self.uses_bl(p) {
                    self.pmf_bl(light) * point_pdf
                } else {
                    0.0
                };
                self.mixture_weight(p, pdf_tl, pdf_bl, bsdf_pdf)
            }
            None => {
                let pmf = match self.technique {
                    Technique::BlMis => self.pmf_bl(light),
                    Technique::TlMisPinf => self.pinf.as_ref().map_or(0.0, |s| s.pmf(light)),
                    _ => self.tl.pmf(light),
                };
                let pdf_l = pmf * point_pdf;
                let k = one_mis_light_samples(self.technique, &self.params) as f32;
                let w = crate::mis::power(1.0, bsdf_pdf, &[(k, pdf_l)]);
                Weighted::checked(Factors {
                    num: w,
                    den: bsdf_pdf,
                    pdf: bsdf_pdf,
                })
            }
        }
    }

    /// Whether a BRDF-aware sample of BL probability `p` is weighted with BL's density.
    #[inline]
    fn uses_bl(&self, p: f32) -> bool {
        if self.technique == Technique::Full {
            p > 0.0
        } else {
            self.bl.is_some() || self.n_mix > 0
        }
    }

    /// `f · L · cos θi` of a light point with the core's material (per channel), and the
    /// local direction.
    #[inline]
    fn value(&self, lp: &LightPoint) -> (Rgb, Vec3) {
        let wi = self.frame.to_local(lp.direction);
        if lp.radiance.is_black() || wi.z <= 0.0 {
            return (Rgb::ZERO, wi);
        }
        (self.material.eval_rgb(self.wo, wi) * lp.radiance * wi.z, wi)
    }

    /// One estimate of the reflected radiance with the core's material and the host's
    /// occluder: the lower level's loop ([`Estimator::start`], [`Estimator::next`],
    /// [`Estimator::weigh`], [`Estimator::bsdf_hits_with`]), summed in f64 per channel
    /// (red, green, blue). Finite and non-negative. For a light set with an environment
    /// light, [`Estimator::estimate_env`] (this gives [`DirectError::NeedsEnvironment`]).
    pub fn estimate<O: Occluder + ?Sized>(
        &mut self,
        occluder: &O,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<[f64; 3], DirectError> {
        self.needs_no_environment()?;
        self.estimate_with(occluder, None, u)
    }

    /// [`Estimator::estimate`] with the host's environment: its samples
    /// ([`Step::Environment`]) from [`Environment::sample`], and for a BSDF ray that escapes
    /// its radiance and pdf from [`Environment::eval`] ([`Estimator::bsdf_hits_with_env`]).
    /// A set without an environment light never calls it.
    pub fn estimate_env<O: Occluder + ?Sized, E: Environment + ?Sized>(
        &mut self,
        occluder: &O,
        environment: &E,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<[f64; 3], DirectError> {
        self.estimate_with(occluder, Some(&environment), u)
    }

    /// The loop of the one call, with the host's environment if the set has one.
    fn estimate_with<O: Occluder + ?Sized>(
        &mut self,
        occluder: &O,
        environment: Option<&dyn Environment>,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<[f64; 3], DirectError> {
        self.start();
        let x = self.x;
        let env_light = self.set.environment();
        let mut sum = [0.0f64; 3];
        loop {
            let d = match self.next(u)? {
                Step::Done => break,
                Step::Light(d) => d,
                Step::Environment(e) => {
                    let Some(s) = environment.and_then(|env| env.sample(e.u)) else {
                        continue;
                    };
                    self.environment_point(&e, s.direction, s.radiance, s.pdf)?
                }
                Step::Bsdf(b) => {
                    let Some((wi, pdf)) = self.material.sample(self.wo, b.u) else {
                        continue;
                    };
                    let f = self.material.eval_rgb(self.wo, wi);
                    let dir = math::normalize(self.frame.to_world(wi));
                    let (env_radiance, env_pdf) = match (environment, env_light) {
                        (Some(env), Some(_)) => env.eval(dir),
                        _ => (Rgb::ZERO, 0.0),
                    };
                    if !(0.0..f32::INFINITY).contains(&env_pdf) {
                        return Err(DirectError::EnvironmentPdf { value: env_pdf });
                    }
                    let mut value = [0.0f64; 3];
                    self.bsdf_hits_with_env(
                        &b,
                        dir,
                        pdf,
                        env_pdf,
                        |lp| !occluder.occluded(x, dir, lp.distance),
                        |h| {
                            let radiance = if Some(h.light) == env_light {
                                env_radiance
                            } else {
                                h.point.radiance
                            };
                            let g = f * radiance * wi.z;
                            add(&mut value, h.weighted.contribution_rgb(g));
                        },
                    )?;
                    for c in 0..3 {
                        sum[c] += value[c];
                    }
                    continue;
                }
            };
            let (g, wi) = self.value(&d.point);
            if g.max_channel() <= 0.0 || occluder.occluded(x, d.point.direction, d.point.distance) {
                continue;
            }
            let pdf_tb = if d.needs_bsdf_pdf {
                self.material.pdf(self.wo, wi)
            } else {
                0.0
            };
            let w = self.weigh(&d, pdf_tb)?;
            add(&mut sum, w.contribution_rgb(g));
        }
        Ok(sum)
    }
}

/// Adds a contribution's channels to an f64 sum (a channel that is not positive adds
/// nothing: [`Weighted::contribution`] gives 0 for it).
#[inline]
fn add(sum: &mut [f64; 3], c: Rgb) {
    for (s, v) in sum.iter_mut().zip(c.to_array()) {
        *s += f64::from(v);
    }
}
