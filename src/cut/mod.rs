//! Light cuts: a set of disjoint clusters (tree slots, and the lights at infinity) that
//! together hold every light that can contribute at a shading point. Fixed capacity
//! ([`CUT_CAPACITY`]), no allocation: a cut is caller-owned per-thread state, rebuilt per
//! shading point.
//!
//! Of [`LightTree`]'s API this file holds [`LightTree::sample_cluster`]: a light sampled under
//! one cluster, with its pmf relative to the cluster (what the cuts' sampling is built on); the
//! rest of the tree's API is in [`crate::tree`], `crate::build`, `crate::sample` and
//! `crate::trace`.
//!
//! Two ways to build one:
//! - **Split sampling** (Conty & Kulla, "Predicted variance"; docs/formulas.md, section 5):
//!   [`LightCut::build_split`] opens a cluster while the variance its single sample would add is
//!   large, and always when the shading point is inside its bounding sphere. Each cluster of the
//!   cut is then sampled once ([`LightCut::sample_in`]) and the estimator sums the clusters'
//!   estimates.
//! - **BRDF-oriented light cuts** (Liu et al. 2019, section 4.1; docs/formulas.md, section 6),
//!   built by the BRDF-oriented importance: a cluster is split when its cap is wide (x inside
//!   its sphere, or close to it: [`BlCutOptions::split_sin`]) or when the BRDF integral over
//!   its cap exceeds δ; [`LightCut::sample`] then picks one cluster by importance and descends
//!   in it.
//!
//! Many queries at once: [`LightCut::sample_each`] (one light in each cluster, what split
//! sampling needs), [`LightCut::pmf_in_each`] and [`LightCut::pmf_each`] return exactly what
//! the one-at-a-time calls return, with the tree walks interleaved four at a time so that
//! their dependent steps overlap.
//!
//! **Lights at infinity.** The distant and environment lights of the tree
//! ([`LightTree::infinite_lights`]) are not in the node tree; a cut holds each that can
//! contribute at its point (importance > 0) as a cluster of its own, after the node tree's
//! clusters ([`LightCut::tree_clusters`]; [`Cluster::infinite_entry`] names its entry), so a
//! cut is self-contained: [`LightCut::sample_in`] and [`LightCut::sample_each`] give a light at
//! infinity with pmf 1 in its cluster (what the estimators' split sampling takes), and
//! [`LightCut::sample`] first makes the estimators' root choice ([`LightCut::root_choice`])
//! between the node tree's clusters and the lights at infinity. `max_size` bounds the node
//! tree's clusters only: a cut holds at most `max_size` plus the number of lights at infinity,
//! at most [`CUT_CAPACITY`].
//!
//! A cut is built breadth-first from the root: a slot that wants splitting is opened unless
//! that would overflow `max_size`, in which case it stays a cluster. Clusters whose weight is 0
//! are left out: by conservativeness no light under them can contribute.
//!
//! Coverage: a cut holds every light that can contribute at its point, but not every light
//! with a TL pmf > 0 there. Below a slot of positive importance whose child's four slots all
//! have importance 0, the tree's descent falls back to the child's energies (so that the pmfs
//! still sum to 1), which gives those lights a TL pmf > 0; a cut that opens such a slot
//! leaves its zero-weight children out. Such lights cannot contribute (they are behind the
//! surface or outside their emission cones). A host combining TL and split pmfs (in MIS
//! weights, say) takes [`LightCut::pmf_in`]'s `None` as a density of 0 for those lights, as
//! the estimators do.
//!
//! Vanishing probabilities follow the tree's rule (see `crate::sample`): every pmf these
//! functions report for a returned light is at least [`MIN_PMF`]. Within a cluster
//! ([`LightCut::sample_in`]) the rule applies to the pmf relative to the cluster. For
//! [`LightCut::sample`] it applies to the whole product: a cluster whose share
//! `weight / total` is below `2 · MIN_PMF` is never chosen (the others share its
//! probability), and inside a cluster of share `q` a light is dropped when its pmf relative to
//! the cluster would be below `2 · MIN_PMF / q`. [`LightCut::pmf`] applies the same rule, so it
//! is exactly what `sample` reports.
//!
//! The variance heuristic: for a cluster of N lights with energy mean E\[e\] and variance V\[e\],
//! distances a = max(d − r, ε) and b = d + r, the inverse-square factor g has
//! E\[g\] = 1/(ab) and V\[g\] = (b³ − a³)/(3(b − a)a³b³) − 1/(a²b²) = (b − a)²/(3a³b³), the form used
//! here (no cancellation). The relative variance of one light's contribution is
//! `ρ = (1 + V[e]/E[e]²)(1 + (b − a)²/(3ab)) − 1`, and the cluster is split when
//! `ρ · (I_C / I_total)² > threshold`, with I the TL importance: its share of the estimate,
//! squared, scales its relative variance into a share of the total's.

use crate::importance::{BlImportance, Importance, TlImportance};
use crate::limits::MAX_INFINITE_LIGHTS;
use crate::math;
use crate::sample::{RootChoice, MIN_PMF};
use crate::tree::{count4, Child, LightTree, Node4};
use wide::f32x4;

/// `x > 0` (false for NaN).
#[inline(always)]
fn positive(x: f32) -> bool {
    x > 0.0
}

/// Fewest clusters a cut may be limited to: the root node's four slots.
pub const MIN_CUT_SIZE: usize = 4;

/// Most clusters of the node tree a cut may be limited to: the largest `max_size`.
pub const MAX_CUT_SIZE: usize = 64;

/// Most clusters a cut holds: [`MAX_CUT_SIZE`] of the node tree and one for each light at
/// infinity (at most [`MAX_INFINITE_LIGHTS`]).
pub const CUT_CAPACITY: usize = MAX_CUT_SIZE + MAX_INFINITE_LIGHTS;

/// Descents [`LightCut::sample_each`] and the pmf walks of a cut keep in flight.
const CUT_LANES: usize = 4;

/// One cluster of a cut: a slot of a node, with its path from the root and its weight; or a
/// light at infinity, a cluster of its own (`node` is [`Cluster::AT_INFINITY`], `slot` its
/// entry in [`LightTree::infinite_lights`], `path` 0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cluster {
    /// The node holding the slot ([`Cluster::AT_INFINITY`] for a light at infinity).
    pub node: u32,
    /// The slot (0..4), or the entry of a light at infinity.
    pub slot: u8,
    /// Path of the slot from the root, encoded as in [`LightTree::path`] (0 for a light at
    /// infinity).
    pub path: u64,
    /// Weight at the shading point (the importance the cut was built with; > 0).
    pub weight: f32,
    /// The split criterion's value for this cluster (BRDF integral or normalised variance; 0
    /// for a light at infinity).
    pub score: f32,
    /// For BRDF-oriented cuts, the glossy lobe's part of the BRDF integral over the cluster's
    /// cap (`ks ∫ f_GGX cos`); 0 for split cuts, Lambert materials and lights at infinity.
    pub glossy_score: f32,
}

impl Cluster {
    /// The `node` of a cluster that is a light at infinity.
    pub const AT_INFINITY: u32 = u32::MAX;

    /// The entry in [`LightTree::infinite_lights`] of a cluster that is a light at infinity
    /// (`None` for a slot of the node tree).
    #[inline]
    #[must_use]
    pub fn infinite_entry(&self) -> Option<usize> {
        (self.node == Cluster::AT_INFINITY).then_some(usize::from(self.slot))
    }
}

/// Options of the split-sampling cut.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitCutOptions {
    /// Split while `ρ · (I_C / I_total)² > threshold`.
    pub threshold: f32,
    /// Most clusters of the node tree (clamped to [`MIN_CUT_SIZE`]..=[`MAX_CUT_SIZE`]); each
    /// light at infinity that can contribute adds one.
    pub max_size: usize,
}

impl Default for SplitCutOptions {
    fn default() -> Self {
        SplitCutOptions {
            threshold: 1e-3,
            max_size: 32,
        }
    }
}

/// Options of the BRDF-oriented light cut (Liu et al. 2019, section 4.1, with the wide-cap
/// rule of docs/formulas.md, section 6). The defaults are the library's: δ = 0.3, caps wider
/// than asin 0.9 split, up to 64 clusters; Liu et al.'s own cut is [`BlCutOptions::PAPER`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlCutOptions {
    /// Split a cluster whose BRDF cap integral SC exceeds δ.
    pub delta: f32,
    /// Most clusters of the node tree (clamped to [`MIN_CUT_SIZE`]..=[`MAX_CUT_SIZE`]); each
    /// light at infinity that can contribute adds one.
    pub max_size: usize,
    /// Split a cluster whose cap is wide: `r ≥ split_sin · d` for a bounding sphere of radius
    /// r at distance d from the shading point (the sine of the cap's half-angle is at least
    /// `split_sin`). 1 splits only the clusters whose sphere holds the point, 0 every cluster
    /// (as far as `max_size` allows); values above 1 and NaN act as 1, negative ones as 0.
    pub split_sin: f32,
}

impl BlCutOptions {
    /// The cut of Liu et al. 2019 (section 4.1): δ = 0.5, split only the clusters whose
    /// sphere holds the point, at most 32 clusters; what `mis-equal` and `full` build by
    /// default ([`crate::direct::Params::mixture_cut`]).
    pub const PAPER: BlCutOptions = BlCutOptions {
        delta: 0.5,
        max_size: 32,
        split_sin: 1.0,
    };
}

impl Default for BlCutOptions {
    fn default() -> Self {
        BlCutOptions {
            delta: 0.3,
            max_size: 64,
            split_sin: 0.9,
        }
    }
}

/// What a cut builder decides for the four slots of a node (slot k in lane or bit k).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SlotDecisions {
    pub weight: [f32; 4],
    pub score: [f32; 4],
    pub glossy_score: [f32; 4],
    /// The slots that want splitting.
    pub split: u32,
}

/// A light cut (see the module documentation).
#[derive(Clone, Copy, Debug)]
pub struct LightCut {
    /// The node tree's clusters (`0..len`), then the lights at infinity's
    /// (`len..len + infinite`).
    clusters: [Cluster; CUT_CAPACITY],
    len: usize,
    infinite: usize,
    /// The choice between the node tree's clusters and the lights at infinity, for a tree
    /// with lights at infinity.
    root: Option<RootChoice>,
    total: f32,
    max_score: f32,
    max_glossy_score: f32,
    /// What [`LightCut::sample`] chooses clusters by: each weight times `scale` (1, or a
    /// power of two below 1 when the weights' sum overflows f32), clusters whose bit is set in
    /// `skipped` left out, and `sample_total` the sum of the others.
    scale: f32,
    skipped: u64,
    sample_total: f32,
    /// `ends[i]`: the sum of the weights [`LightCut::sample`] gives clusters `0..=i` of the
    /// node tree, added in their order (clusters left out add nothing), so `ends[len − 1]` is
    /// `sample_total`.
    ends: [f32; MAX_CUT_SIZE],
    /// The last cluster [`LightCut::sample`] can choose.
    last: usize,
}

impl Default for LightCut {
    fn default() -> Self {
        LightCut::new()
    }
}

impl LightCut {
    /// An empty cut.
    #[must_use]
    pub const fn new() -> LightCut {
        LightCut {
            clusters: [Cluster {
                node: 0,
                slot: 0,
                path: 0,
                weight: 0.0,
                score: 0.0,
                glossy_score: 0.0,
            }; CUT_CAPACITY],
            len: 0,
            infinite: 0,
            root: None,
            total: 0.0,
            max_score: 0.0,
            max_glossy_score: 0.0,
            scale: 1.0,
            skipped: 0,
            sample_total: 0.0,
            ends: [0.0; MAX_CUT_SIZE],
            last: 0,
        }
    }

    /// The clusters: those of the node tree ([`LightCut::tree_clusters`]), then one for each
    /// light at infinity that can contribute.
    #[must_use]
    pub fn clusters(&self) -> &[Cluster] {
        &self.clusters[..self.len + self.infinite]
    }

    /// The clusters of the node tree: the first [`LightCut::clusters`], at most the
    /// `max_size` the cut was built with.
    #[must_use]
    pub fn tree_clusters(&self) -> &[Cluster] {
        &self.clusters[..self.len]
    }

    /// Number of clusters (of the node tree and lights at infinity).
    #[must_use]
    pub fn len(&self) -> usize {
        self.len + self.infinite
    }

    /// Whether no cluster can contribute.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sum of the clusters' weights (the node tree's, in their order, then the lights at
    /// infinity's).
    #[must_use]
    pub fn total_weight(&self) -> f32 {
        self.clusters[self.len..self.len + self.infinite]
            .iter()
            .fold(self.total, |t, c| t + c.weight)
    }

    /// The choice [`LightCut::sample`] makes first between the node tree's clusters (choice
    /// 0, of weight the sum of their weights) and each light at infinity (choice `1 + i` for
    /// entry `i` of [`LightTree::infinite_lights`], of its importance at the point); `None`
    /// for a tree without lights at infinity.
    #[inline]
    #[must_use]
    pub fn root_choice(&self) -> Option<&RootChoice> {
        self.root.as_ref()
    }

    /// Largest score over the node tree's clusters: for BRDF-oriented cuts IB(x) (Liu et al.
    /// 2019, section 4.2), for split cuts the largest normalised variance
    /// `ρ · (I_C / I_total)²` (+∞ where the shading point is inside a cluster that could not
    /// be split).
    #[must_use]
    pub fn max_score(&self) -> f32 {
        self.max_score
    }

    /// The largest glossy part of a cluster's BRDF integral over the cut (see
    /// [`Cluster::glossy_score`]): IB(x) of the glossy lobe alone. 0 for split cuts.
    #[must_use]
    pub fn max_glossy_score(&self) -> f32 {
        self.max_glossy_score
    }

    /// Builds the cut breadth-first. `decide(node, total)` evaluates the four slots of a node;
    /// `total` is `root_total(root)`, the importance of the whole tree at the shading point,
    /// for criteria that normalise by it. At most `max_size` clusters (at least the root's
    /// slots: `max_size` is clamped to [`MIN_CUT_SIZE`]..=[`MAX_CUT_SIZE`]).
    ///
    /// The cut is built in `cut`, whatever it held before (what a cut rebuilt in place per
    /// shading point needs: no copy of its arrays).
    ///
    /// `surely_kept(node)` is a cheap lower bound of what `decide` would keep: a bit set whose
    /// slots `decide(node, _)` certainly gives a positive weight (0 is always correct). Where
    /// even those slots would not fit in the cut, the node is not opened and `decide` is not
    /// called for it: the cut is the same as with `decide` alone.
    pub(crate) fn build_with(
        cut: &mut LightCut,
        tree: &LightTree,
        max_size: usize,
        mut decide: impl FnMut(&Node4, f32) -> SlotDecisions,
        mut surely_kept: impl FnMut(&Node4) -> u32,
        root_total: impl FnOnce(&Node4) -> f32,
    ) {
        cut.clear();
        // The root's (up to four) slots are the coarsest cut there is.
        let max_size = max_size.clamp(MIN_CUT_SIZE, MAX_CUT_SIZE);
        let Some(root) = tree.nodes.first() else {
            return;
        };
        let total = root_total(root);
        if !(positive(total) && total < f32::INFINITY) {
            return;
        }
        // Clusters waiting to be opened, with the node each holds: a ring buffer; accepted +
        // queued ≤ max_size always.
        let mut queue = [(Cluster::default(), 0u32); MAX_CUT_SIZE];
        let (mut head, mut queued) = (0usize, 0usize);
        // What `push` keeps, in locals until the end.
        let mut acc = Accepted::default();
        // The node being opened, its path, and the cluster it replaces (none for the root,
        // whose slots are always taken). One call of `decide` serves every node.
        let (mut index, mut path, mut parent) = (0u32, 1u64, None::<Cluster>);
        loop {
            let node = &tree.nodes[index as usize];
            // The slots that become clusters: positive weight (`positive`, lane by lane), and
            // something in them (an inner node or a light: bit k or k + 4 of the mask).
            let filled = u32::from(node.mask | (node.mask >> 4)) & 0xF;
            // Whether the node's kept slots cannot replace its cluster without passing
            // `max_size`: first from the slots surely kept (`decide` not called), where every
            // filled slot would not fit; else from `decide`'s weights.
            let over = |keep: u32| acc.len + queued + count4(keep) as usize > max_size;
            let skip = parent.is_some() && over(filled) && over(surely_kept(node) & filled);
            let d = if skip {
                None
            } else {
                Some(decide(node, total))
            };
            let keep = d.as_ref().map_or(0, |d| {
                f32x4::new(d.weight).simd_gt(f32x4::ZERO).to_bitmask() & filled
            });
            match (parent, d) {
                (Some(c), _) if skip || over(keep) => acc.push(&mut cut.clusters, c),
                // (Skipped only with a parent: the first arm.)
                (_, None) => {}
                (_, Some(d)) => {
                    // Those to open: inner nodes that want splitting.
                    let open = keep & d.split & u32::from(node.mask);
                    let mut bits = keep;
                    while bits != 0 {
                        let k = bits.trailing_zeros() as usize & 3;
                        bits &= bits - 1;
                        let c = Cluster {
                            node: index,
                            slot: k as u8,
                            path: (path << 2) | k as u64,
                            weight: d.weight[k],
                            score: d.score[k],
                            glossy_score: d.glossy_score[k],
                        };
                        match node.child(k) {
                            Child::Node(child) if open & (1 << k) != 0 => {
                                queue[(head + queued) % MAX_CUT_SIZE] = (c, child);
                                queued += 1;
                            }
                            _ => acc.push(&mut cut.clusters, c),
                        }
                    }
                }
            }
            if queued == 0 {
                break;
            }
            let (c, child) = queue[head];
            head = (head + 1) % MAX_CUT_SIZE;
            queued -= 1;
            (index, path, parent) = (child, c.path, Some(c));
        }
        cut.len = acc.len;
        cut.total = acc.total;
        cut.max_score = acc.max_score;
        cut.max_glossy_score = acc.max_glossy_score;
        cut.finish();
    }

    /// Multiplies each cluster's weight by `factor(cluster)` (the node tree's clusters and the
    /// lights at infinity alike) and makes [`LightCut::sample`], [`LightCut::pmf`] and the
    /// root choice follow the new weights: afterwards the cut is what its build would have
    /// given had the importance returned the scaled weights, its pmfs exact for them. A factor
    /// outside (0, 1] (NaN included) counts as 1, so no cluster that could be chosen before
    /// becomes impossible (though one whose share falls below `2 · MIN_PMF` is left out, as
    /// in any cut). The scores ([`LightCut::max_score`]) are unchanged. `tree` must be the
    /// tree the cut was built on.
    pub fn scale_weights(&mut self, tree: &LightTree, mut factor: impl FnMut(&Cluster) -> f32) {
        let n = self.len + self.infinite;
        let mut total = 0.0f32;
        let mut infinite = [0f32; MAX_INFINITE_LIGHTS];
        for (i, c) in self.clusters[..n].iter_mut().enumerate() {
            let f = factor(c);
            if f > 0.0 && f < 1.0 {
                c.weight *= f;
            }
            if i < self.len {
                total += c.weight;
            } else if let Some(slot) = infinite.get_mut(usize::from(c.slot)) {
                *slot = c.weight;
            }
        }
        self.total = total;
        if self.root.is_some() {
            let m = tree.infinite.len().min(MAX_INFINITE_LIGHTS);
            let w: f64 = self
                .tree_clusters()
                .iter()
                .map(|c| f64::from(c.weight))
                .sum();
            self.root = Some(RootChoice::new(w, infinite[..m].iter().copied()));
        }
        self.finish();
    }

    /// Empties the cut: what [`LightCut::new`] gives, but for the arrays' contents beyond
    /// the (zero) length, which nothing reads.
    fn clear(&mut self) {
        self.len = 0;
        self.infinite = 0;
        self.root = None;
        self.total = 0.0;
        self.max_score = 0.0;
        self.max_glossy_score = 0.0;
        self.scale = 1.0;
        self.skipped = 0;
        self.sample_total = 0.0;
        self.last = 0;
    }

    /// Decides which clusters [`LightCut::sample`] can choose (see the module documentation).
    /// For a cut whose weights sum to a finite total and whose every cluster has a share of at
    /// least `2 · MIN_PMF`, the choice is by the plain weights over [`LightCut::total_weight`].
    fn finish(&mut self) {
        self.scale = if self.total < f32::INFINITY {
            1.0
        } else {
            // Weights are finite, so 64 of them scaled by 2⁻⁶⁴ cannot overflow.
            f32::from_bits((127 - 64) << 23)
        };
        let scale = self.scale;
        // One pass: the scaled weights' sum `all`, added in the clusters' order, its running
        // sums (what `ends` holds when no cluster is left out) and the smallest scaled weight.
        let n = self.len.min(MAX_CUT_SIZE);
        let mut all = 0.0f32;
        let mut least = f32::INFINITY;
        for (c, end) in self.clusters[..n].iter().zip(&mut self.ends[..n]) {
            let w = c.weight * scale;
            all += w;
            least = if w < least { w } else { least };
            *end = all;
        }
        // No cluster is left out when the smallest share passes the test below: with
        // `least > 0` and `least / all ≥ 2 · MIN_PMF > 0`, `all` is positive (it is not NaN,
        // so no scaled weight is NaN), and every scaled weight `w ≥ least` gives
        // `w / all ≥ least / all`, correctly rounded division being non-decreasing in its
        // numerator for a positive divisor. Then `skipped` is 0, `sample_total` is `all`, the
        // running sums are those above and the last cluster can be chosen: what the loops
        // below give, without a division per cluster. (An empty cut passes too: `inf / 0`,
        // and `last` stays 0.)
        if least > 0.0 && least / all >= 2.0 * MIN_PMF {
            self.skipped = 0;
            self.sample_total = all;
            self.last = n.saturating_sub(1);
            return;
        }
        let mut skipped = 0u64;
        let mut kept = 0.0f32;
        for (i, c) in self.tree_clusters().iter().enumerate() {
            if (c.weight * scale) / all >= 2.0 * MIN_PMF {
                kept += c.weight * scale;
            } else {
                skipped |= 1 << i;
            }
        }
        self.skipped = skipped;
        self.sample_total = if skipped == 0 { all } else { kept };
        let mut acc = 0.0f32;
        for i in 0..self.len {
            if let Some(w) = self.sample_weight(i) {
                acc += w;
                self.last = i;
            }
            self.ends[i] = acc;
        }
    }

    /// The weight [`LightCut::sample`] gives cluster `i` (over `sample_total`); `None` for a
    /// cluster it never chooses.
    #[inline]
    fn sample_weight(&self, i: usize) -> Option<f32> {
        let c = self.tree_clusters().get(i)?;
        (self.skipped & (1 << i) == 0).then_some(c.weight * self.scale)
    }

    /// The probability that [`LightCut::sample`] chooses cluster `i`, and the smallest pmf
    /// relative to it a light of it may have (the product stays ≥ [`MIN_PMF`]).
    #[inline]
    fn sample_share(&self, i: usize) -> Option<(f32, f32)> {
        let q = self.sample_weight(i)? / self.sample_total;
        Some((q, 2.0 * MIN_PMF / q))
    }
}

/// The BRDF-oriented cut's decisions for a node's slots ([`LightCut::rebuild_bl`]).
#[derive(Clone, Copy)]
struct BlSplitRule {
    /// s² of the wide-cap rule `r ≥ s·d` (`opts.split_sin` as documented there).
    s2: f32x4,
    delta: f32x4,
}

impl BlSplitRule {
    fn new(opts: &BlCutOptions) -> BlSplitRule {
        // s = 1 makes the rule `d² ≤ r²` exactly: the point inside the sphere.
        let s = if opts.split_sin < 1.0 {
            opts.split_sin.max(0.0)
        } else {
            1.0
        };
        BlSplitRule {
            s2: f32x4::splat(s * s),
            delta: f32x4::splat(opts.delta),
        }
    }

    /// The decisions from a node's [`BlImportance::eval4_for_cut`]: weights its importances,
    /// scores its cap integrals; split where the slot's cap is wide (`s²·|c − x|² ≤ r²` for the
    /// decoded sphere, from the evaluation's own distances) or SC exceeds δ (`sc > delta`,
    /// false for NaN, lane by lane).
    #[inline(always)]
    fn decide(
        &self,
        (w, sc, glossy, [d2, r2]): (f32x4, f32x4, f32x4, [f32x4; 2]),
    ) -> SlotDecisions {
        let wide = (self.s2 * d2).simd_le(r2);
        SlotDecisions {
            weight: w.to_array(),
            score: sc.to_array(),
            glossy_score: glossy.to_array(),
            split: (wide | sc.simd_gt(self.delta)).to_bitmask(),
        }
    }
}

/// A cut's length, total weight and largest scores while [`LightCut::build_with`] accepts
/// clusters, from an empty cut (as [`LightCut::clear`] leaves it), kept in locals.
#[derive(Default)]
struct Accepted {
    len: usize,
    total: f32,
    max_score: f32,
    max_glossy_score: f32,
}

impl Accepted {
    #[inline(always)]
    fn push(&mut self, clusters: &mut [Cluster; CUT_CAPACITY], c: Cluster) {
        if self.len < MAX_CUT_SIZE {
            clusters[self.len] = c;
            self.len += 1;
            self.total += c.weight;
            self.max_score = self.max_score.max(c.score);
            self.max_glossy_score = self.max_glossy_score.max(c.glossy_score);
        }
    }
}

impl LightCut {
    /// The BRDF-oriented light cut of Liu et al. 2019 at the shading point of `imp`: a cluster
    /// is split when its cap is wide (`opts.split_sin`; x inside its bounding sphere is the
    /// widest) or when its BRDF cap integral SC exceeds `opts.delta`. Weights are BL
    /// importances, scores the SC values, so [`LightCut::max_score`] is IB(x).
    #[must_use]
    pub fn build_bl(tree: &LightTree, imp: &BlImportance, opts: &BlCutOptions) -> LightCut {
        let mut cut = LightCut::new();
        cut.rebuild_bl(tree, imp, opts);
        cut
    }

    /// [`LightCut::build_bl`] in place: the cut becomes the one `build_bl(tree, imp, opts)`
    /// returns, whatever it held before, without a copy of its arrays (a cut kept per thread
    /// and rebuilt at each shading point).
    pub fn rebuild_bl(&mut self, tree: &LightTree, imp: &BlImportance, opts: &BlCutOptions) {
        let rule = BlSplitRule::new(opts);
        // The root is evaluated once: its importances (those of `eval4`, bit for bit) give the
        // total, and its integrals its slots' decisions.
        let root = tree.nodes.first();
        let root_eval = root.map(|r| imp.eval4_for_cut(r));
        let decide = |node: &Node4, _: f32| {
            rule.decide(match (root, root_eval) {
                (Some(r), Some(e)) if core::ptr::eq(node, r) => e,
                _ => imp.eval4_for_cut(node),
            })
        };
        let total = |_: &Node4| root_eval.map_or(0.0, |e| e.0.to_array().iter().sum());
        let surely_kept = |node: &Node4| imp.surely_positive4(node);
        LightCut::build_with(self, tree, opts.max_size, decide, surely_kept, total);
        self.add_infinite(tree, imp);
    }

    /// The split-sampling cut of Conty & Kulla at the shading point of `imp` (see the module
    /// documentation); each cluster's weight is its TL importance.
    #[must_use]
    pub fn build_split(tree: &LightTree, imp: &TlImportance, opts: &SplitCutOptions) -> LightCut {
        let mut cut = LightCut::new();
        cut.rebuild_split(tree, imp, opts);
        cut
    }

    /// [`LightCut::build_split`] in place (as [`LightCut::rebuild_bl`] is `build_bl`'s).
    pub fn rebuild_split(&mut self, tree: &LightTree, imp: &TlImportance, opts: &SplitCutOptions) {
        let x = imp.position();
        let threshold = opts.threshold;
        LightCut::build_with(
            self,
            tree,
            opts.max_size,
            |node, total| {
                let w = imp.eval4(node).to_array();
                let mut out = SlotDecisions {
                    weight: w,
                    ..SlotDecisions::default()
                };
                for (k, &wk) in w.iter().enumerate() {
                    if !positive(wk) {
                        continue;
                    }
                    // V[e]/E[e]² of the cluster's energies (0 for a single light).
                    let rel_e = match node.child(k) {
                        Child::Node(c) => tree.energy_rel_variance(c),
                        _ => 0.0,
                    };
                    let sphere = node.sphere(k);
                    let (c, r) = (sphere.center, sphere.radius);
                    let d = math::length(c - x);
                    let inside = d <= r;
                    let score = if inside {
                        f32::INFINITY
                    } else {
                        let a = (d - r).max(1e-6 * d.max(1.0));
                        let b = d + r;
                        let rel_g = (b - a) * (b - a) / (3.0 * a * b);
                        let rho = (1.0 + rel_e) * (1.0 + rel_g) - 1.0;
                        let share = wk / total;
                        rho * share * share
                    };
                    out.score[k] = score;
                    if inside || score > threshold {
                        out.split |= 1 << k;
                    }
                }
                out
            },
            |_| 0,
            |root| imp.eval4(root).to_array().iter().sum(),
        );
        self.add_infinite(tree, imp);
    }

    /// Adds the lights at infinity to a cut of the node tree just built: a cluster for each
    /// whose importance at the point is positive, and the root choice (for a tree with
    /// lights at infinity, whatever their importances).
    fn add_infinite<I: Importance + ?Sized>(&mut self, tree: &LightTree, imp: &I) {
        if tree.infinite.is_empty() {
            return;
        }
        let mut weights = [0f32; MAX_INFINITE_LIGHTS];
        let m = tree.infinite.len().min(MAX_INFINITE_LIGHTS);
        let start = self.len;
        let mut n = 0;
        for (i, e) in tree.infinite[..m].iter().enumerate() {
            let weight = imp.eval_infinite(e);
            weights[i] = weight;
            if weight > 0.0 {
                self.clusters[start + n] = Cluster {
                    node: Cluster::AT_INFINITY,
                    slot: i as u8,
                    path: 0,
                    weight,
                    score: 0.0,
                    glossy_score: 0.0,
                };
                n += 1;
            }
        }
        self.infinite = n;
        let w: f64 = self
            .tree_clusters()
            .iter()
            .map(|c| f64::from(c.weight))
            .sum();
        self.root = Some(RootChoice::new(w, weights[..m].iter().copied()));
    }
}

mod sampling;

#[cfg(test)]
mod tests;
