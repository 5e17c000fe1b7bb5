//! Binned SAOH build of a binary light tree (Conty & Kulla, "Surface Area Orientation
//! Heuristic"; docs/formulas.md, section 3).
//!
//! Light centroids are binned into `buckets` buckets on each of the three axes; every bucket
//! boundary is costed with
//! `K_r · (E_l · M_A(l) · M_Ω(l) + E_r · M_A(r) · M_Ω(r))` (the parent's `M_A · M_Ω` is the
//! same for every candidate of a node, so it is left out), and the cheapest is taken. When all
//! centroids coincide the lights are split by count. A split that would push a subtree past
//! the depth a path can encode is replaced by a split at the median, so every tree fits.
//!
//! Memory: the tree of n lights is one array of 2n − 1 [`BinNode`]s, the n − 1 inner nodes
//! first (in depth-first order), then the n leaves. The leaves are made before the build and
//! serve as its working set: they are partitioned in place, together with an array of the
//! lights' boxes (the only per-light data a leaf does not keep), and end up in left-to-right
//! order. Besides a bit per light for the partitions, nothing else is allocated per light,
//! and nothing per node but for the rare split at the median (which selects on (key, index)
//! pairs).

use super::bins::{bits, fill_bins, Acc, Bucket, Buckets, ToBucket, MAX_BUCKETS};
pub(crate) use super::node::{BinNode, NodeBounds};
use super::Join;
use crate::bounds::{Aabb, Cone, Sphere};
use crate::math::outward;
use alloc::vec::Vec;
use glam::{Vec3, Vec3A};

/// Deepest binary level allowed; the collapsed tree is never deeper than the binary one.
pub(crate) const MAX_BINARY_DEPTH: u32 = crate::tree::MAX_DEPTH;

/// The binary tree; node 0 is the root.
pub(crate) struct BinTree {
    pub nodes: Vec<BinNode>,
}

/// The children (left, right) of inner node `b` of `bin` (a whole tree).
///
/// A subtree of `c` lights has `c − 1` inner nodes, stored contiguously from its root, and its
/// leaves are contiguous from its `first`. So the left child is the next inner node when that
/// starts at the same light, else a leaf; the right child's inner root follows the left
/// child's `mid − 1` inner nodes.
#[inline]
pub(crate) fn children(bin: &[BinNode], b: usize) -> (usize, usize) {
    let leaves = bin.len() / 2; // n − 1 inner nodes precede the leaves
    let node = &bin[b];
    let first = node.first as usize;
    let next = b + 1;
    let mid = if next < leaves && bin[next].first == node.first {
        bin[next].count as usize
    } else {
        1
    };
    let left = if mid >= 2 { next } else { leaves + first };
    let right = if node.count as usize - mid >= 2 {
        b + mid
    } else {
        leaves + first + mid
    };
    (left, right)
}

/// Nodes of at most this many lights are split by sorting them on each axis and costing every
/// boundary ([`sweep_split`]); larger ones are binned.
const SWEEP_MAX: usize = 4;
// `sweep_split` sorts with a network for four.
const _: () = assert!(SWEEP_MAX == 4);

/// The build's scratch: the buckets and the side of each light in a partition (a bit per
/// light), reused by every node of one thread's part of the tree.
struct Ctx {
    buckets: usize,
    bins: Buckets,
    sides: Vec<u64>,
}

impl Ctx {
    /// The scratch for subtrees of at most `n` lights.
    fn new(buckets: usize, n: usize) -> Ctx {
        Ctx {
            buckets,
            bins: Buckets {
                acc: [[Bucket::EMPTY; MAX_BUCKETS]; 3],
                cone: [[Cone::SPHERE; MAX_BUCKETS]; 3],
                used: [0; 3],
            },
            sides: alloc::vec![0; n.div_ceil(64)],
        }
    }
}

/// Subtrees of at least this many lights are built with their two children split over the
/// [`Join`]; smaller ones on the thread that reaches them.
const PARALLEL_MIN: usize = 1 << 14;

/// The root's passes over the lights (its bounds, binning and partition) are split over the
/// [`Join`] when it has at least this many lights: nothing else runs beside them.
const ROOT_SPLIT_MIN: usize = 1 << 16;

/// [`bounds_of`], its two halves (the first a whole number of 64 lights) as `join`'s two
/// halves. A box's minimum over lights keeps the last of equal values (`min` keeps its
/// right operand on ties), and so does the minimum of the halves' minima: the result is
/// [`bounds_of`]'s, bit for bit; likewise the maxima.
fn bounds_of_split<J: Join>(boxes: &[Aabb], join: &J) -> (Aabb, Aabb) {
    let (a, b) = boxes.split_at(boxes.len() / 128 * 64);
    let ((ga, ca), (gb, cb)) = join.join(|| bounds_of(a), || bounds_of(b));
    (ga.union(gb), ca.union(cb))
}

/// Box of the geometry and box of the centroids of the lights with boxes `boxes`.
fn bounds_of(boxes: &[Aabb]) -> (Aabb, Aabb) {
    let mut geo = Aabb::EMPTY;
    let mut cbox = Aabb::EMPTY;
    for b in boxes {
        geo = geo.union(*b);
        cbox = cbox.grow_a(b.center_a());
    }
    (geo, cbox)
}

/// Builds the binary tree in `nodes`: `n − 1` placeholders followed by the `n ≥ 1` leaves,
/// `boxes[i]` the box of the light of leaf `n − 1 + i`. Leaves and boxes are reordered.
/// The two children of a node of [`PARALLEL_MIN`] lights or more are built as `join`'s two
/// halves, each on scratch of its own; the result does not depend on `join`.
pub(crate) fn build<J: Join>(nodes: &mut [BinNode], boxes: &mut [Aabb], buckets: usize, join: &J) {
    let n = boxes.len();
    debug_assert!(n >= 1 && nodes.len() == 2 * n - 1);
    let (inner, leaves) = nodes.split_at_mut(n - 1);
    let mut ctx = Ctx::new(buckets.clamp(2, MAX_BUCKETS), n);
    let (geo, cbox) = if n >= ROOT_SPLIT_MIN && join.is_parallel() {
        bounds_of_split(boxes, join)
    } else {
        bounds_of(boxes)
    };
    ctx.build_rec(inner, leaves, boxes, 0, 0, geo, cbox, join);
}

/// A chosen split: where it is and the boxes of both sides.
struct Split {
    mid: usize,
    left: (Aabb, Aabb),
    right: (Aabb, Aabb),
}

impl Ctx {
    /// Builds the subtree over `leaves` (the leaves from position `lo`, with their boxes) into
    /// `inner`, its `leaves.len() − 1` inner nodes, root first (when it has two lights or
    /// more); `geo`: box of the node's geometry, `cbox`: box of its centroids (both from the
    /// parent). Returns the sum of the lights' energies (in f64).
    #[allow(clippy::too_many_arguments)]
    fn build_rec<J: Join>(
        &mut self,
        inner: &mut [BinNode],
        leaves: &mut [BinNode],
        boxes: &mut [Aabb],
        lo: usize,
        depth: u32,
        geo: Aabb,
        cbox: Aabb,
        join: &J,
    ) -> f64 {
        let n = leaves.len();
        if n == 1 {
            leaves[0].first = lo as u32;
            return f64::from(leaves[0].bounds.energy);
        }
        let center = geo.center();
        let (split, radius) = if n <= SWEEP_MAX {
            sweep_split(leaves, boxes, depth, geo)
        } else {
            let root = (depth == 0 && n >= ROOT_SPLIT_MIN && join.is_parallel()).then_some(join);
            self.choose_split(leaves, boxes, depth, geo, cbox, root)
        };
        let mid = split.mid;
        let (ll, lr) = leaves.split_at_mut(mid);
        let (bl, br) = boxes.split_at_mut(mid);
        // The node, then the left subtree's mid − 1 inner nodes, then the right one's.
        let (node, below) = inner.split_at_mut(1);
        let (il, ir) = below.split_at_mut(mid - 1);
        let (ls, rs) = if n >= PARALLEL_MIN {
            let buckets = self.buckets;
            join.join(
                || self.build_rec(il, ll, bl, lo, depth + 1, split.left.0, split.left.1, join),
                || {
                    Ctx::new(buckets, n - mid).build_rec(
                        ir,
                        lr,
                        br,
                        lo + mid,
                        depth + 1,
                        split.right.0,
                        split.right.1,
                        join,
                    )
                },
            )
        } else {
            let ls = self.build_rec(il, ll, bl, lo, depth + 1, split.left.0, split.left.1, join);
            let rs = self.build_rec(
                ir,
                lr,
                br,
                lo + mid,
                depth + 1,
                split.right.0,
                split.right.1,
                join,
            );
            (ls, rs)
        };
        let left_cone = if mid >= 2 {
            il[0].bounds.cone
        } else {
            ll[0].bounds.cone
        };
        let right_cone = if n - mid >= 2 {
            ir[0].bounds.cone
        } else {
            lr[0].bounds.cone
        };
        let cone = left_cone.union(right_cone);
        let energy_sum = ls + rs;
        let count = n as u32;
        let energy = energy_sum as f32;
        node[0] = BinNode {
            bounds: NodeBounds {
                sphere: Sphere {
                    center,
                    // f32 distances are within a few ulps; `outward` adds 1e-6 relative.
                    radius: outward(f64::from(radius) * (1.0 + 1e-6)),
                },
                cone,
                energy,
            },
            cost: energy * geo.measure() * cone.measure_fast(),
            count,
            leaf: 0,
            first: lo as u32,
        };
        energy_sum
    }

    /// Chooses a split and partitions the lights around it. Also returns the radius of the
    /// sphere around the box centre holding every light's own sphere, found in the same pass
    /// as the bins.
    /// With `root`, the node is the root, whose passes over the lights are split over it.
    fn choose_split<J: Join>(
        &mut self,
        leaves: &mut [BinNode],
        boxes: &mut [Aabb],
        depth: u32,
        geo: Aabb,
        cbox: Aabb,
        root: Option<&J>,
    ) -> (Split, f32) {
        let center = geo.center();
        let n = leaves.len();
        let buckets = self.buckets;
        let ext = cbox.extent();
        let node_ext = geo.extent();
        // Largest child that still fits in the remaining depth.
        let remaining = MAX_BINARY_DEPTH.saturating_sub(depth + 1).min(62);
        let limit = 1usize.checked_shl(remaining).unwrap_or(usize::MAX);

        let scale = Vec3::new(
            if ext.x > 0.0 {
                buckets as f32 / ext.x
            } else {
                0.0
            },
            if ext.y > 0.0 {
                buckets as f32 / ext.y
            } else {
                0.0
            },
            if ext.z > 0.0 {
                buckets as f32 / ext.z
            } else {
                0.0
            },
        );
        let axes: [bool; 3] = [ext.x > 0.0, ext.y > 0.0, ext.z > 0.0];
        // Axes of zero extent have scale 0: everything lands in bucket 0 and the axis is skipped.
        let to_bucket = ToBucket {
            min: cbox.min,
            scale: Vec3A::from(scale),
            top: Vec3A::splat((buckets - 1) as f32),
        };
        let radius = fill_bins(&mut self.bins, leaves, boxes, &to_bucket, center, root);
        let best = self.best_boundary(axes, node_ext, limit);
        match best {
            Some((_, axis, boundary)) => {
                let (mid, lc, rc) = partition(
                    leaves,
                    boxes,
                    &mut self.sides,
                    &to_bucket,
                    axis,
                    boundary,
                    root,
                );
                debug_assert!(mid > 0 && mid < n);
                let acc = &self.bins.acc[axis];
                let side = |acc: &[Bucket]| {
                    acc.iter().fold(Aabb::EMPTY, |g, b| {
                        g.union(Aabb {
                            min: b.lo,
                            max: b.hi,
                        })
                    })
                };
                let split = Split {
                    mid,
                    left: (side(&acc[..=boundary]), lc),
                    right: (side(&acc[boundary + 1..buckets]), rc),
                };
                (split, radius)
            }
            None => {
                // No usable boundary: coincident centroids, or the depth budget forbids every
                // candidate. Split at the median of the widest centroid axis.
                let axis = if ext.x >= ext.y && ext.x >= ext.z {
                    0
                } else if ext.y >= ext.z {
                    1
                } else {
                    2
                };
                let mid = n / 2;
                select_median(leaves, boxes, axis, mid);
                (split_at(boxes, mid), radius)
            }
        }
    }

    /// The cheapest boundary of the binned node: `(cost, axis, boundary)`, boundary `i`
    /// splitting buckets `..=i` from `i + 1..`; the first of equal costs in the order axis 0
    /// to 2, boundaries from the last down. `None` when no boundary has lights on both sides
    /// within the depth budget (`limit` lights at most on either side).
    fn best_boundary(
        &self,
        axes: [bool; 3],
        node_ext: Vec3,
        limit: usize,
    ) -> Option<(f32, usize, usize)> {
        let max_ext = node_ext.max_element();
        let mut best: Option<(f32, usize, usize)> = None; // cost, axis, boundary
        for axis in 0..3 {
            if !axes[axis] {
                continue;
            }
            let (acc, cones) = (&self.bins.acc[axis], &self.bins.cone[axis]);
            // The buckets with lights. An empty bucket changes neither side, so the
            // boundaries between two buckets with lights all cost the same, and the first of
            // them in the scan (the last one) is the only one that can win.
            let mut full = [0u8; MAX_BUCKETS];
            let mut m = 0;
            for i in bits(self.bins.used[axis]) {
                full[m] = i as u8;
                m += 1;
            }
            if m < 2 {
                continue;
            }
            // Costs and counts of the left parts: the buckets up to full[t], for t < m − 1.
            // Each scan unites cones until its sum is omnidirectional, then only adds boxes
            // and energies (two loops, so that no branch depends on each bucket's kind).
            let mut left_cost = [0.0f32; MAX_BUCKETS];
            let mut left_count = [0u32; MAX_BUCKETS];
            let mut sum = Acc::EMPTY;
            let mut t = 0;
            while t < m - 1 && !sum.omni {
                let i = usize::from(full[t]);
                sum.add(&acc[i], &cones[i]);
                left_cost[t] = sum.cost();
                left_count[t] = sum.count;
                t += 1;
            }
            while t < m - 1 {
                sum.add_omni(&acc[usize::from(full[t])]);
                left_cost[t] = sum.cost_omni();
                left_count[t] = sum.count;
                t += 1;
            }
            let kr = if node_ext[axis] > 0.0 {
                max_ext / node_ext[axis]
            } else {
                1.0
            };
            let mut consider = |t: usize, right_cost: f32, right_count: u32| {
                let (nl, nr) = (left_count[t - 1] as usize, right_count as usize);
                if nl.max(nr) <= limit {
                    let cost = kr * (left_cost[t - 1] + right_cost);
                    if best.is_none_or(|b| cost < b.0) {
                        best = Some((cost, axis, usize::from(full[t]) - 1));
                    }
                }
            };
            let mut sum = Acc::EMPTY;
            let mut t = m - 1;
            while t >= 1 && !sum.omni {
                let i = usize::from(full[t]);
                sum.add(&acc[i], &cones[i]);
                consider(t, sum.cost(), sum.count);
                t -= 1;
            }
            while t >= 1 {
                sum.add_omni(&acc[usize::from(full[t])]);
                consider(t, sum.cost_omni(), sum.count);
                t -= 1;
            }
        }
        best
    }
}

/// Reorders the lights so that the one of rank `mid` by centroid on `axis` is at `mid`, the
/// ones before it no greater and the ones after it no smaller: the order
/// `select_nth_unstable_by` gives, applied to the leaves and boxes together.
fn select_median(leaves: &mut [BinNode], boxes: &mut [Aabb], axis: usize, mid: usize) {
    // The selection permutes (key, index) pairs (it depends only on the comparisons), then
    // the permutation is applied in place, cycle by cycle.
    let mut keys: Vec<(f32, u32)> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| (b.center()[axis], i as u32))
        .collect();
    keys.select_nth_unstable_by(mid, |a, b| a.0.total_cmp(&b.0));
    const DONE: u32 = u32::MAX;
    for start in 0..keys.len() {
        if keys[start].1 == DONE {
            continue;
        }
        let (leaf, aabb) = (leaves[start], boxes[start]);
        let mut cur = start;
        loop {
            let src = keys[cur].1 as usize;
            keys[cur].1 = DONE;
            if src == start {
                leaves[cur] = leaf;
                boxes[cur] = aabb;
                break;
            }
            leaves[cur] = leaves[src];
            boxes[cur] = boxes[src];
            cur = src;
        }
    }
}

/// The split of a node of at most [`SWEEP_MAX`] lights: every boundary between the lights
/// sorted on each axis is costed exactly (binning would mostly cost empty buckets), each side
/// its lights added in turn ([`Acc`]); a single light costs what its leaf does (the same
/// product).
fn sweep_split(leaves: &mut [BinNode], boxes: &mut [Aabb], depth: u32, geo: Aabb) -> (Split, f32) {
    let n = leaves.len();
    let center = geo.center();
    let mut radius = 0.0f32;
    for leaf in leaves.iter() {
        let s = &leaf.bounds.sphere;
        radius = radius.max(crate::math::length(s.center - center) + s.radius);
    }
    if n <= 2 {
        return (split_at(boxes, n / 2), radius);
    }
    let node_ext = geo.extent();
    let max_ext = node_ext.max_element();
    let remaining = MAX_BINARY_DEPTH.saturating_sub(depth + 1).min(62);
    let limit = 1usize.checked_shl(remaining).unwrap_or(usize::MAX);

    let mut centroids = [Vec3A::ZERO; SWEEP_MAX];
    for (c, b) in centroids.iter_mut().zip(boxes.iter()) {
        *c = b.center_a();
    }
    let mut best: Option<(f32, usize)> = None; // cost, left size
    let mut best_order = [0u8; SWEEP_MAX];
    for axis in 0..3 {
        // The lights sorted by centroid, ties in their order (what a stable sort by
        // `total_cmp` gives): sorting network on (key, index), the key ordered as `total_cmp`
        // orders the floats; a missing fourth light sorts last.
        let mut keys = [i64::MAX; SWEEP_MAX];
        for (i, (k, c)) in keys.iter_mut().zip(&centroids[..n]).enumerate() {
            let bits = c[axis].to_bits() as i32;
            let ordered = bits ^ (((bits >> 31) as u32) >> 1) as i32;
            *k = (i64::from(ordered) << 2) | i as i64;
        }
        for (x, y) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
            let (a, b) = (keys[x], keys[y]);
            keys[x] = a.min(b);
            keys[y] = a.max(b);
        }
        let order = keys.map(|k| (k & 3) as u8);
        let kr = if node_ext[axis] > 0.0 {
            max_ext / node_ext[axis]
        } else {
            1.0
        };
        let mut left_cost = [0.0f32; SWEEP_MAX];
        let mut acc = Acc::EMPTY;
        for i in 0..n - 1 {
            let k = usize::from(order[i]);
            acc.add_light(&leaves[k], &boxes[k]);
            left_cost[i] = if i == 0 { leaves[k].cost } else { acc.cost() };
        }
        let mut acc = Acc::EMPTY;
        for i in (0..n - 1).rev() {
            let k = usize::from(order[i + 1]);
            acc.add_light(&leaves[k], &boxes[k]);
            let nl = i + 1;
            if nl.max(n - nl) > limit {
                continue;
            }
            let right = if i == n - 2 {
                leaves[k].cost
            } else {
                acc.cost()
            };
            let cost = kr * (left_cost[i] + right);
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, nl));
                best_order = order;
            }
        }
    }
    let mid = match best {
        Some((_, nl)) => {
            let mut sorted_leaves = [BinNode::PLACEHOLDER; SWEEP_MAX];
            let mut sorted_boxes = [Aabb::EMPTY; SWEEP_MAX];
            for (k, &src) in best_order[..n].iter().enumerate() {
                sorted_leaves[k] = leaves[usize::from(src)];
                sorted_boxes[k] = boxes[usize::from(src)];
            }
            leaves.copy_from_slice(&sorted_leaves[..n]);
            boxes.copy_from_slice(&sorted_boxes[..n]);
            nl
        }
        None => n / 2,
    };
    (split_at(boxes, mid), radius)
}

/// The split of the lights with boxes `boxes` (already ordered) after the first `mid`, with
/// both sides' boxes.
fn split_at(boxes: &[Aabb], mid: usize) -> Split {
    let (l, r) = boxes.split_at(mid);
    Split {
        mid,
        left: bounds_of(l),
        right: bounds_of(r),
    }
}

/// Moves the lights whose bucket on `axis` is at most `boundary` to the front (leaves and
/// boxes together); returns how many there are and the boxes of the centroids of both parts.
///
/// The order is the one of the two-sided scan (Hoare): the k-th light from the front that
/// belongs to the back swaps with the k-th light from the back that belongs to the front,
/// while the first is before the second. Here the sides are found first, a bit per light in
/// `sides` (no branch on them), then the pairs are found a word of bits at a time and
/// swapped, as in block partitioning (Edelkamp & Weiß 2016, "BlockQuicksort", section 3).
///
/// With `split`, the sides are found as its two halves (the boxes of the centroids merged as
/// in [`bounds_of_split`]).
fn partition<J: Join>(
    leaves: &mut [BinNode],
    boxes: &mut [Aabb],
    sides: &mut [u64],
    to_bucket: &ToBucket,
    axis: usize,
    boundary: usize,
    split: Option<&J>,
) -> (usize, Aabb, Aabb) {
    // A bucket index is `(c − min) · scale` truncated (and capped at the last bucket, which
    // is above `boundary`): at most `boundary` exactly when the product is below
    // `boundary + 1`.
    let (min, scale) = (to_bucket.min[axis], to_bucket.scale[axis]);
    let below = (boundary + 1) as f32;
    let words = &mut sides[..boxes.len().div_ceil(64)];
    let find = |boxes: &[Aabb], words: &mut [u64]| match axis {
        0 => find_sides::<0>(boxes, words, min, scale, below),
        1 => find_sides::<1>(boxes, words, min, scale, below),
        _ => find_sides::<2>(boxes, words, min, scale, below),
    };
    let (lc, rc) = match split {
        Some(join) => {
            let half = boxes.len() / 128;
            let (ba, bb) = boxes.split_at(half * 64);
            let (wa, wb) = words.split_at_mut(half);
            let ((la, ra), (lb, rb)) = join.join(|| find(ba, wa), || find(bb, wb));
            (la.union(lb), ra.union(rb))
        }
        None => find(boxes, words),
    };
    (swap_sides(leaves, boxes, words), lc, rc)
}

/// Sets bit `i` of `sides` when light `i` goes to the front (and the bits past the last
/// light, so that the search for back lights stops there); returns the boxes of the centroids
/// of both parts (their minima and maxima do not depend on the order but for the sign of a
/// zero, which no use of a centroid box sees).
fn find_sides<const AXIS: usize>(
    boxes: &[Aabb],
    sides: &mut [u64],
    min: f32,
    scale: f32,
    below: f32,
) -> (Aabb, Aabb) {
    // The centroid boxes of the back (0) and front (1) parts.
    let mut part = [Aabb::EMPTY; 2];
    for (chunk, word) in boxes.chunks(64).zip(sides.iter_mut()) {
        let mut w = if chunk.len() == 64 {
            0
        } else {
            !0u64 << chunk.len()
        };
        for (k, b) in chunk.iter().enumerate() {
            let c = b.center_a();
            let front = (c[AXIS] - min) * scale < below;
            w |= u64::from(front) << k;
            let p = &mut part[usize::from(front)];
            *p = p.grow_a(c);
        }
        *word = w;
    }
    (part[1], part[0])
}

/// Swaps the lights into their sides (`sides` as [`find_sides`] sets it); returns how many
/// lights go to the front.
fn swap_sides(leaves: &mut [BinNode], boxes: &mut [Aabb], sides: &[u64]) -> usize {
    let n = boxes.len();
    // The first back light at or after `i` (`n` when none).
    let next_back = |i: usize| -> usize {
        let mut w = i / 64;
        if w == sides.len() {
            return n;
        }
        let mut m = !sides[w] & (!0u64 << (i % 64));
        while m == 0 {
            w += 1;
            if w == sides.len() {
                return n;
            }
            m = !sides[w];
        }
        w * 64 + m.trailing_zeros() as usize
    };
    // The last front light before `j` (`None` when none).
    let prev_front = |j: usize| -> Option<usize> {
        if j == 0 {
            return None;
        }
        let mut w = (j - 1) / 64;
        let mut m = sides[w] & (!0u64 >> (63 - (j - 1) % 64));
        while m == 0 {
            if w == 0 {
                return None;
            }
            w -= 1;
            m = sides[w];
        }
        Some(w * 64 + 63 - m.leading_zeros() as usize)
    };
    let (mut i, mut j) = (0, n);
    loop {
        let a = next_back(i);
        if a >= j {
            return j;
        }
        match prev_front(j) {
            Some(b) if b > a => {
                leaves.swap(a, b);
                boxes.swap(a, b);
                i = a + 1;
                j = b;
            }
            _ => return a,
        }
    }
}
