//! Combining techniques: MIS weights and the adaptive sample allocation of Liu et al. 2019
//! (section 4.2, Algorithm 1; MATH.md section 9).
//!
//! Techniques: **TL** (split sampling: one sample per cluster of the Conty–Kulla cut), **BL**
//! (a light from the BRDF-oriented cut, then a point on it) and **TB** (sampling the BRDF; the
//! host traces the ray and reports whether it hit a light). At a shading point the BRDF-aware
//! techniques get a budget of `N = ceil(Nmax · IB(x))` samples ([`sample_budget`]); for each,
//! [`AdaptiveAllocator`] chooses BL with probability `p = n_nohit / (n_nohit + λ n_hit)` and TB
//! otherwise, counting whether TB's rays hit a light.
//!
//! # Why the combined estimator stays unbiased although p changes
//!
//! Write `q_j(y) = p_j·pdf_BL(y) + (1 − p_j)·pdf_TB(y)` for the density of the j-th BRDF-aware
//! sample given the samples before it: p_j is fixed by the history `F_{j−1}` (the hit counts),
//! and the sample is drawn from the mixture. The estimator is
//!
//! ```text
//! F = Σ_TL-samples f(Y)·w_TL(Y)/pdf_TL(Y)  +  (1/N) Σ_{j=1..N} f(X_j)·w_M(X_j)/q_j(X_j)
//! ```
//!
//! with weights `w_TL(y) + w_M(y) = 1` for every y that are **fixed functions of y** — they may
//! not depend on the hit counts. Then `E[f(X_j) w_M(X_j)/q_j(X_j) | F_{j−1}] = ∫ f w_M` for every
//! j, because q_j is known given `F_{j−1}` and `X_j ~ q_j`; by the tower rule each term of the
//! sum has expectation `∫ f w_M`, so the second part has expectation `∫ f w_M`, the first
//! `∫ f w_TL`, and `E[F] = ∫ f`. (Using the final p, or a p that saw X_j's own outcome, inside
//! the weights would break this: the weight would then depend on the sample it weights.) The
//! requirements are `q_j > 0` wherever `f·w_M > 0` — p stays in (0, 1) because both counts
//! start at 1 — and `pdf_TL > 0` wherever `f·w_TL > 0`, which the balance form guarantees.
//!
//! The weights used ([`CombinedWeights`]) are the balance (or power) heuristic between TL with
//! its sample count and the BRDF-aware mixture with N samples at the fixed reference
//! probability `p_ref` (by default 1/2): `w_TL = n_TL·pdf_TL / (n_TL·pdf_TL + N·q_ref)`,
//! `q_ref = p_ref·pdf_BL + (1 − p_ref)·pdf_TB`. Within the mixture no further weight is needed:
//! the one-sample density `q_j` already is the balance heuristic between BL and TB.
//! For Lambert-only materials BL reduces to TL (Liu et al., end of section 4.2), so only TL and
//! TB are combined: set `p_ref = 0` and always choose TB, with one BRDF sample
//! ([`brdf_budget`]). [`technique_pdfs`] gives a light point's density under each technique.

use crate::cut::LightCut;
use crate::importance::{Importance, TlImportance};
use crate::tree::LightTree;

/// λ of Algorithm 1.
pub const LAMBDA: f32 = 10.0;
/// Nmax of the sample budget.
pub const N_MAX: u32 = 50;

/// The number of BRDF-aware samples at a shading point: `ceil(n_max · ib)` with `ib = IB(x)`
/// (the largest BRDF integral over the cut), at least 1; 0 for a non-positive or NaN `ib`.
pub fn sample_budget(ib: f32, n_max: u32) -> u32 {
    if ib.is_nan() || ib <= 0.0 {
        return 0;
    }
    let n = libm::ceilf(ib.min(1.0) * n_max as f32);
    (n as u32).clamp(1, n_max.max(1))
}

/// The number of BRDF-aware samples at a shading point of this material: the budget
/// [`sample_budget`] for materials with a glossy lobe; one BRDF sample for diffuse-only ones.
///
/// For a Lambert surface BL reduces to TL, so the budget would buy only BRDF samples, which
/// rarely hit small lights: measured with `mlrender estimator`, TL split plus ceil(50·IB) BRDF
/// samples has 2.66× the variance of TL split at equal time on the Lambert configurations, TL
/// split plus one BRDF sample 1.08×. Liu et al. state their sample counts over glossy shading
/// points.
pub fn brdf_budget(diffuse_only: bool, ib: f32, n_max: u32) -> u32 {
    if diffuse_only {
        1
    } else {
        sample_budget(ib, n_max)
    }
}

/// The densities (solid angle) of one light point under the three techniques.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TechniquePdfs {
    /// TL split sampling: the light's pmf within its cluster × the point's pdf.
    pub tl: f32,
    /// BL: the light's pmf through the BRDF-oriented cut × the point's pdf.
    pub bl: f32,
    /// TB: the BRDF sampling pdf of the direction.
    pub tb: f32,
}

/// The densities of a point on `light` under every technique, for MIS: `point_pdf` is the
/// solid-angle pdf of the point on the light (`light_sample::pdf_point`), `brdf_pdf` the
/// BRDF's pdf of the direction towards it. `bl` is `None` when BL is not used (diffuse-only
/// materials). The same function serves light samples and BRDF rays that hit a light.
pub fn technique_pdfs<B: Importance + ?Sized>(
    tree: &LightTree,
    split: &LightCut,
    tl: &TlImportance,
    bl: Option<(&LightCut, &B)>,
    light: u32,
    point_pdf: f32,
    brdf_pdf: f32,
) -> TechniquePdfs {
    let tl_pmf = split.pmf_in(tree, tl, light).map_or(0.0, |(_, p)| p);
    let bl_pmf = bl.map_or(0.0, |(cut, imp)| cut.pmf(tree, imp, light));
    TechniquePdfs {
        tl: tl_pmf * point_pdf,
        bl: bl_pmf * point_pdf,
        tb: brdf_pdf,
    }
}

/// Balance-heuristic weight of technique `a` (`n_a` samples, density `pdf_a`) among
/// `others` (each `(n, pdf)`): `n_a·pdf_a / Σ n·pdf`. 0 when every density is 0.
pub fn balance(n_a: f32, pdf_a: f32, others: &[(f32, f32)]) -> f32 {
    let a = n_a * pdf_a;
    let sum = a + others.iter().map(|&(n, p)| n * p).sum::<f32>();
    if sum > 0.0 && sum < f32::INFINITY {
        a / sum
    } else {
        0.0
    }
}

/// Power-heuristic (β = 2) weight of technique `a` among `others`: `(n_a·pdf_a)² / Σ (n·pdf)²`.
pub fn power(n_a: f32, pdf_a: f32, others: &[(f32, f32)]) -> f32 {
    let a = n_a * pdf_a;
    let sum = a * a + others.iter().map(|&(n, p)| (n * p) * (n * p)).sum::<f32>();
    if sum > 0.0 && sum < f32::INFINITY {
        a * a / sum
    } else {
        0.0
    }
}

/// Which BRDF-aware technique a sample uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Technique {
    /// BRDF-oriented light sampling through the cut.
    Bl,
    /// BRDF sampling.
    Tb,
}

/// Algorithm 1 of Liu et al. 2019 for one shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveAllocator {
    n_hit: u32,
    n_nohit: u32,
    lambda: f32,
    bl_enabled: bool,
}

impl AdaptiveAllocator {
    /// A fresh allocator (`n_hit = n_nohit = 1`). With `bl_enabled = false` (Lambert-only
    /// materials) it always chooses TB.
    pub fn new(bl_enabled: bool) -> AdaptiveAllocator {
        AdaptiveAllocator {
            n_hit: 1,
            n_nohit: 1,
            lambda: LAMBDA,
            bl_enabled,
        }
    }

    /// The probability of choosing BL for the next sample.
    pub fn p_bl(&self) -> f32 {
        if !self.bl_enabled {
            return 0.0;
        }
        let nohit = self.n_nohit as f32;
        nohit / (nohit + self.lambda * self.n_hit as f32)
    }

    /// Chooses the technique of the next sample from `u` in [0, 1) and returns it with `u`
    /// warped back into [0, 1) (`u/p` or `(u − p)/(1 − p)`) and the probability `p` of BL.
    pub fn choose(&self, u: f32) -> (Technique, f32, f32) {
        let p = self.p_bl();
        let u = crate::sample::sanitize(u);
        if u < p {
            (
                Technique::Bl,
                (u / p).min(crate::sample::ONE_MINUS_EPSILON),
                p,
            )
        } else {
            let rest = 1.0 - p;
            (
                Technique::Tb,
                ((u - p) / rest).clamp(0.0, crate::sample::ONE_MINUS_EPSILON),
                p,
            )
        }
    }

    /// Records whether a TB sample's ray hit a light.
    pub fn record_tb(&mut self, hit: bool) {
        if hit {
            self.n_hit = self.n_hit.saturating_add(1);
        } else {
            self.n_nohit = self.n_nohit.saturating_add(1);
        }
    }
}

/// MIS weights of the combined estimator (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CombinedWeights {
    /// TL samples (clusters sampled once each count as one technique with one sample).
    pub n_tl: f32,
    /// BRDF-aware samples N.
    pub n_mixture: f32,
    /// The fixed BL probability used in the weights.
    pub p_ref: f32,
    /// Use the power heuristic instead of the balance heuristic.
    pub power: bool,
}

impl CombinedWeights {
    /// Reference density of the BRDF-aware mixture.
    fn q_ref(&self, pdf_bl: f32, pdf_tb: f32) -> f32 {
        self.p_ref * pdf_bl + (1.0 - self.p_ref) * pdf_tb
    }

    /// `(w_TL, w_M)` for a point whose densities under TL, BL and TB are given; they sum to 1
    /// (both 0 if every density is 0).
    pub fn weights(&self, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> (f32, f32) {
        let q = self.q_ref(pdf_bl, pdf_tb);
        let others = [(self.n_mixture, q)];
        let w_tl = if self.power {
            power(self.n_tl, pdf_tl, &others)
        } else {
            balance(self.n_tl, pdf_tl, &others)
        };
        let any = pdf_tl > 0.0 || q > 0.0;
        if any {
            (w_tl, 1.0 - w_tl)
        } else {
            (0.0, 0.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diffuse_budget_is_one_brdf_sample() {
        assert_eq!(brdf_budget(true, 0.9, 50), 1);
        assert_eq!(brdf_budget(false, 0.9, 50), 45);
    }

    #[test]
    fn budget() {
        assert_eq!(sample_budget(0.0, 50), 0);
        assert_eq!(sample_budget(f32::NAN, 50), 0);
        assert_eq!(sample_budget(1e-9, 50), 1);
        assert_eq!(sample_budget(0.5, 50), 25);
        assert_eq!(sample_budget(0.51, 50), 26);
        assert_eq!(sample_budget(3.0, 50), 50);
    }

    #[test]
    fn allocator_follows_algorithm_1() {
        let mut a = AdaptiveAllocator::new(true);
        assert!((a.p_bl() - 1.0 / 11.0).abs() < 1e-7);
        a.record_tb(false);
        assert!((a.p_bl() - 2.0 / 12.0).abs() < 1e-7);
        a.record_tb(true);
        assert!((a.p_bl() - 2.0 / 22.0).abs() < 1e-7);
        let (t, u, p) = a.choose(0.5 * a.p_bl());
        assert_eq!(t, Technique::Bl);
        assert!((u - 0.5).abs() < 1e-6 && p > 0.0);
        let (t, u, _) = a.choose(a.p_bl() + 0.5 * (1.0 - a.p_bl()));
        assert_eq!(t, Technique::Tb);
        assert!((u - 0.5).abs() < 1e-5);
        let lambert = AdaptiveAllocator::new(false);
        assert_eq!(lambert.choose(0.0).0, Technique::Tb);
    }

    #[test]
    fn weights_sum_to_one() {
        let w = CombinedWeights {
            n_tl: 1.0,
            n_mixture: 7.0,
            p_ref: 0.5,
            power: false,
        };
        for &(a, b, c) in &[
            (1.0, 2.0, 3.0),
            (0.0, 1.0, 0.0),
            (5.0, 0.0, 0.0),
            (1e-20, 1e20, 0.0),
        ] {
            let (x, y) = w.weights(a, b, c);
            assert!((x + y - 1.0).abs() < 1e-6, "{a} {b} {c}: {x} {y}");
            let (x, y) = CombinedWeights { power: true, ..w }.weights(a, b, c);
            assert!((x + y - 1.0).abs() < 1e-6);
        }
        assert_eq!(w.weights(0.0, 0.0, 0.0), (0.0, 0.0));
        assert!((balance(1.0, 2.0, &[(1.0, 2.0)]) - 0.5).abs() < 1e-7);
        assert!((power(1.0, 3.0, &[(1.0, 1.0)]) - 0.9).abs() < 1e-6);
    }
}
