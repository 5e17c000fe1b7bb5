//! Light cuts built by split sampling (`LightCut::build_split`, docs/formulas.md, section 5) and sampled
//! per cluster (`sample_in` / `pmf_in`) or as a whole (`sample` / `pmf`, docs/formulas.md, section 12):
//!
//! 1. structural invariants on random scenes and shading points (size bound, disjoint clusters
//!    named by consistent paths, positive weights, `pmf_in` finding the unique cluster of a
//!    light, per-cluster pmfs summing to 1, `sample_in` agreeing with `pmf_in`, and the batched
//!    `sample_each` / `pmf_in_each` / `pmf_each`, also through a `Memo`, reproducing them bit
//!    for bit);
//! 2. unbiasedness of the split-sampling estimator by exact enumeration;
//! 3. `sample` / `pmf` agreement, pmfs summing to 1, and a chi-square test of `sample`;
//! 4. conservativeness through cuts (every contributing light keeps a positive pmf);
//! 5. the edges: `max_size` 1 (and its clamping), threshold 0 and threshold ∞, empty trees.
//!
//! Everything is seeded. Contribution is decided by `common::contributes` (f64, from the
//! light's geometry alone) with every deciding cosine above [`MARGIN`], as in
//! `tests/importance.rs`.
//!
//! Regressions kept here: a cut used to exceed `max_size` below 4 (now clamped to
//! MIN_CUT_SIZE, the root's slots), and an unsplit cluster whose node had four slots of
//! importance 0 used to make `sample` return `None` on a non-empty cut (its node now falls back
//! to its energies, as any inner node does, so the pmfs sum to 1).

mod common;

use common::cut::{
    check_batched, check_cluster_pmf_sum, check_cluster_slot, check_coverage, check_disjoint,
    check_light_pmf, check_pmf_in, cut_pmfs, cut_sample_counts, levels, lights_in_slot,
    positive_slots,
};
use common::{
    boundary_scene, chi2_critical, chi2_skewed_statistic, chi2_statistic, close, contributes,
    proptest_config, random_importance, random_normal, ring_scene, styled_scene, u_values, Rng,
    SceneSpec, RECEIVERS, Z_999,
};
use glam::Vec3;
use manylights::cut::MAX_CUT_SIZE;
use manylights::cut::MIN_CUT_SIZE;
use manylights::importance::Receiver;
use manylights::internals::tree::Node4Ext;
use manylights::tree::{Child, Node4, Slot};
use manylights::Rgb;
use manylights::MIN_PMF;
use manylights::{Importance, Light, LightCut, LightTree, SplitCutOptions, TlImportance};
use proptest::prelude::{any, prop_oneof, Strategy};
use proptest::test_runner::TestCaseError;

/// Cosine margin of the contribution predicate (see `tests/importance.rs`: two orders of
/// magnitude above the f32 rounding of the importance's cosines).
const MARGIN: f64 = 1e-4;

/// Thresholds every random check draws from: 0, small, the default, large, huge, ∞.
const THRESHOLDS: [f32; 8] = [0.0, 1e-6, 1e-4, 1e-3, 1e-2, 1.0, 1e30, f32::INFINITY];

/// The u values `sample_in` and `sample` are checked with: 0, tiny, 0.5, 1 − 2^-24, random.
const EXTRA_U: usize = 6;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// The f32 test the cut uses for "x is inside the slot's bounding sphere", same operations.
fn inside(node: &Node4, k: usize, x: Vec3) -> bool {
    let c = node.sphere(k).center;
    (c - x).length() <= node.sphere(k).radius
}

/// The split criterion of `cut.rs` / docs/formulas.md, section 5 in f64 for slot `k` of `node` (weight
/// `w`, root total `total`), outside the sphere: `ρ · (w / total)²` with
/// `ρ = (1 + V[e]/E[e]²)(1 + (b − a)²/(3ab)) − 1`, and an absolute tolerance for comparing
/// the crate's f32 value with it (ρ is a difference of numbers ≥ 1: ~1e-7 of them).
/// `None` when x is within 1e-3·d of the sphere (a = d − r then carries the f32 rounding of
/// d at a relative size that no tolerance here would cover).
fn reference_score(
    tree: &LightTree,
    node: &Node4,
    k: usize,
    x: Vec3,
    w: f32,
    total: f64,
) -> Option<(f64, f64)> {
    let c = node.sphere(k).center.as_dvec3();
    let r = f64::from(node.sphere(k).radius);
    let d = (c - x.as_dvec3()).length();
    if d - r < 1e-3 * d {
        return None;
    }
    let rel_e = match tree.slot(node, k) {
        Slot::Node(c) => f64::from(tree.energy_rel_variance(c)),
        _ => 0.0,
    };
    let a = (d - r).max(1e-6 * d.max(1.0));
    let b = d + r;
    let rel_g = (b - a) * (b - a) / (3.0 * a * b);
    let rho = (1.0 + rel_e) * (1.0 + rel_g) - 1.0;
    let share = f64::from(w) / total;
    let tol = 2e-6 * (1.0 + rel_e) * (1.0 + rel_g) * share * share;
    Some((rho * share * share, tol))
}

/// A representative point of a light (for the test's contribution function only).
fn light_point(l: &Light) -> Vec3 {
    match *l {
        Light::Point { position, .. }
        | Light::Spot { position, .. }
        | Light::Vpl { position, .. } => position,
        Light::Sphere { center, .. } | Light::Disk { center, .. } => center,
        Light::Triangle { vertices, .. } => (vertices[0] + vertices[1] + vertices[2]) / 3.0,
        Light::Distant { .. } | Light::Environment { .. } => {
            unreachable!("lights at infinity are tested in tests/infinite.rs")
        }
        _ => unimplemented!("a light kind the tests do not know"),
    }
}

/// A positive contribution exactly for the lights that reach the shading point (energy ×
/// reach / (d² + 10^-6)); any positive function of the reaching lights serves the identities
/// of property 2.
fn contribution(l: &Light, imp: &TlImportance) -> f64 {
    let x = imp.position();
    if l.energy() > 0.0 && contributes(l, x, imp.normal(), imp.receiver(), MARGIN) {
        let d2 = (light_point(l).as_dvec3() - x.as_dvec3()).length_squared();
        f64::from(l.energy()) / (d2 + 1e-6)
    } else {
        0.0
    }
}

/// A shading point: one of `random_importance`'s kinds (in the scene, far, on a light, at a
/// point light), or with probability 1/4 a point inside the bounding sphere of a random slot
/// of a random node (where the cut must split). Random normal and receiver.
fn cut_point(rng: &mut Rng, tree: &LightTree, lights: &[Light], half: f32) -> TlImportance {
    if tree.is_empty() || rng.below(4) != 0 {
        return random_importance(rng, lights, half);
    }
    let nodes = tree.nodes();
    let node = &nodes[rng.below(nodes.len())];
    let filled: Vec<usize> = (0..4).filter(|&k| node.child(k) != Child::Empty).collect();
    let k = filled[rng.below(filled.len())];
    let c = node.sphere(k).center;
    let x = c + rng.unit() * (node.sphere(k).radius * rng.f32());
    TlImportance::with_receiver(x, random_normal(rng), RECEIVERS[rng.below(3)])
}

/// Random split options: every threshold of [`THRESHOLDS`], `max_size` in 1..=64 (small ones
/// often).
fn random_options(rng: &mut Rng) -> SplitCutOptions {
    let threshold = THRESHOLDS[rng.below(THRESHOLDS.len())];
    let max_size = match rng.below(4) {
        0 => 1 + rng.below(4),
        1 => MAX_CUT_SIZE,
        _ => 1 + rng.below(MAX_CUT_SIZE),
    };
    SplitCutOptions {
        threshold,
        max_size,
    }
}

/// What one checked shading point found.
#[derive(Clone, Copy, Debug, Default)]
struct PointReport {
    /// Clusters of the cut.
    clusters: usize,
    /// Lights that reach the point (and so were checked for a positive pmf).
    contributing: usize,
    /// Clusters whose lights all have pmf 0 (`sample_in` returns `None` for them).
    dead: usize,
    /// Σ over all lights of `cut.pmf`.
    pmf_sum: f64,
}

macro_rules! ensure {
    ($cond:expr, $($fmt:tt)*) => {
        if !$cond {
            return Err(format!($($fmt)*));
        }
    };
}

// ---------------------------------------------------------------------------------------------
// Properties 1, 3 (agreement) and 4 at one shading point
// ---------------------------------------------------------------------------------------------

/// Builds the split cut of `tree` at `imp` with `opts` and checks it:
///
/// - size: at most `max_size` (clamped to 1..=64) clusters — or, when that is below the
///   number of positive root slots, at most that number (what the code does today: see
///   `split_cut_len_at_most_max_size`, which fails for it);
/// - every cluster: weight > 0, finite, equal to the importance of its slot; a non-empty slot;
///   its path leads to its (node, slot); its score is docs/formulas.md, section 5's criterion;
///   `total_weight` and `max_score` are the sum and maximum;
/// - disjoint: no cluster's path is a prefix of another's, no light under two clusters;
/// - threshold semantics: every proper ancestor slot of a cluster was split, so it contains x
///   or its criterion exceeds the threshold; when the capacity cannot bind (the tree has at
///   most `max_size` lights), no inner cluster contains x or has a score above the threshold;
/// - coverage and maximality: every slot of positive importance of an opened node is a
///   cluster, an ancestor of one, or holds no path of positive importances down to a light;
///   a cluster that wants splitting was kept only when its children would not have fitted;
/// - `pmf_in(l)` returns exactly the cluster whose subtree holds l (none for lights outside
///   the cut, zero-energy lights and indices out of range), with a pmf in [0, 1];
/// - per cluster, the `pmf_in` of its lights sum to 1 within 1e-4 or are all 0;
/// - `sample_in(i, u)` returns a light of cluster i with the pmf `pmf_in` gives it (1e-5
///   relative), `None` exactly for a cluster of all-zero pmfs, and for i out of range;
/// - `pmf(l)` = weight_i / total · `pmf_in(l)`, and `sample(u)` reports `pmf()` of its light;
/// - property 4: a light that reaches x has a positive `pmf_in` and `pmf`.
fn check_cut(
    tree: &LightTree,
    lights: &[Light],
    imp: &TlImportance,
    opts: &SplitCutOptions,
    us: &[f32],
) -> Result<(LightCut, PointReport), String> {
    let cut = LightCut::build_split(tree, imp, opts);
    let ctx = format!("at {imp:?} with {opts:?}");
    let x = imp.position();
    let n = lights.len();
    let nodes = tree.nodes();
    let clusters = cut.clusters();
    let mut report = PointReport {
        clusters: clusters.len(),
        ..PointReport::default()
    };

    // Size.
    ensure!(
        cut.len() == clusters.len(),
        "len {} ≠ clusters().len() {}",
        cut.len(),
        clusters.len()
    );
    ensure!(
        cut.is_empty() == clusters.is_empty(),
        "is_empty inconsistent {ctx}"
    );
    let cap = opts.max_size.clamp(MIN_CUT_SIZE, MAX_CUT_SIZE);
    let root_slots = nodes.first().map_or(0, |r| positive_slots(imp, r));
    ensure!(
        cut.len() <= cap.max(root_slots),
        "{} clusters > max_size {cap} (root has {root_slots} positive slots) {ctx}",
        cut.len()
    );
    if tree.is_empty() {
        ensure!(cut.is_empty(), "empty tree, {} clusters", cut.len());
    }

    // Root total, as the criterion normalises by it.
    let total: f64 = nodes.first().map_or(0.0, |r| {
        imp.eval4(r).to_array().iter().map(|&w| f64::from(w)).sum()
    });

    // Each cluster.
    let mut members: Vec<Vec<u32>> = Vec::with_capacity(clusters.len());
    let mut weight_sum = 0.0f64;
    let mut max_score = 0.0f32;
    for (i, c) in clusters.iter().enumerate() {
        ensure!(
            c.weight > 0.0 && c.weight.is_finite(),
            "cluster {i} {c:?} has weight {} {ctx}",
            c.weight
        );
        check_cluster_slot(tree, i, c, &ctx)?;
        let node = &nodes[c.node as usize];
        let k = usize::from(c.slot);
        let w = imp.eval4(node).to_array()[k];
        ensure!(
            c.weight == w,
            "cluster {i} {c:?}: weight {} ≠ importance of its slot {w} {ctx}",
            c.weight
        );
        weight_sum += f64::from(c.weight);
        max_score = max_score.max(c.score);

        // Score: ∞ inside the sphere, docs/formulas.md, section 5's criterion outside it.
        if inside(node, k, x) {
            ensure!(
                c.score == f32::INFINITY,
                "cluster {i} {c:?}: x inside, score {} {ctx}",
                c.score
            );
        } else if let Some((s, tol)) = reference_score(tree, node, k, x, c.weight, total) {
            ensure!(
                close(f64::from(c.score), s, 1e-3, tol + 1e-30),
                "cluster {i} {c:?}: score {} vs reference {s} (tol {tol}) {ctx}",
                c.score
            );
        }

        // Ancestors were split: x inside them or their criterion above the threshold.
        let l = levels(c.path);
        for up in 1..l {
            let p = c.path >> (2 * up);
            let (an, ak) = tree
                .slot_at(p)
                .ok_or_else(|| format!("ancestor {p:#b} of {c:?} not in the tree"))?;
            let anode = &nodes[an as usize];
            if inside(anode, ak, x) {
                continue;
            }
            let aw = imp.eval4(anode).to_array()[ak];
            if let Some((s, tol)) = reference_score(tree, anode, ak, x, aw, total) {
                let below = s * (1.0 + 1e-3) + tol < f64::from(opts.threshold);
                ensure!(
                    !below,
                    "cluster {i} {c:?}: ancestor slot ({an}, {ak}) was split, but x is \
                     outside it and its criterion {s} ≤ threshold {} {ctx}",
                    opts.threshold
                );
            }
        }
        let mut m = Vec::new();
        lights_in_slot(tree, c.node, k, &mut m);
        members.push(m);
    }
    ensure!(
        close(f64::from(cut.total_weight()), weight_sum, 1e-5, 0.0),
        "total_weight {} vs Σ weights {weight_sum} {ctx}",
        cut.total_weight()
    );
    ensure!(
        cut.max_score() == max_score,
        "max_score {} vs {max_score} {ctx}",
        cut.max_score()
    );

    // With room for every light, nothing that wants splitting stays a cluster.
    let sampled = tree.stats().sampled_lights as usize;
    if sampled <= cap {
        for (i, c) in clusters.iter().enumerate() {
            let node = &nodes[c.node as usize];
            if let Child::Node(_) = node.child(usize::from(c.slot)) {
                let wants = c.score > opts.threshold;
                ensure!(
                    !inside(node, usize::from(c.slot), x) && !wants,
                    "cluster {i} {c:?} wants splitting (score {}, threshold {}) and there is \
                     room ({sampled} lights, max_size {cap}) {ctx}",
                    c.score,
                    opts.threshold
                );
            }
        }
    }

    // Coverage: the opened nodes are the root and the child nodes of every proper ancestor
    // slot of a cluster. Each slot of positive importance of an opened node is a cluster, an
    // ancestor of one, or was dropped — allowed only when no path of positive importances
    // leads from it to a light (`dead_subtree`; by conservativeness none of its lights can
    // contribute). Then maximality: a cluster that wants splitting (x inside, or score above
    // the threshold) was not opened only because its children would not fit. The count
    // (clusters + queued) only decreases when an opened node has no positive slot (at most
    // `drops` times), so when the cluster was considered the count was at most len + drops;
    // opening it replaces 1 by its n_c positive children: len + drops − 1 + n_c > max_size.
    if !cut.is_empty() {
        let drops = check_coverage(tree, imp, clusters, &ctx)?;
        for (i, c) in clusters.iter().enumerate() {
            let node = &nodes[c.node as usize];
            let k = usize::from(c.slot);
            let Child::Node(child) = node.child(k) else {
                continue;
            };
            if !(inside(node, k, x) || c.score > opts.threshold) {
                continue;
            }
            let n_c = positive_slots(imp, &nodes[child as usize]);
            ensure!(
                cut.len() + drops + n_c > cap + 1,
                "cluster {i} {c:?} wants splitting and its {n_c} children fit: {} clusters,                  {drops} dropped, max_size {cap} {ctx}",
                cut.len()
            );
        }
    }

    // Disjoint.
    let owner = check_disjoint(clusters, &members, n, &ctx)?;

    // pmf_in: the owner, a pmf in [0, 1].
    let pmf_in = check_pmf_in(&cut, tree, imp, &owner, &ctx)?;
    for bad in [n as u32, u32::MAX] {
        ensure!(
            cut.pmf_in(tree, imp, bad).is_none(),
            "pmf_in of index {bad}"
        );
        ensure!(cut.pmf(tree, imp, bad) == 0.0, "pmf of index {bad}");
    }
    check_batched(&cut, tree, *imp, n, us, &ctx)?;

    // Per cluster: pmfs sum to 1 or are all 0; sample_in agrees.
    for (i, m) in members.iter().enumerate() {
        let (sum, dead) = check_cluster_pmf_sum(clusters, i, m, &pmf_in, &ctx)?;
        report.dead += usize::from(dead);
        for &u in us {
            match cut.sample_in(tree, imp, i, u) {
                None => ensure!(
                    dead,
                    "cluster {i} {:?}: sample_in(u={u}) is None but its pmfs sum to {sum} {ctx}",
                    clusters[i]
                ),
                Some(s) => {
                    ensure!(
                        !dead,
                        "cluster {i}: sample_in(u={u}) returned {s:?} from a cluster of zero pmfs {ctx}"
                    );
                    ensure!(
                        owner.get(s.light as usize) == Some(&Some(i)),
                        "cluster {i} {:?}: sample_in(u={u}) returned light {} outside it {ctx}",
                        clusters[i],
                        s.light
                    );
                    let p = pmf_in[s.light as usize];
                    ensure!(
                        s.pmf > 0.0 && close(f64::from(s.pmf), f64::from(p), 1e-5, 0.0),
                        "cluster {i}: sample_in(u={u}) light {} pmf {} vs pmf_in {p} {ctx}",
                        s.light,
                        s.pmf
                    );
                }
            }
        }
    }
    for &u in &us[..2] {
        ensure!(
            cut.sample_in(tree, imp, cut.len(), u).is_none(),
            "sample_in of cluster len()"
        );
    }

    // pmf = weight / total · pmf_in; sample reports pmf().
    for l in 0..n {
        let p = check_light_pmf(&cut, tree, imp, &owner, &pmf_in, l, &ctx)?;
        report.pmf_sum += f64::from(p);
    }
    for &u in us {
        if let Some(s) = cut.sample(tree, imp, u) {
            let l = s.light as usize;
            ensure!(
                l < n && owner[l].is_some(),
                "sample(u={u}) returned {s:?} outside the cut {ctx}"
            );
            let p = cut.pmf(tree, imp, s.light);
            ensure!(
                s.pmf > 0.0 && close(f64::from(s.pmf), f64::from(p), 1e-5, 0.0),
                "sample(u={u}) light {l}: pmf {} vs pmf() {p} {ctx}",
                s.pmf
            );
        } else {
            ensure!(
                report.dead > 0 || cut.is_empty(),
                "sample(u={u}) is None on a cut of {} clusters none of them dead {ctx}",
                cut.len()
            );
        }
    }

    // Property 4: conservative through the cut.
    for (l, light) in lights.iter().enumerate() {
        if contribution(light, imp) > 0.0 {
            report.contributing += 1;
            let p = cut.pmf(tree, imp, l as u32);
            ensure!(
                owner[l].is_some() && pmf_in[l] > 0.0 && p > 0.0,
                "light {l} {light:?} reaches the point but is in cluster {:?} with pmf_in {} \
                 and pmf {p} {ctx}",
                owner[l],
                pmf_in[l]
            );
        }
    }
    Ok((cut, report))
}

/// Property 2 at one shading point: the split-sampling estimator Σ_i f(L_i)/p_i(L_i), one
/// light L_i drawn per cluster with the pmf `pmf_in` gives, has expectation
/// Σ_i Σ_{l in cluster i, p_i(l) > 0} p_i(l) · f(l)/p_i(l); it must equal Σ_l f(l) over all
/// lights (1e-4 relative). The one-sample estimator f(L)/p(L) of `sample` / `pmf` is
/// enumerated the same way. Returns (expectation, exact sum).
fn check_unbiased(
    tree: &LightTree,
    lights: &[Light],
    imp: &TlImportance,
    cut: &LightCut,
) -> Result<(f64, f64), String> {
    let mut exact = 0.0f64;
    let mut split = 0.0f64;
    let mut one = 0.0f64;
    let mut missing = Vec::new();
    for (l, light) in lights.iter().enumerate() {
        let f = contribution(light, imp);
        exact += f;
        let got = cut.pmf_in(tree, imp, l as u32);
        if let Some((_, p)) = got {
            if p > 0.0 {
                split += f64::from(p) * (f / f64::from(p));
            }
        }
        let p = f64::from(cut.pmf(tree, imp, l as u32));
        if p > 0.0 {
            one += p * (f / p);
        }
        if f > 0.0 && !matches!(got, Some((_, p)) if p > 0.0) {
            missing.push((l, got));
        }
    }
    ensure!(
        missing.is_empty() && close(split, exact, 1e-4, 0.0) && close(one, exact, 1e-4, 0.0),
        "biased at {imp:?}: E[split estimator] = {split}, E[one-sample] = {one}, Σf = {exact}; \
         contributing lights without a cluster of positive pmf_in (light, pmf_in): {missing:?}"
    );
    Ok((split, exact))
}

// ---------------------------------------------------------------------------------------------
// Property 1 (and 3, 4) on random scenes
// ---------------------------------------------------------------------------------------------

/// Scene sizes: mostly small, some medium, a few up to 3,000.
fn scene_size() -> impl Strategy<Value = usize> {
    prop_oneof![
        4 => 1usize..=8,
        4 => 9usize..=300,
        1 => 301usize..=3000,
    ]
}

/// `points` shading points of a scene, each with `opts_per_point` random option sets (and
/// always threshold 0 and ∞ at max_size 64): [`check_cut`] and [`check_unbiased`].
fn check_scene(
    lights: &[Light],
    half: f32,
    rng: &mut Rng,
    points: usize,
    opts_per_point: usize,
) -> Result<PointReport, String> {
    let tree = LightTree::build(lights).map_err(|e| e.to_string())?;
    let mut total = PointReport::default();
    for _ in 0..points {
        let imp = cut_point(rng, &tree, lights, half);
        let us = u_values(rng, EXTRA_U);
        let mut all = vec![
            SplitCutOptions {
                threshold: 0.0,
                max_size: MAX_CUT_SIZE,
            },
            SplitCutOptions {
                threshold: f32::INFINITY,
                max_size: MAX_CUT_SIZE,
            },
        ];
        all.extend((0..opts_per_point).map(|_| random_options(rng)));
        for opts in &all {
            let (cut, r) = check_cut(&tree, lights, &imp, opts, &us)?;
            check_unbiased(&tree, lights, &imp, &cut)?;
            total.clusters += r.clusters;
            total.contributing += r.contributing;
            total.dead += r.dead;
        }
    }
    Ok(total)
}

proptest::proptest! {
    #![proptest_config(proptest_config(96, 0x6375_7473))]

    /// Properties 1, 3 (agreement) and 4 over random scenes of 1 to 3,000 lights of all kinds
    /// and styles, shading points of every kind (inside clusters, on lights, at point lights,
    /// far), every receiver, thresholds from 0 to ∞ and max_size 1..=64.
    #[test]
    fn split_cut_invariants_on_random_scenes(n in scene_size(), seed in any::<u64>()) {
        let (lights, half) = styled_scene(seed, n);
        let mut rng = Rng::new(seed ^ 0xC07);
        let points = if n > 500 { 3 } else { 8 };
        check_scene(&lights, half, &mut rng, points, 3).map_err(TestCaseError::fail)?;
    }
}

/// The same on fixed sizes: 1 to 5 lights (every shape of a root), around one and two levels
/// of 4-wide nodes, and 3,000. Asserts the checks are not vacuous.
#[test]
fn split_cut_invariants_fixed_sizes() {
    let mut total = PointReport::default();
    for (i, n) in [1usize, 2, 3, 4, 5, 16, 17, 64, 65, 200, 3000]
        .into_iter()
        .enumerate()
    {
        let seeds = if n > 500 { 2 } else { 6 };
        for s in 0..seeds {
            let seed = 7000 + 100 * i as u64 + s;
            let (lights, half) = styled_scene(seed, n);
            let mut rng = Rng::new(seed);
            let r = check_scene(&lights, half, &mut rng, 6, 3)
                .unwrap_or_else(|e| panic!("n={n} seed={seed}: {e}"));
            total.clusters += r.clusters;
            total.contributing += r.contributing;
        }
    }
    eprintln!("fixed sizes: {total:?}");
    assert!(total.clusters > 5_000, "{total:?}");
    assert!(total.contributing > 20_000, "{total:?}");
}

// ---------------------------------------------------------------------------------------------
// Property 2: unbiasedness by exact enumeration
// ---------------------------------------------------------------------------------------------

/// Split sampling is unbiased: on 60 scenes of up to 200 lights, at 30 shading points each,
/// with thresholds from 0 to ∞ and max_size 1..=64, the enumerated expectation of the
/// split-sampling estimator (and of the one-sample estimator of `sample`) equals Σ_l f(l)
/// over all lights. Asserts many contributing pairs and multi-cluster cuts were seen.
#[test]
fn split_sampling_is_unbiased_by_exact_enumeration() {
    let mut rng = Rng::new(0xE7AC7);
    let (mut points, mut pairs, mut multi) = (0usize, 0usize, 0usize);
    for scene in 0..60u64 {
        let n = 1 + rng.below(200);
        let (lights, half) = styled_scene(0x5EED_0000 + scene, n);
        let tree = LightTree::build(&lights).unwrap();
        for _ in 0..30 {
            let imp = cut_point(&mut rng, &tree, &lights, half);
            for opts in [
                random_options(&mut rng),
                random_options(&mut rng),
                SplitCutOptions::default(),
            ] {
                let cut = LightCut::build_split(&tree, &imp, &opts);
                let (_, exact) = check_unbiased(&tree, &lights, &imp, &cut)
                    .unwrap_or_else(|e| panic!("scene {scene} (n={n}) {opts:?}: {e}"));
                points += 1;
                pairs += lights
                    .iter()
                    .filter(|l| contribution(l, &imp) > 0.0)
                    .count();
                multi += usize::from(cut.len() > 4 && exact > 0.0);
            }
        }
    }
    eprintln!("{points} (point, options), {pairs} contributing pairs, {multi} cuts > 4 clusters");
    assert!(pairs > 50_000, "only {pairs} contributing pairs");
    assert!(multi > 1_000, "only {multi} cuts of more than 4 clusters");
}

// ---------------------------------------------------------------------------------------------
// Property 3: sample / pmf of the whole cut
// ---------------------------------------------------------------------------------------------

/// `cut.pmf` over all lights sums to 1 (1e-4) whenever the cut is non-empty, and `sample`
/// returns a light for every u then: on random scenes and points with random options.
/// (`check_cut` already holds `sample`'s pmf equal to `pmf()`; this is the normalisation.)
#[test]
fn cut_pmfs_sum_to_one_on_random_scenes() {
    let mut rng = Rng::new(0x5017);
    let mut failures = Vec::new();
    let mut checked = 0;
    for scene in 0..80u64 {
        let n = [1, 3, 10, 50, 200, 1000][rng.below(6)];
        let (lights, half) = styled_scene(0x50_0000 + scene, n);
        let tree = LightTree::build(&lights).unwrap();
        for _ in 0..12 {
            let imp = cut_point(&mut rng, &tree, &lights, half);
            let opts = random_options(&mut rng);
            let us = u_values(&mut rng, EXTRA_U);
            let (cut, r) = check_cut(&tree, &lights, &imp, &opts, &us)
                .unwrap_or_else(|e| panic!("scene {scene} (n={n}): {e}"));
            if cut.is_empty() {
                assert_eq!(r.pmf_sum, 0.0);
                assert!(us.iter().all(|&u| cut.sample(&tree, &imp, u).is_none()));
                continue;
            }
            checked += 1;
            if (r.pmf_sum - 1.0).abs() > 1e-4 {
                failures.push(format!(
                    "scene 0x{:x} (n={n}) at {imp:?} with {opts:?}: Σ pmf = {}, {} of {} \
                     clusters have only zero-pmf lights",
                    0x50_0000 + scene,
                    r.pmf_sum,
                    r.dead,
                    r.clusters
                ));
            }
        }
    }
    assert!(checked > 500, "only {checked} non-empty cuts");
    assert!(
        failures.is_empty(),
        "{} of {checked} cuts: pmfs do not sum to 1; first ones:\n{}",
        failures.len(),
        failures[..failures.len().min(5)].join("\n")
    );
}

/// The deterministic reproduction of the failure above, if any: the ring scene of
/// `tests/sampling.rs` (64 one-sided disks facing +z on a unit circle, four point lights far
/// below, the omnidirectional point just below the circle's centre). A cluster of disks has a
/// positive importance (its sphere reaches the point) but all four of its children have
/// importance 0. When the cut keeps that cluster unsplit (threshold ∞, only inside-sphere
/// splits), `sample_in` returns `None` for it, so `sample(u)` returns `None` for u in its share
/// of the total weight and the pmfs of the non-empty cut sum to less than 1 — whereas
/// `LightTree::sample` falls back to the energies at such a node (docs/formulas.md, section 12) and
/// never fails below a root of positive importance. With threshold ∞ and max_size 16 the cut
/// has 13 clusters, 4 of them dead (paths 20, 22, 25, 26), Σ pmf = 0.98634, and
/// `cut.sample(.., 0.85)` is `None` (1.37 % of all u are).
#[test]
fn cut_sample_is_some_and_pmfs_sum_to_one_with_zero_importance_cluster() {
    let (lights, imp) = ring_scene();
    let tree = LightTree::build(&lights).unwrap();
    let mut rng = Rng::new(0x121C);
    let us = u_values(&mut rng, 200);
    let mut failures = Vec::new();
    for threshold in [f32::INFINITY, 1.0, 1e-3, 0.0] {
        for max_size in [1, 4, 8, 16, 64] {
            let opts = SplitCutOptions {
                threshold,
                max_size,
            };
            // Everything else holds (including unbiasedness: the dead cluster holds no light
            // that reaches the point).
            let (cut, r) = check_cut(&tree, &lights, &imp, &opts, &us).unwrap();
            check_unbiased(&tree, &lights, &imp, &cut).unwrap();
            assert!(!cut.is_empty());
            let none = us
                .iter()
                .filter(|&&u| cut.sample(&tree, &imp, u).is_none())
                .count();
            if (r.pmf_sum - 1.0).abs() > 1e-4 || none > 0 {
                let dead: Vec<_> = (0..cut.len())
                    .filter(|&i| cut.sample_in(&tree, &imp, i, 0.5).is_none())
                    .map(|i| cut.clusters()[i])
                    .collect();
                failures.push(format!(
                    "{opts:?}: {} clusters, Σ pmf = {}, sample() None for {none} of {} u; \
                     dead clusters {dead:?}",
                    cut.len(),
                    r.pmf_sum,
                    us.len()
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "non-empty cuts whose sample() fails / pmfs do not sum to 1:\n{}",
        failures.join("\n")
    );
}

/// `sample` clamps u like `LightTree::sample`: 1 and above act as 1 − 2^-24, NaN and
/// negatives as 0.
#[test]
fn cut_sample_clamps_u() {
    let (lights, half) = styled_scene(0xC1A, 100);
    let tree = LightTree::build(&lights).unwrap();
    let mut rng = Rng::new(0xC1A);
    for _ in 0..50 {
        let imp = cut_point(&mut rng, &tree, &lights, half);
        let cut = LightCut::build_split(&tree, &imp, &random_options(&mut rng));
        let top = cut.sample(&tree, &imp, 1.0 - f32::EPSILON / 2.0);
        let zero = cut.sample(&tree, &imp, 0.0);
        assert_eq!(cut.sample(&tree, &imp, 1.0), top);
        assert_eq!(cut.sample(&tree, &imp, 7.5), top);
        assert_eq!(cut.sample(&tree, &imp, f32::INFINITY), top);
        assert_eq!(cut.sample(&tree, &imp, f32::NAN), zero);
        assert_eq!(cut.sample(&tree, &imp, -1.0), zero);
        for i in 0..cut.len() {
            let top = cut.sample_in(&tree, &imp, i, 1.0 - f32::EPSILON / 2.0);
            assert_eq!(cut.sample_in(&tree, &imp, i, 1.0), top);
            assert_eq!(
                cut.sample_in(&tree, &imp, i, f32::NAN),
                cut.sample_in(&tree, &imp, i, 0.0)
            );
        }
    }
}

/// Pearson's chi-square (level 0.001, bins of expected count < 5 merged, Wilson–Hilferty
/// critical value) of 10^6 `cut.sample` draws against `cut.pmf`, at three shading points of a
/// 64-light scene (fixed seed) with cuts of several clusters; "no light" is one more outcome,
/// of probability 1 − Σ pmf (the normalisation itself is the subject of
/// `cut_pmfs_sum_to_one_on_random_scenes`). Lights of pmf 0 must never be drawn. The test has power: the same counts against the pmfs with the largest one 5 % too
/// big (renormalised) are rejected.
#[test]
fn cut_chi_square_against_pmf() {
    let spec = SceneSpec {
        half: 10.0,
        zero_energy: 0.05,
        power: (0.5, 5.0),
        ..SceneSpec::default()
    };
    let mut rng = Rng::new(0xC41C);
    let lights = common::random_scene(&mut rng, 64, &spec);
    let tree = LightTree::build(&lights).unwrap();
    let cases = [
        (
            TlImportance::new(Vec3::new(0.5, -1.0, 0.2), Vec3::new(0.2, 0.3, 1.0)),
            SplitCutOptions {
                threshold: 1e-3,
                max_size: 8,
            },
        ),
        (
            TlImportance::with_receiver(Vec3::new(3.0, 2.0, -4.0), Vec3::X, Receiver::Transmissive),
            SplitCutOptions {
                threshold: 1e-4,
                max_size: 32,
            },
        ),
        (
            TlImportance::with_receiver(Vec3::ZERO, Vec3::ZERO, Receiver::Omnidirectional),
            SplitCutOptions {
                threshold: 0.0,
                max_size: 64,
            },
        ),
    ];
    let samples = 1_000_000usize;
    for (case, (imp, opts)) in cases.iter().enumerate() {
        let cut = LightCut::build_split(&tree, imp, opts);
        assert!(cut.len() >= 4, "case {case}: only {} clusters", cut.len());
        let pmfs = cut_pmfs(&cut, &tree, imp, lights.len());
        let total: f64 = pmfs.iter().sum();
        assert!(total <= 1.0 + 1e-4, "case {case}: Σ pmf = {total}");
        // `sample` may return no light (see `cut_pmfs_sum_to_one_on_random_scenes`): that
        // outcome is a bin of its own, of expected mass 1 − Σ pmf.
        let none_mass = (1.0 - total).max(0.0);
        let dead = (0..cut.len())
            .filter(|&i| cut.sample_in(&tree, imp, i, 0.5).is_none())
            .count();
        let (counts, none) = cut_sample_counts(&cut, &tree, imp, lights.len(), samples, &mut rng);
        // Normalised so that the expected counts add up to exactly `samples`.
        let norm = total + none_mass;
        let (mut obs, mut exp) = (vec![none], vec![samples as f64 * none_mass / norm]);
        for l in 0..lights.len() {
            if pmfs[l] == 0.0 {
                assert_eq!(counts[l], 0, "case {case}: light {l} of pmf 0 drawn");
            } else {
                obs.push(counts[l]);
                exp.push(samples as f64 * pmfs[l] / norm);
            }
        }
        eprintln!(
            "case {case}: Σ pmf = {total:.6}, {dead} dead clusters, {none} draws of no light"
        );
        let (stat, dof) = chi2_statistic(&obs, &exp);
        let crit = chi2_critical(dof, Z_999);
        eprintln!(
            "case {case}: {} clusters, chi2 = {stat:.2}, critical {crit:.2}, dof {dof}",
            cut.len()
        );
        assert!(dof >= 15, "case {case}: only {dof} degrees of freedom");
        assert!(
            stat < crit,
            "case {case}: chi2 = {stat:.2} ≥ {crit:.2} (dof {dof})"
        );
        let skewed_stat = chi2_skewed_statistic(&obs, &exp, samples);
        assert!(
            skewed_stat > crit,
            "case {case}: a 5 % error in the largest pmf goes unnoticed ({skewed_stat} ≤ {crit})"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Property 4 near the boundaries
// ---------------------------------------------------------------------------------------------

/// Property 4 on scenes built to sit near the zero boundaries (half the one-sided emitters and
/// spots flattened into z = 0, shading points just above or below that plane), through cuts of
/// every threshold and size: each light that reaches the point has a positive `pmf_in` and
/// `pmf`, and the enumerated estimator is unbiased. Asserts the test is not vacuous.
#[test]
fn contributing_lights_have_positive_cut_pmf_near_boundaries() {
    let mut rng = Rng::new(0xB0C);
    let mut checked = 0;
    for _ in 0..30 {
        let lights = boundary_scene(&mut rng);
        let tree = LightTree::build(&lights).unwrap();
        for _ in 0..8 {
            let mut x = rng.in_cube(10.0);
            x.z = [0.0, 1e-3, -1e-3, 0.05, -0.05][rng.below(5)];
            let n = [Vec3::Z, -Vec3::Z, Vec3::X, rng.unit()][rng.below(4)];
            let us = u_values(&mut rng, 2);
            for receiver in RECEIVERS {
                let imp = TlImportance::with_receiver(x, n, receiver);
                for threshold in [0.0, 1e-3, f32::INFINITY] {
                    let opts = SplitCutOptions {
                        threshold,
                        max_size: 1 + rng.below(MAX_CUT_SIZE),
                    };
                    let (cut, r) = check_cut(&tree, &lights, &imp, &opts, &us)
                        .unwrap_or_else(|e| panic!("{e}"));
                    check_unbiased(&tree, &lights, &imp, &cut).unwrap_or_else(|e| panic!("{e}"));
                    checked += r.contributing;
                }
            }
        }
    }
    assert!(checked > 10_000, "only {checked} contributing pairs");
}

// ---------------------------------------------------------------------------------------------
// Property 5: edges
// ---------------------------------------------------------------------------------------------

/// An empty tree (no lights, or only zero-energy ones) and a shading point with a non-finite
/// position give an empty cut: no cluster, total 0, `sample`/`sample_in` `None`, pmfs 0.
#[test]
fn empty_tree_gives_empty_cut() {
    let zero = vec![
        Light::Point {
            position: Vec3::ONE,
            intensity: Rgb::grey(0.0),
        },
        Light::Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
            radiance: Rgb::grey(0.0),
        },
    ];
    let imp = TlImportance::new(Vec3::ZERO, Vec3::Z);
    for lights in [Vec::new(), zero] {
        let tree = LightTree::build(&lights).unwrap();
        assert!(tree.is_empty());
        for threshold in THRESHOLDS {
            for max_size in [0, 1, 4, 64, 1000] {
                let opts = SplitCutOptions {
                    threshold,
                    max_size,
                };
                let cut = LightCut::build_split(&tree, &imp, &opts);
                assert!(cut.is_empty() && cut.clusters().is_empty());
                assert_eq!(cut.len(), 0);
                assert_eq!(cut.total_weight(), 0.0);
                assert_eq!(cut.sample(&tree, &imp, 0.5), None);
                assert_eq!(cut.sample_in(&tree, &imp, 0, 0.5), None);
                for l in 0..lights.len() as u32 + 1 {
                    assert_eq!(cut.pmf(&tree, &imp, l), 0.0);
                    assert_eq!(cut.pmf_in(&tree, &imp, l), None);
                }
            }
        }
    }
    assert!(LightCut::new().is_empty());
    assert!(LightCut::default().is_empty());
    // A shading point nothing can reach: a non-finite position.
    let (lights, _) = styled_scene(0xE, 50);
    let tree = LightTree::build(&lights).unwrap();
    for x in [Vec3::NAN, Vec3::splat(f32::INFINITY)] {
        let imp = TlImportance::new(x, Vec3::Z);
        let cut = LightCut::build_split(&tree, &imp, &SplitCutOptions::default());
        assert!(cut.is_empty());
        assert_eq!(cut.sample(&tree, &imp, 0.3), None);
    }
}

/// `max_size` is clamped to MIN_CUT_SIZE..=64: 0..4 build what 4 builds, anything above 64 what
/// 64 builds.
#[test]
fn max_size_is_clamped() {
    let mut rng = Rng::new(0xC1A4);
    for scene in 0..20u64 {
        let (lights, half) = styled_scene(0xC1A4_0000 + scene, 1 + rng.below(2000));
        let tree = LightTree::build(&lights).unwrap();
        for _ in 0..10 {
            let imp = cut_point(&mut rng, &tree, &lights, half);
            let threshold = THRESHOLDS[rng.below(THRESHOLDS.len())];
            let build = |max_size| {
                LightCut::build_split(
                    &tree,
                    &imp,
                    &SplitCutOptions {
                        threshold,
                        max_size,
                    },
                )
            };
            for small in 0..MIN_CUT_SIZE {
                assert_eq!(build(small).clusters(), build(MIN_CUT_SIZE).clusters());
            }
            assert_eq!(build(65).clusters(), build(64).clusters());
            assert_eq!(build(usize::MAX).clusters(), build(64).clusters());
        }
    }
}

/// The documented size bound: at most `max_size` clusters, `max_size` clamped to
/// MIN_CUT_SIZE..=MAX_CUT_SIZE (a cut can be no coarser than the root's four slots), for every
/// max_size 1..=64 on random scenes and points. (Regression: below 4 the root's slots used to
/// be placed unchecked while the documentation promised `max_size`.)
#[test]
fn split_cut_len_at_most_max_size() {
    let mut rng = Rng::new(0x512E);
    let mut failures = Vec::new();
    for scene in 0..40u64 {
        let n = [1, 2, 3, 4, 5, 20, 300][rng.below(7)];
        let (lights, half) = styled_scene(0x512E_0000 + scene, n);
        let tree = LightTree::build(&lights).unwrap();
        for _ in 0..4 {
            let imp = cut_point(&mut rng, &tree, &lights, half);
            for max_size in 1..=MAX_CUT_SIZE {
                let threshold = THRESHOLDS[rng.below(THRESHOLDS.len())];
                let opts = SplitCutOptions {
                    threshold,
                    max_size,
                };
                let cut = LightCut::build_split(&tree, &imp, &opts);
                if cut.len() > max_size.clamp(MIN_CUT_SIZE, MAX_CUT_SIZE) {
                    failures.push(format!(
                        "scene styled_scene(0x{:x}, {n}) at {imp:?} with {opts:?}: {} clusters \
                         {:?}",
                        0x512E_0000 + scene,
                        cut.len(),
                        cut.clusters()
                    ));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} cuts exceed max_size; first ones:\n{}",
        failures.len(),
        failures[..failures.len().min(3)].join("\n")
    );
}

/// max_size = 1, deterministic: four far-apart point lights around the origin, shading point
/// at the origin (inside the root's sphere of radius ~10 but outside every light). The root has
/// four leaf slots, and the cut is those four: max_size is clamped up to MIN_CUT_SIZE.
#[test]
fn max_size_one_four_point_lights() {
    let lights: Vec<Light> = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y]
        .iter()
        .map(|&p| Light::Point {
            position: p * 10.0,
            intensity: Rgb::grey(1.0),
        })
        .collect();
    let tree = LightTree::build(&lights).unwrap();
    let imp = TlImportance::with_receiver(Vec3::ZERO, Vec3::ZERO, Receiver::Omnidirectional);
    let mut rng = Rng::new(1);
    let us = u_values(&mut rng, 4);
    for threshold in [0.0, f32::INFINITY] {
        let opts = SplitCutOptions {
            threshold,
            max_size: 1,
        };
        let (cut, r) = check_cut(&tree, &lights, &imp, &opts, &us).unwrap();
        check_unbiased(&tree, &lights, &imp, &cut).unwrap();
        assert_eq!(r.contributing, 4);
        assert!(
            cut.len() == 4,
            "max_size 1 {opts:?}: the cut has {} clusters {:?} (root slots {:?})",
            cut.len(),
            cut.clusters(),
            tree.nodes()[0].raw().mask
        );
    }
}

/// max_size = 1 on random scenes: clamped to MIN_CUT_SIZE, so the cut never exceeds four
/// clusters, and is complete and unbiased.
#[test]
fn max_size_one_cut_shape() {
    let mut rng = Rng::new(0x1);
    for scene in 0..40u64 {
        let n = [1, 2, 5, 50, 500][rng.below(5)];
        let (lights, half) = styled_scene(0x1_0000 + scene, n);
        let tree = LightTree::build(&lights).unwrap();
        for _ in 0..8 {
            let imp = cut_point(&mut rng, &tree, &lights, half);
            let us = u_values(&mut rng, 2);
            for threshold in THRESHOLDS {
                let opts = SplitCutOptions {
                    threshold,
                    max_size: 1,
                };
                let (cut, _) = check_cut(&tree, &lights, &imp, &opts, &us)
                    .unwrap_or_else(|e| panic!("scene {scene}: {e}"));
                check_unbiased(&tree, &lights, &imp, &cut)
                    .unwrap_or_else(|e| panic!("scene {scene}: {e}"));
                assert!(cut.len() <= MIN_CUT_SIZE, "scene {scene} {opts:?}");
            }
        }
    }
}

/// Threshold 0 splits everything that fits: on scenes of at most 64 lights with max_size 64
/// (the capacity never binds) every cluster is a single light, or a cluster whose criterion
/// is exactly 0 (lights at one point of equal energies) with x outside it. (`check_cut`
/// verifies the criterion's value.) Asserts cuts of many clusters were seen.
#[test]
fn threshold_zero_splits_everything_that_fits() {
    let mut rng = Rng::new(0x7E0);
    let mut lights_clusters = 0usize;
    for scene in 0..60u64 {
        let n = 1 + rng.below(64);
        let (lights, half) = styled_scene(0x7E0_0000 + scene, n);
        let tree = LightTree::build(&lights).unwrap();
        for _ in 0..10 {
            let imp = cut_point(&mut rng, &tree, &lights, half);
            let us = u_values(&mut rng, 2);
            let opts = SplitCutOptions {
                threshold: 0.0,
                max_size: 64,
            };
            let (cut, _) = check_cut(&tree, &lights, &imp, &opts, &us)
                .unwrap_or_else(|e| panic!("scene {scene}: {e}"));
            for c in cut.clusters() {
                let node = &tree.nodes()[c.node as usize];
                let k = usize::from(c.slot);
                match tree.slot(node, k) {
                    Slot::Light(_) => lights_clusters += 1,
                    _ => assert!(
                        c.score == 0.0 && !inside(node, k, imp.position()),
                        "scene {scene}: threshold 0 left {c:?} unsplit at {imp:?}"
                    ),
                }
            }
        }
    }
    assert!(
        lights_clusters > 5_000,
        "only {lights_clusters} single-light clusters"
    );
}

/// Threshold ∞ (and 1e30, and NaN which no score exceeds) splits only slots whose bounding
/// sphere holds x: every ancestor of every cluster contains x, and with room for every light
/// no inner cluster contains x. A point far outside the scene gives the root's slots.
#[test]
fn threshold_infinite_splits_only_inside() {
    let mut rng = Rng::new(0x1F);
    let mut opened = 0usize;
    for scene in 0..60u64 {
        let n = 1 + rng.below(300);
        let (lights, half) = styled_scene(0x1F_0000 + scene, n);
        let tree = LightTree::build(&lights).unwrap();
        for i in 0..10 {
            let imp = if i == 0 {
                // Far outside every sphere, omnidirectional: exactly the root's slots.
                TlImportance::with_receiver(
                    Vec3::splat(1e4 * half),
                    Vec3::ZERO,
                    Receiver::Omnidirectional,
                )
            } else {
                cut_point(&mut rng, &tree, &lights, half)
            };
            let us = u_values(&mut rng, 2);
            for threshold in [f32::INFINITY, 1e30, f32::NAN] {
                let opts = SplitCutOptions {
                    threshold,
                    max_size: 1 + rng.below(MAX_CUT_SIZE),
                };
                let (cut, _) = check_cut(&tree, &lights, &imp, &opts, &us)
                    .unwrap_or_else(|e| panic!("scene {scene}: {e}"));
                let x = imp.position();
                for c in cut.clusters() {
                    let l = levels(c.path);
                    opened += usize::from(l > 1);
                    for up in 1..l {
                        let (an, ak) = tree.slot_at(c.path >> (2 * up)).unwrap();
                        assert!(
                            inside(&tree.nodes()[an as usize], ak, x),
                            "scene {scene} {opts:?}: ancestor ({an}, {ak}) of {c:?} was split \
                             without containing x = {x:?}"
                        );
                    }
                }
                if i == 0 {
                    let root_slots = positive_slots(&imp, &tree.nodes()[0]);
                    assert_eq!(cut.len(), root_slots, "scene {scene}: far point {opts:?}");
                    assert!(cut.clusters().iter().all(|c| levels(c.path) == 1));
                }
            }
        }
    }
    assert!(opened > 1_000, "only {opened} clusters below the root");
}

// ---------------------------------------------------------------------------------------------
// Regressions: vanishing probabilities
// ---------------------------------------------------------------------------------------------

/// Scenes whose pmfs span more than f32's range: the example of a light of intensity 1e-40
/// between two ordinary ones, a shading point on a point light at 1e15 with the others 1e15
/// away, and 16 groups of three point lights each 1e-3 as bright as the one before.
fn vanishing_scenes() -> Vec<(Vec<Light>, TlImportance)> {
    let example = vec![
        Light::Point {
            position: Vec3::new(1.0, 1.0, 1.0),
            intensity: Rgb::grey(2.0),
        },
        Light::Point {
            position: Vec3::new(0.0, 0.0, 2.0),
            intensity: Rgb::grey(1e-40),
        },
        Light::Sphere {
            center: Vec3::new(-1.0, 0.5, 1.5),
            radius: 0.25,
            radiance: Rgb::grey(3.0),
        },
    ];
    let at = Vec3::new(1e15, 0.0, 0.0);
    let mut far = vec![Light::Point {
        position: at,
        intensity: Rgb::grey(1.0),
    }];
    for i in 0..12 {
        far.push(Light::Point {
            position: Vec3::new(0.0, i as f32 * 1e13, 0.0),
            intensity: Rgb::grey(1.0 + i as f32),
        });
        far.push(Light::Point {
            position: Vec3::new(1e15, 1e15, i as f32 * 1e13),
            intensity: Rgb::grey(2.0),
        });
    }
    let mut chain = Vec::new();
    let mut intensity = 1.0f64;
    for i in 0..16 {
        for j in 0..3 {
            chain.push(Light::Point {
                position: Vec3::new(i as f32 * 10.0 + j as f32, 0.0, 1.0),
                intensity: Rgb::grey(intensity as f32),
            });
        }
        intensity *= 1e-3;
    }
    vec![
        (
            example,
            TlImportance::new(Vec3::new(0.0, 0.0, 1.0), Vec3::X),
        ),
        (
            far,
            TlImportance::with_receiver(at, Vec3::ZERO, Receiver::Omnidirectional),
        ),
        (
            chain,
            TlImportance::with_receiver(
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::ZERO,
                Receiver::Omnidirectional,
            ),
        ),
    ]
}

/// Regression: `LightCut::sample` returned lights with pmf 0 (a cluster whose share
/// `weight / total` underflows, or a light whose pmf in the cluster times that share does),
/// and `sample_in` did within a cluster. Every pmf reported for a returned light is now at
/// least `MIN_PMF`, equal bit for bit to `pmf` / `pmf_in` (and to the batched calls), and the
/// pmfs of all lights still sum to 1 (within 1e-4: products of at most 32 ratios, each a few
/// ulps off).
#[test]
fn cut_sample_never_returns_vanishing_pmf() {
    let mut rng = Rng::new(0xC07);
    for (scene, (lights, at)) in vanishing_scenes().into_iter().enumerate() {
        let tree = LightTree::build(&lights).unwrap();
        let n = lights.len();
        let mut points = vec![at];
        points.extend((0..20).map(|_| random_importance(&mut rng, &lights, 4.0)));
        for imp in points {
            for (threshold, max_size) in [(0.0, MAX_CUT_SIZE), (1e-3, 32), (f32::INFINITY, 4)] {
                let opts = SplitCutOptions {
                    threshold,
                    max_size,
                };
                let cut = LightCut::build_split(&tree, &imp, &opts);
                let ctx = format!("scene {scene} at {imp:?} with {opts:?}");
                let mut us = u_values(&mut rng, 16);
                us.extend([f32::NAN, -1.0]);
                let pmfs: Vec<f32> = (0..n as u32).map(|l| cut.pmf(&tree, &imp, l)).collect();
                for (l, &p) in pmfs.iter().enumerate() {
                    assert!(
                        p == 0.0 || (MIN_PMF..=1.0).contains(&p),
                        "light {l} has cut pmf {p:e}, {ctx}"
                    );
                }
                for &u in &us {
                    if let Some(s) = cut.sample(&tree, &imp, u) {
                        assert!((MIN_PMF..=1.0).contains(&s.pmf), "u={u}: {s:?}, {ctx}");
                        assert_eq!(s.pmf, pmfs[s.light as usize], "u={u}: {s:?}, {ctx}");
                    }
                    for i in 0..cut.len() {
                        let Some(s) = cut.sample_in(&tree, &imp, i, u) else {
                            continue;
                        };
                        assert!(
                            (MIN_PMF..=1.0).contains(&s.pmf),
                            "cluster {i}, u={u}: {s:?}, {ctx}"
                        );
                        assert_eq!(
                            cut.pmf_in(&tree, &imp, s.light),
                            Some((i, s.pmf)),
                            "cluster {i}, u={u}: {s:?}, {ctx}"
                        );
                    }
                }
                let sum: f64 = pmfs.iter().map(|&p| f64::from(p)).sum();
                if cut.is_empty() {
                    assert_eq!(sum, 0.0, "{ctx}");
                } else {
                    assert!((sum - 1.0).abs() <= 1e-4, "pmfs sum to {sum}, {ctx}");
                    assert!(cut.sample(&tree, &imp, 0.0).is_some(), "{ctx}");
                }
                check_batched(&cut, &tree, imp, n, &us, &ctx).unwrap();
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Lights at infinity: a host's own cut sampling
// ---------------------------------------------------------------------------------------------

/// `f · L · cos θ / pdf` of a light chosen by a cut, with a Lambert BRDF of albedo `albedo`
/// at the origin (normal +z): a point on the light, or for the environment a direction the
/// host's sky samples (what a host does with a light the cut gives it). Channel 0.
fn host_contribution(
    lights: &[Light],
    sky: &manylights::light::UniformSky,
    light: u32,
    albedo: f64,
    uv: [f32; 2],
) -> f64 {
    use manylights::light::Environment;
    let f = albedo / std::f64::consts::PI;
    match &lights[light as usize] {
        Light::Environment { .. } => sky.sample(uv).map_or(0.0, |s| {
            let cos = f64::from(s.direction.z.max(0.0));
            f * f64::from(s.radiance.to_array()[0]) * cos / f64::from(s.pdf)
        }),
        l => manylights::light::sample_point(l, Vec3::ZERO, uv).map_or(0.0, |p| {
            let cos = f64::from(p.direction.z.max(0.0));
            if p.pdf > 0.0 {
                f * f64::from(p.radiance.to_array()[0]) * cos / f64::from(p.pdf)
            } else {
                0.0
            }
        }),
    }
}

/// A host sampling a light cut on its own (`LightCut::sample` / `pmf` one light at a time,
/// `sample_each` / `pmf_in` one light per cluster, the BRDF-oriented and the split cut) reaches
/// a sun and the environment: on a Lambert plane of albedo 0.8 (normal +z) under a sun of
/// irradiance E at θ (reflects 0.8·E·cos θ / π), a uniform sky of radiance L (reflects 0.8·L),
/// both, and both with a sphere light (0.8·L·(r/d)²·cos θ), each estimate's mean is within 5
/// standard errors of the closed form. The pmfs the cut reports are those it samples with,
/// the estimators' BL sampler's bit for bit, and sum to 1; a sun below the horizon alone
/// leaves the cut empty.
#[test]
fn a_hosts_own_cut_sampling_counts_the_sun_and_the_sky() {
    use manylights::direct::{CutSampler, LightSampler};
    use manylights::light::{Environment, UniformSky};
    use manylights::{BlCutOptions, BlImportance, Material, ShadingPoint};
    let albedo = 0.8f64;
    let sky = UniformSky {
        radiance: Rgb::grey(0.3),
    };
    // The tree level takes the sky's light as it is.
    let sky_light = Light::Environment {
        irradiance: sky.irradiance_bounds(),
    };
    let sun_dir = Vec3::new(0.3, -0.2, 1.0);
    let sun = Light::Distant {
        direction: sun_dir,
        angular_radius: 0.0047,
        irradiance: Rgb::grey(2.0),
    };
    let (c, r, l) = (Vec3::new(0.5, -0.3, 2.0), 0.3f32, 4.0f32);
    let sphere = Light::Sphere {
        center: c,
        radius: r,
        radiance: Rgb::grey(l),
    };
    let pi = std::f64::consts::PI;
    let sun_exact = albedo / pi * 2.0 * f64::from(sun_dir.normalize().z);
    let sky_exact = albedo * 0.3;
    let d = f64::from(c.length());
    let sphere_exact = albedo * f64::from(l * r * r) / (d * d) * f64::from(c.z) / d;
    let scenes: [(Vec<Light>, f64); 4] = [
        (vec![sun], sun_exact),
        (vec![sky_light], sky_exact),
        (vec![sky_light, sun], sun_exact + sky_exact),
        (
            vec![sun, sphere, sky_light],
            sun_exact + sky_exact + sphere_exact,
        ),
    ];
    let sp = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::new(0.2, 0.1, 1.0),
        material: Material::Lambert {
            albedo: Rgb::grey(albedo as f32),
        },
    };
    let tl = TlImportance::new(Vec3::ZERO, Vec3::Z);
    let bl = BlImportance::new(&sp).unwrap();
    for (k, (lights, exact)) in scenes.iter().enumerate() {
        let tree = LightTree::build(lights).unwrap();
        let n = lights.len() as u32;
        let bl_cut = LightCut::build_bl(&tree, &bl, &BlCutOptions::default());
        let split = LightCut::build_split(&tree, &tl, &SplitCutOptions::default());
        let sampler = CutSampler::new(&tree, &sp, &BlCutOptions::default()).unwrap();
        for (name, cut, imp) in [
            ("bl", &bl_cut, &bl as &dyn Importance),
            ("split", &split, &tl as &dyn Importance),
        ] {
            let ctx = format!("scene {k}, {name} cut {:?}", cut.clusters());
            // The sun and the sky are clusters of their own.
            let infinite = lights.iter().filter(|l| l.is_infinite()).count();
            assert_eq!(cut.len(), cut.tree_clusters().len() + infinite, "{ctx}");
            let sum: f64 = (0..n).map(|l| f64::from(cut.pmf(&tree, imp, l))).sum();
            assert!((sum - 1.0).abs() <= 1e-5, "pmfs sum to {sum}, {ctx}");
            // One light of the whole cut per sample.
            let mut rng = Rng::new(0xC0_7000 + k as u64);
            let mut st = common::Stats::default();
            for _ in 0..40_000 {
                let Some(s) = cut.sample(&tree, imp, rng.f32()) else {
                    st.add(0.0);
                    continue;
                };
                assert_eq!(
                    s.pmf.to_bits(),
                    cut.pmf(&tree, imp, s.light).to_bits(),
                    "{ctx}"
                );
                let uv = [rng.f32(), rng.f32()];
                let v = host_contribution(lights, &sky, s.light, albedo, uv);
                st.add(v / f64::from(s.pmf));
            }
            let z = (st.mean() - exact) / st.se().max(1e-9 * exact);
            assert!(
                z.abs() <= 5.0,
                "sample: mean {} exact {exact} ({z:.2} SE), {ctx}",
                st.mean()
            );
            // One light in each cluster per sample (split sampling).
            let mut st = common::Stats::default();
            let mut out = [None; manylights::cut::CUT_CAPACITY];
            for _ in 0..10_000 {
                let us: Vec<f32> = (0..cut.len()).map(|_| rng.f32()).collect();
                cut.sample_each(&tree, imp, &us, &mut out[..cut.len()]);
                let mut v = 0.0;
                for (i, s) in out[..cut.len()].iter().enumerate() {
                    let s = s.unwrap_or_else(|| panic!("cluster {i} gave no light, {ctx}"));
                    assert_eq!(cut.pmf_in(&tree, imp, s.light), Some((i, s.pmf)), "{ctx}");
                    let uv = [rng.f32(), rng.f32()];
                    v += host_contribution(lights, &sky, s.light, albedo, uv) / f64::from(s.pmf);
                }
                st.add(v);
            }
            let z = (st.mean() - exact) / st.se().max(1e-9 * exact);
            assert!(
                z.abs() <= 5.0,
                "split: mean {} exact {exact} ({z:.2} SE), {ctx}",
                st.mean()
            );
        }
        // The estimators' BL sampler samples the same cut.
        for l in 0..n {
            let p = bl_cut.pmf(&tree, &bl, l);
            assert_eq!(
                sampler.pmf(l).to_bits(),
                p.to_bits(),
                "scene {k}, light {l}"
            );
        }
    }
    // A sun below the horizon alone: nothing can contribute, the cut is empty.
    let below = [Light::Distant {
        direction: Vec3::new(0.2, 0.0, -1.0),
        angular_radius: 0.0047,
        irradiance: Rgb::grey(2.0),
    }];
    let tree = LightTree::build(&below).unwrap();
    assert!(LightCut::build_split(&tree, &tl, &SplitCutOptions::default()).is_empty());
    assert!(LightCut::build_bl(&tree, &bl, &BlCutOptions::default()).is_empty());
}
