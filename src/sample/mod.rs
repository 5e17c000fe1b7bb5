//! Sampling a light by tree descent with one warped uniform number, and the exact pmf of any
//! light (the forum post that introduced light-tree sampling; docs/formulas.md, section 12).
//!
//! This file holds the sampling part of [`LightTree`]'s API: [`LightTree::sample`] and
//! [`LightTree::pmf`] at one shading point, [`LightTree::sample_batch`] and
//! [`LightTree::pmf_batch`] over many, and the crate's descents from any node that the cuts
//! share. The tree's layout and accessors are in [`crate::tree`], its build in
//! [`crate::build`], sampling inside one cluster ([`LightTree::sample_cluster`]) in
//! [`crate::cut`] and ray queries in [`crate::trace`].
//!
//! At a node the four slot importances `I_k` are computed at once; slot k is chosen with
//! probability `I_k / ΣI`, the pmf is multiplied by that ratio and `u` is rescaled into the
//! chosen interval. [`LightTree::pmf`] recomputes the same ratios along the light's stored
//! path, so it returns exactly the pmf [`LightTree::sample`] reported.
//!
//! Three cases, decided once:
//! - ΣI = 0 (or not finite) at the root: no light is returned and every pmf is 0.
//! - ΣI = 0 below the root (a cluster's importance bounds its lights but is not the sum of its
//!   children's, so a positive slot can hold four zero children): the node falls back to its
//!   slots' energies, so the pmfs of all lights still sum to 1. Conservativeness guarantees no
//!   contributing light is under such a node.
//! - Vanishing lights: a light whose pmf would be below [`MIN_PMF`] (f32's smallest normal
//!   number; its pmf would round to a subnormal or to 0, and dividing by it overflows) is
//!   never sampled and its pmf is 0. The descent enforces it node by node: at a node reached
//!   with probability `P`, a slot with `P · I_k / ΣI < MIN_PMF` gets weight 0 and the other
//!   slots share its probability; if that leaves no slot, the slot of largest weight alone is
//!   taken (probability 1, so the path keeps `P ≥ MIN_PMF`). A returned pmf is therefore
//!   always at least [`MIN_PMF`], `sample` and `pmf` apply the same rule, and the pmfs of the
//!   lights still sum to 1. Only lights whose share of the importance is below about 1e-38
//!   are affected; for all other inputs the weights are untouched.
//!
//! Precision: `u` loses bits at every level; pass a second uniform number for the point on the
//! light rather than reusing what is left of `u`.

use crate::error::LengthMismatch;
use crate::importance::Importance;
use crate::tree::{path_len, Child, LightTree, Node4};
use wide::f32x4;

mod root;
pub use root::RootChoice;
pub(crate) use root::{root_product, tree_floor};

/// A sampled light and the probability of having chosen it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledLight {
    /// Index of the light in the slice the tree was built from.
    pub light: u32,
    /// Probability of this choice: finite, at most 1 and at least [`MIN_PMF`].
    pub pmf: f32,
}

/// The smallest pmf a sampled light has: f32's smallest normal number (2⁻¹²⁶). A light whose
/// probability would be smaller is never sampled (see the module documentation).
pub const MIN_PMF: f32 = f32::MIN_POSITIVE;

pub use crate::math::ONE_MINUS_EPSILON;

/// Clamps `u` into [0, 1) (NaN becomes 0).
#[inline(always)]
pub(crate) fn sanitize(u: f32) -> f32 {
    if u >= 0.0 {
        u.min(ONE_MINUS_EPSILON)
    } else {
        0.0
    }
}

/// Selection weights at a node reached with probability `reach`: the importances, or the
/// energies below the root when the importances are all zero, with the slots whose path
/// probability would fall below `floor` set to 0 ([`admit`]). `None` at the root when
/// nothing is sampled, and below it when the energies give nothing to choose from either (a
/// corrupt tree).
#[inline(always)]
pub(crate) fn weights<I: Importance + ?Sized>(
    imp: &I,
    node: &Node4,
    root: bool,
    reach: f32,
    floor: f32,
) -> Option<(f32x4, f32)> {
    weights_of(imp.eval4(node), node, root, reach, floor)
}

/// [`weights`] from `w`, the importances of `node`'s slots (`imp.eval4(node)`). The weights
/// stay in their vector from the importances to [`pick`]: as `[f32; 4]` they went through the
/// stack on the descent's chain of dependences once per function they passed.
#[inline(always)]
pub(crate) fn weights_of(
    w: f32x4,
    node: &Node4,
    root: bool,
    reach: f32,
    floor: f32,
) -> Option<(f32x4, f32)> {
    let a = w.to_array();
    let sum = a[0] + a[1] + a[2] + a[3];
    if positive_finite(sum) {
        return Some(admit4(w, sum, reach, floor));
    }
    if root {
        return None;
    }
    let e = node.energies();
    let sum = e[0] + e[1] + e[2] + e[3];
    if positive_finite(sum) {
        return Some(admit4(f32x4::from(e), sum, reach, floor));
    }
    None
}

/// `x > 0 && x < ∞` in one integer comparison: the bits of the positive finite f32 are
/// 1..=0x7F7F_FFFF, and those of every other (±0, negative, ∞, NaN) fall outside.
#[inline(always)]
fn positive_finite(x: f32) -> bool {
    x.to_bits().wrapping_sub(1) < 0x7F7F_FFFF
}

/// [`admit`] on a node's four lanes: the same result, its test that every slot passes taken
/// on all lanes at once. A lane passes when it is 0 or when `reach · (w_k / sum) ≥ floor`,
/// which a negative or NaN lane never is (`floor` > 0); division and product by positive
/// numbers are monotonic under rounding, so the positive lanes all pass exactly when the
/// smallest does, which is [`admit`]'s test.
#[inline(always)]
pub(crate) fn admit4(w: f32x4, sum: f32, reach: f32, floor: f32) -> (f32x4, f32) {
    let share = f32x4::splat(reach) * (w / f32x4::splat(sum));
    let pass = w.simd_eq(f32x4::ZERO) | share.simd_ge(f32x4::splat(floor));
    if pass.to_bitmask() == 0b1111 {
        return (w, sum);
    }
    let (w, sum) = admit_slow(w.to_array(), reach, floor);
    (f32x4::from(w), sum)
}

/// The weights a descent picks from, given the raw weights `w` with finite positive sum `sum`
/// at a node reached with probability `reach` (≥ `floor`): a slot whose probability
/// `reach · w_k / sum` would be below `floor` (or whose weight is not positive) gets weight
/// 0, and the others renormalise; if none is left, the slot of largest weight alone (the
/// first of equal ones). Every slot left then has `reach · w_k / sum' ≥ floor`, so the
/// descent's pmf never drops below `floor`. When every positive slot passes, `(w, sum)` is
/// returned unchanged.
///
/// The scalar twin of [`admit4`] (the binary baseline tree's rule).
#[cfg(any(test, feature = "baseline"))]
#[inline(always)]
pub(crate) fn admit(w: [f32; 4], sum: f32, reach: f32, floor: f32) -> ([f32; 4], f32) {
    // The smallest positive weight passing means every one does.
    let mut min = f32::INFINITY;
    let mut negative = false;
    for x in w {
        if x > 0.0 {
            min = min.min(x);
        } else if x < 0.0 || x.is_nan() {
            negative = true;
        }
    }
    if !negative && reach * (min / sum) >= floor {
        return (w, sum);
    }
    admit_slow(w, reach, floor)
}

/// [`admit`] when some slot is dropped.
#[cold]
fn admit_slow(w: [f32; 4], reach: f32, floor: f32) -> ([f32; 4], f32) {
    let positive = w.map(|x| if x > 0.0 { x } else { 0.0 });
    let s1 = positive[0] + positive[1] + positive[2] + positive[3];
    // A subset of the positive weights, summed in the same order, sums to at most `s1`, so
    // the ratios only grow when the dropped slots are removed.
    let kept = positive.map(|x| if reach * (x / s1) >= floor { x } else { 0.0 });
    let s2 = kept[0] + kept[1] + kept[2] + kept[3];
    if s2 > 0.0 && s2 < f32::INFINITY {
        return (kept, s2);
    }
    let mut best = 0;
    for k in 1..4 {
        if positive[k] > positive[best] {
            best = k;
        }
    }
    let mut only = [0.0; 4];
    only[best] = positive[best];
    (only, positive[best])
}

/// Picks slot k with probability `w[k] / sum` from `u` in [0, 1) and returns it with `w[k]`
/// and `u` rescaled into [0, 1). A slot of weight 0 is never picked. Branch-free: k counts the
/// prefix sums at or below `u · sum` (a zero-weight slot repeats its predecessor's prefix sum,
/// so it is skipped), clamped to the last positive slot against rounding.
#[inline(always)]
pub(crate) fn pick(w: f32x4, sum: f32, u: f32) -> (usize, f32, f32) {
    let w = w.to_array();
    let t = u * sum;
    let c0 = w[0];
    let c1 = c0 + w[1];
    let c2 = c1 + w[2];
    let k = usize::from(t >= c0) + usize::from(t >= c1) + usize::from(t >= c2);
    let last = if w[3] > 0.0 {
        3
    } else if w[2] > 0.0 {
        2
    } else if w[1] > 0.0 {
        1
    } else {
        0
    };
    let k = k.min(last);
    let before = [0.0, c0, c1, c2][k];
    (k, w[k], ((t - before) / w[k]).clamp(0.0, ONE_MINUS_EPSILON))
}

/// Whether the descents prefetch the next level's nodes ([`crate::prefetch`]); without the
/// hint they touch them with plain loads ([`touch`]).
pub(crate) const PREFETCH: bool = crate::prefetch::ENABLED;

/// Loads the first word of each inner child of `node` (consecutive nodes, so consecutive
/// cache lines), so that the memory latency of the next level overlaps the evaluation of
/// `node`: what the single descent does without the prefetch hint. Returns a value to be fed
/// to `black_box`.
#[inline(always)]
fn touch(tree: &LightTree, node: &Node4) -> u32 {
    let base = node.child_base as usize;
    let n = node.inner_count() as usize;
    let mut t = 0u32;
    if let Some(children) = tree.nodes.get(base..base + n) {
        if let Some(last) = n.checked_sub(1) {
            // Four loads and no loop: a node with fewer inner children loads its last again.
            for i in 0..4 {
                t ^= children[i.min(last)].sphere[0];
            }
        }
    }
    t
}

/// Gets the inner children of `node` on their way: prefetched with the feature `prefetch`,
/// touched ([`touch`]) without it. Returns a value to be fed to `black_box` (0 when
/// prefetched).
#[inline(always)]
fn ahead(tree: &LightTree, node: &Node4) -> u32 {
    if !PREFETCH {
        return touch(tree, node);
    }
    // The node's light slots, which the descent reads if it picks one.
    if node.leaf_count() > 0 {
        tree.leaves.prefetch(node.leaf_base as usize);
    }
    let base = node.child_base as usize;
    let n = node.inner_count() as usize;
    if let Some(children) = tree.nodes.get(base..base + n) {
        if let Some(last) = n.checked_sub(1) {
            // Four hints and no loop, as `touch` loads.
            for i in 0..4 {
                crate::prefetch::prefetch(&children[i.min(last)]);
            }
        }
    }
    0
}

/// Whether the batch calls evaluate their lanes two at a time ([`Importance::eval4_pair`]):
/// where AVX makes an `f32x8` one register. Without it an `f32x8` is two `f32x4`, the pair
/// only doubles what must stay in registers, and the lanes, independent of one another,
/// overlap in the core as well one at a time (docs/measurements.md, "Batch widths and the next
/// level's loads").
const PAIRS: bool = cfg!(target_feature = "avx");

/// One round's importances of the batch calls' lanes: `imp[j].eval4(node(j))` for every busy
/// lane (`imp[j]` is `None` for an idle one, whose entry stays 0), two lanes at a time with
/// [`Importance::eval4_pair`] where [`PAIRS`] says so, else one at a time. With `leaf_hint`,
/// the light slots of each busy lane's node are prefetched first (read in the step if the
/// lane picks one).
#[inline(always)]
fn eval_lanes<'a, I, const K: usize>(
    tree: &LightTree,
    imp: &[Option<&'a I>; K],
    node: impl Fn(usize) -> &'a Node4,
    leaf_hint: bool,
) -> [f32x4; K]
where
    I: Importance + 'a,
{
    let lane = |j: usize| {
        let i = imp[j]?;
        let nd = node(j);
        if leaf_hint && nd.leaf_count() > 0 {
            tree.leaves.prefetch(nd.leaf_base as usize);
        }
        Some((i, nd))
    };
    let mut w = [f32x4::ZERO; K];
    if !PAIRS {
        for (j, wj) in w.iter_mut().enumerate() {
            if let Some((i, nd)) = lane(j) {
                *wj = i.eval4(nd);
            }
        }
        return w;
    }
    for j in (0..K).step_by(2) {
        let second = if j + 1 < K { lane(j + 1) } else { None };
        match (lane(j), second) {
            (Some((ia, a)), Some((ib, b))) => (w[j], w[j + 1]) = ia.eval4_pair(a, ib, b),
            (Some((ia, a)), None) => w[j] = ia.eval4(a),
            (None, Some((ib, b))) => w[j + 1] = ib.eval4(b),
            (None, None) => {}
        }
    }
    w
}

/// Without the prefetch hint: the nodes `node(j)` of the busy lanes (`imp[j]` not `None`)
/// touched by loads back to back, so that their misses overlap.
#[inline(always)]
fn touch_lanes<'a, I: ?Sized + 'a, const K: usize>(
    imp: &[Option<&'a I>; K],
    node: impl Fn(usize) -> &'a Node4,
) {
    let mut first = 0u32;
    for (j, i) in imp.iter().enumerate() {
        if i.is_some() {
            first ^= node(j).sphere[0];
        }
    }
    core::hint::black_box(first);
}

/// The mask of `K` lanes (bits `0..K`) of the batch descents' idle sets; `K` is at most 64.
#[inline(always)]
const fn all_lanes<const K: usize>() -> u64 {
    assert!(K > 0 && K <= 64);
    u64::MAX >> (64 - K)
}

/// Where one descent of [`LightTree::descend_many`] starts.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Start {
    /// The node.
    pub node: u32,
    /// The node is the root: ΣI = 0 there returns `None` (see the module documentation).
    pub root: bool,
    /// The uniform number (sanitised here).
    pub u: f32,
    /// The smallest pmf a light may get (see [`admit`]).
    pub floor: f32,
}

/// Where one pmf walk of [`LightTree::pmf_many`] starts.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WalkStart {
    /// The node the light's path reaches after `from_level` levels.
    pub node: u32,
    /// The node is the root.
    pub root: bool,
    /// The light's path.
    pub path: u64,
    /// Levels of `path` above `node`.
    pub from_level: u32,
    /// The light.
    pub light: u32,
    /// The floor the matching descent used.
    pub floor: f32,
}

/// Descents [`LightTree::sample_batch`] keeps in flight: the loads of that many descents'
/// next levels are issued in one round, each right after its descent's step, so their memory
/// latencies overlap. The results do not depend on it (each lane returns what
/// [`LightTree::sample`] returns); the width was chosen by measurement (docs/measurements.md,
/// "Batch widths and the next level's loads").
pub const BATCH_LANES: usize = 32;

/// The pmf walks [`LightTree::pmf_batch`] keeps in flight in a tree whose nodes fit in a
/// last-level cache (below [`PMF_WIDE_NODES`]). A walk's next node depends on the node it
/// reads and its path alone, not on the importances, so the core already runs ahead from
/// level to level of one walk; with the nodes in cache more walks in flight mostly add their
/// bookkeeping. The results do not depend on it (each lane returns what [`LightTree::pmf`]
/// returns); the widths were chosen by measurement (docs/measurements.md, "The chain of a
/// 4-wide level").
const PMF_BATCH_LANES: usize = 4;

/// The pmf walks [`LightTree::pmf_batch`] keeps in flight in a tree of at least
/// [`PMF_WIDE_NODES`] nodes, whose levels come from DRAM or a distant last-level cache: there
/// a walk waits on a miss per level, and more of them in flight overlap more misses (the same
/// bits as [`PMF_BATCH_LANES`]; measured in docs/measurements.md, "Batch widths and the next
/// level's loads").
const PMF_BATCH_LANES_WIDE: usize = 64;

/// The node count from which [`LightTree::pmf_batch`] keeps [`PMF_BATCH_LANES_WIDE`] walks in
/// flight: 2¹⁷ nodes of 64 bytes, 8 MiB, more than a core's share of most last-level caches.
/// Both widths return the same bits; only the speed depends on the choice.
const PMF_WIDE_NODES: usize = 1 << 17;

/// How many queries ahead [`LightTree::pmf_batch`] prefetches the path of the light it will
/// query, in a tree of at least [`PMF_WIDE_NODES`] nodes (a walk reads its light's path as it
/// starts; there the paths, read at random beside megabytes of nodes, miss a core's L2). A hint
/// only: the pmfs are the same bits with or without it (docs/measurements.md, "Batch widths and
/// the next level's loads").
const PATH_AHEAD: usize = 16;

impl LightTree {
    /// Samples a light at the shading point of `imp` with the uniform number `u` in [0, 1)
    /// (clamped into it). `None` when no light can contribute (the root's importance is 0).
    #[inline]
    pub fn sample<I: Importance + ?Sized>(&self, imp: &I, u: f32) -> Option<SampledLight> {
        if !self.infinite.is_empty() {
            // The root choice among the nodes and the lights at infinity first.
            return self.sample_with_infinite(imp, u);
        }
        self.descend_from(imp, 0, true, u, MIN_PMF)
    }

    /// Descends from node `start` as [`LightTree::sample`] does from the root; the pmf is
    /// relative to `start`'s subtree and at least `floor` (in [`MIN_PMF`, 1]; see [`admit`]).
    /// With `is_root`, ΣI = 0 at `start` returns `None`; without it `start` falls back to its
    /// energies like any inner node.
    #[inline]
    pub(crate) fn descend_from<I: Importance + ?Sized>(
        &self,
        imp: &I,
        start: usize,
        is_root: bool,
        u: f32,
        floor: f32,
    ) -> Option<SampledLight> {
        let mut u = sanitize(u);
        let mut node = self.nodes.get(start)?;
        let mut touched = ahead(self, node);
        let mut pmf = 1.0f32;
        let (mut w, mut sum) = weights(imp, node, is_root, pmf, floor)?;
        loop {
            let (k, wk, next_u) = pick(w, sum, u);
            pmf *= wk / sum;
            u = next_u;
            match node.child(k) {
                Child::Leaf(i) => {
                    core::hint::black_box(touched);
                    let light = self.leaf_light(i)?;
                    return Some(SampledLight { light, pmf });
                }
                Child::Node(c) => {
                    node = self.nodes.get(c as usize)?;
                    touched ^= ahead(self, node);
                    (w, sum) = weights(imp, node, false, pmf, floor)?;
                }
                Child::Empty => return None,
            }
        }
    }

    /// Samples at many shading points at once: `out[j]` gets exactly (bit for bit) what
    /// `self.sample(&imps[j], us[j])` returns.
    ///
    /// A descent is a chain of dependent loads (a node's importances decide which node is read
    /// next), so one descent leaves the core waiting on memory. This call keeps
    /// `BATCH_LANES` descents in flight, taking one level of each in turn and starting the
    /// next shading point in a lane once its descent ends, so that their latencies overlap.
    /// The importances may be of any kind, [`crate::Memo`] included.
    ///
    /// ```
    /// use manylights::{Light, LightTree, TlImportance};
    /// use glam::Vec3;
    ///
    /// let lights: Vec<Light> = (0..500)
    ///     .map(|i| Light::Point {
    ///         position: Vec3::new((i % 25) as f32, (i / 25) as f32, 3.0),
    ///         intensity: (1.0 + (i % 3) as f32).into(),
    ///     })
    ///     .collect();
    /// let tree = LightTree::build(&lights)?;
    /// let imps: Vec<TlImportance> = (0..64)
    ///     .map(|j| TlImportance::new(Vec3::new(j as f32 * 0.3, 5.0, 0.0), Vec3::Z))
    ///     .collect();
    /// let us: Vec<f32> = (0..64).map(|j| (j as f32 + 0.5) / 64.0).collect();
    /// let mut out = vec![None; 64];
    /// tree.sample_batch(&imps, &us, &mut out)?;
    /// for j in 0..64 {
    ///     assert_eq!(out[j], tree.sample(&imps[j], us[j]));
    /// }
    /// let lights: Vec<u32> = out.iter().map(|s| s.map_or(0, |s| s.light)).collect();
    /// let mut pmfs = vec![0.0; 64];
    /// tree.pmf_batch(&imps, &lights, &mut pmfs)?;
    /// assert_eq!(pmfs[7].to_bits(), out[7].unwrap().pmf.to_bits());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn sample_batch<I: Importance>(
        &self,
        imps: &[I],
        us: &[f32],
        out: &mut [Option<SampledLight>],
    ) -> Result<(), LengthMismatch> {
        LengthMismatch::check("us", imps.len(), us.len())?;
        LengthMismatch::check("out", imps.len(), out.len())?;
        if !self.infinite.is_empty() {
            // With lights at infinity, the single calls (their root choice first).
            for ((o, imp), &u) in out.iter_mut().zip(imps).zip(us) {
                *o = self.sample(imp, u);
            }
            return Ok(());
        }
        self.descend_many::<I, BATCH_LANES>(
            imps.len(),
            |j| &imps[j],
            |j| {
                Ok(Start {
                    node: 0,
                    root: true,
                    u: us[j],
                    floor: MIN_PMF,
                })
            },
            |j, s| out[j] = s,
        );
        Ok(())
    }

    /// The pmfs of many lights at many shading points: `out[j]` gets exactly (bit for bit)
    /// `self.pmf(&imps[j], lights[j])`, the walks interleaved as in
    /// [`LightTree::sample_batch`] (as many in flight as the tree's size calls for: see
    /// `PMF_BATCH_LANES` and `PMF_BATCH_LANES_WIDE`).
    pub fn pmf_batch<I: Importance>(
        &self,
        imps: &[I],
        lights: &[u32],
        out: &mut [f32],
    ) -> Result<(), LengthMismatch> {
        LengthMismatch::check("lights", imps.len(), lights.len())?;
        LengthMismatch::check("out", imps.len(), out.len())?;
        if !self.infinite.is_empty() {
            for ((o, imp), &light) in out.iter_mut().zip(imps).zip(lights) {
                *o = self.pmf(imp, light);
            }
            return Ok(());
        }
        if self.nodes.len() >= PMF_WIDE_NODES {
            self.pmf_batch_lanes::<I, PMF_BATCH_LANES_WIDE>(imps, lights, out, PREFETCH);
        } else {
            self.pmf_batch_lanes::<I, PMF_BATCH_LANES>(imps, lights, out, false);
        }
        Ok(())
    }

    /// [`LightTree::pmf_batch`] with `K` walks in flight, the lengths checked; with
    /// `path_hint`, each light's path prefetched [`PATH_AHEAD`] queries before its walk.
    fn pmf_batch_lanes<I: Importance, const K: usize>(
        &self,
        imps: &[I],
        lights: &[u32],
        out: &mut [f32],
        path_hint: bool,
    ) {
        self.pmf_many::<I, K>(
            imps.len(),
            |j| &imps[j],
            |j| {
                if path_hint {
                    if let Some(&ahead) = lights.get(j + PATH_AHEAD) {
                        self.paths.prefetch(ahead as usize);
                    }
                }
                let light = lights[j];
                Ok(WalkStart {
                    node: 0,
                    root: true,
                    path: self.path(light),
                    from_level: 0,
                    light,
                    floor: MIN_PMF,
                })
            },
            |j, p| out[j] = p,
        );
    }

    /// The engine of the batch calls: `n` descents, `K` in flight. Descent `j` evaluates
    /// `imp_of(j)`; `start_of(j)` says where it starts, or answers it at once (`Err`); its
    /// result goes to `emit(j, ·)`: exactly what [`LightTree::descend_from`] returns for the
    /// same start.
    /// The next level's nodes are prefetched with the feature `prefetch` and touched by a load
    /// without it.
    #[inline(always)]
    pub(crate) fn descend_many<'a, I, const K: usize>(
        &self,
        n: usize,
        imp_of: impl Fn(usize) -> &'a I,
        mut start_of: impl FnMut(usize) -> Result<Start, Option<SampledLight>>,
        mut emit: impl FnMut(usize, Option<SampledLight>),
    ) where
        I: Importance + 'a,
    {
        // A lane's descent: its item, the node it is at, its uniform number, pmf so far,
        // root flag and floor. The importance of a lane is `imp[j]`, `None` for an idle lane.
        #[derive(Clone, Copy)]
        struct Lane<'t> {
            item: usize,
            node: &'t Node4,
            u: f32,
            pmf: f32,
            root: bool,
            floor: f32,
        }
        let mut imp: [Option<&'a I>; K] = [None; K];
        let mut lane = [Lane {
            item: 0,
            node: &Node4::EMPTY,
            u: 0.0,
            pmf: 1.0,
            root: false,
            floor: MIN_PMF,
        }; K];
        // Bit j: lane j is idle.
        let all = const { all_lanes::<K>() };
        let (mut next, mut idle) = (0usize, all);
        loop {
            // Idle lanes take the next descents that need one, the lowest lane first.
            while idle != 0 && next < n {
                // The lowest idle lane (`idle` has no bit from K on: `% K` changes nothing).
                let j = idle.trailing_zeros() as usize % K;
                let i = next;
                next += 1;
                match start_of(i) {
                    Ok(s) => match self.nodes.get(s.node as usize) {
                        Some(nd) => {
                            imp[j] = Some(imp_of(i));
                            lane[j] = Lane {
                                item: i,
                                node: nd,
                                u: sanitize(s.u),
                                pmf: 1.0,
                                root: s.root,
                                floor: s.floor,
                            };
                            idle &= !(1 << j);
                        }
                        None => emit(i, None),
                    },
                    Err(answer) => emit(i, answer),
                }
            }
            if idle == all {
                break;
            }
            // One level of every busy lane.
            let evals = eval_lanes(self, &imp, |j| lane[j].node, PREFETCH);
            // The step of every busy lane, and the load of its next level issued at once
            // (nothing depends on it until the next round, so the misses of all lanes
            // overlap): the next node's prefetch, or the light of a lane that reached a leaf.
            for j in 0..K {
                if imp[j].is_none() {
                    continue;
                }
                let l = &mut lane[j];
                let nd = l.node;
                let step = weights_of(evals[j], nd, l.root, l.pmf, l.floor).map(|(w, sum)| {
                    let (k, wk, next_u) = pick(w, sum, l.u);
                    l.pmf *= wk / sum;
                    l.u = next_u;
                    l.root = false;
                    nd.child(k)
                });
                let answer = match step {
                    Some(Child::Node(c)) => match self.nodes.get(c as usize) {
                        Some(next) => {
                            if PREFETCH {
                                crate::prefetch::prefetch(next);
                            }
                            l.node = next;
                            continue;
                        }
                        None => None,
                    },
                    Some(Child::Leaf(i)) => self
                        .leaf_light(i)
                        .map(|light| SampledLight { light, pmf: l.pmf }),
                    _ => None,
                };
                emit(l.item, answer);
                imp[j] = None;
                idle |= 1 << j;
            }
            if !PREFETCH {
                touch_lanes(&imp, |j| lane[j].node);
            }
        }
    }

    /// The pmf walks of the batch calls, as [`LightTree::descend_many`] runs descents: walk
    /// `j` gets exactly what [`LightTree::pmf_from`] returns for the same start.
    /// The next level's nodes are prefetched with the feature `prefetch` and touched by a load
    /// without it.
    #[inline(always)]
    pub(crate) fn pmf_many<'a, I, const K: usize>(
        &self,
        n: usize,
        imp_of: impl Fn(usize) -> &'a I,
        mut start_of: impl FnMut(usize) -> Result<WalkStart, f32>,
        mut emit: impl FnMut(usize, f32),
    ) where
        I: Importance + 'a,
    {
        // A lane's walk: its item, the node it is at, the light, its path and the level of
        // `node` on it, the path's length, the pmf so far, root flag and floor. The
        // importance of a lane is `imp[j]`, `None` for an idle lane.
        #[derive(Clone, Copy)]
        struct Lane<'t> {
            item: usize,
            node: &'t Node4,
            light: u32,
            path: u64,
            level: u32,
            levels: u32,
            pmf: f32,
            root: bool,
            floor: f32,
        }
        let mut imp: [Option<&'a I>; K] = [None; K];
        let mut lane = [Lane {
            item: 0,
            node: &Node4::EMPTY,
            light: 0,
            path: 0,
            level: 0,
            levels: 0,
            pmf: 1.0,
            root: false,
            floor: MIN_PMF,
        }; K];
        // Bit j: lane j is idle.
        let all = const { all_lanes::<K>() };
        let (mut next, mut idle) = (0usize, all);
        let leaf_hint = PREFETCH && self.nodes.len() >= PMF_WIDE_NODES;
        loop {
            // Idle lanes take the next walks that need one, the lowest lane first.
            while idle != 0 && next < n {
                // The lowest idle lane (`idle` has no bit from K on: `% K` changes nothing).
                let j = idle.trailing_zeros() as usize % K;
                let i = next;
                next += 1;
                match start_of(i) {
                    Ok(s) if s.from_level < path_len(s.path) => {
                        match self.nodes.get(s.node as usize) {
                            Some(nd) => {
                                imp[j] = Some(imp_of(i));
                                lane[j] = Lane {
                                    item: i,
                                    node: nd,
                                    light: s.light,
                                    path: s.path,
                                    level: s.from_level,
                                    levels: path_len(s.path),
                                    pmf: 1.0,
                                    root: s.root,
                                    floor: s.floor,
                                };
                                idle &= !(1 << j);
                            }
                            None => emit(i, 0.0),
                        }
                    }
                    Ok(_) => emit(i, 0.0),
                    Err(answer) => emit(i, answer),
                }
            }
            if idle == all {
                break;
            }
            // One level of every walk going on (the light slots prefetched only in trees
            // whose leaf array does not stay in cache).
            let evals = eval_lanes(self, &imp, |j| lane[j].node, leaf_hint);
            // The step of every walk going on, and the load of its next level issued at once
            // (see `descend_many`): the next node's prefetch, or the leaf entry of a walk that
            // reached its leaf.
            for j in 0..K {
                if imp[j].is_none() {
                    continue;
                }
                let l = &mut lane[j];
                let nd = l.node;
                let k = ((l.path >> (2 * (l.levels - 1 - l.level))) & 3) as usize;
                let Some((w, sum)) = weights_of(evals[j], nd, l.root, l.pmf, l.floor) else {
                    emit(l.item, 0.0);
                    imp[j] = None;
                    idle |= 1 << j;
                    continue;
                };
                l.pmf *= w.to_array()[k] / sum;
                l.root = false;
                l.level += 1;
                let answer = match nd.child(k) {
                    Child::Node(c) if l.level < l.levels => match self.nodes.get(c as usize) {
                        Some(next) => {
                            if PREFETCH {
                                crate::prefetch::prefetch(next);
                            }
                            l.node = next;
                            continue;
                        }
                        None => 0.0,
                    },
                    Child::Leaf(i)
                        if l.level == l.levels && self.leaf_light(i) == Some(l.light) =>
                    {
                        l.pmf
                    }
                    _ => 0.0,
                };
                emit(l.item, answer);
                imp[j] = None;
                idle |= 1 << j;
            }
            if !PREFETCH {
                touch_lanes(&imp, |j| lane[j].node);
            }
        }
    }

    /// The probability that [`LightTree::sample`] returns `light` at the shading point of
    /// `imp`: exactly the pmf it reports. 0 for lights not in the tree or out of range.
    pub fn pmf<I: Importance + ?Sized>(&self, imp: &I, light: u32) -> f32 {
        if !self.infinite.is_empty() {
            return self.pmf_with_infinite(imp, light);
        }
        let path = self.path(light);
        self.pmf_from(
            imp,
            &WalkStart {
                node: 0,
                root: true,
                path,
                from_level: 0,
                light,
                floor: MIN_PMF,
            },
        )
    }

    /// The pmf of `walk.light` (whose path is `walk.path`) relative to node `walk.node`, which
    /// its path reaches after `walk.from_level` levels: [`LightTree::descend_from`]'s pmf for
    /// it (with the same root flag and floor).
    /// With the feature `prefetch`, the next node of the path is prefetched as soon as it is
    /// known.
    pub(crate) fn pmf_from<I: Importance + ?Sized>(&self, imp: &I, walk: &WalkStart) -> f32 {
        let WalkStart {
            node: start,
            root: is_root,
            path,
            from_level,
            light,
            floor,
        } = *walk;
        let levels = path_len(path);
        let mut index = start as usize;
        let mut pmf = 1.0f32;
        for level in from_level..levels {
            let k = ((path >> (2 * (levels - 1 - level))) & 3) as usize;
            let Some(node) = self.nodes.get(index) else {
                return 0.0;
            };
            let child = node.child(k);
            if PREFETCH {
                if let Child::Node(c) = child {
                    if let Some(next) = self.nodes.get(c as usize) {
                        crate::prefetch::prefetch(next);
                    }
                }
            }
            let Some((w, sum)) = weights(imp, node, is_root && level == from_level, pmf, floor)
            else {
                return 0.0;
            };
            pmf *= w.to_array()[k] / sum;
            match child {
                Child::Node(c) => index = c as usize,
                Child::Leaf(i) if level + 1 == levels && self.leaf_light(i) == Some(light) => {
                    return pmf
                }
                _ => return 0.0,
            }
        }
        0.0
    }
}

#[cfg(test)]
mod tests;
