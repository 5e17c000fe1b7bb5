//! Collapse of the binary SAOH tree into 4-wide [`Node4`]s. The binary tree's clusters are
//! kept; which of them become slots of one node is chosen by a dynamic programme over the
//! binary tree that minimises the number of nodes (the memory a tree takes), opening the
//! costlier child first on ties, as wide-BVH collapsing does. Every set of slots covers its
//! node's subtree exactly, so the 4-wide tree bounds what the binary one bounds.

use super::saoh::{children, BinNode, BinTree};
use crate::error::BuildError;
use crate::quantize;
use crate::tree::{LightTree, Node4, NodeStats, LEAF_BIT, MAX_DEPTH};
use alloc::vec;
use alloc::vec::Vec;
use bytemuck::Zeroable;

struct Collapser<'a> {
    bin: &'a [BinNode],
    plans: Vec<Plan>,
    nodes: Vec<Node4>,
    stats: Vec<NodeStats>,
    paths: Vec<u64>,
    depth: u32,
}

/// Per inner binary node, the result of the collapse's dynamic programme: `g(k)` is the fewest
/// [`Node4`]s needed below a set of at most `k` slots covering the node's subtree (`g(1)`: the
/// node kept as one slot), and `split(k)` how that set is formed (0 = keep the node as one
/// slot, `j` = open it, giving `j` slots to the left child and `k − j` to the right). A leaf
/// has no plan: its `g` and `split` are all 0.
///
/// Packed into 16 bytes: `g(2)`, `g(3)`, `g(4)` as 40-bit numbers and the three splits in 5
/// bits. `g(1)` is `g(4) + NODE_WEIGHT + count` (the node as a 4-wide node of its own opens
/// its best 4-slot set), so it is not stored. Every `g` is at most the root's `g(1)`, which
/// is at most `Σ_inner (NODE_WEIGHT + count) ≤ (NODE_WEIGHT + MAX_DEPTH) · n < 2^37` for
/// `n < 2^31` lights, so 40 bits always hold it.
#[derive(Clone, Copy, Default)]
struct Plan(u128);

const G_BITS: u32 = 40;
const G_MASK: u64 = (1 << G_BITS) - 1;

impl Plan {
    /// `g` holds `g(2), g(3), g(4)`, `split` the splits for k = 2, 3, 4.
    fn new(g: [u64; 3], split: [u8; 3]) -> Plan {
        debug_assert!(g.iter().all(|&v| v <= G_MASK) && split[0] <= 1 && split[1] <= 2);
        let mut p = 0u128;
        for (i, &v) in g.iter().enumerate() {
            p |= u128::from(v & G_MASK) << (G_BITS * i as u32);
        }
        p |= u128::from(split[0] & 1) << 120;
        p |= u128::from(split[1] & 3) << 121;
        p |= u128::from(split[2] & 3) << 123;
        Plan(p)
    }

    /// `g(k)` for `k` in 2..=4.
    #[inline]
    fn g(self, k: usize) -> u64 {
        (self.0 >> (G_BITS * (k as u32 - 2))) as u64 & G_MASK
    }

    /// `split(k)` for `k` in 2..=4.
    #[inline]
    fn split(self, k: usize) -> usize {
        let (shift, mask) = [(120, 1), (121, 3), (123, 3)][k - 2];
        (self.0 >> shift) as usize & mask
    }
}

/// Weight of one node against one level of one light's path in the collapse objective
/// `Σ_nodes (NODE_WEIGHT + lights under the node)`: the second term is the sum of all
/// lights' depths, so the objective trades memory against the length of a descent.
const NODE_WEIGHT: u64 = 8;

/// `g(k)` of binary node `b` for `k` in 1..=4 (index 0 unused).
#[inline]
fn g_of(bin: &[BinNode], plans: &[Plan], b: usize) -> [u64; 5] {
    if bin[b].light.is_some() {
        return [0; 5];
    }
    let p = plans[b];
    let g4 = p.g(4);
    [
        0,
        g4 + NODE_WEIGHT + u64::from(bin[b].count),
        p.g(2),
        p.g(3),
        g4,
    ]
}

/// Computes the plans bottom-up (children follow their parent among the inner nodes, and
/// leaves come last). Opening is preferred on ties, so the tree stays shallow; among equal
/// counts, the split giving the costlier child more slots wins.
fn plan(bin: &[BinNode]) -> Vec<Plan> {
    let inner = bin.len() / 2;
    let mut plans = vec![Plan::default(); inner];
    for b in (0..inner).rev() {
        let (l, r) = children(bin, b);
        let (pl, pr) = (g_of(bin, &plans, l), g_of(bin, &plans, r));
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
        // The node as a 4-wide node of its own.
        let (open4, j4) = best_open(4);
        let own = open4.saturating_add(NODE_WEIGHT + u64::from(bin[b].count));
        let mut g = [0u64; 3];
        let mut split = [0u8; 3];
        for k in 2..=4 {
            let (open, j) = if k == 4 { (open4, j4) } else { best_open(k) };
            if open <= own {
                g[k - 2] = open;
                split[k - 2] = j;
            } else {
                g[k - 2] = own;
            }
        }
        debug_assert_eq!(g[2] + NODE_WEIGHT + u64::from(bin[b].count), own);
        plans[b] = Plan::new(g, split);
    }
    plans
}

/// Appends to `out` the slots that cover binary node `b` with at most `k` slots.
fn frontier(bin: &[BinNode], plans: &[Plan], b: usize, k: usize, out: &mut ([usize; 4], usize)) {
    let j = if k >= 2 && bin[b].light.is_none() {
        plans[b].split(k)
    } else {
        0
    };
    if j == 0 {
        out.0[out.1] = b;
        out.1 += 1;
    } else {
        let (l, r) = children(bin, b);
        frontier(bin, plans, l, j, out);
        frontier(bin, plans, r, k - j, out);
    }
}

/// The up-to-four binary descendants of inner node `b` that become one node's slots.
fn open(bin: &[BinNode], plans: &[Plan], b: usize) -> ([usize; 4], usize) {
    let (l, r) = children(bin, b);
    let (gl, gr) = (g_of(bin, plans, l), g_of(bin, plans, r));
    let mut best = (u64::MAX, 1);
    for j in 1..4 {
        let c = gl[j].saturating_add(gr[4 - j]);
        if c < best.0 {
            best = (c, j);
        }
    }
    let mut out = ([0usize; 4], 0usize);
    frontier(bin, plans, l, best.1, &mut out);
    frontier(bin, plans, r, 4 - best.1, &mut out);
    out
}

fn write_slot(node: &mut Node4, k: usize, b: &BinNode) {
    let s = &b.bounds.sphere;
    node.center_x[k] = s.center.x;
    node.center_y[k] = s.center.y;
    node.center_z[k] = s.center.z;
    node.radius[k] = s.radius;
    node.energy[k] = b.bounds.energy;
    let (axis, angles) = quantize::encode_cone(&b.bounds.cone);
    node.axis[k] = axis;
    node.angles[k] = angles;
}

fn stats_of(b: &BinNode) -> NodeStats {
    NodeStats {
        count: b.count,
        energy_rel_variance: b.energy_rel_variance(),
    }
}

impl Collapser<'_> {
    fn fill(&mut self, node: usize, b: usize, path: u64, level: u32) -> Result<(), BuildError> {
        if level >= MAX_DEPTH {
            return Err(BuildError::TooDeep { depth: level + 1 });
        }
        self.depth = self.depth.max(level + 1);
        let (set, len) = if self.bin[b].light.is_some() {
            ([b, 0, 0, 0], 1)
        } else {
            open(self.bin, &self.plans, b)
        };
        self.stats[node] = stats_of(&self.bin[b]);
        let first = self.nodes.len();
        let mut inner = [(0usize, 0usize, 0u64); 4];
        let mut n_inner = 0;
        for (k, &c) in set[..len].iter().enumerate() {
            let slot_path = (path << 2) | k as u64;
            write_slot(&mut self.nodes[node], k, &self.bin[c]);
            match self.bin[c].light {
                Some(l) => {
                    self.nodes[node].child[k] = LEAF_BIT | l;
                    self.paths[l as usize] = slot_path;
                }
                None => {
                    let idx = first + n_inner;
                    self.nodes[node].child[k] = idx as u32;
                    inner[n_inner] = (idx, c, slot_path);
                    n_inner += 1;
                }
            }
        }
        self.nodes.resize(first + n_inner, Node4::EMPTY);
        self.stats.resize(first + n_inner, NodeStats::zeroed());
        for &(idx, c, p) in &inner[..n_inner] {
            self.fill(idx, c, p, level + 1)?;
        }
        Ok(())
    }
}

/// Turns the binary tree into the flat 4-wide tree; `n_lights` is the length of the build's
/// input (lights absent from `bin` get path 0).
pub(crate) fn collapse(bin: &BinTree, n_lights: usize) -> Result<LightTree, BuildError> {
    let mut c = Collapser {
        bin: &bin.nodes,
        plans: plan(&bin.nodes),
        nodes: Vec::with_capacity(bin.nodes.len() / 5 + 1),
        stats: Vec::with_capacity(bin.nodes.len() / 5 + 1),
        paths: vec![0; n_lights],
        depth: 0,
    };
    if !bin.nodes.is_empty() {
        c.nodes.push(Node4::EMPTY);
        c.stats.push(NodeStats::zeroed());
        c.fill(0, 0, 1, 0)?;
    }
    Ok(LightTree {
        nodes: c.nodes,
        node_stats: c.stats,
        paths: c.paths,
        depth: c.depth,
    })
}
