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
//! The renderer reuses these estimators with visibility: [`Setup::with_occluder`] makes every
//! light sample cast a shadow ray and cuts every BRDF ray at the first surface ([`Occluder`]);
//! without it (the estimator instrument) nothing is occluded.

use super::scene::Scene;
use glam::Vec3;
use manylights::light_sample::{intersect, sample_point};
use manylights::mis::{
    brdf_budget, sample_budget, AdaptiveAllocator, CombinedWeights, SequentialWeights,
    Technique as Mix, N_MAX,
};
use manylights::tree::Slot;
use manylights::{
    BlImportance, Brdf, CutOptions, Frame, LightCut, LightPoint, Material, ShadingPoint,
    SplitOptions, TlImportance, CUT_CAPACITY,
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

/// A ray-vs-bounding-sphere test, conservative against f32 rounding of the stored spheres.
#[inline(always)]
fn may_hit(c: Vec3, r: f32, x: Vec3, d: Vec3) -> bool {
    let v = c - x;
    let r = r * (1.0 + 1e-4) + 1e-6 * (1.0 + c.abs().max_element());
    let r2 = r * r;
    let v2 = v.length_squared();
    if v2 <= r2 {
        return true;
    }
    let b = v.dot(d);
    if b <= 0.0 {
        return false;
    }
    (v - d * b).length_squared() <= r2
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
        for k in 0..4 {
            let slot = node.slot(k);
            if slot == Slot::Empty {
                continue;
            }
            let c = Vec3::new(node.center_x[k], node.center_y[k], node.center_z[k]);
            if !may_hit(c, node.radius[k], x, d) {
                continue;
            }
            match slot {
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
    tl: TlImportance,
    split: LightCut,
    bl: Option<BlImportance>,
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

    /// The value for `light` in `table`, computed by `f` and stored on a miss.
    #[inline]
    fn get(table: &mut [(u32, f32); MEMO_SLOTS], light: u32, f: impl FnOnce() -> f32) -> f32 {
        let slot = &mut table[light as usize % MEMO_SLOTS];
        if slot.0 != light {
            *slot = (light, f());
        }
        slot.1
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
            tl,
            split,
            bl,
            bl_cut,
            n_mix,
            bl_in_full: !diffuse || p.lambert == LambertMode::BlTb,
            power: p.power,
            occluder: None,
            memo: RefCell::new(PmfMemo::new()),
        }
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

    /// TL's density of a point on `light`: its pmf within its cluster of the split cut × the
    /// point's density (as the core's [`manylights::mis::technique_pdfs`] computes it; memoised).
    fn pdf_tl(&self, light: u32, point_pdf: f32) -> f32 {
        let pmf = PmfMemo::get(&mut self.memo.borrow_mut().tl, light, || {
            self.split
                .pmf_in(&self.scene.tree, &self.tl, light)
                .map_or(0.0, |(_, p)| p)
        });
        pmf * point_pdf
    }

    /// BL's density of a point on `light` (0 without BL): its pmf through the BL cut × the
    /// point's density (memoised).
    fn pdf_bl(&self, light: u32, point_pdf: f32) -> f32 {
        match &self.bl {
            Some(imp) => {
                let pmf = PmfMemo::get(&mut self.memo.borrow_mut().bl, light, || {
                    self.bl_cut.pmf(&self.scene.tree, imp, light)
                });
                pmf * point_pdf
            }
            None => 0.0,
        }
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
            Technique::Tl => match self.scene.tree.sample(&self.tl, rng.random::<f32>()) {
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
                let imp = self.bl.as_ref().expect("set up for BL");
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
        for i in 0..self.split.len() {
            let u = rng.random::<f32>();
            let uv = [rng.random::<f32>(), rng.random::<f32>()];
            let Some(s) = self.split.sample_in(tree, &self.tl, i, u) else {
                continue;
            };
            let Some(lp) = sample_point(&self.scene.lights[s.light as usize], self.x, uv) else {
                continue;
            };
            let (g, wi) = self.contribution(&lp);
            if g <= 0.0 || self.blocked(&lp) {
                continue;
            }
            let (pdf_bl, pdf_tb) = match mis {
                Some(bl_on) => (
                    if bl_on {
                        self.pdf_bl(s.light, lp.pdf)
                    } else {
                        0.0
                    },
                    self.material.pdf(self.wo, wi),
                ),
                None => (0.0, 0.0),
            };
            take(g, s.pmf * lp.pdf, pdf_bl, pdf_tb);
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
        for _ in 0..half {
            let u = rng.random::<f32>();
            sum += self.bl_sample(u, wt, rng);
        }
        for _ in 0..half {
            let u = rng.random::<f32>();
            sum += self.tb_sample(u, wt, rng).0;
        }
        if n % 2 == 1 {
            let u = rng.random::<f32>();
            if u < 0.5 {
                sum += self.bl_sample(2.0 * u, wt, rng);
            } else {
                sum += self.tb_sample((2.0 * u - 1.0).min(ONE_MINUS), wt, rng).0;
            }
        }
        sum
    }

    /// `full`: TL split, then N BRDF-aware samples allocated by [`AdaptiveAllocator`] and
    /// weighted by [`SequentialWeights`]; the TL samples (independent of the allocator) are
    /// drawn first and weighted once every p_j is known.
    fn full(&self, rng: &mut impl Rng) -> f64 {
        let bl_on = self.bl.is_some() && self.bl_in_full;
        let n = self.n_mix;
        let mut tl = [[0f32; 4]; CUT_CAPACITY];
        let mut n_tl = 0usize;
        // Without BRDF-aware samples TL's weight is 1: no densities needed.
        self.tl_samples(
            (n > 0).then_some(bl_on),
            rng,
            |g, pdf_tl, pdf_bl, pdf_tb| {
                if n_tl < CUT_CAPACITY {
                    tl[n_tl] = [g, pdf_tl, pdf_bl, pdf_tb];
                    n_tl += 1;
                }
            },
        );
        let mut sw = SequentialWeights::new(n, 1.0, self.power);
        let mut sum = 0.0f64;
        let mut alloc = AdaptiveAllocator::new(bl_on);
        for _ in 0..sw.budget() {
            let (t, u, p) = alloc.choose(rng.random::<f32>());
            let wt = Weighting::Sequential(&sw, p);
            match t {
                Mix::Bl => sum += self.bl_sample(u, wt, rng),
                Mix::Tb => {
                    let (v, hit) = self.tb_sample(u, wt, rng);
                    sum += v;
                    alloc.record_tb(hit);
                }
            }
            sw.record(p);
        }
        for &[g, pdf_tl, pdf_bl, pdf_tb] in &tl[..n_tl] {
            sum += f64::from(sw.tl_term(g, pdf_tl, pdf_bl, pdf_tb));
        }
        sum
    }

    /// One BL sample of the mixture, with the (warped) uniform `u`.
    fn bl_sample(&self, u: f32, wt: Weighting<'_>, rng: &mut impl Rng) -> f64 {
        let imp = self.bl.as_ref().expect("set up for BL");
        let uv = [rng.random::<f32>(), rng.random::<f32>()];
        let Some(s) = self.bl_cut.sample(&self.scene.tree, imp, u) else {
            return 0.0;
        };
        let Some(lp) = sample_point(&self.scene.lights[s.light as usize], self.x, uv) else {
            return 0.0;
        };
        let (g, wi) = self.contribution(&lp);
        if g <= 0.0 || self.blocked(&lp) {
            return 0.0;
        }
        let pdf_bl = s.pmf * lp.pdf;
        let pdf_tl = self.pdf_tl(s.light, lp.pdf);
        let pdf_tb = self.material.pdf(self.wo, wi);
        f64::from(wt.term(g, pdf_tl, pdf_bl, pdf_tb))
    }

    /// One TB sample of the mixture: its value and whether the ray hit a light with non-zero
    /// radiance.
    fn tb_sample(&self, u: f32, wt: Weighting<'_>, rng: &mut impl Rng) -> (f64, bool) {
        let v = rng.random::<f32>();
        let Some((wi, pdf_tb)) = self.material.sample(self.wo, [u, v]) else {
            return (0.0, false);
        };
        let f = self.material.eval(self.wo, wi);
        let dir = self.frame.to_world(wi).normalize();
        let mut sum = 0.0f64;
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
            let pdf_tl = self.pdf_tl(light, lp.pdf);
            let pdf_bl = if wt.uses_bl() {
                self.pdf_bl(light, lp.pdf)
            } else {
                0.0
            };
            sum += f64::from(wt.term(g, pdf_tl, pdf_bl, pdf_tb));
        });
        (sum, hit)
    }
}

/// How a BRDF-aware sample is weighted.
#[derive(Clone, Copy, Debug)]
enum Weighting<'w> {
    /// `mis-equal`: fixed weights against the mixture at `p_ref`, density `a pdf_BL + b pdf_TB`.
    Fixed(CombinedWeights, Denominator),
    /// `full`: the sequential weights, and this sample's BL probability.
    Sequential(&'w SequentialWeights, f32),
}

impl Weighting<'_> {
    #[inline]
    fn term(self, g: f32, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> f32 {
        match self {
            Weighting::Fixed(w, den) => mixture_term(g, w, pdf_tl, pdf_bl, pdf_tb, den),
            Weighting::Sequential(sw, p) => sw.mixture_term(g, p, pdf_tl, pdf_bl, pdf_tb),
        }
    }

    /// Whether the term needs pdf_BL.
    #[inline]
    fn uses_bl(self) -> bool {
        match self {
            Weighting::Fixed(w, den) => w.p_ref > 0.0 || den.a > 0.0,
            Weighting::Sequential(_, p) => p > 0.0,
        }
    }
}
