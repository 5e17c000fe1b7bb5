//! Combining techniques: MIS weights and the adaptive sample allocation of Liu et al. 2019
//! (section 4.2, Algorithm 1; docs/formulas.md, section 9).
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
//! Two choices of weights are provided. [`CombinedWeights`] are fixed functions of y: the
//! balance (or power) heuristic between TL with its sample count and the BRDF-aware mixture
//! with N samples at a fixed reference probability `p_ref`:
//! `w_TL = n_TL·pdf_TL / (n_TL·pdf_TL + N·q_ref)`, `q_ref = p_ref·pdf_BL + (1 − p_ref)·pdf_TB`.
//! They are exact for equal allocation (`p_j = p_ref`). Under the adaptive allocation p_j
//! wanders from 1/11 towards 1, and a sample drawn where `q_j ≪ q_ref` is divided by the small
//! `q_j` but weighted for `q_ref` (docs/measurements.md has what that costs).
//! [`SequentialWeights`] remove that mismatch: sample j is weighted against its own `q_j`
//! (known before it is drawn), and TL gets the mean of the per-sample TL weights; the proof
//! extends the one above (TL's samples are independent of the allocator, so their weight may
//! use every p_j) and is in the type's documentation.
//!
//! Within the mixture no further weight is needed: the one-sample density `q_j` already is
//! the balance heuristic between BL and TB. For Lambert-only materials BL reduces to TL
//! (Liu et al., end of section 4.2), so only TL and TB can be combined: `p = 0`, always TB
//! (with as many BRDF samples as the host wants: [`brdf_budget`] gives none, since the Lambert
//! share of IB(x) asks for none). [`technique_pdfs`] gives a light point's density under each
//! technique.
//!
//! The balance heuristic hands a technique that is nearly perfect alone (TL split on a sphere
//! light a few radii away, sampled uniformly in its cap) a share of its own integrand that a
//! poor technique then estimates; the power heuristic (β = 2) keeps that share small.
//!
//! # Bad densities and counts
//!
//! Every weight here is in [0, 1] and never NaN, whatever it is given, by one rule: a density,
//! sample count or probability that is negative or NaN counts as 0 (a probability above 1 as
//! 1); a technique whose count or density is +∞ (and the other positive) takes the whole
//! weight, shared equally with the other such techniques (the rest get 0); finite terms whose
//! f32 sum overflows are summed in f64. For finite non-negative inputs whose sum does not
//! overflow the weights are the plain formulas, bit for bit.

use crate::cut::LightCut;
#[cfg(any(test, feature = "internals"))]
use crate::importance::{Importance, TlImportance};
use crate::math;
#[cfg(any(test, feature = "internals"))]
use crate::tree::LightTree;

/// λ of Algorithm 1.
pub(crate) const LAMBDA: f32 = 10.0;
/// Nmax of the sample budget.
pub const N_MAX: u32 = 50;

/// The number of BRDF-aware samples at a shading point: `ceil(n_max · ib)` with `ib = IB(x)`
/// (the largest BRDF integral over the cut), at least 1; 0 for a non-positive or NaN `ib`.
/// `n_max` is clamped to 1..=[`MAX_BUDGET`].
#[must_use]
pub fn sample_budget(ib: f32, n_max: u32) -> u32 {
    if ib.is_nan() || ib <= 0.0 {
        return 0;
    }
    let n_max = n_max.clamp(1, MAX_BUDGET);
    let n = math::ceil(ib.min(1.0) * n_max as f32);
    (n as u32).clamp(1, n_max)
}

/// The number of BRDF-aware samples at a shading point from its BRDF-oriented cut:
/// [`sample_budget`] of the glossy lobe's IB(x), `ceil(n_max · max_C ks∫_C f_GGX cos)`
/// ([`LightCut::max_glossy_score`]); 0 for Lambert materials and empty cuts.
///
/// Liu et al.'s IB(x) is the largest BRDF cap integral over the cut. For a constant (Lambert)
/// BRDF, BL is TL and the budget buys nothing TL does not already give; for plastic, a large
/// light close by has a large Lambert integral although the glossy lobe sees little of it, so
/// only the glossy part asks for BRDF-aware samples. For pure GGX this is Liu et al.'s budget.
#[must_use]
pub fn brdf_budget(cut: &LightCut, n_max: u32) -> u32 {
    sample_budget(cut.max_glossy_score(), n_max)
}

/// The densities (solid angle) of one light point under the three techniques.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg(any(test, feature = "internals"))]
pub struct TechniquePdfs {
    /// TL split sampling: the light's pmf within its cluster × the point's pdf.
    pub tl: f32,
    /// BL: the light's pmf through the BRDF-oriented cut × the point's pdf.
    pub bl: f32,
    /// TB: the BRDF sampling pdf of the direction.
    pub tb: f32,
}

/// The densities of a point on `light` under every technique, for MIS: `point_pdf` is the
/// solid-angle pdf of the point on the light (`light_point::pdf_point`), `brdf_pdf` the
/// BRDF's pdf of the direction towards it. `bl` is `None` when BL is not used (diffuse-only
/// materials). The same function serves light samples and BRDF rays that hit a light.
#[must_use]
#[cfg(any(test, feature = "internals"))]
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
/// `others` (each `(n, pdf)`): `n_a·pdf_a / Σ n·pdf`, in [0, 1]. 0 when every density is 0;
/// negative, NaN and infinite inputs as the module documentation says.
#[must_use]
#[cfg(any(test, feature = "internals"))]
pub fn balance(n_a: f32, pdf_a: f32, others: &[(f32, f32)]) -> f32 {
    heuristic(n_a, pdf_a, others, false)
}

/// Power-heuristic (β = 2) weight of technique `a` among `others`: `(n_a·pdf_a)² / Σ (n·pdf)²`,
/// in [0, 1]. 0 when every density is 0; negative, NaN and infinite inputs as the module
/// documentation says.
#[must_use]
pub fn power(n_a: f32, pdf_a: f32, others: &[(f32, f32)]) -> f32 {
    heuristic(n_a, pdf_a, others, true)
}

/// The MIS heuristic of the combined estimators (Veach 1997, section 9.2): how the weight of a
/// technique grows with its density against the others'.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Heuristic {
    /// `n_a·pdf_a / Σ n·pdf` (`balance`).
    Balance,
    /// `(n_a·pdf_a)² / Σ (n·pdf)²`, β = 2 (`power`); the default.
    #[default]
    Power,
}

impl Heuristic {
    /// Both heuristics.
    pub const ALL: [Heuristic; 2] = [Heuristic::Balance, Heuristic::Power];

    /// The heuristic's name (`balance`, `power`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Heuristic::Balance => "balance",
            Heuristic::Power => "power",
        }
    }

    /// The weight of technique `a` among `others` by this heuristic (`balance` or
    /// `power`).
    #[inline]
    #[must_use]
    pub fn weight(self, n_a: f32, pdf_a: f32, others: &[(f32, f32)]) -> f32 {
        heuristic(n_a, pdf_a, others, self == Heuristic::Power)
    }
}

/// A density, count or probability as the weights count it: negative and NaN are 0.
#[inline(always)]
fn non_negative(x: f32) -> f32 {
    if x > 0.0 {
        x
    } else {
        0.0
    }
}

/// `n·pdf` of one technique with [`non_negative`] inputs (0 when either is 0, so ∞·0 is 0).
#[inline(always)]
fn term(n: f32, pdf: f32) -> f32 {
    let (n, pdf) = (non_negative(n), non_negative(pdf));
    if n > 0.0 && pdf > 0.0 {
        n * pdf
    } else {
        0.0
    }
}

/// The balance (`square` false) or power heuristic by the rule of the module documentation.
fn heuristic(n_a: f32, pdf_a: f32, others: &[(f32, f32)], square: bool) -> f32 {
    let a = term(n_a, pdf_a);
    let sum = if square {
        a * a
            + others
                .iter()
                .map(|&(n, p)| term(n, p) * term(n, p))
                .sum::<f32>()
    } else {
        a + others.iter().map(|&(n, p)| term(n, p)).sum::<f32>()
    };
    if sum > 0.0 && sum < f32::INFINITY {
        return if square { a * a / sum } else { a / sum };
    }
    if sum.is_nan() || sum <= 0.0 {
        return 0.0;
    }
    // The sum overflowed: an infinite term, or large finite ones.
    let infinite = |n: f32, p: f32| {
        let (n, p) = (non_negative(n), non_negative(p));
        n > 0.0 && p > 0.0 && (n == f32::INFINITY || p == f32::INFINITY)
    };
    let count =
        usize::from(infinite(n_a, pdf_a)) + others.iter().filter(|&&(n, p)| infinite(n, p)).count();
    if count > 0 {
        return if infinite(n_a, pdf_a) {
            1.0 / count as f32
        } else {
            0.0
        };
    }
    // Products of finite f32 values, and their squares, are finite in f64.
    let t64 = |n: f32, p: f32| {
        let (n, p) = (non_negative(n), non_negative(p));
        let t = if n > 0.0 && p > 0.0 {
            f64::from(n) * f64::from(p)
        } else {
            0.0
        };
        if square {
            t * t
        } else {
            t
        }
    };
    let a = t64(n_a, pdf_a);
    let sum = a + others.iter().map(|&(n, p)| t64(n, p)).sum::<f64>();
    (a / sum).clamp(0.0, 1.0) as f32
}

/// `p·x + (1 − p)·y` for a probability `p` (clamped into [0, 1], NaN as 0) and densities
/// `x`, `y` ([`non_negative`]); a term whose probability is 0 is 0 even for an infinite
/// density.
#[inline(always)]
fn mixture(p: f32, x: f32, y: f32) -> f32 {
    let p = sanitize_probability(p);
    let bx = if p > 0.0 { p * non_negative(x) } else { 0.0 };
    let by = if p < 1.0 {
        (1.0 - p) * non_negative(y)
    } else {
        0.0
    };
    bx + by
}

/// Which BRDF-aware technique a sample uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mixture {
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
    #[must_use]
    pub fn new(bl_enabled: bool) -> AdaptiveAllocator {
        AdaptiveAllocator {
            n_hit: 1,
            n_nohit: 1,
            lambda: LAMBDA,
            bl_enabled,
        }
    }

    /// The probability of choosing BL for the next sample.
    #[must_use]
    pub fn p_bl(&self) -> f32 {
        if !self.bl_enabled {
            return 0.0;
        }
        let nohit = self.n_nohit as f32;
        nohit / (nohit + self.lambda * self.n_hit as f32)
    }

    /// Chooses the technique of the next sample from `u` in [0, 1) and returns it with `u`
    /// warped back into [0, 1) (`u/p` or `(u − p)/(1 − p)`) and the probability `p` of BL.
    #[must_use]
    pub fn choose(&self, u: f32) -> (Mixture, f32, f32) {
        let p = self.p_bl();
        let u = crate::sample::sanitize(u);
        if u < p {
            (
                Mixture::Bl,
                (u / p).min(crate::sample::ONE_MINUS_EPSILON),
                p,
            )
        } else {
            let rest = 1.0 - p;
            (
                Mixture::Tb,
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
    /// The heuristic between TL and the BRDF-aware mixture.
    pub heuristic: Heuristic,
}

impl CombinedWeights {
    /// Reference density of the BRDF-aware mixture.
    fn q_ref(&self, pdf_bl: f32, pdf_tb: f32) -> f32 {
        mixture(self.p_ref, pdf_bl, pdf_tb)
    }

    /// `(w_TL, w_M)` for a point whose densities under TL, BL and TB are given: each in
    /// [0, 1], summing to 1 (both 0 if every density is 0).
    /// Negative, NaN and infinite densities, counts and `p_ref` as the module documentation
    /// says.
    #[must_use]
    pub fn weights(&self, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> (f32, f32) {
        let q = self.q_ref(pdf_bl, pdf_tb);
        let others = [(self.n_mixture, q)];
        let w_tl = self.heuristic.weight(self.n_tl, pdf_tl, &others);
        let any = non_negative(pdf_tl) > 0.0 || q > 0.0;
        if any {
            (w_tl, 1.0 - w_tl)
        } else {
            (0.0, 0.0)
        }
    }
}

/// A sample's term `g · num / den` in the form an estimator evaluates it, with the density
/// `pdf` it was drawn with: the MIS weight is `num · pdf / den`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Factors {
    /// Multiplies the sample's value.
    pub num: f32,
    /// Divides it.
    pub den: f32,
    /// The sampling density.
    pub pdf: f32,
}

/// The most BRDF-aware samples per shading point `SequentialWeights` can record
/// (`sample_budget` never asks for more).
pub const MAX_BUDGET: u32 = 64;

/// MIS weights for TL plus a sequence of N BRDF-aware samples whose BL probability `p_j`
/// changes from sample to sample (the adaptive allocation), without the variance a fixed
/// reference probability costs.
///
/// Sample j is drawn from `q_j = p_j·pdf_BL + (1 − p_j)·pdf_TB`, with `p_j` known before it is
/// drawn. It gets the weight `W_j(y) = (1 − r_j(y)) / N`, where `r_j` is the balance (or power)
/// heuristic weight of TL against N samples of `q_j` — the weight TL would get if every
/// sample used sample j's mixture — so it contributes `f·W_j/q_j`, which is
/// `f / (n_TL·pdf_TL + N·q_j)` for the balance heuristic: never more than TL's own estimate,
/// however small `p_j` or `1 − p_j` is. TL's samples get what is left,
/// `w_TL(y) = 1 − Σ_j W_j(y) = (1/N) Σ_j r_j(y)`, the mean of the per-sample weights; they are
/// independent of the allocator, so TL may be sampled first and weighted after the last
/// BRDF-aware sample ([`SequentialWeights::tl_term`]).
///
/// Unbiased: `W_j` and `q_j` are fixed by the samples before j, so
/// `E[f(X_j)·W_j(X_j)/q_j(X_j) | F_{j−1}] = ∫ f·W_j`; TL's samples, independent of the
/// mixture, give `∫ f·(1 − Σ_j W_j)` given the whole history; the sum is `∫ f`. Coverage:
/// `W_j > 0` only where `q_j > 0`, and where `pdf_TL = 0` every `r_j = 0`, so TL is never asked
/// for a point it cannot sample. A sample that was planned but not taken counts as `W_j = 0`.
/// With a constant `p_j = p` this is the balance (power) heuristic between TL and N samples of
/// the mixture at p, [`CombinedWeights`] with `p_ref = p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SequentialWeights {
    n: u32,
    n_tl: f32,
    heuristic: Heuristic,
    len: u32,
    p: [f32; MAX_BUDGET as usize],
}

impl SequentialWeights {
    /// Weights for `n` BRDF-aware samples (at most [`MAX_BUDGET`]) after TL with `n_tl`
    /// samples per cluster (1 for split sampling), by `heuristic`.
    #[must_use]
    pub fn new(n: u32, n_tl: f32, heuristic: Heuristic) -> SequentialWeights {
        SequentialWeights {
            n: n.min(MAX_BUDGET),
            n_tl: if n_tl > 0.0 && n_tl.is_finite() {
                n_tl
            } else {
                1.0
            },
            heuristic,
            len: 0,
            p: [0.0; MAX_BUDGET as usize],
        }
    }

    /// The planned number of BRDF-aware samples N.
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn budget(&self) -> u32 {
        self.n
    }

    /// Records the BL probability of a sample that was taken (in any order; at most N).
    pub fn record(&mut self, p_bl: f32) {
        if self.len < self.n {
            self.p[self.len as usize] = sanitize_probability(p_bl);
            self.len += 1;
        }
    }

    /// `r`: TL's weight against N samples of a mixture of density `q`.
    #[inline]
    fn tl_share(&self, pdf_tl: f32, q: f32) -> f32 {
        let a = term(self.n_tl, pdf_tl);
        if a <= 0.0 {
            let b = term(self.n as f32, q);
            return if b > 0.0 { 0.0 } else { 1.0 };
        }
        self.heuristic
            .weight(self.n_tl, pdf_tl, &[(self.n as f32, q)])
    }

    /// What a BRDF-aware sample drawn with BL probability `p_bl` contributes: `g·W_j/q_j` for
    /// a point of value `g` (`f·L·cos`) and densities `pdf_tl`, `pdf_bl`, `pdf_tb` (0 if the
    /// sample's mixture density there is 0).
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn mixture_term(&self, g: f32, p_bl: f32, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> f32 {
        if g.is_nan() || g <= 0.0 {
            return 0.0;
        }
        let Some(f) = self.mixture_factors(p_bl, pdf_tl, pdf_bl, pdf_tb) else {
            return 0.0;
        };
        let v = g * f.num / f.den;
        if v.is_finite() {
            v
        } else {
            0.0
        }
    }

    /// [`SequentialWeights::mixture_term`] as `g · num / den`: `num / den = W_j / q_j`, the
    /// sampling density `pdf = N q_j` and the MIS weight `N W_j`. `None` where the sample's
    /// mixture density is 0 (or N = 0).
    #[must_use]
    pub fn mixture_factors(
        &self,
        p_bl: f32,
        pdf_tl: f32,
        pdf_bl: f32,
        pdf_tb: f32,
    ) -> Option<Factors> {
        let p = sanitize_probability(p_bl);
        let q = p * pdf_bl.max(0.0) + (1.0 - p) * pdf_tb.max(0.0);
        if q.is_nan() || q <= 0.0 || self.n == 0 {
            return None;
        }
        let a = self.n_tl * pdf_tl.max(0.0);
        let b = self.n as f32 * q;
        Some(if self.heuristic == Heuristic::Power {
            Factors {
                num: b,
                den: a * a + b * b,
                pdf: b,
            }
        } else {
            Factors {
                num: 1.0,
                den: a + b,
                pdf: b,
            }
        })
    }

    /// TL's weight at a point once the BRDF-aware samples are recorded: `(1/N) Σ_j r_j`, with
    /// `r = 1` for planned samples not taken; 1 when N = 0.
    #[must_use]
    pub fn tl_weight(&self, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> f32 {
        if self.n == 0 {
            return 1.0;
        }
        let mut sum = (self.n - self.len) as f32;
        for &p in &self.p[..self.len as usize] {
            let q = mixture(p, pdf_bl, pdf_tb);
            sum += self.tl_share(pdf_tl, q);
        }
        (sum / self.n as f32).clamp(0.0, 1.0)
    }

    /// What a TL sample of value `g` and densities `pdf_tl` (> 0), `pdf_bl`, `pdf_tb`
    /// contributes: `g·w_TL/pdf_TL` (0 if `pdf_tl` is not positive).
    #[must_use]
    #[cfg(any(test, feature = "internals"))]
    pub fn tl_term(&self, g: f32, pdf_tl: f32, pdf_bl: f32, pdf_tb: f32) -> f32 {
        if pdf_tl.is_nan() || pdf_tl <= 0.0 || g.is_nan() || g <= 0.0 {
            return 0.0;
        }
        let v = g * self.tl_weight(pdf_tl, pdf_bl, pdf_tb) / pdf_tl;
        if v.is_finite() {
            v
        } else {
            0.0
        }
    }
}

/// A probability clamped to [0, 1] (NaN → 0).
fn sanitize_probability(p: f32) -> f32 {
    if p > 0.0 {
        p.min(1.0)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sequential_weights_sum_to_one_and_reduce_to_the_fixed_ones() {
        let cases = [
            (0.7f32, 0.2f32, 0.05f32),
            (2.0, 0.0, 0.3),
            (0.0, 1.5, 0.4),
            (1e-6, 3.0, 2.0),
            (5.0, 1e-7, 0.0),
        ];
        let ps = [1.0 / 11.0, 0.5, 0.9, 0.0, 1.0, 2.0 / 12.0, 0.3];
        for heuristic in Heuristic::ALL {
            for &(tl, bl, tb) in &cases {
                let n = ps.len() as u32;
                let mut sw = SequentialWeights::new(n, 1.0, heuristic);
                let mut mix = 0.0f32;
                for &p in &ps {
                    sw.record(p);
                    let q = p * bl + (1.0 - p) * tb;
                    // W_j = term(g = 1) · q_j.
                    mix += sw.mixture_term(1.0, p, tl, bl, tb) * q;
                }
                let w_tl = sw.tl_weight(tl, bl, tb);
                if tl > 0.0 || bl > 0.0 || tb > 0.0 {
                    assert!(
                        (w_tl + mix - 1.0).abs() < 1e-5,
                        "{tl} {bl} {tb}: {w_tl} + {mix}"
                    );
                }
                // A constant p: the fixed weights at p_ref = p.
                for &p in &ps[..3] {
                    let mut sw = SequentialWeights::new(4, 1.0, heuristic);
                    (0..4).for_each(|_| sw.record(p));
                    let fixed = CombinedWeights {
                        n_tl: 1.0,
                        n_mixture: 4.0,
                        p_ref: p,
                        heuristic,
                    };
                    let (w, _) = fixed.weights(tl, bl, tb);
                    if tl > 0.0 {
                        assert!((sw.tl_weight(tl, bl, tb) - w).abs() < 1e-5);
                    }
                    let q = p * bl + (1.0 - p) * tb;
                    if q > 0.0 {
                        // g·w_M/(N q) in f64 (f32's 1 − w_TL cancels where TL dominates).
                        let (a, b) = (f64::from(tl), 4.0 * f64::from(q));
                        let w_m = if heuristic == Heuristic::Power {
                            b * b / (a * a + b * b)
                        } else {
                            b / (a + b)
                        };
                        let want = (0.8 * w_m / b) as f32;
                        let got = sw.mixture_term(0.8, p, tl, bl, tb);
                        assert!(
                            (got - want).abs() <= 1e-5 * want.max(1.0),
                            "{got} vs {want}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn sequential_weights_edges() {
        // No samples: TL takes everything.
        let sw = SequentialWeights::new(0, 1.0, Heuristic::Balance);
        assert_eq!(sw.tl_weight(0.5, 1.0, 1.0), 1.0);
        assert_eq!(sw.mixture_term(1.0, 0.5, 0.5, 1.0, 1.0), 0.0);
        // Planned but not taken: those samples weigh nothing, TL keeps their share.
        let mut sw = SequentialWeights::new(4, 1.0, Heuristic::Balance);
        sw.record(0.5);
        let w = sw.tl_weight(1.0, 1.0, 1.0);
        assert!((w - (3.0 + 1.0 / 5.0) / 4.0).abs() < 1e-6, "{w}");
        // Where TL cannot sample, TL's weight is 0 once a sample could reach the point.
        assert_eq!(sw.tl_weight(0.0, 1.0, 1.0), 0.75);
        let mut full = sw;
        (0..3).for_each(|_| full.record(0.5));
        assert_eq!(full.tl_weight(0.0, 1.0, 1.0), 0.0);
        // Bad inputs give finite numbers, never NaN.
        let mut sw = SequentialWeights::new(1000, f32::NAN, Heuristic::Power);
        assert_eq!(sw.budget(), MAX_BUDGET);
        sw.record(f32::NAN);
        for v in [
            sw.tl_weight(f32::NAN, f32::INFINITY, -1.0),
            sw.mixture_term(f32::NAN, f32::NAN, 1.0, 1.0, 1.0),
            sw.mixture_term(1.0, 0.5, f32::INFINITY, 1.0, 1.0),
            sw.tl_term(1.0, f32::MIN_POSITIVE, 0.0, f32::MAX),
        ] {
            assert!(v.is_finite() && v >= 0.0, "{v}");
        }
        assert_eq!(sample_budget(1.0, 1000), MAX_BUDGET);
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
        assert_eq!(t, Mixture::Bl);
        assert!((u - 0.5).abs() < 1e-6 && p > 0.0);
        let (t, u, _) = a.choose(a.p_bl() + 0.5 * (1.0 - a.p_bl()));
        assert_eq!(t, Mixture::Tb);
        assert!((u - 0.5).abs() < 1e-5);
        let lambert = AdaptiveAllocator::new(false);
        assert_eq!(lambert.choose(0.0).0, Mixture::Tb);
    }

    #[test]
    fn weights_sum_to_one() {
        let w = CombinedWeights {
            n_tl: 1.0,
            n_mixture: 7.0,
            p_ref: 0.5,
            heuristic: Heuristic::Balance,
        };
        for &(a, b, c) in &[
            (1.0, 2.0, 3.0),
            (0.0, 1.0, 0.0),
            (5.0, 0.0, 0.0),
            (1e-20, 1e20, 0.0),
        ] {
            let (x, y) = w.weights(a, b, c);
            assert!((x + y - 1.0).abs() < 1e-6, "{a} {b} {c}: {x} {y}");
            let (x, y) = CombinedWeights {
                heuristic: Heuristic::Power,
                ..w
            }
            .weights(a, b, c);
            assert!((x + y - 1.0).abs() < 1e-6);
        }
        assert_eq!(w.weights(0.0, 0.0, 0.0), (0.0, 0.0));
        assert!((balance(1.0, 2.0, &[(1.0, 2.0)]) - 0.5).abs() < 1e-7);
        assert!((power(1.0, 3.0, &[(1.0, 1.0)]) - 0.9).abs() < 1e-6);
    }
}
