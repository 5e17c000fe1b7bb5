//! Helpers shared by the cut tests (`tests/cut.rs`, `tests/bl.rs`): light-tree paths, walks of
//! the slots, and the checks of a cut's structure that do not depend on how it was built
//! (disjointness, coverage of the opened nodes, `pmf_in` ownership).

use super::Rng;
use manylights::cut::Cluster;
use manylights::importance::MemoTable;
use manylights::tree::{Child, Node4, Slot};
use manylights::{Importance, LightCut, LightTree, Memo, SampledLight};
use std::collections::HashSet;

macro_rules! ensure {
    ($cond:expr, $($fmt:tt)*) => {
        if !$cond {
            return Err(format!($($fmt)*));
        }
    };
}

/// Levels of a path encoded as in `LightTree::paths` (marker bit, 2 bits per level).
pub fn levels(path: u64) -> u32 {
    if path == 0 {
        0
    } else {
        (63 - path.leading_zeros()) / 2
    }
}

/// Whether path `p` is a prefix of path `q` (equal paths included).
pub fn is_prefix(p: u64, q: u64) -> bool {
    let (m, k) = (levels(p), levels(q));
    m >= 1 && m <= k && q >> (2 * (k - m)) == p
}

/// Every light under slot `k` of node `node`, by walking the nodes (independent of paths).
pub fn lights_in_slot(tree: &LightTree, node: u32, k: usize, out: &mut Vec<u32>) {
    match tree.slot(&tree.nodes()[node as usize], k) {
        Slot::Light(l) => out.push(l),
        Slot::Node(c) => {
            for j in 0..4 {
                lights_in_slot(tree, c, j, out);
            }
        }
        Slot::Empty => {}
    }
}

/// `x > 0` (false for NaN).
pub fn positive(x: f32) -> bool {
    x > 0.0
}

/// Number of non-empty slots of `node` with positive importance.
pub fn positive_slots<I: Importance>(imp: &I, node: &Node4) -> usize {
    let w = imp.eval4(node).to_array();
    (0..4)
        .filter(|&k| node.child(k) != Child::Empty && w[k] > 0.0)
        .count()
}

/// Whether no path of positive importances leads from node `node` to a light (so the cut may
/// drop a slot holding it); counts in `bottoms` the nodes of that subtree reached by positive
/// importances that have no slot of positive importance (each one a possible drop).
pub fn dead_subtree<I: Importance>(
    tree: &LightTree,
    imp: &I,
    node: u32,
    bottoms: &mut usize,
) -> bool {
    let n = &tree.nodes()[node as usize];
    let w = imp.eval4(n).to_array();
    let mut any = false;
    for (k, &wk) in w.iter().enumerate() {
        if !positive(wk) {
            continue;
        }
        match tree.slot(n, k) {
            Slot::Empty => {}
            Slot::Light(_) => return false,
            Slot::Node(c) => {
                any = true;
                if !dead_subtree(tree, imp, c, bottoms) {
                    return false;
                }
            }
        }
    }
    if !any {
        *bottoms += 1;
    }
    true
}

/// Cluster `i` of a cut names a non-empty slot (node, slot) of `tree`, and its path leads to
/// that slot.
pub fn check_cluster_slot(
    tree: &LightTree,
    i: usize,
    c: &Cluster,
    ctx: &str,
) -> Result<(), String> {
    let nodes = tree.nodes();
    ensure!(
        (c.node as usize) < nodes.len() && c.slot < 4,
        "cluster {i} {c:?} names no slot {ctx}"
    );
    let node = &nodes[c.node as usize];
    let k = usize::from(c.slot);
    ensure!(
        node.child(k) != Child::Empty,
        "cluster {i} {c:?} is an empty slot {ctx}"
    );
    ensure!(
        tree.slot_at(c.path) == Some((c.node, k)),
        "cluster {i} {c:?}: its path leads to {:?} {ctx}",
        tree.slot_at(c.path)
    );
    Ok(())
}

/// Disjointness of the clusters (`members[i]`: the lights under cluster i): no cluster's path
/// is a prefix of another's, no light under two clusters. Returns the owning cluster of each
/// of the `n` lights.
pub fn check_disjoint(
    clusters: &[Cluster],
    members: &[Vec<u32>],
    n: usize,
    ctx: &str,
) -> Result<Vec<Option<usize>>, String> {
    for (i, a) in clusters.iter().enumerate() {
        for (j, b) in clusters.iter().enumerate() {
            ensure!(
                i == j || !is_prefix(a.path, b.path),
                "cluster {i} {a:?} contains cluster {j} {b:?} {ctx}"
            );
        }
    }
    let mut owner: Vec<Option<usize>> = vec![None; n];
    for (i, m) in members.iter().enumerate() {
        for &l in m {
            let prev = owner[l as usize].replace(i);
            ensure!(
                prev.is_none(),
                "light {l} is under clusters {prev:?} and {i} {ctx}"
            );
        }
    }
    Ok(owner)
}

/// Coverage of a non-empty cut: the opened nodes are the root and the child nodes of every
/// proper ancestor slot of a cluster. Each slot of positive importance of an opened node is a
/// cluster, an ancestor of one, or was dropped — allowed only when no path of positive
/// importances leads from it to a light (`dead_subtree`; by conservativeness none of its
/// lights can contribute). Returns the number of possible drops (`dead_subtree`'s `bottoms`),
/// which the maximality check of the callers needs.
pub fn check_coverage<I: Importance>(
    tree: &LightTree,
    imp: &I,
    clusters: &[Cluster],
    ctx: &str,
) -> Result<usize, String> {
    let nodes = tree.nodes();
    let mut ancestors: HashSet<u64> = HashSet::new();
    let mut opened: HashSet<u32> = HashSet::from([0]);
    for c in clusters {
        for up in 1..levels(c.path) {
            let p = c.path >> (2 * up);
            let (an, ak) = tree.slot_at(p).unwrap();
            match tree.slot(&nodes[an as usize], ak) {
                Slot::Node(child) => {
                    opened.insert(child);
                    ancestors.insert(p);
                }
                other => return Err(format!("ancestor {p:#b} of {c:?} is {other:?}")),
            }
        }
    }
    let cluster_paths: HashSet<u64> = clusters.iter().map(|c| c.path).collect();
    let mut drops = 0usize;
    for &o in &opened {
        let node = &nodes[o as usize];
        let w = imp.eval4(node).to_array();
        // The path of node o: any slot's path leading into it (the root: marker 1).
        let base = if o == 0 {
            Some(1u64)
        } else {
            ancestors.iter().copied().find(|&p| {
                let (an, ak) = tree.slot_at(p).unwrap();
                tree.slot(&nodes[an as usize], ak) == Slot::Node(o)
            })
        };
        let base = base.ok_or_else(|| format!("opened node {o} has no ancestor path"))?;
        for (k, &wk) in w.iter().enumerate() {
            let p = (base << 2) | k as u64;
            if node.child(k) == Child::Empty
                || !positive(wk)
                || cluster_paths.contains(&p)
                || ancestors.contains(&p)
            {
                continue;
            }
            let dead = match tree.slot(node, k) {
                Slot::Node(child) => dead_subtree(tree, imp, child, &mut drops),
                _ => false,
            };
            ensure!(
                dead,
                "slot ({o}, {k}) (path {p:#b}) of an opened node has importance {wk} and a \
                 path of positive importance to a light, but is in no cluster {ctx}"
            );
        }
    }
    Ok(drops)
}

/// `pmf_in(l)` returns exactly the cluster `owner[l]` (none for a light outside the cut), with
/// a finite pmf in [0, 1] (1e-6). Returns the `pmf_in` of every light (0 outside the cut).
pub fn check_pmf_in<I: Importance>(
    cut: &LightCut,
    tree: &LightTree,
    imp: &I,
    owner: &[Option<usize>],
    ctx: &str,
) -> Result<Vec<f32>, String> {
    let n = owner.len();
    let mut pmf_in: Vec<f32> = vec![0.0; n];
    for l in 0..n {
        let got = cut.pmf_in(tree, imp, l as u32);
        match (owner[l], got) {
            (None, None) => {}
            (Some(i), Some((j, p))) if i == j => {
                ensure!(
                    p.is_finite() && (0.0..=1.0 + 1e-6).contains(&p),
                    "light {l}: pmf_in {p} {ctx}"
                );
                pmf_in[l] = p;
            }
            _ => {
                return Err(format!(
                    "light {l} (path {:#b}) is under cluster {:?} but pmf_in says {got:?} {ctx}",
                    tree.path(l as u32),
                    owner[l]
                ))
            }
        }
    }
    Ok(pmf_in)
}

/// `cut.pmf` of each of the `n` lights, in f64.
pub fn cut_pmfs<I: Importance>(cut: &LightCut, tree: &LightTree, imp: &I, n: usize) -> Vec<f64> {
    (0..n as u32)
        .map(|l| f64::from(cut.pmf(tree, imp, l)))
        .collect()
}

/// Draws `samples` lights with `cut.sample` (u from `rng`): how often each of the `n` lights
/// was drawn, and how often no light was.
pub fn cut_sample_counts<I: Importance>(
    cut: &LightCut,
    tree: &LightTree,
    imp: &I,
    n: usize,
    samples: usize,
    rng: &mut Rng,
) -> (Vec<u64>, u64) {
    let mut counts = vec![0u64; n];
    let mut none = 0u64;
    for _ in 0..samples {
        match cut.sample(tree, imp, rng.f32()) {
            Some(s) => counts[s.light as usize] += 1,
            None => none += 1,
        }
    }
    (counts, none)
}

/// The `pmf_in` of the lights `m` of cluster `i` sum to 1 (1e-4) or are all 0. Returns their
/// sum and whether they are all 0 (a dead cluster).
pub fn check_cluster_pmf_sum(
    clusters: &[Cluster],
    i: usize,
    m: &[u32],
    pmf_in: &[f32],
    ctx: &str,
) -> Result<(f64, bool), String> {
    let sum: f64 = m.iter().map(|&l| f64::from(pmf_in[l as usize])).sum();
    let dead = m.iter().all(|&l| pmf_in[l as usize] == 0.0);
    ensure!(
        dead || (sum - 1.0).abs() <= 1e-4,
        "cluster {i} {:?}: pmf_in of its {} lights sum to {sum} {ctx}",
        clusters[i],
        m.len()
    );
    Ok((sum, dead))
}

/// `cut.pmf(l)` is finite and equals weight / total · `pmf_in(l)` of its owning cluster (0
/// outside the cut) within 1e-5 relative (1e-37 absolute). Returns `cut.pmf(l)`.
pub fn check_light_pmf<I: Importance>(
    cut: &LightCut,
    tree: &LightTree,
    imp: &I,
    owner: &[Option<usize>],
    pmf_in: &[f32],
    l: usize,
    ctx: &str,
) -> Result<f32, String> {
    let ctotal = f64::from(cut.total_weight());
    let p = cut.pmf(tree, imp, l as u32);
    let expect = owner[l].map_or(0.0, |i| {
        f64::from(cut.clusters()[i].weight) / ctotal * f64::from(pmf_in[l])
    });
    ensure!(
        p.is_finite() && super::close(f64::from(p), expect, 1e-5, 1e-37),
        "light {l}: pmf {p} vs weight/total·pmf_in {expect} {ctx}"
    );
    Ok(p)
}

/// The batched queries against the one-at-a-time ones they must reproduce bit for bit, with
/// `imp` and with a [`Memo`] of it (whose table is reused, so the second pass reads it):
/// - `sample_each` with every u of `us` for all clusters, and with the u varying by cluster,
///   against `sample_in`; shorter `u` and `out` slices fill only their common prefix;
/// - `pmf_in_each` and `pmf_each` of all `n` lights in order and reversed, plus indices `n`
///   and `u32::MAX`, against `pmf_in` and `pmf`.
pub fn check_batched<I: Importance + Copy>(
    cut: &LightCut,
    tree: &LightTree,
    imp: I,
    n: usize,
    us: &[f32],
    ctx: &str,
) -> Result<(), String> {
    let table = MemoTable::new();
    let memo = Memo::new(imp, tree, &table);
    for pass in 0..2 {
        let imp_b: &dyn Importance = if pass == 0 { &imp } else { &memo };
        let len = cut.len();
        for (j, &u) in us.iter().enumerate() {
            let u_all: Vec<f32> = (0..len)
                .map(|i| {
                    if j % 2 == 0 {
                        u
                    } else {
                        us[(i + j) % us.len()]
                    }
                })
                .collect();
            let mut out = vec![Some(SampledLight { light: 7, pmf: 7.0 }); len + 2];
            cut.sample_each(tree, imp_b, &u_all, &mut out);
            for i in 0..len {
                let want = cut.sample_in(tree, &imp, i, u_all[i]);
                ensure!(
                    out[i].map(|s| (s.light, s.pmf.to_bits()))
                        == want.map(|s| (s.light, s.pmf.to_bits())),
                    "pass {pass}: sample_each[{i}] (u={}) = {:?}, sample_in = {want:?} {ctx}",
                    u_all[i],
                    out[i]
                );
            }
            ensure!(
                out[len..]
                    .iter()
                    .all(|s| *s == Some(SampledLight { light: 7, pmf: 7.0 })),
                "sample_each wrote past len {ctx}"
            );
            if len > 1 {
                let mut short = vec![None; len];
                cut.sample_each(tree, imp_b, &u_all[..len / 2], &mut short);
                ensure!(
                    short[len / 2..].iter().all(Option::is_none)
                        && short[..len / 2] == out[..len / 2],
                    "sample_each with a short u slice {ctx}"
                );
            }
        }
        let mut lights: Vec<u32> = (0..n as u32).collect();
        lights.extend([n as u32, u32::MAX]);
        for order in 0..2 {
            if order == 1 {
                lights.reverse();
            }
            let mut within = vec![Some((99, 9.0)); lights.len()];
            cut.pmf_in_each(tree, imp_b, &lights, &mut within);
            let mut whole = vec![9.0f32; lights.len()];
            cut.pmf_each(tree, imp_b, &lights, &mut whole);
            for (k, &l) in lights.iter().enumerate() {
                let want = cut.pmf_in(tree, &imp, l);
                ensure!(
                    within[k].map(|(c, p)| (c, p.to_bits())) == want.map(|(c, p)| (c, p.to_bits())),
                    "pass {pass}: pmf_in_each of light {l} = {:?}, pmf_in = {want:?} {ctx}",
                    within[k]
                );
                let want = cut.pmf(tree, &imp, l);
                ensure!(
                    whole[k].to_bits() == want.to_bits(),
                    "pass {pass}: pmf_each of light {l} = {}, pmf = {want} {ctx}",
                    whole[k]
                );
            }
        }
    }
    Ok(())
}
