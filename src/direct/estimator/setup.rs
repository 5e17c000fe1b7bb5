//! The set-up of an estimator at a shading point: what its technique needs there is decided
//! and validated first ([`Plan`]), then built by one function that both construction and
//! [`Estimator::reset`] run, so that the two cannot drift apart.

use super::{Estimator, Phase, PmfCache, Run, SPLIT_CAPACITY};
use crate::brdf::Frame;
use crate::cut::{BlCutOptions, LightCut};
use crate::direct::sampler::{CutSampler, PinfSampler, TreeSampler};
use crate::direct::visibility::VisibilityCache;
use crate::direct::{DirectError, LambertMode, Params, Technique};
use crate::error::Problem;
use crate::importance::{BlImportance, TlImportance};
use crate::light_set::LightSet;
use crate::material::{ShadingError, ShadingField, ShadingPoint};
use crate::math;
use crate::mis::{brdf_budget, sample_budget, AdaptiveAllocator, SequentialWeights};
use glam::Vec3;

/// The BRDF-oriented cut `technique` builds: `bl_cut` for `bl` and `bl-mis`, `mixture_cut`
/// for `mis-equal` and `full`.
#[inline]
fn bl_cut_options(technique: Technique, params: &Params) -> &BlCutOptions {
    match technique {
        Technique::MisEqual | Technique::Full => &params.mixture_cut,
        _ => &params.bl_cut,
    }
}

/// What a technique needs at one shading point, decided and validated before anything is
/// built: shared by [`Estimator::new`] and [`Estimator::reset`].
pub(super) struct Plan {
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
    /// An estimator for `set`, `technique` and `params` at `sp` with nothing set up but
    /// `plan`'s frame: what [`Estimator::set_up`] starts from in `new` and `with_visibility`.
    fn empty(
        set: &'a LightSet,
        sp: &ShadingPoint,
        technique: Technique,
        params: &Params,
        plan: &Plan,
    ) -> Estimator<'a> {
        Estimator {
            set,
            technique,
            params: *params,
            x: sp.position,
            frame: plan.frame,
            wo: plan.wo,
            material: sp.material,
            tl: TreeSampler::with_importance(set.tree(), plan.tl),
            split: LightCut::new(),
            bl: None,
            pinf: None,
            n_mix: 0,
            bl_in_full: false,
            pmfs: PmfCache::EMPTY,
            visibility: None,
            cell: 0,
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
        }
    }

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
        let mut e = Estimator::empty(set, sp, technique, params, &plan);
        e.set_up(sp, plan);
        Ok(e)
    }

    /// [`Estimator::new`] with learned visibility: the BRDF-oriented cut's cluster weights are
    /// scaled by `visibility`'s committed factors at `sp` (see [`VisibilityCache`]), and
    /// [`Estimator::estimate`] records its shadow rays in it. Pmfs stay exact and every
    /// technique unbiased; the techniques without a BRDF-oriented cut (`uniform`, `energy`,
    /// `tl`, `tl-mis`, `tl-mis-pinf`, `tl-split`) sample as without it and record nothing
    /// (the cache counts clusters of that cut). [`Estimator::reset`] keeps the cache.
    ///
    /// Errors: those of `new`, and [`DirectError::VisibilityCache`] for a cache made for
    /// another light set.
    pub fn with_visibility(
        set: &'a LightSet,
        visibility: &'a VisibilityCache,
        sp: &ShadingPoint,
        technique: Technique,
        params: &Params,
    ) -> Result<Estimator<'a>, DirectError> {
        if !visibility.fits(set.tree()) {
            return Err(DirectError::VisibilityCache);
        }
        let plan = Plan::new(sp, technique, params)?;
        let mut e = Estimator::empty(set, sp, technique, params, &plan);
        e.visibility = Some(visibility);
        e.set_up(sp, plan);
        Ok(e)
    }

    /// Moves the estimator to the shading point `sp`, with the same light set, technique and
    /// parameters: afterwards it is what [`Estimator::new`] would have returned at `sp`, and
    /// gives bit for bit the same estimates, but it is set up in place, without the copy of
    /// the whole estimator that returning a new one costs. The current estimate is
    /// forgotten (call [`Estimator::start`] before the lower level's steps, as after
    /// `new`). An invalid `sp` is the error `new` would give, and leaves the estimator
    /// unchanged.
    pub fn reset(&mut self, sp: &ShadingPoint) -> Result<(), DirectError> {
        let plan = Plan::new(sp, self.technique, &self.params)?;
        self.set_up(sp, plan);
        Ok(())
    }

    /// The set-up at `sp` that `plan` decided, shared by [`Estimator::new`] (from an empty
    /// estimator) and [`Estimator::reset`]: it cannot fail.
    fn set_up(&mut self, sp: &ShadingPoint, plan: Plan) {
        let params = self.params;
        let tree = self.set.tree();
        self.tl = TreeSampler::with_importance(tree, plan.tl);
        // A technique without split sampling keeps the empty cut it was made with.
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
        if let (Some(v), Some(b)) = (self.visibility, self.bl.as_mut()) {
            let cell = v.cell(sp.position, plan.frame.normal);
            self.cell = cell;
            b.scale_weights(|c| v.factor(cell, c));
        } else if let Some(v) = self.visibility {
            self.cell = v.cell(sp.position, plan.frame.normal);
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
    }

    /// The estimator at `sp` from a per-thread `slot`: the one in it moved there by
    /// [`Estimator::reset`] when it was made by `new` for `set`, `technique` and `params`,
    /// else a new one put in it. Either way what [`Estimator::new`] gives at `sp`. On error (an invalid
    /// `sp`, `new`'s error) the slot keeps what it held.
    pub fn reuse<'s>(
        slot: &'s mut Option<Estimator<'a>>,
        set: &'a LightSet,
        sp: &ShadingPoint,
        technique: Technique,
        params: &Params,
    ) -> Result<&'s mut Estimator<'a>, DirectError> {
        Estimator::reuse_in(slot, set, None, sp, technique, params)
    }

    /// [`Estimator::reuse`] for [`Estimator::with_visibility`]: the slot's estimator is moved
    /// to `sp` when it was made for `set`, `visibility`, `technique` and `params`, else a new
    /// one is put in it.
    pub fn reuse_with_visibility<'s>(
        slot: &'s mut Option<Estimator<'a>>,
        set: &'a LightSet,
        visibility: &'a VisibilityCache,
        sp: &ShadingPoint,
        technique: Technique,
        params: &Params,
    ) -> Result<&'s mut Estimator<'a>, DirectError> {
        Estimator::reuse_in(slot, set, Some(visibility), sp, technique, params)
    }

    fn reuse_in<'s>(
        slot: &'s mut Option<Estimator<'a>>,
        set: &'a LightSet,
        visibility: Option<&'a VisibilityCache>,
        sp: &ShadingPoint,
        technique: Technique,
        params: &Params,
    ) -> Result<&'s mut Estimator<'a>, DirectError> {
        let same = slot.as_ref().is_some_and(|e| {
            core::ptr::eq(e.set, set)
                && e.technique == technique
                && e.params == *params
                && match (e.visibility, visibility) {
                    (None, None) => true,
                    (Some(a), Some(b)) => core::ptr::eq(a, b),
                    _ => false,
                }
        });
        let fresh = |set, sp: &ShadingPoint| match visibility {
            Some(v) => Estimator::with_visibility(set, v, sp, technique, params),
            None => Estimator::new(set, sp, technique, params),
        };
        match slot {
            Some(e) if same => e.reset(sp)?,
            _ => return Ok(slot.insert(fresh(set, sp)?)),
        }
        // Reset in place; `same` held, so the slot holds it.
        match slot {
            Some(e) => Ok(e),
            None => Ok(slot.insert(fresh(set, sp)?)),
        }
    }
}
