//! Collapse of the binary SAOH tree into 4-wide [`Node4`]s. The binary tree's clusters are
//! kept; which of them become slots of one node is chosen by a dynamic programme over the
//! binary tree that minimises the number of nodes (the memory a tree takes), opening the
//! costlier child first on ties, as wide-BVH collapsing does. Every set of slots covers its
//! node's subtree exactly, so the 4-wide tree bounds what the binary one bounds.

use super::saoh::{BinNode, BinTree};
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

/// Per binary node, the result of the collapse's dynamic programme: `g[k]` is the fewest
/// [`Node4`]s needed below a set of at most `k` slots covering the node's subtree (`g[1]`: the
/// node kept as one slot), and `split[k]` how that set is formed (0 = keep the node as one slot,
/// `j` = open it, giving `j` slots to the left child and `k − j` to the right).
#[derive(Clone, Copy, Default)]
struct Plan {
    g: [u64; 5],
    split: [u8; 5],
}

/// Weight of one node against one level of one light's path in the collapse objective
/// `Σ_nodes (NODE_WEIGHT + lights under the node)`: the second term is the sum of all
/// lights' depths, so the objective trades memory against the length of a descent.
const NODE_WEIGHT: u64 = 8;

/// Computes the plans bottom-up. Opening is preferred on ties, so the tree stays shallow;
/// among equal counts, the split giving the costlier child more slots wins.
fn plan(bin: &[BinNode]) -> Vec<Plan> {
    let mut plans = vec![Plan::default(); bin.len()];
    for b in (0..bin.len()).rev() {
        if bin[b].light.is_some() {
            continue; // a leaf is one slot and needs no node: all zero
        }
        let (l, r) = (b + 1, bin[b].right as usize);
        let (pl, pr) = (plans[l], plans[r]);
        let best_open = |k: usize| -> (u64, u8) {
            let mut best = (u64::MAX, 0u8);
            for j in 1..k {
                let c = pl.g[j].saturating_add(pr.g[k - j]);
                let better = c < best.0
                    || (c == best.0 && (bin[l].cost >= bin[r].cost) == (j > usize::from(best.1)));
                if better {
                    best = (c, j as u8);
                }
            }
            best
        };
        // The node as a 4-wide node of its own.
        let own = best_open(4)
            .0
            .saturating_add(NODE_WEIGHT + u64::from(bin[b].count));
        let mut p = Plan::default();
        p.g[1] = own;
        for k in 2..=4 {
            let (open, j) = best_open(k);
            if open <= own {
                p.g[k] = open;
                p.split[k] = j;
            } else {
                p.g[k] = own;
            }
        }
        plans[b] = p;
    }
    plans
}

/// Appends to `out` the slots that cover binary node `b` with at most `k` slots.
fn frontier(bin: &[BinNode], plans: &[Plan], b: usize, k: usize, out: &mut ([usize; 4], usize)) {
    let j = if k >= 2 && bin[b].light.is_none() {
        usize::from(plans[b].split[k])
    } else {
        0
    };
    if j == 0 {
        out.0[out.1] = b;
        out.1 += 1;
    } else {
        frontier(bin, plans, b + 1, j, out);
        frontier(bin, plans, bin[b].right as usize, k - j, out);
    }
}

/// The up-to-four binary descendants of inner node `b` that become one node's slots.
fn open(bin: &[BinNode], plans: &[Plan], b: usize) -> ([usize; 4], usize) {
    let (l, r) = (b + 1, bin[b].right as usize);
    let mut best = (u64::MAX, 1);
    for j in 1..4 {
        let c = plans[l].g[j].saturating_add(plans[r].g[4 - j]);
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
