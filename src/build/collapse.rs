//! Collapse of the binary SAOH tree into 4-wide [`Node4`]s, as wide BVHs are collapsed: a
//! node's four slots are found by repeatedly opening the costliest inner node among its
//! current children, until there are four or only leaves are left.

use super::saoh::{BinNode, BinTree};
use crate::error::BuildError;
use crate::quantize;
use crate::tree::{LightTree, Node4, NodeStats, LEAF_BIT, MAX_DEPTH};
use alloc::vec;
use alloc::vec::Vec;
use bytemuck::Zeroable;

struct Collapser<'a> {
    bin: &'a [BinNode],
    nodes: Vec<Node4>,
    stats: Vec<NodeStats>,
    paths: Vec<u64>,
    depth: u32,
}

/// The up-to-four binary descendants of inner node `b` that become one node's slots.
fn open(bin: &[BinNode], b: usize) -> ([usize; 4], usize) {
    let mut set = [b + 1, bin[b].right as usize, 0, 0];
    let mut len = 2;
    while len < 4 {
        let mut pick = None;
        let mut best = f32::NEG_INFINITY;
        for (i, &c) in set[..len].iter().enumerate() {
            if bin[c].light.is_none() && bin[c].cost > best {
                best = bin[c].cost;
                pick = Some(i);
            }
        }
        let Some(i) = pick else { break };
        let c = set[i];
        set[i] = c + 1;
        set[len] = bin[c].right as usize;
        len += 1;
    }
    (set, len)
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
        energy_variance: b.energy_variance(),
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
            open(self.bin, b)
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
