//! The per-shading-point estimator: set-up, the step machine of the lower level, and the one
//! call built on it. What differs between the techniques lives in one file per family:
//! [`single`] (`uniform`, `power`, `tl`, `bl`), [`one_mis`] (`tl-mis`, `bl-mis`,
//! `tl-mis-pinf`) and [`mixture`] (`tl-split`, `mis-equal`, `full`); the steps and weights the
//! host sees are in [`draws`].

mod draws;
mod mixture;
mod one_mis;
mod setup;
mod single;

use draws::Role;
pub use draws::{BsdfDraw, LightDraw, LightHit, Step, Weighted};
use mixture::PmfCache;

use super::sampler::{CutSampler, PinfSampler, TreeSampler};
use super::visibility::VisibilityCache;
use super::{DirectError, Occluder, Params, Technique, Uniforms};
use crate::brdf::{Brdf, Frame};
use crate::colour::Rgb;
use crate::cut::{LightCut, CUT_CAPACITY};
use crate::infinite_light::InfiniteKind;
use crate::light::point::{intersect, LightPoint};
use crate::light_set::{environment_eval, LightSet};
use crate::limits::MAX_INFINITE_LIGHTS;
use crate::material::Material;
use crate::math;
use crate::mis::{AdaptiveAllocator, SequentialWeights};
use glam::Vec3;

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
    /// The learned visibility the BRDF-oriented cut's weights are scaled by, and the cell of
    /// the shading point in it.
    visibility: Option<&'a VisibilityCache>,
    cell: u32,
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

impl<'a> Estimator<'a> {
    /// The parameters.
    #[inline]
    #[must_use]
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The technique.
    #[inline]
    #[must_use]
    pub fn technique(&self) -> Technique {
        self.technique
    }

    /// The split cut (empty for techniques without split sampling).
    #[inline]
    #[must_use]
    pub fn split_cut(&self) -> &LightCut {
        &self.split
    }

    /// The BRDF-oriented sampler, where the technique built one.
    #[inline]
    #[must_use]
    pub fn cut_sampler(&self) -> Option<&CutSampler<'a>> {
        self.bl.as_ref()
    }

    /// The tree sampler with TL importance at this point.
    #[inline]
    #[must_use]
    pub fn tree_sampler(&self) -> &TreeSampler<'a> {
        &self.tl
    }

    /// IB(x): the largest BRDF integral over the BRDF-oriented cut (0 without one).
    #[inline]
    #[must_use]
    pub fn ib(&self) -> f32 {
        self.bl.as_ref().map_or(0.0, |b| b.cut().max_score())
    }

    /// The number of BRDF-aware samples N of `mis-equal` and `full` (0 otherwise).
    #[inline]
    #[must_use]
    pub fn budget(&self) -> u32 {
        self.n_mix
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

    /// A light sample of `light` chosen with probability `pmf`, its point from `uv` (for the
    /// environment, the host's sample: [`LightSet::sample_point`]); `None` where it has no point.
    #[inline]
    fn draw(
        &self,
        light: u32,
        pmf: f32,
        uv: [f32; 2],
        role: Role,
    ) -> Result<Option<Step>, DirectError> {
        let Some(point) = self.set.sample_point(light, self.x, uv)? else {
            return Ok(None);
        };
        Ok(Some(Step::Light(LightDraw {
            light,
            pmf,
            point,
            needs_bsdf_pdf: self.needs_bsdf_pdf(role, point.delta),
            role,
        })))
    }

    /// The next step of the estimate begun by [`Estimator::start`], drawing uniform numbers
    /// from `u` as needed. After [`Step::Done`] it keeps returning `Done`.
    pub fn next(&mut self, u: &mut (impl Uniforms + ?Sized)) -> Result<Step, DirectError> {
        self.settle_pending();
        loop {
            // Each phase yields a step, or moves on to the next phase (`None`).
            let step = match self.run.phase {
                Phase::Done => return Ok(Step::Done),
                Phase::Start => self.first_step(u)?,
                Phase::OneMisLight => self.one_mis_light(u)?,
                Phase::OneMisBsdf => Some(self.one_mis_bsdf(u)?),
                Phase::TlFirst => self.tl_first()?,
                Phase::Mixture => self.mixture(u)?,
                Phase::TlLast => self.tl_last()?,
            };
            if let Some(step) = step {
                return Ok(step);
            }
        }
    }

    /// The first step of an estimate: the technique's family takes it from here.
    fn first_step(
        &mut self,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<Option<Step>, DirectError> {
        self.run.phase = Phase::Done;
        match self.technique {
            Technique::Uniform | Technique::Energy | Technique::Tl | Technique::Bl => {
                self.single_sample(u)
            }
            Technique::TlMis | Technique::BlMis | Technique::TlMisPinf => {
                self.run.j = 0;
                self.run.phase = Phase::OneMisLight;
                Ok(None)
            }
            Technique::TlSplit | Technique::MisEqual | Technique::Full => {
                self.begin_split(u)?;
                Ok(None)
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
        Ok(match draw.role {
            Role::Plain => Weighted::plain(pdf),
            Role::OneMis => self.one_mis_weight(pdf, pdf_tb),
            Role::Split => self.split_weight(draw.light, pdf, draw.point.pdf, pdf_tb),
            Role::MixtureBl { p, pmf_bl } => {
                self.mixture_bl_weight(draw.light, p, pmf_bl, draw.point.pdf, pdf_tb)
            }
        })
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
            Some(p) => self.mixture_hit_weight(p, light, point_pdf, bsdf_pdf),
            None => self.one_mis_hit_weight(light, point_pdf, bsdf_pdf),
        }
    }

    /// Reports a BSDF sample: the host sampled `direction` (world space, any positive length)
    /// with density `bsdf_pdf`, and `visible` says whether its ray reaches a light point
    /// before any surface — for a ray whose first surface is at distance t (+∞ when it
    /// escapes), `|p| p.reached_before(t)` ([`LightPoint::reached_before`]); a host may test
    /// each point with a shadow ray instead. Calls `each` for every light reached with
    /// non-zero radiance, with its weight: the lights in front of it, and for a ray that
    /// escapes the distant lights whose cones hold its direction and the set's environment
    /// (its radiance and pdf along `direction` from
    /// [`Environment::eval`](crate::light::Environment::eval), `point.distance` = +∞).
    /// Returns whether any light was reached (what the adaptive allocation learns; the
    /// environment counts whatever its radiance).
    ///
    /// Errors: a zero or non-finite `direction`, a NaN, negative or infinite `bsdf_pdf`, and
    /// the environment's bad radiance or pdf along `direction` ([`DirectError`]).
    pub fn bsdf_hits(
        &mut self,
        draw: &BsdfDraw,
        direction: Vec3,
        bsdf_pdf: f32,
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
        // A direction already of unit length (to f32 rounding) is taken as it is.
        let dir = if (l2 - 1.0).abs() <= 4.0 * f32::EPSILON {
            direction
        } else {
            direction / crate::math::sqrt(l2)
        };
        let set = self.set;
        // The environment along the ray, checked before anything is reported.
        let env = match set.environment() {
            Some(env) => Some(environment_eval(env, dir)?),
            None => None,
        };
        let mixture = draw.p;
        // This sample's outcome is recorded here, not when the next step settles it.
        let pending = if mixture.is_some() {
            self.run.pending_tb.take()
        } else {
            None
        };
        let mut hit = false;
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
            let environment = e.kind() == Some(InfiniteKind::Environment);
            let lp = match (e.kind(), env) {
                (Some(InfiniteKind::Distant), _) => set
                    .lights()
                    .get(e.light as usize)
                    .and_then(|l| intersect(l, x, dir)),
                (Some(InfiniteKind::Environment), Some((radiance, pdf))) => Some(LightPoint {
                    position: dir,
                    normal: Vec3::ZERO,
                    direction: dir,
                    distance: f32::INFINITY,
                    pdf,
                    delta: false,
                    radiance,
                }),
                _ => None,
            };
            let Some(lp) = lp else {
                continue;
            };
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

    /// Records the host's shadow ray for the light sample `draw` of this estimator: whether
    /// it was `visible`, into the estimator's [`VisibilityCache`], counted for the cluster of
    /// the BRDF-oriented cut that holds the light (nothing without a cache or such a cut, or
    /// with the cache's recording off). Call it once per light sample whose unshadowed value is
    /// positive, as [`Estimator::estimate`] does for its own; what is recorded changes the
    /// cut's weights only after the cache's [`commit`](VisibilityCache::commit).
    #[inline]
    pub fn record(&self, draw: &LightDraw, visible: bool) {
        if let (Some(v), Some(b)) = (self.visibility, &self.bl) {
            if let Some(c) = b.cut().cluster_holding(self.set.tree(), draw.light) {
                v.record(self.cell, c, visible);
            }
        }
    }

    /// The visibility cache the estimator uses, if any.
    #[inline]
    #[must_use]
    pub fn visibility(&self) -> Option<&'a VisibilityCache> {
        self.visibility
    }

    /// One estimate of the reflected radiance with the core's material and the host's
    /// occluder (and the set's environment, if it has one): the lower level's loop
    /// ([`Estimator::start`], [`Estimator::next`], [`Estimator::weigh`],
    /// [`Estimator::bsdf_hits`]), summed in f64 per channel (red, green, blue). Finite and
    /// non-negative. With a [`VisibilityCache`], every shadow ray of a light sample is
    /// recorded in it ([`Estimator::record`]).
    pub fn estimate<O: Occluder + ?Sized>(
        &mut self,
        occluder: &O,
        u: &mut (impl Uniforms + ?Sized),
    ) -> Result<[f64; 3], DirectError> {
        self.start();
        let x = self.x;
        let mut sum = [0.0f64; 3];
        loop {
            let d = match self.next(u)? {
                Step::Done => break,
                Step::Light(d) => d,
                Step::Bsdf(b) => {
                    let Some((wi, pdf)) = self.material.sample(self.wo, b.u) else {
                        continue;
                    };
                    let f = self.material.eval_rgb(self.wo, wi);
                    let dir = math::normalize(self.frame.to_world(wi));
                    let mut value = [0.0f64; 3];
                    self.bsdf_hits(
                        &b,
                        dir,
                        pdf,
                        |lp| !occluder.occluded(x, dir, lp.distance),
                        |h| {
                            let g = f * h.point.radiance * wi.z;
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
            if g.max_channel() <= 0.0 {
                continue;
            }
            let blocked = occluder.occluded(x, d.point.direction, d.point.distance);
            self.record(&d, !blocked);
            if blocked {
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
