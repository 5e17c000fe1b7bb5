//! Collapse of the binary SAOH tree into 4-wide [`Node4`]s, and their quantisation.
//!
//! **Which clusters become slots.** A dynamic programme over the binary tree chooses, for
//! every node, the slots that cover its subtree, minimising `Σ_nodes (NODE_WEIGHT + lights
//! under the node)`: the number of nodes (the memory a tree takes) traded against the sum of
//! all lights' depths. Slots are binary clusters, opened costlier child first on ties, as
//! wide-BVH collapsing does; and, with [`crate::BuildOptions::compact`], a subtree of at most
//! [`FREE_MAX`] lights may instead be packed free-form, its lights (in the binary tree's
//! left-to-right order, which keeps neighbours together) grouped into consecutive runs so that
//! its nodes are full — the binary tree alone leaves many nodes of two or three lights at the
//! bottom.
//!
//! **What the slots store.** The nodes are laid out top-down (the inner children of a node
//! consecutive, its lights consecutive in the leaf array), and each is quantised as soon as
//! its children are: a light slot bounds the light's exact bounds, an inner slot the exact
//! bounds of the lights below it (the binary cluster's sphere and cone, or those enclosing a
//! free-form run's lights) and the sum of their energies, each rounded outwards by
//! `quantize`. Rounding never compounds: a slot need not contain its child's slots, only the
//! lights below it.
//!
//! **Memory.** The binary tree's leaves are contiguous per subtree, so a free-form run is a
//! range of them. Only inner binary nodes have a plan (16 bytes). The layout and the
//! quantisation are one depth-first walk that returns each node's energy sums to its parent,
//! so nothing per node is kept besides the finished arrays. The leaf entries are written
//! straight into their packed width (known from the light count); the paths, whose width
//! depends on the depth, are written by one walk of the finished tree
//! ([`LightTree::with_paths`]).

use super::saoh::{children, BinNode, BinTree};
use super::Join;
use crate::bounds::{Cone, Sphere};
use crate::error::BuildError;
use crate::packed::{index_bits, Packed};
use crate::quantize;
use crate::tree::{LightTree, Node4, MAX_DEPTH};
use alloc::vec::Vec;
use bytemuck::Zeroable;

/// Weight of one node against one level of one light's path in the collapse objective
/// `Σ_nodes (NODE_WEIGHT + lights under the node)`.
const NODE_WEIGHT: u64 = 8;

/// Largest subtree (in lights) the collapse may pack free-form.
pub(crate) const FREE_MAX: usize = 16;

/// `split` value of a free-form cover.
const FREE: u8 = u8::MAX;

/// The free-form packing of a run of `m ≤ FREE_MAX` consecutive lights into at most `k`
/// slots: `cost[m][k]` of the objective, `first[m][k]` the number of lights the first slot
/// takes (a run of more than one light becomes a node packed the same way with 4 slots).
struct FreeTable {
    cost: [[u64; 5]; FREE_MAX + 1],
    first: [[u8; 5]; FREE_MAX + 1],
}

impl FreeTable {
    fn new() -> FreeTable {
        let mut t = FreeTable {
            cost: [[0; 5]; FREE_MAX + 1],
            first: [[1; 5]; FREE_MAX + 1],
        };
        for m in 2..=FREE_MAX {
            // k ≥ 2 first (it only needs shorter runs), then k = 1: one node of all m.
            for k in 2..=4 {
                let mut best = (u64::MAX, 1u8);
                for s in 1..m {
                    let c = t.cost[s][1].saturating_add(t.cost[m - s][k - 1]);
                    if c < best.0 {
                        best = (c, s as u8);
                    }
                }
                t.cost[m][k] = best.0;
                t.first[m][k] = best.1;
            }
            let one = NODE_WEIGHT + m as u64 + t.cost[m][4];
            t.cost[m][1] = one;
            t.first[m][1] = m as u8;
            for k in 2..=4 {
                if one < t.cost[m][k] {
                    t.cost[m][k] = one;
                    t.first[m][k] = m as u8;
                }
            }
        }
        t
    }
}

/// Per inner binary node, the result of the collapse's dynamic programme: `g(k)` is the
/// objective below a set of at most `k` slots covering the node's subtree (`g(1)`: the node
/// kept as one slot), and `split(k)` how that set is formed (0 = keep the node as one slot,
/// `j` = open it, giving `j` slots to the left child and `k − j` to the right, [`FREE`] =
/// free-form); `own_free`: the node's own 4 slots, when it is one node, are free-form. A leaf
/// has no plan: its `g` and `split` are all 0.
///
/// Packed into 16 bytes: `g(2)`, `g(3)`, `g(4)` as 40-bit numbers in bits 0–119, the splits
/// for k = 2, 3, 4 in 2, 2 and 3 bits (bits 120–126, [`FREE`] as all ones) and `own_free` in
/// bit 127. `g(1)` is `g(4) + NODE_WEIGHT + count` (the node as a 4-wide node of its own takes
/// its best 4-slot cover), so it is not stored. Every `g` is at most the root's `g(1)`, which
/// is at most `Σ_inner (NODE_WEIGHT + count) ≤ (NODE_WEIGHT + MAX_DEPTH) · n < 2^37` for
/// `n < 2^31` lights, so 40 bits always hold it.
#[derive(Clone, Copy, Default, Zeroable)]
struct Plan(u128);

const G_BITS: u32 = 40;
const G_MASK: u64 = (1 << G_BITS) - 1;

/// (shift, mask) of `split(k)` for k = 2, 3, 4.
const SPLIT_FIELDS: [(u32, u8); 3] = [(120, 3), (122, 3), (124, 7)];

impl Plan {
    /// `g` holds `g(2), g(3), g(4)`, `split` the splits for k = 2, 3, 4.
    fn new(g: [u64; 3], split: [u8; 3], own_free: bool) -> Plan {
        debug_assert!(g.iter().all(|&v| v <= G_MASK));
        debug_assert!(split[0] <= 1 || split[0] == FREE);
        debug_assert!(split[1] <= 2 || split[1] == FREE);
        debug_assert!(split[2] <= 3 || split[2] == FREE);
        let mut p = 0u128;
        for (i, &v) in g.iter().enumerate() {
            p |= u128::from(v & G_MASK) << (G_BITS * i as u32);
        }
        for (&s, &(shift, mask)) in split.iter().zip(&SPLIT_FIELDS) {
            p |= u128::from(s & mask) << shift;
        }
        p |= u128::from(own_free) << 127;
        Plan(p)
    }

    /// `g(k)` for `k` in 2..=4.
    #[inline]
    fn g(self, k: usize) -> u64 {
        (self.0 >> (G_BITS * (k as u32 - 2))) as u64 & G_MASK
    }

    /// `split(k)` for `k` in 2..=4 ([`FREE`] for a free-form cover).
    #[inline]
    fn split(self, k: usize) -> u8 {
        let (shift, mask) = SPLIT_FIELDS[k - 2];
        let s = (self.0 >> shift) as u8 & mask;
        if s == mask {
            FREE
        } else {
            s
        }
    }

    /// Whether the node's own 4 slots are free-form.
    #[inline]
    fn own_free(self) -> bool {
        self.0 >> 127 != 0
    }
}

/// `g(k)` of binary node `b` for `k` in 1..=4 (index 0 unused).
#[inline]
fn g_of(bin: &[BinNode], plans: &[Plan], b: usize) -> [u64; 5] {
    g_with(bin, b, plans.get(b).copied().unwrap_or_default())
}

/// `g(k)` of binary node `b` whose plan (when it is an inner node) is `p`.
#[inline]
fn g_with(bin: &[BinNode], b: usize, p: Plan) -> [u64; 5] {
    if bin[b].light().is_some() {
        return [0; 5];
    }
    let g4 = p.g(4);
    [
        0,
        g4 + NODE_WEIGHT + u64::from(bin[b].count),
        p.g(2),
        p.g(3),
        g4,
    ]
}

/// Subtrees of at least this many lights have their two halves (planning) or their children
/// (laying out) done as the [`Join`]'s two halves.
const PARALLEL_MIN: usize = 1 << 14;

/// Computes the plans bottom-up (children follow their parent among the inner nodes, and
/// leaves come last), the two subtrees of a large node as `join`'s two halves. Opening is
/// preferred on ties, so the tree stays shallow; among equal counts, the split giving the
/// costlier child more slots wins; a free-form cover is taken only when strictly cheaper than
/// the binary one.
fn plan<J: Join>(bin: &[BinNode], free: &FreeTable, free_max: usize, join: &J) -> Vec<Plan> {
    let inner = bin.len() / 2;
    // Zeroed, so that its pages are first touched by the threads that plan.
    let mut plans: Vec<Plan> = bytemuck::zeroed_vec(inner);
    if inner > 0 {
        plan_sub(bin, free, free_max, &mut plans, 0, join);
    }
    plans
}

/// The plans of the inner nodes of the subtree of inner node `root`: `plans[i]` is that of
/// node `root + i` (the subtree's inner nodes are contiguous from its root).
fn plan_sub<J: Join>(
    bin: &[BinNode],
    free: &FreeTable,
    free_max: usize,
    plans: &mut [Plan],
    root: usize,
    join: &J,
) {
    let n = plans.len() + 1;
    if n < PARALLEL_MIN {
        for b in (root..root + plans.len()).rev() {
            let (l, r) = children(bin, b);
            let of = |c: usize| plans.get(c.wrapping_sub(root)).copied().unwrap_or_default();
            plans[b - root] = node_plan(bin, free, free_max, b, of(l), of(r));
        }
        return;
    }
    let (l, r) = children(bin, root);
    // The left subtree's inner nodes follow the root, then the right one's.
    let mid = bin[l].count as usize;
    let (me, below) = plans.split_at_mut(1);
    let (pl, pr) = below.split_at_mut(mid - 1);
    join.join(
        || {
            if !pl.is_empty() {
                plan_sub(bin, free, free_max, pl, l, join);
            }
        },
        || {
            if !pr.is_empty() {
                plan_sub(bin, free, free_max, pr, r, join);
            }
        },
    );
    let first = |p: &[Plan]| p.first().copied().unwrap_or_default();
    me[0] = node_plan(bin, free, free_max, root, first(pl), first(pr));
}

/// The plan of inner node `b` from those of its children (ignored for a leaf).
fn node_plan(
    bin: &[BinNode],
    free: &FreeTable,
    free_max: usize,
    b: usize,
    plan_l: Plan,
    plan_r: Plan,
) -> Plan {
    {
        let (l, r) = children(bin, b);
        let (pl, pr) = (g_with(bin, l, plan_l), g_with(bin, r, plan_r));
        let left_costlier = bin[l].cost >= bin[r].cost;
        let best_open = |k: usize| -> (u64, u8) {
            let mut best = (u64::MAX, 0u8);
            for j in 1..k {
                let c = pl[j].saturating_add(pr[k - j]);
                let better =
                    c < best.0 || (c == best.0 && left_costlier == (j > usize::from(best.1)));
                if better {
                    best = (c, j as u8);
                }
            }
            best
        };
        let m = bin[b].count as usize;
        let free_cost = |k: usize| {
            if m <= free_max {
                free.cost[m][k]
            } else {
                u64::MAX
            }
        };
        let open4 = best_open(4);
        let own_free = free_cost(4) < open4.0;
        let own = open4
            .0
            .min(free_cost(4))
            .saturating_add(NODE_WEIGHT + u64::from(bin[b].count));
        let mut g = [0u64; 3];
        let mut split = [0u8; 3];
        for k in 2..=4 {
            let (mut open, mut j) = if k == 4 { open4 } else { best_open(k) };
            if free_cost(k) < open {
                (open, j) = (free_cost(k), FREE);
            }
            if open <= own {
                g[k - 2] = open;
                split[k - 2] = j;
            } else {
                g[k - 2] = own;
            }
        }
        debug_assert_eq!(g[2] + NODE_WEIGHT + u64::from(bin[b].count), own);
        Plan::new(g, split, own_free)
    }
}

/// A run of consecutive binary leaves (`len` of them from index `start` of the binary tree)
/// packed free-form.
#[derive(Clone, Copy)]
struct Run {
    start: u32,
    len: u32,
}

/// What becomes one slot.
#[derive(Clone, Copy)]
enum Src {
    /// A binary node (a leaf, or an inner node that becomes a node of its own).
    Bin(usize),
    /// A free-form run of two or more lights, a node of its own.
    Run(Run),
}

/// The binary leaves of subtree `b` (at most [`FREE_MAX`] lights), left to right.
fn run_of(bin: &[BinNode], b: usize) -> Run {
    let n = &bin[b];
    debug_assert!(n.count as usize <= FREE_MAX);
    Run {
        start: (bin.len() / 2 + n.first()) as u32,
        len: n.count,
    }
}

/// Appends the slots of the free-form cover of `run` with at most `k` slots.
fn free_slots(free: &FreeTable, run: Run, k: usize, out: &mut ([Src; 4], usize)) {
    let len = run.len as usize;
    let mut start = 0;
    let mut k = k;
    while start < len {
        let m = len - start;
        let s = usize::from(free.first[m][k]).clamp(1, m);
        out.0[out.1] = if s == 1 {
            Src::Bin(run.start as usize + start)
        } else {
            Src::Run(Run {
                start: run.start + start as u32,
                len: s as u32,
            })
        };
        out.1 += 1;
        start += s;
        k = k.saturating_sub(1).max(1);
    }
}

/// Appends to `out` the slots that cover binary node `b` with at most `k` slots.
fn frontier(
    bin: &[BinNode],
    plans: &[Plan],
    free: &FreeTable,
    b: usize,
    k: usize,
    out: &mut ([Src; 4], usize),
) {
    let j = if k >= 2 && bin[b].light().is_none() {
        plans[b].split(k)
    } else {
        0
    };
    match j {
        0 => {
            out.0[out.1] = Src::Bin(b);
            out.1 += 1;
        }
        FREE => free_slots(free, run_of(bin, b), k, out),
        j => {
            let j = usize::from(j);
            let (l, r) = children(bin, b);
            frontier(bin, plans, free, l, j, out);
            frontier(bin, plans, free, r, k - j, out);
        }
    }
}

/// The up-to-four slots of the node that inner binary node `b` becomes.
fn open(bin: &[BinNode], plans: &[Plan], free: &FreeTable, b: usize) -> ([Src; 4], usize) {
    let mut out = ([Src::Bin(0); 4], 0usize);
    if plans[b].own_free() {
        free_slots(free, run_of(bin, b), 4, &mut out);
        return out;
    }
    let (l, r) = children(bin, b);
    let (gl, gr) = (g_of(bin, plans, l), g_of(bin, plans, r));
    let mut best = (u64::MAX, 1);
    for j in 1..4 {
        let c = gl[j].saturating_add(gr[4 - j]);
        if c < best.0 {
            best = (c, j);
        }
    }
    frontier(bin, plans, free, l, best.1, &mut out);
    frontier(bin, plans, free, r, 4 - best.1, &mut out);
    out
}

/// The exact bounds of what `src` covers: a binary node's sphere and cone, or for a free-form
/// run the sphere enclosing its lights' and the union of their cones.
fn exact_of(bin: &[BinNode], src: Src) -> (Sphere, Cone) {
    match src {
        Src::Bin(b) => (bin[b].bounds.sphere, bin[b].bounds.cone),
        Src::Run(run) => {
            let leaves = &bin[run.start as usize..(run.start + run.len) as usize];
            let mut spheres = [Sphere::enclosing(&[]); FREE_MAX];
            let mut cone: Option<Cone> = None;
            for (s, leaf) in spheres.iter_mut().zip(leaves) {
                *s = leaf.bounds.sphere;
                cone = Some(cone.map_or(leaf.bounds.cone, |c| c.union(leaf.bounds.cone)));
            }
            (
                Sphere::enclosing(&spheres[..leaves.len()]),
                cone.unwrap_or(Cone::SPHERE),
            )
        }
    }
}

/// What a slot's parent needs of the lights below it: their number and the sums of their
/// energies and squared energies (in f64, summed in slot order).
#[derive(Clone, Copy)]
struct Sums {
    count: u32,
    energy: f64,
    energy_sq: f64,
}

/// One slot's exact bounds and the sums of its lights.
#[derive(Clone, Copy)]
struct Part {
    sphere: Sphere,
    cone: Cone,
    energy: f32,
    sums: Sums,
}

/// The bits of a cone, what [`quantize::encode_cone`] reads.
fn cone_key(c: &Cone) -> [u32; 5] {
    [
        c.axis.x.to_bits(),
        c.axis.y.to_bits(),
        c.axis.z.to_bits(),
        c.theta_o.to_bits(),
        c.theta_e.to_bits(),
    ]
}

/// [`quantize::encode_cone`] with its codes of [`Cone::SPHERE`] (the cone of every
/// omnidirectional light and of most clusters above them) and of the last cone it coded
/// kept: the same words, without the trigonometry for repeated cones.
struct ConeCodes {
    sphere: ([u32; 5], u32),
    last: ([u32; 5], u32),
}

impl ConeCodes {
    fn new() -> ConeCodes {
        let sphere = (
            cone_key(&Cone::SPHERE),
            quantize::encode_cone(&Cone::SPHERE),
        );
        ConeCodes {
            sphere,
            last: sphere,
        }
    }

    #[inline]
    fn code(&mut self, c: &Cone) -> u32 {
        let key = cone_key(c);
        if key == self.sphere.0 {
            return self.sphere.1;
        }
        if key != self.last.0 {
            self.last = (key, quantize::encode_cone(c));
        }
        self.last.1
    }
}

struct Collapser<'a> {
    bin: &'a [BinNode],
    plans: &'a [Plan],
    free: &'a FreeTable,
    cones: ConeCodes,
    nodes: Vec<Node4>,
    variances: Vec<u16>,
    leaves: Packed,
    /// Light slots written so far.
    n_leaves: usize,
    depth: u32,
}

impl<'a> Collapser<'a> {
    /// An empty layout for `lights` light slots of `bits` bits each.
    fn new(
        bin: &'a [BinNode],
        plans: &'a [Plan],
        free: &'a FreeTable,
        lights: usize,
        bits: u32,
    ) -> Collapser<'a> {
        Collapser {
            bin,
            plans,
            free,
            cones: ConeCodes::new(),
            nodes: Vec::with_capacity(2 * lights / 5 + 1),
            variances: Vec::with_capacity(2 * lights / 5 + 1),
            leaves: Packed::zeros(lights, bits),
            n_leaves: 0,
            depth: 0,
        }
    }

    /// The layout of the subtree of `src` alone, as [`collapse`] lays out a whole tree: its
    /// node at index 0 (at `level`), then its descendants, its lights from 0.
    fn subtree<J: Join>(&self, src: Src, level: u32, join: &J) -> Result<(Self, Sums), BuildError> {
        let lights = match src {
            Src::Bin(b) => self.bin[b].count as usize,
            Src::Run(run) => run.len as usize,
        };
        let mut sub = Collapser::new(self.bin, self.plans, self.free, lights, self.leaves.bits());
        sub.nodes.push(Node4::EMPTY);
        sub.variances.push(0);
        let sums = sub.fill(0, src, level, join)?;
        Ok((sub, sums))
    }

    /// The layouts of the subtrees of `srcs` (at `level`), split over `join`.
    #[allow(clippy::type_complexity)]
    fn subtrees<J: Join>(
        &self,
        srcs: &[Src],
        level: u32,
        join: &J,
    ) -> Vec<Result<(Self, Sums), BuildError>> {
        match srcs {
            [] => return Vec::new(),
            [one] => return alloc::vec![self.subtree(*one, level, join)],
            _ => {}
        }
        let (a, b) = srcs.split_at(srcs.len() / 2);
        let (mut ra, rb) = join.join(
            || self.subtrees(a, level, join),
            || self.subtrees(b, level, join),
        );
        ra.extend(rb);
        ra
    }

    /// Appends the layout `sub` of a subtree ([`Collapser::subtree`]), its node becoming node
    /// `node`: exactly what laying it out in place would have written.
    fn append(&mut self, node: usize, sub: &Collapser<'_>) {
        // Node i ≥ 1 of `sub` lands at `base + i − 1`, its light slot j at `lights + j`.
        let base = self.nodes.len() as u32;
        let lights = self.n_leaves as u32;
        fn moved(n: &Node4, base: u32, lights: u32) -> Node4 {
            let mut n = *n;
            n.child_base = base + n.child_base - 1;
            n.leaf_base += lights;
            n
        }
        self.nodes[node] = moved(&sub.nodes[0], base, lights);
        self.variances[node] = sub.variances[0];
        self.nodes
            .extend(sub.nodes[1..].iter().map(|n| moved(n, base, lights)));
        self.variances.extend_from_slice(&sub.variances[1..]);
        debug_assert_eq!(sub.n_leaves, sub.leaves.len());
        self.leaves.fill_from(self.n_leaves, &sub.leaves);
        self.n_leaves += sub.n_leaves;
        self.depth = self.depth.max(sub.depth);
    }

    /// Lays out node `node` from `src` (an inner binary node, a free-form run, or the lone
    /// light of a one-light tree), then, depth first, its children, and quantises it. Returns
    /// the sums of its lights. The children of a node of [`PARALLEL_MIN`] lights or more are
    /// laid out apart, split over `join`, then appended in order, when `join` is parallel
    /// ([`Join::is_parallel`]); in place otherwise.
    fn fill<J: Join>(
        &mut self,
        node: usize,
        src: Src,
        level: u32,
        join: &J,
    ) -> Result<Sums, BuildError> {
        if level >= MAX_DEPTH {
            return Err(BuildError::TooDeep { depth: level + 1 });
        }
        self.depth = self.depth.max(level + 1);
        let (set, len) = match src {
            Src::Bin(b) if self.bin[b].light().is_some() => ([src; 4], 1), // a single light
            Src::Bin(b) => open(self.bin, self.plans, self.free, b),
            Src::Run(run) => {
                let mut out = ([Src::Bin(0); 4], 0usize);
                free_slots(self.free, run, 4, &mut out);
                out
            }
        };
        let parallel = join.is_parallel()
            && matches!(src, Src::Bin(b) if self.bin[b].count as usize >= PARALLEL_MIN);
        let first = self.nodes.len();
        let mut n_inner = 0;
        let mut mask = 0u8;
        let leaf_base = self.n_leaves as u32;
        for (k, &c) in set[..len].iter().enumerate() {
            match c {
                Src::Bin(b) if self.bin[b].light().is_some() => {
                    let light = self.bin[b].light().unwrap_or(0);
                    mask |= 1 << (4 + k);
                    self.leaves.set(self.n_leaves, u64::from(light));
                    self.n_leaves += 1;
                }
                _ => {
                    mask |= 1 << k;
                    n_inner += 1;
                }
            }
        }
        self.nodes.resize(first + n_inner, Node4::EMPTY);
        self.variances.resize(first + n_inner, 0);

        // The children, depth first, then this node's slots from their exact bounds.
        let mut parts = [Part {
            sphere: Sphere::enclosing(&[]),
            cone: Cone::SPHERE,
            energy: 0.0,
            sums: Sums {
                count: 0,
                energy: 0.0,
                energy_sq: 0.0,
            },
        }; 4];
        let mut idx = first;
        // The inner children's layouts, made apart when the node is large.
        let mut subs = if parallel {
            let mut inner = [Src::Bin(0); 4];
            let mut m = 0;
            for &c in &set[..len] {
                if !matches!(c, Src::Bin(b) if self.bin[b].light().is_some()) {
                    inner[m] = c;
                    m += 1;
                }
            }
            self.subtrees(&inner[..m], level + 1, join)
        } else {
            Vec::new()
        }
        .into_iter();
        for (k, &c) in set[..len].iter().enumerate() {
            parts[k] = match c {
                Src::Bin(b) if self.bin[b].light().is_some() => {
                    let n = &self.bin[b];
                    let e = f64::from(n.bounds.energy);
                    Part {
                        sphere: n.bounds.sphere,
                        cone: n.bounds.cone,
                        energy: n.bounds.energy,
                        sums: Sums {
                            count: 1,
                            energy: e,
                            energy_sq: e * e,
                        },
                    }
                }
                _ => {
                    let sums = match subs.next() {
                        Some(sub) => {
                            let (sub, sums) = sub?;
                            self.append(idx, &sub);
                            sums
                        }
                        None => self.fill(idx, c, level + 1, join)?,
                    };
                    idx += 1;
                    let (sphere, cone) = exact_of(self.bin, c);
                    Part {
                        sphere,
                        cone,
                        energy: round_up(sums.energy),
                        sums,
                    }
                }
            };
        }
        let parts = &parts[..len];

        let mut spheres = [Sphere::enclosing(&[]); 4];
        for (s, p) in spheres.iter_mut().zip(parts) {
            *s = p.sphere;
        }
        let (origin, exponent, words) = quantize::encode_spheres(&spheres[..len]);
        let (mut count, mut sum, mut sq) = (0u32, 0.0f64, 0.0f64);
        let out = &mut self.nodes[node];
        out.origin = origin;
        out.exponent = exponent;
        out.child_base = first as u32;
        out.leaf_base = leaf_base;
        out.mask = mask;
        for (k, p) in parts.iter().enumerate() {
            out.sphere[k] = words[k];
            out.cone[k] = self.cones.code(&p.cone);
            out.set_energy_code(k, quantize::encode_energy(p.energy));
            count += p.sums.count;
            sum += p.sums.energy;
            sq += p.sums.energy_sq;
        }
        let mean = sum / f64::from(count.max(1));
        let variance = if mean > 0.0 {
            ((sq / f64::from(count.max(1)) - mean * mean).max(0.0) / (mean * mean)) as f32
        } else {
            0.0
        };
        self.variances[node] = quantize::encode_bf16(variance);
        Ok(Sums {
            count,
            energy: sum,
            energy_sq: sq,
        })
    }
}

/// `x` as the smallest f32 at least `x`.
fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) < x {
        crate::math::next_up(f)
    } else {
        f
    }
}

/// Turns the binary tree into the flat, quantised 4-wide tree; `n_lights` is the length of
/// the build's input (lights absent from `bin` get path 0).
/// With `compact`, subtrees of at most [`FREE_MAX`] lights may be packed free-form.
/// The planning and the layout of large subtrees are split over `join`, and the binary tree
/// is freed as the other half of a join with the walk that writes the paths; the tree does
/// not depend on it.
pub(crate) fn collapse<J: Join>(
    bin: BinTree,
    n_lights: usize,
    compact: bool,
    join: &J,
) -> Result<LightTree, BuildError> {
    let free = FreeTable::new();
    let n_leaves = bin.nodes.len().div_ceil(2);
    let plans = plan(&bin.nodes, &free, if compact { FREE_MAX } else { 1 }, join);
    let mut c = Collapser::new(&bin.nodes, &plans, &free, n_leaves, index_bits(n_lights));
    if !bin.nodes.is_empty() {
        c.nodes.push(Node4::EMPTY);
        c.variances.push(0);
        c.fill(0, Src::Bin(0), 0, join)?;
    }
    debug_assert_eq!(c.n_leaves, n_leaves);
    let Collapser {
        nodes,
        variances,
        leaves,
        depth,
        ..
    } = c;
    let (tree, ()) = join.join(
        || LightTree::with_paths(nodes, variances, leaves, n_lights, depth),
        move || drop((bin, plans)),
    );
    Ok(tree)
}
