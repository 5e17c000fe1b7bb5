//! The choice at the root among the node tree and the lights at infinity ([`RootChoice`]):
//! what [`LightTree::sample`](crate::LightTree::sample) and the light cuts
//! ([`crate::cut`]) choose with before a descent (docs/formulas.md, section 16). It lives
//! here, below the cuts, so that both can use it; `crate::infinite` describes the choice.

use super::{MIN_PMF, ONE_MINUS_EPSILON};
use crate::limits::MAX_INFINITE_LIGHTS;

/// The choice at the root among the node tree (choice 0) and the lights at infinity (choice
/// `1 + i` for entry `i`), from their weights at one shading point (see the module
/// documentation). No allocation.
#[derive(Clone, Copy, Debug)]
pub struct RootChoice {
    w: [f64; MAX_INFINITE_LIGHTS + 1],
    n: usize,
    sum: f64,
}

impl RootChoice {
    /// The choice among `tree` (the node tree's weight) and the weights of the lights at
    /// infinity (at most [`MAX_INFINITE_LIGHTS`]; more are ignored).
    pub fn new(tree: f64, infinite: impl IntoIterator<Item = f32>) -> RootChoice {
        let clean = |x: f64| if x > 0.0 && x.is_finite() { x } else { 0.0 };
        let mut w = [0.0f64; MAX_INFINITE_LIGHTS + 1];
        w[0] = clean(tree);
        let mut n = 1;
        for x in infinite.into_iter().take(MAX_INFINITE_LIGHTS) {
            w[n] = clean(f64::from(x));
            n += 1;
        }
        // Drop the choices whose probability would be below MIN_PMF, until none is (the
        // largest never is: its share is at least 1 / (MAX_INFINITE_LIGHTS + 1)).
        let mut sum: f64 = w[..n].iter().sum();
        loop {
            let mut dropped = false;
            for x in w[..n].iter_mut() {
                if *x > 0.0 && ((*x / sum) as f32) < MIN_PMF {
                    *x = 0.0;
                    dropped = true;
                }
            }
            if !dropped {
                break;
            }
            sum = w[..n].iter().sum();
        }
        RootChoice { w, n, sum }
    }

    /// Number of choices (1 + the lights at infinity).
    #[inline]
    #[must_use]
    pub fn len(&self) -> usize {
        self.n
    }

    /// Never empty: the node tree is choice 0.
    #[inline]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The probability of choice `k` (0 outside, or when nothing can be chosen).
    #[inline]
    #[must_use]
    pub fn probability(&self, k: usize) -> f32 {
        if k >= self.n || self.sum <= 0.0 {
            return 0.0;
        }
        (self.w[k] / self.sum) as f32
    }

    /// The choice for the uniform number `u` (clamped into [0, 1); NaN counts as 0): `(k,
    /// its probability, u rescaled into [0, 1))`; `None` when every weight is 0. A choice of
    /// weight 0 is never made.
    #[must_use]
    pub fn pick(&self, u: f32) -> Option<(usize, f32, f32)> {
        if self.sum <= 0.0 {
            return None;
        }
        let u = if u >= 0.0 {
            u.min(ONE_MINUS_EPSILON)
        } else {
            0.0
        };
        let t = f64::from(u) * self.sum;
        let last = (0..self.n).rev().find(|&k| self.w[k] > 0.0)?;
        let (mut k, mut before) = (last, 0.0);
        for (j, &w) in self.w[..self.n].iter().enumerate() {
            if w <= 0.0 {
                continue;
            }
            if t < before + w || j == last {
                k = j;
                break;
            }
            before += w;
        }
        let rest = ((t - before) / self.w[k]) as f32;
        Some((k, self.probability(k), rest.clamp(0.0, ONE_MINUS_EPSILON)))
    }
}

/// The floor of a descent of the node tree chosen at the root with probability `p`: the
/// smallest descent pmf whose product with `p` is still at least [`MIN_PMF`] (rounded up).
#[inline]
pub(crate) fn tree_floor(p: f32) -> f32 {
    (MIN_PMF / p * (1.0 + 4.0 * f32::EPSILON)).clamp(MIN_PMF, 1.0)
}

/// `p · pmf` if it is at least [`MIN_PMF`](super::MIN_PMF), else 0: the pmf of a light of the
/// node tree chosen at the root with probability `p` (a cut's or a sampler's root choice).
#[inline]
pub(crate) fn root_product(p: f32, pmf: f32) -> f32 {
    let q = p * pmf;
    if q >= super::MIN_PMF {
        q
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pick has the probability `probability` reports, its interval is the weight's
    /// share, the rescaled number stays in [0, 1), and vanishing weights are dropped.
    #[test]
    fn root_choice_picks_by_weight() {
        let c = RootChoice::new(2.0, [1.0, 0.0, 1.0]);
        assert_eq!(c.len(), 4);
        let p: f32 = (0..4).map(|k| c.probability(k)).sum();
        assert!((p - 1.0).abs() < 1e-6);
        assert_eq!(c.pick(0.0).map(|x| x.0), Some(0));
        assert_eq!(c.pick(0.49).map(|x| x.0), Some(0));
        assert_eq!(c.pick(0.5).map(|x| x.0), Some(1));
        assert_eq!(c.pick(0.8).map(|x| x.0), Some(3));
        assert_eq!(c.pick(ONE_MINUS_EPSILON).map(|x| x.0), Some(3));
        let (k, p, r) = c.pick(0.625).unwrap();
        assert_eq!((k, p), (1, 0.25));
        assert!((r - 0.5).abs() < 1e-6);
        for i in 0..1000 {
            let u = i as f32 / 1000.0;
            let (k, p, r) = c.pick(u).unwrap();
            assert!(p > 0.0 && p == c.probability(k) && (0.0..1.0).contains(&r));
        }
        // Nothing to choose.
        assert!(RootChoice::new(0.0, [0.0, f32::NAN, -1.0])
            .pick(0.3)
            .is_none());
        // A share below MIN_PMF is dropped.
        let c = RootChoice::new(1.0, [1e-40, f32::INFINITY]);
        assert_eq!(c.probability(1), 0.0);
        assert_eq!(c.probability(2), 0.0);
        assert_eq!(c.probability(0), 1.0);
    }

    #[test]
    fn tree_floor_keeps_the_product_above_min_pmf() {
        for p in [1.0f32, 0.5, 1e-3, 1e-20, 3.7e-38, MIN_PMF] {
            let f = tree_floor(p);
            assert!((MIN_PMF..=1.0).contains(&f));
            assert!(p * f >= MIN_PMF, "{p}: {f}");
        }
    }
}
