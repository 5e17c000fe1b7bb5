//! Sampling a light by tree descent with one warped uniform number, and the exact pmf of any
//! light (the forum post that introduced light-tree sampling; docs/formulas.md, section 12).
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

use crate::importance::Importance;
use crate::tree::{path_len, LightTree, Node4, Slot, EMPTY_SLOT, LEAF_BIT};

/// Descents [`LightTree::descend_lanes`] interleaves.
pub(crate) const LANES: usize = 4;

/// A sampled light and the probability of having chosen it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Index of the light in the slice the tree was built from.
    pub light: u32,
    /// Probability of this choice: finite, at most 1 and at least [`MIN_PMF`].
    pub pmf: f32,
}

/// The smallest pmf a sampled light has: f32's smallest normal number (2⁻¹²⁶). A light whose
/// probability would be smaller is never sampled (see the module documentation).
pub const MIN_PMF: f32 = f32::MIN_POSITIVE;

/// The largest f32 below 1.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

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
) -> Option<([f32; 4], f32)> {
    let w = imp.eval4(node).to_array();
    let sum = w[0] + w[1] + w[2] + w[3];
    if sum > 0.0 && sum < f32::INFINITY {
        return Some(admit(w, sum, reach, floor));
    }
    if root {
        return None;
    }
    let e = node.energy;
    let sum = e[0] + e[1] + e[2] + e[3];
    if sum > 0.0 && sum < f32::INFINITY {
        return Some(admit(e, sum, reach, floor));
    }
    None
}

/// The weights a descent picks from, given the raw weights `w` with finite positive sum `sum`
/// at a node reached with probability `reach` (≥ `floor`): a slot whose probability
/// `reach · w_k / sum` would be below `floor` (or whose weight is not positive) gets weight
/// 0, and the others renormalise; if none is left, the slot of largest weight alone (the
/// first of equal ones). Every slot left then has `reach · w_k / sum' ≥ floor`, so the
/// descent's pmf never drops below `floor`. When every positive slot passes, `(w, sum)` is
/// returned unchanged.
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

/// Picks slot k with probability `w[k] / sum` from `u` in [0, 1) and returns it with `u`
/// rescaled into [0, 1). A slot of weight 0 is never picked. Branch-free: k counts the
/// prefix sums at or below `u · sum` (a zero-weight slot repeats its predecessor's prefix sum,
/// so it is skipped), clamped to the last positive slot against rounding.
#[inline(always)]
pub(crate) fn pick(w: [f32; 4], sum: f32, u: f32) -> (usize, f32) {
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
    (k, ((t - before) / w[k]).clamp(0.0, ONE_MINUS_EPSILON))
}

/// Loads the first word of each cache line of the child nodes of `node`, so that their memory
/// latency overlaps the evaluation of `node` (the core has no `unsafe`, so no prefetch
/// intrinsic). Returns a value to be fed to `black_box`.
#[inline(always)]
fn touch_children(nodes: &[Node4], node: &Node4) -> u32 {
    let mut t = 0u32;
    for &c in &node.child {
        if c & LEAF_BIT == 0 {
            if let Some(n) = nodes.get(c as usize) {
                t ^= n.center_x[0].to_bits() ^ n.energy[0].to_bits();
            }
        }
    }
    t
}

impl LightTree {
    /// Samples a light at the shading point of `imp` with the uniform number `u` in [0, 1)
    /// (clamped into it). `None` when no light can contribute (the root's importance is 0).
    #[inline]
    pub fn sample<I: Importance + ?Sized>(&self, imp: &I, u: f32) -> Option<LightSample> {
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
    ) -> Option<LightSample> {
        let mut u = sanitize(u);
        let mut node = self.nodes.get(start)?;
        let mut touched = touch_children(&self.nodes, node);
        let mut pmf = 1.0f32;
        let (mut w, mut sum) = weights(imp, node, is_root, pmf, floor)?;
        loop {
            let (k, next_u) = pick(w, sum, u);
            pmf *= w[k] / sum;
            u = next_u;
            match node.slot(k) {
                Slot::Light(light) => {
                    core::hint::black_box(touched);
                    return Some(LightSample { light, pmf });
                }
                Slot::Node(c) => {
                    node = self.nodes.get(c as usize)?;
                    touched ^= touch_children(&self.nodes, node);
                    (w, sum) = weights(imp, node, false, pmf, floor)?;
                }
                Slot::Empty => return None,
            }
        }
    }

    /// Up to [`LANES`] descents from inner nodes, interleaved: `starts[j] = (node, u)`, and
    /// `out[j]` gets exactly what `descend_from(imp, node, false, u, MIN_PMF)` returns.
    ///
    /// One descent is a chain of dependent steps (a node's importances decide which node is
    /// read next), so a core runs it far below its throughput. Taking a level of every
    /// descent in turn gives it independent work to overlap. Each lane's step is branch-free
    /// up to the test that its light has been reached.
    pub(crate) fn descend_lanes<I: Importance + ?Sized>(
        &self,
        imp: &I,
        starts: &[(u32, f32)],
        out: &mut [Option<LightSample>],
    ) {
        let n = starts.len().min(out.len()).min(LANES);
        let mut node = [0usize; LANES];
        let mut u = [0f32; LANES];
        let mut pmf = [1f32; LANES];
        let mut live = 0u32;
        let mut touched = 0u32;
        for j in 0..n {
            out[j] = None;
            if (starts[j].0 as usize) < self.nodes.len() {
                node[j] = starts[j].0 as usize;
                u[j] = sanitize(starts[j].1);
                live |= 1 << j;
            }
        }
        while live != 0 {
            for j in 0..n {
                if live & (1 << j) == 0 {
                    continue;
                }
                let nd = &self.nodes[node[j]];
                touched ^= touch_children(&self.nodes, nd);
                // Below the start every node has a weight (`false`: never the root case).
                let Some((w, sum)) = weights(imp, nd, false, pmf[j], MIN_PMF) else {
                    live &= !(1 << j);
                    continue;
                };
                let (k, next_u) = pick(w, sum, u[j]);
                pmf[j] *= w[k] / sum;
                u[j] = next_u;
                let c = nd.child[k];
                if c & LEAF_BIT == 0 && (c as usize) < self.nodes.len() {
                    node[j] = c as usize;
                } else {
                    if c != EMPTY_SLOT && c & LEAF_BIT != 0 {
                        out[j] = Some(LightSample {
                            light: c & !LEAF_BIT,
                            pmf: pmf[j],
                        });
                    }
                    live &= !(1 << j);
                }
            }
        }
        core::hint::black_box(touched);
    }

    /// Up to [`LANES`] pmf walks, interleaved as [`LightTree::descend_lanes`] interleaves
    /// descents: `walks[j] = (node, path, from_level, light, floor)`, and `out[j]` gets exactly
    /// `pmf_from(imp, node, false, path, from_level, light, floor)`.
    pub(crate) fn pmf_lanes<I: Importance + ?Sized>(
        &self,
        imp: &I,
        walks: &[(u32, u64, u32, u32, f32)],
        out: &mut [f32],
    ) {
        let n = walks.len().min(out.len()).min(LANES);
        let mut node = [0usize; LANES];
        let mut level = [0u32; LANES];
        let mut levels = [0u32; LANES];
        let mut live = 0u32;
        for j in 0..n {
            let (start, path, from, _, _) = walks[j];
            out[j] = 1.0;
            node[j] = start as usize;
            level[j] = from;
            levels[j] = path_len(path);
            if from < levels[j] {
                live |= 1 << j;
            } else {
                out[j] = 0.0;
            }
        }
        while live != 0 {
            for j in 0..n {
                if live & (1 << j) == 0 {
                    continue;
                }
                let (_, path, _, light, floor) = walks[j];
                let k = ((path >> (2 * (levels[j] - 1 - level[j]))) & 3) as usize;
                let Some(nd) = self.nodes.get(node[j]) else {
                    out[j] = 0.0;
                    live &= !(1 << j);
                    continue;
                };
                let Some((w, sum)) = weights(imp, nd, false, out[j], floor) else {
                    out[j] = 0.0;
                    live &= !(1 << j);
                    continue;
                };
                out[j] *= w[k] / sum;
                level[j] += 1;
                match nd.slot(k) {
                    Slot::Node(c) if level[j] < levels[j] => node[j] = c as usize,
                    Slot::Light(l) if l == light && level[j] == levels[j] => live &= !(1 << j),
                    _ => {
                        out[j] = 0.0;
                        live &= !(1 << j);
                    }
                }
            }
        }
    }

    /// The probability that [`LightTree::sample`] returns `light` at the shading point of
    /// `imp`: exactly the pmf it reports. 0 for lights not in the tree or out of range.
    pub fn pmf<I: Importance + ?Sized>(&self, imp: &I, light: u32) -> f32 {
        let Some(&path) = self.paths.get(light as usize) else {
            return 0.0;
        };
        self.pmf_from(imp, 0, true, path, 0, light, MIN_PMF)
    }

    /// The pmf of `light` (whose path is `path`) relative to node `start`, which its path
    /// reaches after `from_level` levels: [`LightTree::descend_from`]'s pmf for it (with the
    /// same `is_root` and `floor`).
    #[allow(clippy::too_many_arguments)] // the walk's state, as `descend_from` takes it
    pub(crate) fn pmf_from<I: Importance + ?Sized>(
        &self,
        imp: &I,
        start: usize,
        is_root: bool,
        path: u64,
        from_level: u32,
        light: u32,
        floor: f32,
    ) -> f32 {
        let levels = path_len(path);
        let mut index = start;
        let mut pmf = 1.0f32;
        for level in from_level..levels {
            let k = ((path >> (2 * (levels - 1 - level))) & 3) as usize;
            let Some(node) = self.nodes.get(index) else {
                return 0.0;
            };
            let Some((w, sum)) = weights(imp, node, is_root && level == from_level, pmf, floor)
            else {
                return 0.0;
            };
            pmf *= w[k] / sum;
            match node.slot(k) {
                Slot::Node(c) => index = c as usize,
                Slot::Light(l) if l == light && level + 1 == levels => return pmf,
                _ => return 0.0,
            }
        }
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pick_never_takes_zero_slots() {
        let cases = [
            [0.0, 1.0, 0.0, 2.0],
            [3.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 1e-30],
            [1e-30, 1e30, 0.0, 0.0],
        ];
        for w in cases {
            let sum = w[0] + w[1] + w[2] + w[3];
            for u in [0.0, 1e-9, 0.25, 0.5, 0.999, ONE_MINUS_EPSILON] {
                let (k, u2) = pick(w, sum, u);
                assert!(w[k] > 0.0, "w={w:?} u={u} picked {k}");
                assert!((0.0..1.0).contains(&u2), "w={w:?} u={u}: u'={u2}");
            }
        }
    }

    #[test]
    fn pick_warps_uniformly() {
        let w = [1.0, 2.0, 0.0, 1.0];
        let (k, u2) = pick(w, 4.0, 0.5);
        assert_eq!(k, 1);
        assert!((u2 - 0.5).abs() < 1e-6);
        let (k, u2) = pick(w, 4.0, 0.875);
        assert_eq!(k, 3);
        assert!((u2 - 0.5).abs() < 1e-6);
    }

    #[test]
    fn admit_drops_vanishing_slots() {
        let m = MIN_PMF;
        // Nothing to drop: unchanged.
        let w = [1.0, 2.0, 0.0, 3.0];
        assert_eq!(admit(w, 6.0, 1.0, m), (w, 6.0));
        // A share below MIN_PMF, and a negative weight, get 0; the rest renormalise.
        let w = [1.0, 1e-40, -2.0, 1.0];
        assert_eq!(
            admit(w, w[0] + w[1] + w[2] + w[3], 1.0, m),
            ([1.0, 0.0, 0.0, 1.0], 2.0)
        );
        // The path probability counts: at reach 1e-30 a share of 1e-10 is too small.
        let w = [1.0, 1e-10, 0.0, 0.0];
        assert_eq!(admit(w, 1.0, 1e-30, m), ([1.0, 0.0, 0.0, 0.0], 1.0));
        // No slot passes: the largest alone, with probability 1.
        let w = [1.0, 3.0, 3.0, 2.0];
        assert_eq!(admit(w, 9.0, 2.0 * m, m), ([0.0, 3.0, 0.0, 0.0], 3.0));
    }

    #[test]
    fn sanitize_clamps() {
        assert_eq!(sanitize(f32::NAN), 0.0);
        assert_eq!(sanitize(-1.0), 0.0);
        assert_eq!(sanitize(1.0), ONE_MINUS_EPSILON);
        const { assert!(ONE_MINUS_EPSILON < 1.0) };
    }
}
