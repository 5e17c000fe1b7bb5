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
use crate::sample::{
    sanitize, RootChoice, SampledLight, Start, WalkStart, MIN_PMF, ONE_MINUS_EPSILON,
};
use crate::tree::{count4, path_len, Child, LightTree, Node4, Slot};
use core::cell::Cell;
use wide::f32x4;

/// `p · pmf` if it is at least [`MIN_PMF`], else 0: the pmf of a light of the node tree chosen
/// at the root with probability `p`.
#[inline]
fn product(p: f32, pmf: f32) -> f32 {
    let q = p * pmf;
    if q >= MIN_PMF {
        q
    } else {
        0.0
    }
}

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

    /// Samples a light in cluster `i` with `u`: its pmf is relative to the cluster (the
    /// split-sampling estimator divides cluster i's contribution by it). `None` if `i` is out of
    /// range or no light of the cluster can contribute.
    pub fn sample_in<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        i: usize,
        u: f32,
    ) -> Option<SampledLight> {
        let c = self.clusters().get(i)?;
        tree.sample_cluster(imp, c, u)
    }

    /// One light in each cluster: `out[i]` gets exactly what `sample_in(tree, imp, i, u[i])`
    /// returns, for `i < min(len, u.len(), out.len())` (what split sampling needs).
    ///
    /// Faster than calling [`LightCut::sample_in`] for each cluster: the descents run four at
    /// a time, interleaved, so their dependent steps overlap.
    ///
    /// ```
    /// use manylights::cut::CUT_CAPACITY;
    /// use manylights::importance::MemoTable;
    /// use manylights::{Light, LightCut, LightTree, Memo, SplitCutOptions, TlImportance};
    /// use glam::Vec3;
    ///
    /// let lights: Vec<Light> = (0..200)
    ///     .map(|i| Light::Point {
    ///         position: Vec3::new((i % 20) as f32, (i / 20) as f32, 2.0),
    ///         intensity: 1.0.into(),
    ///     })
    ///     .collect();
    /// let tree = LightTree::build(&lights)?;
    /// let at = TlImportance::new(Vec3::new(3.0, 4.0, 0.0), Vec3::Z);
    /// let cut = LightCut::build_split(&tree, &at, &SplitCutOptions::default());
    /// // Many samples at this point: let the importance remember the nodes it evaluated (in a
    /// // table kept per thread and reused at every point).
    /// let table = MemoTable::new();
    /// let memo = Memo::new(at, &tree, &table);
    /// let (u, mut out) = ([0.5; CUT_CAPACITY], [None; CUT_CAPACITY]);
    /// cut.sample_each(&tree, &memo, &u[..cut.len()], &mut out[..cut.len()]);
    /// for (i, s) in out[..cut.len()].iter().enumerate() {
    ///     assert_eq!(*s, cut.sample_in(&tree, &at, i, 0.5));
    /// }
    /// # Ok::<(), manylights::BuildError>(())
    /// ```
    pub fn sample_each<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        u: &[f32],
        out: &mut [Option<SampledLight>],
    ) {
        let n = self.len().min(u.len()).min(out.len());
        tree.descend_many::<&I, CUT_LANES>(
            n,
            |_| &imp,
            |i| match tree.slot_of(&self.clusters[i]) {
                Slot::Light(light) => Err(Some(SampledLight { light, pmf: 1.0 })),
                Slot::Node(child) => Ok(Start {
                    node: child,
                    root: false,
                    u: u[i],
                    floor: MIN_PMF,
                }),
                Slot::Empty => Err(None),
            },
            |i, s| out[i] = s,
        );
    }

    /// [`LightCut::pmf_in`] for many lights: `out[i]` gets exactly `pmf_in(tree, imp,
    /// lights[i])`, for `i < min(lights.len(), out.len())`. The walks run four at a time,
    /// interleaved (as in [`LightCut::sample_each`]).
    pub fn pmf_in_each<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        lights: &[u32],
        out: &mut [Option<(usize, f32)>],
    ) {
        self.walk_each(tree, imp, lights, out, false);
    }

    /// The walks of [`LightCut::pmf_in_each`] (`whole` false) or of [`LightCut::pmf_each`]
    /// (`whole` true: the pmf within the cluster as [`LightCut::sample`] reports it, `None` for
    /// lights of clusters it never chooses).
    fn walk_each<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        lights: &[u32],
        out: &mut [Option<(usize, f32)>],
        whole: bool,
    ) {
        let n = lights.len().min(out.len());
        for o in out[..n].iter_mut() {
            *o = None;
        }
        // `start_of` records the cluster of each light; `emit` adds the pmf within it.
        let cluster: [Cell<usize>; CUT_CAPACITY] = core::array::from_fn(|_| Cell::new(usize::MAX));
        let mut done = 0;
        while done < n {
            let m = (n - done).min(CUT_CAPACITY);
            let ls = &lights[done..done + m];
            let os = &mut out[done..done + m];
            tree.pmf_many::<&I, CUT_LANES>(
                m,
                |_| &imp,
                |i| {
                    let light = ls[i];
                    cluster[i].set(usize::MAX);
                    let found = self.cluster_of(tree, light).and_then(|(ci, c, path)| {
                        if whole {
                            Some((ci, c, path, self.sample_share(ci)?.1))
                        } else {
                            Some((ci, c, path, MIN_PMF))
                        }
                    });
                    let Some((ci, c, path, floor)) = found else {
                        return Err(f32::NAN);
                    };
                    cluster[i].set(ci);
                    // A cluster that is a node takes the walk; otherwise the single-light
                    // answer of `pmf_cluster`.
                    match tree.slot_of(c) {
                        Slot::Node(child) => Ok(WalkStart {
                            node: child,
                            root: false,
                            path,
                            from_level: path_len(c.path),
                            light,
                            floor,
                        }),
                        _ => Err(tree.pmf_cluster(imp, c, path, light, floor)),
                    }
                },
                |i, p| {
                    if cluster[i].get() != usize::MAX {
                        os[i] = Some((cluster[i].get(), p));
                    }
                },
            );
            done += m;
        }
    }

    /// [`LightCut::pmf`] for many lights: `out[i]` gets exactly `pmf(tree, imp, lights[i])`,
    /// for `i < min(lights.len(), out.len())`, the walks interleaved as in
    /// [`LightCut::pmf_in_each`].
    pub fn pmf_each<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        lights: &[u32],
        out: &mut [f32],
    ) {
        if self.root.is_some() {
            for (o, &l) in out.iter_mut().zip(lights) {
                *o = self.pmf(tree, imp, l);
            }
            return;
        }
        let mut within = [None; CUT_CAPACITY];
        for (ls, os) in lights
            .chunks(CUT_CAPACITY)
            .zip(out.chunks_mut(CUT_CAPACITY))
        {
            let m = ls.len().min(os.len());
            self.walk_each(tree, imp, &ls[..m], &mut within[..m], true);
            for j in 0..m {
                os[j] = match within[j].and_then(|(ci, p)| Some((self.sample_share(ci)?.0, p))) {
                    Some((q, p)) => q * p,
                    None => 0.0,
                };
            }
        }
    }

    /// The cluster of the cut on `light`'s path, its index, and the light's path.
    ///
    /// A cluster's path is a prefix of the light's exactly when shifting the light's path right
    /// by the difference of their leading zeros gives the cluster's. The clusters are disjoint,
    /// so at most one matches; the scan has no data-dependent branch.
    fn cluster_of(&self, tree: &LightTree, light: u32) -> Option<(usize, &Cluster, u64)> {
        let path = tree.path(light);
        if path == 0 {
            // Not in the node tree: a light at infinity, a cluster of its own, or none.
            let entry = tree.infinite_entry(light)?;
            let i = self.len
                + self.clusters[self.len..self.len + self.infinite]
                    .iter()
                    .position(|c| usize::from(c.slot) == entry)?;
            return Some((i, &self.clusters[i], 0));
        }
        let lz = path.leading_zeros();
        let mut found = usize::MAX;
        for (i, c) in self.tree_clusters().iter().enumerate() {
            let shift = c.path.leading_zeros().wrapping_sub(lz);
            let hit = c.path != 0 && shift < 64 && path >> (shift & 63) == c.path;
            found = if hit { i } else { found };
        }
        self.clusters.get(found).map(|c| (found, c, path))
    }

    /// The cluster holding `light` and the light's pmf within it (what
    /// [`LightCut::sample_in`] reports for it); `None` if no cluster of the cut holds it.
    pub fn pmf_in<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        light: u32,
    ) -> Option<(usize, f32)> {
        let (i, c, path) = self.cluster_of(tree, light)?;
        Some((i, tree.pmf_cluster(imp, c, path, light, MIN_PMF)))
    }

    /// Samples one light of the whole cut: a cluster with probability weight / total, then a
    /// light in it. The pmf is the product (at least [`MIN_PMF`]: clusters and lights whose
    /// share would be smaller are never chosen; see the module documentation).
    ///
    /// With lights at infinity, the choice is first made at the root
    /// ([`LightCut::root_choice`]): between the node tree's clusters, of weight the sum of
    /// their weights, and each light at infinity, of its weight (its cluster's), as the
    /// estimators' [`crate::direct::CutSampler`] chooses (`u` rescaled into the chosen
    /// interval). A light at infinity then has the pmf of its choice; a light of the node
    /// tree has that of the node tree times what the cut's clusters give it, and a product
    /// below [`MIN_PMF`] counts as no light (`None`, and [`LightCut::pmf`] 0).
    pub fn sample<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        u: f32,
    ) -> Option<SampledLight> {
        let Some(root) = &self.root else {
            return self.sample_tree(tree, imp, u);
        };
        let (k, p, rest) = root.pick(u)?;
        if k > 0 {
            let light = tree.infinite.get(k - 1)?.light;
            return Some(SampledLight { light, pmf: p });
        }
        let s = self.sample_tree(tree, imp, rest)?;
        let pmf = product(p, s.pmf);
        (pmf > 0.0).then_some(SampledLight {
            light: s.light,
            pmf,
        })
    }

    /// [`LightCut::sample`] among the node tree's clusters alone.
    fn sample_tree<I: Importance + ?Sized>(
        &self,
        tree: &LightTree,
        imp: &I,
        u: f32,
    ) -> Option<SampledLight> {
        if self.len == 0 {
            return None;
        }
        let total = self.sample_total;
        let t = sanitize(u) * total;
        // The first cluster whose running sum passes t (one that is left out repeats the sum
        // before it, so it is never the first), else the last that can be chosen: the
        // clusters' weights in [0, total) laid end to end in their order.
        let ends = &self.ends[..self.len];
        let i = ends.partition_point(|&e| e <= t).min(self.last);
        let w = self.sample_weight(i)?;
        let before = if i == 0 { 0.0 } else { ends[i - 1] };
        let u2 = ((t - before) / w).clamp(0.0, ONE_MINUS_EPSILON);
        let (q, floor) = self.sample_share(i)?;
        let s = tree.sample_cluster_from(imp, &self.clusters[i], u2, floor)?;
        Some(SampledLight {
            light: s.light,
            pmf: q * s.pmf,
        })
    }

    /// The probability that [`LightCut::sample`] returns `light`: exactly the pmf it reports.
    pub fn pmf<I: Importance + ?Sized>(&self, tree: &LightTree, imp: &I, light: u32) -> f32 {
        let Some(root) = &self.root else {
            return self.pmf_tree(tree, imp, light);
        };
        if let Some(i) = tree.infinite_entry(light) {
            return root.probability(1 + i);
        }
        let p = root.probability(0);
        if p <= 0.0 {
            return 0.0;
        }
        product(p, self.pmf_tree(tree, imp, light))
    }

    /// [`LightCut::pmf`] among the node tree's clusters alone (0 for a light at infinity).
    fn pmf_tree<I: Importance + ?Sized>(&self, tree: &LightTree, imp: &I, light: u32) -> f32 {
        let Some((i, c, path)) = self.cluster_of(tree, light) else {
            return 0.0;
        };
        match self.sample_share(i) {
            Some((q, floor)) => q * tree.pmf_cluster(imp, c, path, light, floor),
            None => 0.0,
        }
    }
}

impl LightTree {
    /// What `cluster`'s slot holds ([`Slot::Empty`] for a cluster naming no node of this tree).
    #[inline]
    fn slot_of(&self, cluster: &Cluster) -> Slot {
        if let Some(entry) = cluster.infinite_entry() {
            return self
                .infinite
                .get(entry)
                .map_or(Slot::Empty, |e| Slot::Light(e.light));
        }
        self.nodes
            .get(cluster.node as usize)
            .map_or(Slot::Empty, |n| self.slot(n, usize::from(cluster.slot) & 3))
    }

    /// Samples a light under `cluster` (pmf relative to it, at least [`MIN_PMF`]).
    pub fn sample_cluster<I: Importance + ?Sized>(
        &self,
        imp: &I,
        cluster: &Cluster,
        u: f32,
    ) -> Option<SampledLight> {
        self.sample_cluster_from(imp, cluster, u, MIN_PMF)
    }

    /// [`LightTree::sample_cluster`] with lights of pmf below `floor` (in [`MIN_PMF`, 1]) left
    /// out.
    fn sample_cluster_from<I: Importance + ?Sized>(
        &self,
        imp: &I,
        cluster: &Cluster,
        u: f32,
        floor: f32,
    ) -> Option<SampledLight> {
        match self.slot_of(cluster) {
            Slot::Light(light) => Some(SampledLight { light, pmf: 1.0 }),
            // Below the cluster's slot, whose weight was positive: a node whose four children
            // all have importance 0 falls back to its energies, so a non-empty cut always
            // returns a light and its pmfs sum to 1.
            Slot::Node(c) => self.descend_from(imp, c as usize, false, u, floor),
            Slot::Empty => None,
        }
    }

    /// The pmf of `light` (path `path`) under `cluster`, as
    /// [`LightTree::sample_cluster_from`] reports it with the same `floor`; the caller has
    /// checked the path goes through the cluster.
    fn pmf_cluster<I: Importance + ?Sized>(
        &self,
        imp: &I,
        cluster: &Cluster,
        path: u64,
        light: u32,
        floor: f32,
    ) -> f32 {
        match self.slot_of(cluster) {
            Slot::Light(l) if l == light => 1.0,
            Slot::Node(c) => self.pmf_from(
                imp,
                &WalkStart {
                    node: c,
                    root: false,
                    path,
                    from_level: path_len(cluster.path),
                    light,
                    floor,
                },
            ),
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests;
