//! The seven estimators of direct illumination without visibility, one estimate per call.
//!
//! Every light sample contributes `f(ωo, ωi) · L · cos θi / pdf` (the estimator of
//! [`manylights::light_sample`]); a BRDF sample whose ray hits lights contributes the same
//! term for every light it hits (there is no occlusion: lights do not shadow each other), each
//! weighted for its own light point.
//!
//! - `uniform`: one light uniformly, a point on it by `sample_point`.
//! - `power`: one light with probability ∝ its energy.
//! - `tl`: one light by [`manylights::LightTree::sample`] with [`TlImportance`].
//! - `tl-split`: the Conty–Kulla split cut ([`LightCut::build_split`]), one sample per cluster,
//!   summed.
//! - `bl`: one light from the BRDF-oriented cut ([`LightCut::build`]).
//! - `mis-equal`: `tl-split` plus `N = brdf_budget(cut, 50)` BRDF-aware samples (from the
//!   glossy lobe's part of IB(x): none at Lambert points): ⌊N/2⌋ BL,
//!   ⌊N/2⌋ TB and, for an odd N, one more that is BL or TB with probability 1/2. The TL samples
//!   and the BRDF-aware ones are weighted by [`CombinedWeights`] with `p_ref = 1/2`; a
//!   BRDF-aware sample y contributes `g(y) w_M(y) / (N q_ref(y))`, `q_ref = (pdf_BL + pdf_TB)/2`,
//!   which is the expected number of BRDF-aware samples landing at y per unit measure
//!   (`⌊N/2⌋ pdf_BL + ⌊N/2⌋ pdf_TB + [N odd] q_ref`), so the sum is unbiased wherever `q_ref`
//!   covers `g·w_M`: neither technique alone needs to. (A deterministic split with
//!   `n_BL pdf_BL + n_TB pdf_TB` in the denominator would need both to cover it when a count
//!   can be 0.)
//! - `full`: `tl-split` plus N BRDF-aware samples chosen by [`AdaptiveAllocator`]
//!   (Algorithm 1); sample j contributes `g w_M / (N q_j)` with
//!   `q_j = p_j pdf_BL + (1 − p_j) pdf_TB` and p_j the allocator's probability before the
//!   sample (the derivation is in [`manylights::mis`]). Each choice takes a fresh uniform
//!   number; [`AdaptiveAllocator::choose`] warps it and the warped number drives the chosen
//!   technique's first dimension (it is not fed to the next choice: a TB sample's hit depends
//!   on it, so the next choice would no longer have probability p_{j+1} given the counts).
//!   The budget is the same as `mis-equal`'s. For Lambert-only materials BL is off and
//!   `full` is TL split alone ([`LambertMode::TlOnly`], the default; see [`LambertMode`] for
//!   TL + TB alternatives).
//!
//! TL and the BRDF-aware mixture are weighted by the power heuristic (β = 2) by default
//! ([`Params::power`]).
//!
//! pdfs of a light point y on light l, for MIS: TL `split.pmf_in(l) · pdf_point(y)`, BL
//! `bl_cut.pmf(l) · pdf_point(y)`, TB the material's solid-angle pdf of the direction. A BRDF
//! ray is traced against all lights by walking the light tree's bounding spheres ([`trace`]).
//! The TB "hit" the allocator counts: the ray hit at least one light with non-zero radiance.
//!
//! How the work is ordered (none of it changes a value: images are bit-identical to computing
//! each sample's densities on the spot, one descent at a time):
//! - a shading point's importances are wrapped in [`Memo`]s, because every sample at the point
//!   walks the same upper nodes again;
//! - split sampling draws all its uniform numbers first, then descends in every cluster with
//!   [`LightCut::sample_each`] (four descents interleaved: one descent is a chain of dependent
//!   steps), loads each chosen light's record, and only then samples points and casts shadow
//!   rays;
//! - pmfs go through a per-light memo, and the ones missing are computed together
//!   ([`LightCut::pmf_in_each`], [`LightCut::pmf_each`]): the TL samples' BL pmfs after the
//!   shadow rays, the BRDF-aware samples' TL (and TB points' BL) pmfs once all of them are
//!   drawn. A BRDF-aware sample's term depends only on the budget and its own p_j, so it can
//!   be computed after the allocator has moved on.
//!
//! The renderer reuses these estimators with visibility: [`Setup::with_occluder`] makes every
//! light sample cast a shadow ray and cuts every BRDF ray at the first surface ([`Occluder`]);
//! without it (the estimator instrument) nothing is occluded.

use super::scene::Scene;
use glam::Vec3;
use manylights::light_sample::{intersect, sample_point};
use manylights::mis::{
    brdf_budget, sample_budget, AdaptiveAllocator, CombinedWeights, SequentialWeights,
    Technique as Mix, MAX_BUDGET, N_MAX,
};
use manylights::tree::Slot;
use manylights::{
    f32x4, BlImportance, Brdf, CutOptions, Frame, LightCut, LightPoint, Material, Memo, Node4,
    ShadingPoint, SplitOptions, TlImportance, CUT_CAPACITY,
};
use rand::Rng;
use std::cell::RefCell;

/// The largest f32 below 1.
const ONE_MINUS: f32 = 1.0 - f32::EPSILON / 2.0;

/// A technique.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Technique {
    /// One light uniformly.
    Uniform,
    /// One light ∝ energy.
    Power,
    /// Tree descent with TL importance, one sample.
    Tl,
    /// Split sampling, one sample per cluster.
    TlSplit,
    /// BRDF-oriented cut, one sample.
    Bl,
    /// TL split + BL/TB in equal numbers.
    MisEqual,
    /// TL split + BL/TB adaptively (the full method).
    Full,
}

impl Technique {
    /// All techniques, in report order.
    pub const ALL: [Technique; 7] = [
        Technique::Uniform,
        Technique::Power,
        Technique::Tl,
        Technique::TlSplit,
        Technique::Bl,
        Technique::MisEqual,
        Technique::Full,
    ];

    /// The technique of a name (as [`Technique::name`] gives it).
    pub fn from_name(name: &str) -> Option<Technique> {
        Technique::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The name used everywhere.
    pub fn name(self) -> &'static str {
        match self {
            Technique::Uniform => "uniform",
            Technique::Power => "power",
            Technique::Tl => "tl",
            Technique::TlSplit => "tl-split",
            Technique::Bl => "bl",
            Technique::MisEqual => "mis-equal",
            Technique::Full => "full",
        }
    }
}

/// What `full` does at a Lambert-only shading point.
///
/// Measured with `mlrender compare --quick` (power heuristic, glossy-share budget, weights at
/// a fixed p_ref = 1/2): `full`'s RMSE at equal time against TL split's was 1.095× with
/// [`LambertMode::TbOne`] and 1.069× with [`LambertMode::TlOnly`] on `stairs`, 0.774× and
/// 0.692× on `cornell`; `mlrender estimator --estimates 20000`: variance × time against TL
/// split's at the Lambert configurations 1.105× with `TbOne`, 1.028× with `TlOnly`. Next to a
/// small sphere light a few radii from a wall, TL samples the light's cap uniformly and is
/// nearly exact, and a cosine-distributed BRDF sample only adds variance and a ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum LambertMode {
    /// TL split alone (the default): the Lambert share of IB(x) asks for no BRDF-aware
    /// samples (the core's `mis::brdf_budget`), and for a constant BRDF BL is TL.
    TlOnly,
    /// TL split + N = sample_budget(IB(x)) TB samples (Liu et al.: TL + TB only; the budget
    /// as at any other point).
    TbBudget,
    /// TL split + 1 TB sample (no BL cut is built: IB is not needed).
    TbOne,
    /// As at glossy points: TL split + N samples allocated adaptively between BL (which for
    /// Lambert is TL with exact cap integrals) and TB.
    BlTb,
}

/// Parameters of the cuts, the budget and the weights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// The split-sampling cut.
    pub split: SplitOptions,
    /// The BRDF-oriented cut.
    pub cut: CutOptions,
    /// Nmax of the budget.
    pub n_max: u32,
    /// `full` at Lambert-only points.
    pub lambert: LambertMode,
    /// Power heuristic (β = 2, the default) instead of the balance heuristic between TL and
    /// the BRDF-aware mixture (see the core's `mis` module for the measurements).
    pub power: bool,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            split: SplitOptions::default(),
            cut: CutOptions::default(),
            n_max: N_MAX,
            lambert: LambertMode::TlOnly,
            power: true,
        }
    }
}

/// Geometry that blocks light: the renderer's visibility (the estimator has none).
///
/// With an occluder, a light sample counts only if the segment from the shading point to the
/// light point is free, and a BRDF ray reaches only the lights in front of the first surface
/// it hits. Lights do not block each other in either case, so every technique estimates the
/// same integral.
pub trait Occluder: Sync + std::fmt::Debug {
    /// Whether a surface lies on the ray from `x` along the unit `d` before distance `t`.
    fn occluded(&self, x: Vec3, d: Vec3, t: f32) -> bool;
}

/// Ray-vs-bounding-sphere tests of a node's four slots at once, conservative against f32
/// rounding of the stored spheres: bit k of the result is set when the ray from `x` along the
/// unit `d` may reach slot k's sphere (empty slots included; the caller skips them).
#[inline(always)]
fn may_hit4(node: &Node4, x: Vec3, d: Vec3) -> u32 {
    let (cx, cy, cz) = (
        f32x4::new(node.center_x),
        f32x4::new(node.center_y),
        f32x4::new(node.center_z),
    );
    let (vx, vy, vz) = (
        cx - f32x4::splat(x.x),
        cy - f32x4::splat(x.y),
        cz - f32x4::splat(x.z),
    );
    let extent = cx.abs().fast_max(cy.abs()).fast_max(cz.abs());
    let r = f32x4::new(node.radius) * f32x4::splat(1.0 + 1e-4)
        + f32x4::splat(1e-6) * (f32x4::ONE + extent);
    let r2 = r * r;
    let v2 = vx * vx + vy * vy + vz * vz;
    let b = vx * f32x4::splat(d.x) + vy * f32x4::splat(d.y) + vz * f32x4::splat(d.z);
    let (px, py, pz) = (
        vx - f32x4::splat(d.x) * b,
        vy - f32x4::splat(d.y) * b,
        vz - f32x4::splat(d.z) * b,
    );
    let miss2 = px * px + py * py + pz * pz;
    let hit = v2.simd_le(r2) | (b.simd_gt(f32x4::ZERO) & miss2.simd_le(r2));
    hit.to_bitmask()
}

/// Calls `hit(light, point)` for every light the ray from `x` along the unit `d` reaches
/// (no occlusion), walking the tree's bounding spheres.
pub fn trace(scene: &Scene, x: Vec3, d: Vec3, mut hit: impl FnMut(u32, &LightPoint)) {
    let nodes = scene.tree.nodes();
    if nodes.is_empty() {
        return;
    }
    let mut stack = [0u32; 128];
    let mut top = 1usize;
    while top > 0 {
        top -= 1;
        let node = &nodes[stack[top] as usize];
        let mut mask = may_hit4(node, x, d);
        while mask != 0 {
            let k = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            match node.slot(k) {
                Slot::Light(l) => {
                    if let Some(lp) = intersect(&scene.lights[l as usize], x, d) {
                        hit(l, &lp);
                    }
                }
                Slot::Node(c) => {
                    stack[top] = c;
                    top += 1;
                }
                Slot::Empty => {}
            }
        }
    }
}

/// The lights a ray reaches, by brute force (for tests of [`trace`]).
pub fn trace_brute(scene: &Scene, x: Vec3, d: Vec3) -> Vec<(u32, LightPoint)> {
    scene
        .lights
        .iter()
        .enumerate()
        .filter_map(|(i, l)| intersect(l, x, d).map(|lp| (i as u32, lp)))
        .collect()
}

/// Everything an estimator sets up once per shading point.
#[derive(Clone, Debug)]
pub struct Setup<'a> {
    scene: &'a Scene,
    x: Vec3,
    frame: Frame,
    wo: Vec3,
    material: Material,
    /// TL importance, remembering its node values (sampling and pmfs query the same nodes at
    /// every sample of the shading point; see [`Memo`]); only for the techniques that use it
    /// (the table costs its initialisation at every shading point; boxed, so that moving a
    /// set-up does not copy it).
    tl: Option<Box<Memo<'a, TlImportance>>>,
    split: LightCut,
    /// BL importance (when a BL cut is built), likewise remembered.
    bl: Option<Box<Memo<'a, BlImportance>>>,
    bl_cut: LightCut,
    n_mix: u32,
    /// BL takes part in `full`'s mixture (false at Lambert-only points unless
    /// [`LambertMode::BlTb`]).
    bl_in_full: bool,
    power: bool,
    occluder: Option<&'a dyn Occluder>,
    /// Memo of the lights' pmfs in the split cut and in the BL cut: a shading point's estimates
    /// query the same few lights again and again (every BRDF-aware sample needs its TL pmf,
    /// every TL sample its BL pmf), and a pmf walks the tree with the importance at every
    /// level. The pmfs are fixed functions of the light at this point, so the memo changes no
    /// value.
    memo: RefCell<PmfMemo>,
}

/// Direct-mapped memo of per-light pmfs (see [`Setup`]).
#[derive(Clone, Debug)]
struct PmfMemo {
    tl: [(u32, f32); MEMO_SLOTS],
    bl: [(u32, f32); MEMO_SLOTS],
}

/// Slots of each memo table.
const MEMO_SLOTS: usize = 64;

impl PmfMemo {
    fn new() -> PmfMemo {
        PmfMemo {
            tl: [(u32::MAX, 0.0); MEMO_SLOTS],
            bl: [(u32::MAX, 0.0); MEMO_SLOTS],
        }
    }

    /// The stored value for `light`, if any.
    #[inline]
    fn lookup(table: &[(u32, f32); MEMO_SLOTS], light: u32) -> Option<f32> {
        let slot = &table[light as usize % MEMO_SLOTS];
        (slot.0 == light).then_some(slot.1)
    }

    /// Stores the value for `light`.
    #[inline]
    fn store(table: &mut [(u32, f32); MEMO_SLOTS], light: u32, value: f32) {
        table[light as usize % MEMO_SLOTS] = (light, value);
    }
}

/// One BRDF-aware sample's denominator `a pdf_BL + b pdf_TB`: `a = N p_j`, `b = N (1 − p_j)`
/// for `full`'s j-th sample (p_j the allocator's BL probability before it), `a = n_BL`,
/// `b = n_TB` for `mis-equal`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Denominator {
    /// Factor of pdf_BL.
    pub a: f32,
    /// Factor of pdf_TB.
    pub b: f32,
}

/// What a TL sample with `g = f·L·cos` and densities `pdf_tl` (> 0), `pdf_bl`, `pdf_tb`
/// contributes: `g · w_TL / pdf_TL`.
#[inline]
pub fn tl_term(g: f32, w: CombinedWeights, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> f32 {
    let (w_tl, _) = w.weights(pdf_tl, pdf_bl, pdf_tb);
    g * w_tl / pdf_tl
}

/// What a BRDF-aware sample (BL or TB) contributes: `g · w_M / (a pdf_BL + b pdf_TB)`.
#[inline]
pub fn mixture_term(
    g: f32,
    w: CombinedWeights,
    pdf_tl: f32,
    pdf_bl: f32,
    pdf_tb: f32,
    den: Denominator,
) -> f32 {
    let (_, w_m) = w.weights(pdf_tl, pdf_bl, pdf_tb);
    g * w_m / (den.a * pdf_bl + den.b * pdf_tb)
}

impl<'a> Setup<'a> {
    /// What `technique` needs at `sp` (only that, so that timing a technique with its set-up
    /// measures its own cost).
    pub fn new(scene: &'a Scene, sp: &ShadingPoint, technique: Technique, p: &Params) -> Self {
        let frame = Frame::from_normal(sp.normal).expect("non-zero normal");
        let tl = TlImportance::new(sp.position, frame.normal);
        let uses_tl = matches!(
            technique,
            Technique::Tl | Technique::TlSplit | Technique::MisEqual | Technique::Full
        );
        let needs_split = matches!(
            technique,
            Technique::TlSplit | Technique::MisEqual | Technique::Full
        );
        let diffuse = sp.material.is_diffuse_only();
        // Lambert points where `full` needs no IB(x): no BL cut is built.
        let no_ib = diffuse && matches!(p.lambert, LambertMode::TlOnly | LambertMode::TbOne);
        let needs_bl = match technique {
            Technique::Bl => true,
            Technique::MisEqual => !diffuse,
            Technique::Full => !no_ib,
            _ => false,
        };
        let split = if needs_split {
            LightCut::build_split(&scene.tree, &tl, &p.split)
        } else {
            LightCut::new()
        };
        let bl = needs_bl.then(|| BlImportance::new(sp).expect("valid shading point"));
        let bl_cut = match &bl {
            Some(imp) => LightCut::build(&scene.tree, imp, &p.cut),
            None => LightCut::new(),
        };
        let ib = bl_cut.max_score();
        let n_mix = match technique {
            Technique::Full if diffuse => match p.lambert {
                LambertMode::TlOnly => 0,
                LambertMode::TbOne => 1,
                LambertMode::TbBudget | LambertMode::BlTb => sample_budget(ib, p.n_max),
            },
            Technique::MisEqual | Technique::Full => brdf_budget(&bl_cut, p.n_max),
            _ => 0,
        };
        Setup {
            scene,
            x: sp.position,
            frame,
            wo: frame.to_local(sp.wo.normalize()),
            material: sp.material,
            tl: uses_tl.then(|| Box::new(Memo::new(tl, &scene.tree))),
            split,
            bl: bl.map(|imp| Box::new(Memo::new(imp, &scene.tree))),
            bl_cut,
            n_mix,
            bl_in_full: !diffuse || p.lambert == LambertMode::BlTb,
            power: p.power,
            occluder: None,
            memo: RefCell::new(PmfMemo::new()),
        }
    }

    /// The TL importance (of the techniques that use it).
    #[inline]
    fn tl(&self) -> &Memo<'a, TlImportance> {
        self.tl.as_deref().expect("set up for a technique using TL")
    }

    /// The same set-up with visibility through `occluder` (see [`Occluder`]).
    pub fn with_occluder(mut self, occluder: &'a dyn Occluder) -> Self {
        self.occluder = Some(occluder);
        self
    }

    /// Whether the light point is hidden by the occluder.
    #[inline]
    fn blocked(&self, lp: &LightPoint) -> bool {
        match self.occluder {
            Some(o) => o.occluded(self.x, lp.direction, lp.distance),
            None => false,
        }
    }

    /// Number of clusters of the split cut.
    pub fn split_len(&self) -> usize {
        self.split.len()
    }

    /// Number of clusters of the BL cut.
    pub fn bl_cut_len(&self) -> usize {
        self.bl_cut.len()
    }

    /// IB(x).
    pub fn ib(&self) -> f32 {
        self.bl_cut.max_score()
    }

    /// The BRDF-aware budget N.
    pub fn n_mix(&self) -> u32 {
        self.n_mix
    }

    /// `f · L · cos θi` of a light point, and the local direction.
    #[inline]
    fn contribution(&self, lp: &LightPoint) -> (f32, Vec3) {
        let wi = self.frame.to_local(lp.direction);
        if lp.radiance <= 0.0 || wi.z <= 0.0 {
            return (0.0, wi);
        }
        (self.material.eval(self.wo, wi) * lp.radiance * wi.z, wi)
    }

    /// A point on `light` and its contribution divided by `pmf · pdf`.
    #[inline]
    fn light_term(&self, light: u32, pmf: f32, u: [f32; 2]) -> f64 {
        let Some(lp) = sample_point(&self.scene.lights[light as usize], self.x, u) else {
            return 0.0;
        };
        let (g, _) = self.contribution(&lp);
        if g > 0.0 && !self.blocked(&lp) {
            f64::from(g / (pmf * lp.pdf))
        } else {
            0.0
        }
    }

    /// Split-cut pmfs of `lights` within their clusters (TL's density of a point is this ×
    /// the point's density, as the core's [`manylights::mis::technique_pdfs`] computes it).
    /// Memoised; the ones not in the memo are computed together ([`LightCut::pmf_in_each`]).
    fn pmfs_tl(&self, lights: &[u32], out: &mut [f32]) {
        let mut memo = self.memo.borrow_mut();
        memoised(&mut memo.tl, lights, out, |ls, got| {
            let mut within = [None; BATCH];
            self.split
                .pmf_in_each(&self.scene.tree, self.tl(), ls, &mut within[..ls.len()]);
            for (g, w) in got.iter_mut().zip(&within) {
                *g = w.map_or(0.0, |(_, p)| p);
            }
        });
    }

    /// BL-cut pmfs of `lights` (0 without BL), memoised and batched as in
    /// [`Setup::pmfs_tl`] ([`LightCut::pmf_each`]).
    fn pmfs_bl(&self, lights: &[u32], out: &mut [f32]) {
        let Some(imp) = self.bl.as_deref() else {
            out.fill(0.0);
            return;
        };
        let mut memo = self.memo.borrow_mut();
        memoised(&mut memo.bl, lights, out, |ls, got| {
            self.bl_cut.pmf_each(&self.scene.tree, imp, ls, got);
        });
    }

    /// One estimate of the reflected radiance with `technique` (which must be the one the
    /// set-up was built for, or one needing less).
    pub fn estimate(&self, technique: Technique, rng: &mut impl Rng) -> f64 {
        let u2 = |rng: &mut dyn rand::RngCore| [rng.random::<f32>(), rng.random::<f32>()];
        let lights = &self.scene.lights;
        match technique {
            Technique::Uniform => {
                let n = lights.len();
                let l = ((rng.random::<f64>() * n as f64) as usize).min(n - 1);
                self.light_term(l as u32, 1.0 / n as f32, u2(rng))
            }
            Technique::Power => {
                let u = rng.random::<f64>();
                let cdf = &self.scene.power_cdf;
                let l = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
                self.light_term(l as u32, self.scene.power_pmf[l] as f32, u2(rng))
            }
            Technique::Tl => match self.scene.tree.sample(self.tl(), rng.random::<f32>()) {
                Some(s) => self.light_term(s.light, s.pmf, u2(rng)),
                None => 0.0,
            },
            Technique::TlSplit => {
                let mut sum = 0.0;
                self.tl_samples(None, rng, |g, pdf_tl, _, _| {
                    sum += f64::from(g / pdf_tl);
                });
                sum
            }
            Technique::Bl => {
                let imp = self.bl.as_deref().expect("set up for BL");
                match self
                    .bl_cut
                    .sample(&self.scene.tree, imp, rng.random::<f32>())
                {
                    Some(s) => self.light_term(s.light, s.pmf, u2(rng)),
                    None => 0.0,
                }
            }
            Technique::MisEqual => self.combined(false, rng),
            Technique::Full => self.combined(true, rng),
        }
    }

    /// The split-sampling part shared by `tl-split`, `mis-equal` and `full`: one sample per
    /// cluster of the split cut; calls `take(g, pdf_tl, pdf_bl, pdf_tb)` for each unoccluded
    /// sample with `g > 0`. The MIS densities pdf_BL (only if BL takes part) and pdf_TB are
    /// computed only with `mis = Some(bl_on)`, and are 0 otherwise.
    fn tl_samples(
        &self,
        mis: Option<bool>,
        rng: &mut impl Rng,
        mut take: impl FnMut(f32, f32, f32, f32),
    ) {
        let tree = &self.scene.tree;
        let lights = &self.scene.lights;
        let m = self.split.len();
        let mut us = [0f32; CUT_CAPACITY];
        let mut uvs = [[0f32; 2]; CUT_CAPACITY];
        for i in 0..m {
            us[i] = rng.random::<f32>();
            uvs[i] = [rng.random::<f32>(), rng.random::<f32>()];
        }
        let mut chosen = [None; CUT_CAPACITY];
        self.split
            .sample_each(tree, self.tl(), &us[..m], &mut chosen[..m]);
        let mut picked = [(0u32, 0f32, [0f32; 2]); CUT_CAPACITY];
        let mut n = 0;
        let mut touched = 0u32;
        for i in 0..m {
            let Some(s) = chosen[i] else { continue };
            if let Some(l) = lights.get(s.light as usize) {
                touched ^= first_word(l);
            }
            picked[n] = (s.light, s.pmf, uvs[i]);
            n += 1;
        }
        std::hint::black_box(touched);
        // The unoccluded samples with g > 0: (light, g, pdf_TL, point pdf, pdf_TB).
        let mut kept = [(0u32, 0f32, 0f32, 0f32, 0f32); CUT_CAPACITY];
        let mut k = 0;
        for &(light, pmf, uv) in &picked[..n] {
            let Some(lp) = sample_point(&lights[light as usize], self.x, uv) else {
                continue;
            };
            let (g, wi) = self.contribution(&lp);
            if g <= 0.0 || self.blocked(&lp) {
                continue;
            }
            let pdf_tb = if mis.is_some() {
                self.material.pdf(self.wo, wi)
            } else {
                0.0
            };
            kept[k] = (light, g, pmf * lp.pdf, lp.pdf, pdf_tb);
            k += 1;
        }
        let mut pmf_bl = [0f32; CUT_CAPACITY];
        if mis == Some(true) {
            let ids: [u32; CUT_CAPACITY] = core::array::from_fn(|i| kept[i].0);
            self.pmfs_bl(&ids[..k], &mut pmf_bl[..k]);
        }
        for (&(_, g, pdf_tl, point_pdf, pdf_tb), &pmf) in kept[..k].iter().zip(&pmf_bl[..k]) {
            take(g, pdf_tl, pmf * point_pdf, pdf_tb);
        }
    }

    /// `mis-equal` (`adaptive = false`) and `full`.
    fn combined(&self, adaptive: bool, rng: &mut impl Rng) -> f64 {
        if adaptive {
            return self.full(rng);
        }
        let bl_on = self.bl.is_some();
        let n = self.n_mix;
        let w = CombinedWeights {
            n_tl: 1.0,
            n_mixture: n as f32,
            p_ref: if bl_on { 0.5 } else { 0.0 },
            power: self.power,
        };
        let mut sum = 0.0f64;
        // Without BRDF-aware samples TL's weight is 1: no densities needed.
        self.tl_samples(
            (n > 0).then_some(bl_on),
            rng,
            |g, pdf_tl, pdf_bl, pdf_tb| {
                sum += f64::from(tl_term(g, w, pdf_tl, pdf_bl, pdf_tb));
            },
        );
        if n == 0 || !bl_on {
            return sum;
        }
        // ⌊N/2⌋ BL and ⌊N/2⌋ TB samples, and for an odd N one more that is BL or TB with
        // probability 1/2: every sample's density in the sum is N q_ref.
        let nf = n as f32;
        let half = n / 2;
        let wt = Weighting::Fixed(
            w,
            Denominator {
                a: 0.5 * nf,
                b: 0.5 * nf,
            },
        );
        let mut d = Deferred::new(wt);
        let mut j = 0;
        for _ in 0..half {
            let u = rng.random::<f32>();
            self.bl_sample(u, j, 0.5, &mut d, rng);
            j += 1;
        }
        for _ in 0..half {
            let u = rng.random::<f32>();
            self.tb_sample(u, j, 0.5, &mut d, rng);
            j += 1;
        }
        if n % 2 == 1 {
            let u = rng.random::<f32>();
            if u < 0.5 {
                self.bl_sample(2.0 * u, j, 0.5, &mut d, rng);
            } else {
                self.tb_sample((2.0 * u - 1.0).min(ONE_MINUS), j, 0.5, &mut d, rng);
            }
            j += 1;
        }
        self.settle(&mut d);
        for &v in &d.values[..j] {
            sum += v;
        }
        sum
    }

    /// `full`: TL split, then N BRDF-aware samples allocated by [`AdaptiveAllocator`] and
    /// weighted by [`SequentialWeights`]; the TL samples (independent of the allocator) are
    /// drawn first and weighted once every p_j is known.
    fn full(&self, rng: &mut impl Rng) -> f64 {
        let bl_on = self.bl.is_some() && self.bl_in_full;
        let n = self.n_mix;
        let mut sw = SequentialWeights::new(n, 1.0, self.power);
        if n == 0 {
            // No BRDF-aware samples (every Lambert point): TL split, each term weighted 1,
            // summed as the samples come.
            let mut sum = 0.0f64;
            self.tl_samples(None, rng, |g, pdf_tl, _, _| {
                sum += f64::from(sw.tl_term(g, pdf_tl, 0.0, 0.0));
            });
            return sum;
        }
        let mut tl = [[0f32; 4]; CUT_CAPACITY];
        let mut n_tl = 0usize;
        self.tl_samples(Some(bl_on), rng, |g, pdf_tl, pdf_bl, pdf_tb| {
            if n_tl < CUT_CAPACITY {
                tl[n_tl] = [g, pdf_tl, pdf_bl, pdf_tb];
                n_tl += 1;
            }
        });
        let budget = sw.budget() as usize;
        // A BRDF-aware sample's term depends on the budget and its own p only, so it can be
        // computed before or after the other p are recorded: `terms` is `sw` before any.
        let terms = sw;
        let mut d = Deferred::new(Weighting::Sequential(&terms));
        let mut alloc = AdaptiveAllocator::new(bl_on);
        for j in 0..budget {
            let (t, u, p) = alloc.choose(rng.random::<f32>());
            match t {
                Mix::Bl => self.bl_sample(u, j, p, &mut d, rng),
                Mix::Tb => {
                    let hit = self.tb_sample(u, j, p, &mut d, rng);
                    alloc.record_tb(hit);
                }
            }
            sw.record(p);
        }
        self.settle(&mut d);
        let mut sum = 0.0f64;
        for &v in &d.values[..budget] {
            sum += v;
        }
        for &[g, pdf_tl, pdf_bl, pdf_tb] in &tl[..n_tl] {
            sum += f64::from(sw.tl_term(g, pdf_tl, pdf_bl, pdf_tb));
        }
        sum
    }

    /// One BL sample of the mixture, with the (warped) uniform `u`: the `j`-th BRDF-aware
    /// sample, drawn with BL probability `p`. Its light point waits in `d` for its TL density.
    fn bl_sample(&self, u: f32, j: usize, p: f32, d: &mut Deferred<'_>, rng: &mut impl Rng) {
        let imp = self.bl.as_deref().expect("set up for BL");
        let uv = [rng.random::<f32>(), rng.random::<f32>()];
        let Some(s) = self.bl_cut.sample(&self.scene.tree, imp, u) else {
            return;
        };
        let Some(lp) = sample_point(&self.scene.lights[s.light as usize], self.x, uv) else {
            return;
        };
        let (g, wi) = self.contribution(&lp);
        if g <= 0.0 || self.blocked(&lp) {
            return;
        }
        let hit = Pending {
            light: s.light,
            sample: j as u16,
            g,
            point_pdf: lp.pdf,
            pdf_bl: Some(s.pmf * lp.pdf),
            pdf_tb: self.material.pdf(self.wo, wi),
            p,
        };
        self.defer(d, hit);
    }

    /// One TB sample of the mixture (the `j`-th BRDF-aware sample, drawn with BL probability
    /// `p`): its light points wait in `d` for their densities. Returns whether the ray hit a
    /// light with non-zero radiance.
    fn tb_sample(
        &self,
        u: f32,
        j: usize,
        p: f32,
        d: &mut Deferred<'_>,
        rng: &mut impl Rng,
    ) -> bool {
        let v = rng.random::<f32>();
        let Some((wi, pdf_tb)) = self.material.sample(self.wo, [u, v]) else {
            return false;
        };
        let f = self.material.eval(self.wo, wi);
        let dir = self.frame.to_world(wi).normalize();
        let mut hit = false;
        // The lights first, then visibility only up to each light reached: most BRDF rays miss
        // every light and then cost no ray cast against the geometry.
        trace(self.scene, self.x, dir, |light, lp| {
            if lp.radiance <= 0.0 {
                return;
            }
            if let Some(o) = self.occluder {
                if o.occluded(self.x, dir, lp.distance) {
                    return;
                }
            }
            hit = true;
            let g = f * lp.radiance * wi.z;
            if g <= 0.0 {
                return;
            }
            let pending = Pending {
                light,
                sample: j as u16,
                g,
                point_pdf: lp.pdf,
                pdf_bl: None,
                pdf_tb,
                p,
            };
            self.defer(d, pending);
        });
        hit
    }

    /// Queues a light point of a BRDF-aware sample (settling the queue first when it is full).
    #[inline]
    fn defer(&self, d: &mut Deferred<'_>, hit: Pending) {
        if d.len == d.pending.len() {
            self.settle(d);
        }
        d.pending[d.len] = hit;
        d.len += 1;
    }

    /// Computes the MIS densities of every queued light point together (the tree walks of
    /// [`Setup::pmfs_tl`] and [`Setup::pmfs_bl`] run interleaved) and adds each point's term
    /// to its sample's value, in the order the points were found.
    fn settle(&self, d: &mut Deferred<'_>) {
        let (n, wt) = (d.len, d.weighting);
        if n == 0 {
            return;
        }
        let mut lights = [0u32; PENDING];
        let mut pmf_tl = [0f32; PENDING];
        for (l, h) in lights.iter_mut().zip(&d.pending[..n]) {
            *l = h.light;
        }
        self.pmfs_tl(&lights[..n], &mut pmf_tl[..n]);
        // BL's pmfs of the TB points whose term needs them.
        let mut need = [0u32; PENDING];
        let mut at = [0usize; PENDING];
        let mut m = 0;
        for (i, h) in d.pending[..n].iter().enumerate() {
            if h.pdf_bl.is_none() && wt.uses_bl(h.p) {
                need[m] = h.light;
                at[m] = i;
                m += 1;
            }
        }
        let mut pmf_bl = [0f32; PENDING];
        self.pmfs_bl(&need[..m], &mut pmf_bl[..m]);
        let mut bl_of = [0f32; PENDING];
        for k in 0..m {
            bl_of[at[k]] = pmf_bl[k] * d.pending[at[k]].point_pdf;
        }
        for (i, h) in d.pending[..n].iter().enumerate() {
            let pdf_tl = pmf_tl[i] * h.point_pdf;
            let pdf_bl = h.pdf_bl.unwrap_or(bl_of[i]);
            d.values[usize::from(h.sample)] +=
                f64::from(wt.term(h.p, h.g, pdf_tl, pdf_bl, h.pdf_tb));
        }
        d.len = 0;
    }
}

/// Light points of BRDF-aware samples queued at once by [`Setup::defer`].
const PENDING: usize = 32;

/// Lights whose pmfs [`memoised`] computes in one call.
const BATCH: usize = 64;

/// A BRDF-aware sample's light point whose MIS densities are computed later, together with
/// the others' ([`Setup::settle`]).
#[derive(Clone, Copy, Debug, Default)]
struct Pending {
    light: u32,
    /// Which BRDF-aware sample found it (its index among them).
    sample: u16,
    /// `f·L·cos`.
    g: f32,
    /// The density of the point on its light.
    point_pdf: f32,
    /// BL's density when the sample is BL's own (otherwise computed when settled).
    pdf_bl: Option<f32>,
    /// TB's density.
    pdf_tb: f32,
    /// The sample's BL probability.
    p: f32,
}

/// The queue of [`Pending`] points and the values of the BRDF-aware samples so far.
#[derive(Clone, Debug)]
struct Deferred<'w> {
    /// How the samples are weighted.
    weighting: Weighting<'w>,
    pending: [Pending; PENDING],
    len: usize,
    /// Each BRDF-aware sample's value (the sum of its points' terms).
    values: [f64; MAX_BUDGET as usize + 1],
}

impl<'w> Deferred<'w> {
    fn new(weighting: Weighting<'w>) -> Deferred<'w> {
        Deferred {
            weighting,
            pending: [Pending::default(); PENDING],
            len: 0,
            values: [0.0; MAX_BUDGET as usize + 1],
        }
    }
}

/// `out[i]` = the pmf of `lights[i]`, from `table` where it holds it, otherwise computed by
/// `compute(lights, out)` for all the missing ones at once (`BATCH` at a time) and stored.
fn memoised(
    table: &mut [(u32, f32); MEMO_SLOTS],
    lights: &[u32],
    out: &mut [f32],
    mut compute: impl FnMut(&[u32], &mut [f32]),
) {
    let mut missing = [0u32; BATCH];
    let mut at = [0usize; BATCH];
    let mut m = 0;
    let mut flush =
        |missing: &[u32], at: &[usize], out: &mut [f32], table: &mut [(u32, f32); MEMO_SLOTS]| {
            let mut got = [0f32; BATCH];
            compute(missing, &mut got[..missing.len()]);
            for (k, &l) in missing.iter().enumerate() {
                out[at[k]] = got[k];
                PmfMemo::store(table, l, got[k]);
            }
        };
    for (i, &l) in lights.iter().enumerate() {
        if let Some(p) = PmfMemo::lookup(table, l) {
            out[i] = p;
            continue;
        }
        missing[m] = l;
        at[m] = i;
        m += 1;
        if m == BATCH {
            flush(&missing[..m], &at[..m], out, table);
            m = 0;
        }
    }
    flush(&missing[..m], &at[..m], out, table);
}

/// A word of a light's record, to have it loaded.
#[inline(always)]
fn first_word(l: &manylights::Light) -> u32 {
    match *l {
        manylights::Light::Point { position, .. }
        | manylights::Light::Spot { position, .. }
        | manylights::Light::Vpl { position, .. } => position.x.to_bits(),
        manylights::Light::Sphere { center, .. } | manylights::Light::Disk { center, .. } => {
            center.x.to_bits()
        }
        manylights::Light::Triangle { vertices, .. } => vertices[0].x.to_bits(),
    }
}

/// How a BRDF-aware sample is weighted.
#[derive(Clone, Copy, Debug)]
enum Weighting<'w> {
    /// `mis-equal`: fixed weights against the mixture at `p_ref`, density `a pdf_BL + b pdf_TB`.
    Fixed(CombinedWeights, Denominator),
    /// `full`: the sequential weights (the sample's BL probability is passed to each call).
    Sequential(&'w SequentialWeights),
}

impl Weighting<'_> {
    /// The term of a point found by a sample of BL probability `p` (ignored by `Fixed`).
    #[inline]
    fn term(self, p: f32, g: f32, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> f32 {
        match self {
            Weighting::Fixed(w, den) => mixture_term(g, w, pdf_tl, pdf_bl, pdf_tb, den),
            Weighting::Sequential(sw) => sw.mixture_term(g, p, pdf_tl, pdf_bl, pdf_tb),
        }
    }

    /// Whether the term of a sample of BL probability `p` needs pdf_BL.
    #[inline]
    fn uses_bl(self, p: f32) -> bool {
        match self {
            Weighting::Fixed(w, den) => w.p_ref > 0.0 || den.a > 0.0,
            Weighting::Sequential(_) => p > 0.0,
        }
    }
}
