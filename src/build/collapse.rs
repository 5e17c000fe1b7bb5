//! Collapse of the binary SAOH tree into 4-wide [`Node4`]s, and their quantisation.
//!
//! **Which clusters become slots.** A dynamic programme over the binary tree chooses, for
//! every node, the slots that cover its subtree, minimising `Σ_nodes (NODE_WEIGHT + lights
//! under the node)`: the number of nodes (the memory a tree takes) traded against the sum of
//! all lights' depths. Slots are binary clusters, opened costlier child first on ties, as
//! wide-BVH collapsing does; and, with [`crate::BuildOptions::compact`], a subtree of at most
//! [`FREE_MAX`] lights may instead be packed free-form, its lights (in the binary tree's depth-first order, which keeps
//! neighbours together) grouped into consecutive runs so that its nodes are full — the binary
//! tree alone leaves many nodes of two or three lights at the bottom.
//!
//! **What the slots store.** The nodes are laid out top-down (the inner children of a node
//! consecutive, its lights consecutive in the leaf array), then quantised bottom-up: a light
//! slot bounds the light's exact bounds, an inner slot bounds the *decoded* bounds of its
//! child's slots (their enclosing sphere, the union of their cones, the sum of their
//! energies), and each is rounded outwards by `quantize`. So every decoded slot contains its
//! children's decoded slots, and by induction every light below it.

use super::saoh::{BinNode, BinTree};
use crate::bounds::{Cone, LightBounds, Sphere};
use crate::error::BuildError;
use crate::quantize;
use crate::tree::{LightTree, Node4, Paths, MAX_DEPTH};
use alloc::vec;
use alloc::vec::Vec;

/// Weight of one node against one level of one light's path in the collapse objective
/// `Σ_nodes (NODE_WEIGHT + lights under the node)`.
const NODE_WEIGHT: u64 = 8;

/// Largest subtree (in lights) the collapse may pack free-form.
pub(crate) const FREE_MAX: usize = 16;

/// `Plan::split` value of a free-form cover.
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

/// Per binary node, the result of the collapse's dynamic programme: `g[k]` is the objective
/// below a set of at most `k` slots covering the node's subtree (`g[1]`: the node kept as one
/// slot), and `split[k]` how that set is formed (0 = keep the node as one slot, `j` = open
/// it, giving `j` slots to the left child and `k − j` to the right, [`FREE`] = free-form);
/// `own_free`: the node's own 4 slots, when it is one node, are free-form.
#[derive(Clone, Copy, Default)]
struct Plan {
    g: [u64; 5],
    split: [u8; 5],
    own_free: bool,
}

/// Computes the plans bottom-up. Opening is preferred on ties, so the tree stays shallow;
/// among equal counts, the split giving the costlier child more slots wins; a free-form
/// cover is taken only when strictly cheaper than the binary one.
fn plan(bin: &[BinNode], free: &FreeTable, free_max: usize) -> Vec<Plan> {
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
        let m = bin[b].count as usize;
        let free_cost = |k: usize| {
            if m <= free_max {
                free.cost[m][k]
            } else {
                u64::MAX
            }
        };
        let mut p = Plan::default();
        let open4 = best_open(4).0;
        p.own_free = free_cost(4) < open4;
        let own = open4
            .min(free_cost(4))
            .saturating_add(NODE_WEIGHT + u64::from(bin[b].count));
        p.g[1] = own;
        for k in 2..=4 {
            let (mut open, mut j) = best_open(k);
            if free_cost(k) < open {
                (open, j) = (free_cost(k), FREE);
            }
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

/// A run of consecutive lights (binary leaf indices) packed free-form.
#[derive(Clone, Copy)]
struct Run {
    leaves: [u32; FREE_MAX],
    len: usize,
}

/// What becomes one slot.
#[derive(Clone, Copy)]
enum Src {
    /// A binary node (a leaf, or an inner node that becomes a node of its own).
    Bin(usize),
    /// A free-form run of two or more lights, a node of its own.
    Run(Run),
}

/// The binary leaves of subtree `b` (at most [`FREE_MAX`] lights) in depth-first order.
fn run_of(bin: &[BinNode], b: usize) -> Run {
    let mut run = Run {
        leaves: [0; FREE_MAX],
        len: 0,
    };
    let end = (b + 2 * bin[b].count as usize - 1).min(bin.len());
    for (i, n) in bin[b..end].iter().enumerate() {
        if n.light.is_some() && run.len < FREE_MAX {
            run.leaves[run.len] = (b + i) as u32;
            run.len += 1;
        }
    }
    run
}

/// Appends the slots of the free-form cover of `run` with at most `k` slots.
fn free_slots(free: &FreeTable, run: &Run, k: usize, out: &mut ([Src; 4], usize)) {
    let mut start = 0;
    let mut k = k;
    while start < run.len {
        let m = run.len - start;
        let s = usize::from(free.first[m][k]).clamp(1, m);
        if s == 1 {
            out.0[out.1] = Src::Bin(run.leaves[start] as usize);
        } else {
            let mut sub = Run {
                leaves: [0; FREE_MAX],
                len: s,
            };
            sub.leaves[..s].copy_from_slice(&run.leaves[start..start + s]);
            out.0[out.1] = Src::Run(sub);
        }
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
    let j = if k >= 2 && bin[b].light.is_none() {
        plans[b].split[k]
    } else {
        0
    };
    match j {
        0 => {
            out.0[out.1] = Src::Bin(b);
            out.1 += 1;
        }
        FREE => free_slots(free, &run_of(bin, b), k, out),
        j => {
            let j = usize::from(j);
            frontier(bin, plans, free, b + 1, j, out);
            frontier(bin, plans, free, bin[b].right as usize, k - j, out);
        }
    }
}

/// The up-to-four slots of the node that inner binary node `b` becomes.
fn open(bin: &[BinNode], plans: &[Plan], free: &FreeTable, b: usize) -> ([Src; 4], usize) {
    let mut out = ([Src::Bin(0); 4], 0usize);
    if plans[b].own_free {
        free_slots(free, &run_of(bin, b), 4, &mut out);
        return out;
    }
    let (l, r) = (b + 1, bin[b].right as usize);
    let mut best = (u64::MAX, 1);
    for j in 1..4 {
        let c = plans[l].g[j].saturating_add(plans[r].g[4 - j]);
        if c < best.0 {
            best = (c, j);
        }
    }
    frontier(bin, plans, free, l, best.1, &mut out);
    frontier(bin, plans, free, r, 4 - best.1, &mut out);
    out
}

/// The exact bounds of a free-form run's lights: the sphere enclosing theirs and the union of
/// their cones.
fn exact_of_run(bin: &[BinNode], run: &Run) -> (Sphere, Cone) {
    let mut spheres = [Sphere::enclosing(&[]); FREE_MAX];
    let mut cone: Option<Cone> = None;
    for (i, &b) in run.leaves[..run.len].iter().enumerate() {
        let bounds = &bin[b as usize].bounds;
        spheres[i] = bounds.sphere;
        cone = Some(cone.map_or(bounds.cone, |c| c.union(bounds.cone)));
    }
    (
        Sphere::enclosing(&spheres[..run.len]),
        cone.unwrap_or(Cone::SPHERE),
    )
}

/// A slot of the laid-out tree before quantisation.
#[derive(Clone, Copy)]
enum Laid {
    Empty,
    /// A light: the binary leaf holding its bounds.
    Light(u32),
    /// An inner node.
    Node(u32),
}

/// The decoded bounds of a whole node (what its parent's slot must contain) and the sums of
/// its lights' energies and squared energies.
#[derive(Clone, Copy)]
struct Summary {
    bounds: LightBounds,
    count: u32,
    energy_sum: f64,
    energy_sq_sum: f64,
}

struct Collapser<'a> {
    bin: &'a [BinNode],
    plans: Vec<Plan>,
    free: FreeTable,
    nodes: Vec<Node4>,
    variances: Vec<u16>,
    laid: Vec<[Laid; 4]>,
    /// Per node, the exact bounds of its lights (the binary node's, or those of a free-form
    /// run): what the parent's slot is widened from, so that quantisation errors do not
    /// accumulate up the tree.
    exact: Vec<(Sphere, Cone)>,
    leaves: Vec<u32>,
    paths: Vec<u64>,
    depth: u32,
}

impl Collapser<'_> {
    /// Lays out node `node` from `src` and, depth first, its children.
    fn fill(&mut self, node: usize, src: Src, path: u64, level: u32) -> Result<(), BuildError> {
        if level >= MAX_DEPTH {
            return Err(BuildError::TooDeep { depth: level + 1 });
        }
        self.depth = self.depth.max(level + 1);
        self.exact[node] = match src {
            Src::Bin(b) => (self.bin[b].bounds.sphere, self.bin[b].bounds.cone),
            Src::Run(run) => exact_of_run(self.bin, &run),
        };
        let (set, len) = match src {
            Src::Bin(b) if self.bin[b].light.is_some() => ([Src::Bin(b); 4], 1),
            Src::Bin(b) => open(self.bin, &self.plans, &self.free, b),
            Src::Run(run) => {
                let mut out = ([Src::Bin(0); 4], 0usize);
                free_slots(&self.free, &run, 4, &mut out);
                out
            }
        };
        let first = self.nodes.len();
        let mut inner = [(0usize, Src::Bin(0), 0u64); 4];
        let mut n_inner = 0;
        let mut mask = 0u8;
        self.nodes[node].child_base = first as u32;
        self.nodes[node].leaf_base = self.leaves.len() as u32;
        for (k, &c) in set[..len].iter().enumerate() {
            let slot_path = (path << 2) | k as u64;
            match c {
                Src::Bin(b) if self.bin[b].light.is_some() => {
                    let light = self.bin[b].light.unwrap_or(0);
                    mask |= 1 << (4 + k);
                    self.laid[node][k] = Laid::Light(b as u32);
                    self.leaves.push(light);
                    self.paths[light as usize] = slot_path;
                }
                _ => {
                    let idx = first + n_inner;
                    mask |= 1 << k;
                    self.laid[node][k] = Laid::Node(idx as u32);
                    inner[n_inner] = (idx, c, slot_path);
                    n_inner += 1;
                }
            }
        }
        self.nodes[node].mask = mask;
        self.nodes.resize(first + n_inner, Node4::EMPTY);
        self.laid.resize(first + n_inner, [Laid::Empty; 4]);
        self.exact
            .resize(first + n_inner, (Sphere::enclosing(&[]), Cone::SPHERE));
        for &(idx, c, p) in &inner[..n_inner] {
            self.fill(idx, c, p, level + 1)?;
        }
        Ok(())
    }

    /// Quantises every node, children before parents (a child's index is above its
    /// parent's).
    fn quantise(&mut self) {
        let mut summary: Vec<Option<Summary>> = vec![None; self.nodes.len()];
        self.variances = vec![0; self.nodes.len()];
        for i in (0..self.nodes.len()).rev() {
            let mut parts: [Option<Summary>; 4] = [None; 4];
            for (k, part) in parts.iter_mut().enumerate() {
                *part = match self.laid[i][k] {
                    Laid::Empty => None,
                    Laid::Light(b) => {
                        let n = &self.bin[b as usize];
                        let e = f64::from(n.bounds.energy);
                        Some(Summary {
                            bounds: n.bounds,
                            count: 1,
                            energy_sum: e,
                            energy_sq_sum: e * e,
                        })
                    }
                    Laid::Node(c) => summary[c as usize].take(),
                };
            }
            let node = &mut self.nodes[i];
            let mut spheres = [Sphere {
                center: glam::Vec3::ZERO,
                radius: 0.0,
            }; 4];
            let mut n = 0;
            for p in parts.iter().flatten() {
                spheres[n] = p.bounds.sphere;
                n += 1;
            }
            let (origin, exponent, words) = quantize::encode_spheres(&spheres[..n]);
            node.origin = origin;
            node.exponent = exponent;
            let mut j = 0;
            let (mut count, mut sum, mut sq) = (0u32, 0.0f64, 0.0f64);
            for (k, p) in parts.iter().enumerate() {
                let Some(p) = p else { continue };
                node.sphere[k] = words[j];
                j += 1;
                node.cone[k] = quantize::encode_cone(&p.bounds.cone);
                node.set_energy_code(k, quantize::encode_energy(p.bounds.energy));
                count += p.count;
                sum += p.energy_sum;
                sq += p.energy_sq_sum;
            }
            let mean = sum / f64::from(count.max(1));
            let variance = if mean > 0.0 {
                ((sq / f64::from(count.max(1)) - mean * mean).max(0.0) / (mean * mean)) as f32
            } else {
                0.0
            };
            self.variances[i] = quantize::encode_bf16(variance);
            // What the parent's slot bounds: the exact bounds of the node's lights (each
            // level is rounded from the exact bounds, so rounding never compounds: a slot
            // need not contain its child's slots, only the lights below it).
            let (sphere, cone) = self.exact[i];
            let energy = sum;
            summary[i] = Some(Summary {
                bounds: LightBounds {
                    aabb: crate::bounds::Aabb::EMPTY,
                    sphere,
                    cone,
                    energy: round_up(energy),
                },
                count,
                energy_sum: sum,
                energy_sq_sum: sq,
            });
        }
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
pub(crate) fn collapse(
    bin: &BinTree,
    n_lights: usize,
    compact: bool,
) -> Result<LightTree, BuildError> {
    let free = FreeTable::new();
    let mut c = Collapser {
        bin: &bin.nodes,
        plans: plan(&bin.nodes, &free, if compact { FREE_MAX } else { 1 }),
        free,
        nodes: Vec::with_capacity(bin.nodes.len() / 5 + 1),
        variances: Vec::new(),
        laid: Vec::with_capacity(bin.nodes.len() / 5 + 1),
        exact: Vec::with_capacity(bin.nodes.len() / 5 + 1),
        leaves: Vec::with_capacity(bin.nodes.len() / 2 + 1),
        paths: vec![0; n_lights],
        depth: 0,
    };
    if !bin.nodes.is_empty() {
        c.nodes.push(Node4::EMPTY);
        c.laid.push([Laid::Empty; 4]);
        c.exact.push((Sphere::enclosing(&[]), Cone::SPHERE));
        c.fill(0, Src::Bin(0), 1, 0)?;
        c.plans = Vec::new();
        c.quantise();
    }
    let mut paths = Paths::zeros(n_lights, c.depth);
    for (l, &p) in c.paths.iter().enumerate() {
        if p != 0 {
            paths.set(l, p);
        }
    }
    Ok(LightTree {
        nodes: c.nodes,
        variances: c.variances,
        leaves: c.leaves,
        paths,
        depth: c.depth,
    })
}
