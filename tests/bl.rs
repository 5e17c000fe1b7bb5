//! The BRDF-oriented importance BL (`BlImportance`, docs/formulas.md, sections 7 and 8) and the light
//! cut it builds (`LightCut::build_bl`, docs/formulas.md, section 6), sampled as a whole (`sample` /
//! `pmf`) or per cluster (`sample_in` / `pmf_in`), and by plain tree descent (docs/formulas.md
//! section 12):
//!
//! 1. the 4-wide `eval4_with_integrals` equals the scalar `eval` lane by lane (importance, through
//!    the check shared with TL, and cap integral SC) on random nodes and shading points of every
//!    kind;
//! 2. conservativeness of BL alone: every light that can reach x keeps a positive pmf, through
//!    the tree and through a BL cut, including a mirror-like GGX lobe (α = 0.005) with tiny
//!    lights far from the mirror direction, where SC is 0 (lights of zero extent) or
//!    negligible;
//! 3. sampling: `sample`'s pmf equals `pmf()`, the pmfs sum to 1, zero-energy lights are never
//!    returned, and a chi-square test of `cut.sample`;
//! 4. cut properties: size, disjointness, the inside-sphere rule, the SC > δ rule, coverage,
//!    `max_score()` = IB(x) within the albedo bound;
//! 5. SC against ground truth for one sphere light: Lambert exactly (f64 quadrature and Monte
//!    Carlo), GGX within the SPTD's documented accuracy (MIS Monte Carlo);
//! 6. bad shading points: `BlImportance::new` names the field, never panics.
//!
//! Regressions are kept at the end: BL of a zero-extent cluster (point and spot lights,
//! coincident lights) used to ignore the BRDF (it now takes the point limit `f cos`), BL
//! used to overflow to +∞ where TL is finite (it is now clamped to `MAX_IMPORTANCE`), huge and
//! tiny normals and ωo, and three found by the `sptd` fuzz target (the SPTD lobe of a tiny
//! normal, the cap of a cluster closer than 1e-6, an infinite cap axis).
//!
//! Everything is seeded. Contribution is decided by `common::contributes` (f64, from the
//! light's geometry alone) for a reflective receiver whose normal is the one BL uses (turned to
//! the side of ωo), with every deciding cosine above [`MARGIN`], as in `tests/importance.rs`.

mod common;

use common::cut::{
    check_batched, check_cluster_pmf_sum, check_cluster_slot, check_coverage, check_disjoint,
    check_light_pmf, check_pmf_in, cut_pmfs, cut_sample_counts, levels, lights_in_slot,
    positive_slots,
};
use common::{
    chi2_critical, chi2_skewed_statistic, chi2_statistic, close, contributes, lanes_match_scalar,
    push_emitter_points, push_sphere_points, random_nodes, random_shading_point, shading_point,
    styled_scene, u_values, Rng, SceneSpec, Where, Z_999,
};
use glam::{DVec3, Vec3};
use manylights::cut::MAX_CUT_SIZE;
use manylights::cut::MIN_CUT_SIZE;
use manylights::error::ShadingField;
use manylights::importance::{f32x4, Receiver};
use manylights::internals::bl::DEFENSIVE;
use manylights::internals::sptd::SptdGgx;
use manylights::internals::tree::Node4Ext;
use manylights::tree::{Child, Node4, Slot, SlotBounds};
use manylights::Rgb;
use manylights::{
    BlCutOptions, BlImportance, Importance, Light, LightCut, LightTree, Material, ShadingPoint,
    SplitCutOptions, TlImportance,
};
use manylights_testkit::ggx::{Cap64, Ggx};
use std::f64::consts::PI;

/// Cosine margin of the contribution predicate (see `tests/importance.rs`: two orders of
/// magnitude above the f32 rounding of the importance's cosines).
const MARGIN: f64 = 1e-4;

/// The GGX roughnesses every check draws from (α = 0.005 is the table's floor).
const ALPHAS: [f32; 5] = [0.005, 0.05, 0.2, 0.6, 1.0];

/// The δ of the BL cut every check draws from (NaN: no SC exceeds it).
const DELTAS: [f32; 6] = [0.0, 0.1, 0.5, 1.0, f32::INFINITY, f32::NAN];

/// Wide-cap rules of the cut tests: every cluster (0), the default, Liu et al.'s (1), and
/// values out of range.
const SPLIT_SINS: [f32; 7] = [0.0, 0.5, 0.9, 1.0, 2.0, -1.0, f32::NAN];

macro_rules! ensure {
    ($cond:expr, $($fmt:tt)*) => {{
        let ok: bool = $cond;
        if !ok {
            return Err(format!($($fmt)*));
        }
    }};
}

// ---------------------------------------------------------------------------------------------
// Shading points
// ---------------------------------------------------------------------------------------------

/// A random material: Lambert, GGX (α from [`ALPHAS`]) or plastic, weights in (0, 1] (often 1).
fn random_material(rng: &mut Rng) -> Material {
    let weight = |rng: &mut Rng| {
        if rng.chance(0.3) {
            1.0
        } else {
            1.0 - rng.f32() // (0, 1]
        }
    };
    match rng.below(3) {
        0 => Material::Lambert {
            albedo: Rgb::grey(weight(rng)),
        },
        1 => Material::Ggx {
            alpha: ALPHAS[rng.below(ALPHAS.len())],
            specular: weight(rng),
        },
        _ => Material::Plastic {
            albedo: Rgb::grey(weight(rng)),
            specular: weight(rng),
            alpha: ALPHAS[rng.below(ALPHAS.len())],
        },
    }
}

/// A non-zero normal: usually unit, sometimes not normalised (the API normalises).
fn random_normal(rng: &mut Rng) -> Vec3 {
    if rng.below(5) == 0 {
        rng.unit() * rng.log_range(1e-3, 1e3)
    } else {
        rng.unit()
    }
}

/// A random ωo for the normal `n`: above the surface (uniform in cos θo), along the normal,
/// grazing (exactly in the tangent plane or up to 0.05 rad above it), or any of these below the
/// surface (the importance then turns the normal over). Not normalised.
fn random_wo(rng: &mut Rng, n: Vec3) -> Vec3 {
    let n = n.normalize();
    let u = rng.unit();
    let t = (u - n * u.dot(n))
        .try_normalize()
        .unwrap_or_else(|| n.any_orthonormal_vector());
    let grazing = |rng: &mut Rng| {
        let e: f32 = [0.0, 1e-6, 1e-4, 1e-2, 0.05][rng.below(5)];
        t * e.cos() + n * e.sin()
    };
    let above = |rng: &mut Rng| {
        let c = rng.f32();
        n * c + t * (1.0 - c * c).max(0.0).sqrt()
    };
    let w = match rng.below(8) {
        0..=2 => above(rng),
        3 => n,
        4 => grazing(rng),
        5 => -above(rng),
        6 => -grazing(rng),
        _ => -n,
    };
    w * rng.log_range(1e-3, 1e3)
}

/// The BL importance at `x` with a random normal, ωo and material (returned too).
fn random_bl_at(rng: &mut Rng, x: Vec3) -> (BlImportance, Material) {
    let normal = random_normal(rng);
    let sp = ShadingPoint {
        position: x,
        normal,
        wo: random_wo(rng, normal),
        material: random_material(rng),
    };
    let imp = BlImportance::new(&sp).unwrap_or_else(|e| panic!("{sp:?} rejected: {e}"));
    (imp, sp.material)
}

/// A shading point: in the scene, far, on a light, at a point light, or with probability 1/4
/// inside the bounding sphere of a random slot of a random node (where the cut must split);
/// random normal, ωo and material (returned too).
fn bl_point(
    rng: &mut Rng,
    tree: &LightTree,
    lights: &[Light],
    half: f32,
) -> (BlImportance, Material) {
    if tree.is_empty() || rng.below(4) == 0 {
        let x = random_shading_point(rng, lights, half);
        return random_bl_at(rng, x);
    }
    let nodes = tree.nodes();
    let node = &nodes[rng.below(nodes.len())];
    let filled: Vec<usize> = (0..4).filter(|&k| node.child(k) != Child::Empty).collect();
    let k = filled[rng.below(filled.len())];
    let c = node.sphere(k).center;
    let x = c + rng.unit() * (node.sphere(k).radius * rng.f32());
    random_bl_at(rng, x)
}

/// A representative point of a light: its position, centre, or the centroid of a triangle.
fn light_center(l: &Light) -> Vec3 {
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

/// Whether `light` reaches the shading point of `imp` (a reflective receiver on the side of
/// ωo, with every deciding cosine above [`MARGIN`]) and carries energy.
fn reaches(light: &Light, imp: &BlImportance) -> bool {
    light.energy() > 0.0
        && contributes(
            light,
            imp.position(),
            imp.normal(),
            Receiver::Reflective,
            MARGIN,
        )
}

// ---------------------------------------------------------------------------------------------
// Tree helpers
// ---------------------------------------------------------------------------------------------

/// The f32 test `build` uses for "x is inside the slot's bounding sphere", same operations.
fn inside(node: &Node4, k: usize, x: Vec3) -> bool {
    wide(node, k, x, 1.0)
}

/// The wide-cap rule of [`BlCutOptions::split_sin`]: `r ≥ s·d` (s clamped to [0, 1], NaN as 1).
fn wide(node: &Node4, k: usize, x: Vec3, split_sin: f32) -> bool {
    let c = node.sphere(k).center;
    let r = node.sphere(k).radius;
    let s = if split_sin < 1.0 {
        split_sin.max(0.0)
    } else {
        1.0
    };
    s * s * (c - x).length_squared() <= r * r
}

// ---------------------------------------------------------------------------------------------
// 1. Scalar vs 4-wide
// ---------------------------------------------------------------------------------------------

/// Relative tolerance of the lane comparison. The scalar `eval` and the 4-wide
/// `eval4_with_integrals` are written operation for operation alike: the same `ClusterView`
/// arithmetic, the same polynomial `atan2` (`sptd::trig`, whose scalar and 4-wide forms "agree
/// bit for bit"), the same cap and lens formulas, and IEEE `sqrt`/division in both; the wide
/// path only evaluates both sides of each branch and selects. So the expected difference is 0,
/// and anything beyond a few ulps is a bug. The tolerance, 1e-4 relative, leaves room for one
/// legitimately different rounding (e.g. a compiler-reordered sum, or the horizon area taken
/// by the other branch of a boundary test `cos ω ≥ sin σ` one ulp apart) propagated through the
/// ill-conditioned steps, the worst being the lens area of a cap straddling the horizon, whose
/// condition number is ~(cap size)/(lens size) — bounded here by 1e-4/6e-8 ≈ 1.7e3 — and still
/// catches any wrong formula, lane mix-up or branch error (those are O(1)). Documented in the
/// report with the worst difference seen.
const LANE_REL: f64 = 1e-4;

/// Absolute floor of the importance comparison: below f32's smallest normal (values there have
/// no relative precision).
const LANE_ABS_IMPORTANCE: f64 = 1e-37;

/// Absolute floor of the SC comparison, relative to the material's albedo: SC is a fraction of
/// it, and 1e-9 of it is below anything the cut's δ or IB(x) resolve.
const LANE_ABS_SC: f64 = 1e-9;

/// Worst lane differences seen (relative, over pairs not both zero), and counts.
#[derive(Clone, Copy, Debug, Default)]
struct LaneReport {
    lanes: usize,
    worst_importance: f64,
    worst_sc: f64,
    /// Lanes where the two paths differ at all (importance or SC).
    differing: usize,
    /// Lanes with SC = 0 while the importance is positive (the defensive share at work).
    zero_sc_positive: usize,
    /// Largest SC / albedo.
    max_sc_over_albedo: f64,
}

fn rel_diff(a: f64, b: f64) -> f64 {
    let m = a.abs().max(b.abs());
    if m == 0.0 {
        0.0
    } else {
        (a - b).abs() / m
    }
}

/// Bound of SC / albedo. The exact `∫_{C∩H} f cos` of a cap is at most the whole hemisphere's,
/// the albedo, and the SPTD ties the hemisphere to the albedo exactly; but its masking
/// correction `M(c̄)/M(½)` (evaluated at the mean cosine of the cap's visible part, 1/2 for the
/// hemisphere) lets a cap slightly smaller than the hemisphere and centred higher exceed it by
/// a little. 5 %: the "~1.05" of the albedo bound allowing the fit's error.
const SC_OVER_ALBEDO: f64 = 1.05;

/// Lane k of `imp.eval4_with_integrals(node)` against `imp.eval(&node.bounds(k))`, both
/// values: the importance through the check every importance shares
/// ([`common::lanes_match_scalar`]: `eval4` against `eval_lane`, for BL `eval_slot`, within
/// [`LANE_REL`] and [`LANE_ABS_IMPORTANCE`], never negative or NaN, 0 for slots of zero
/// energy), then what is
/// BL's own: importances finite, SC within [`LANE_REL`], never negative, at most
/// [`SC_OVER_ALBEDO`] × the albedo, `eval4` = the first half of `eval4_with_integrals`, and
/// `eval_slot` = the importance of `eval`.
fn check_lanes(imp: &BlImportance, node: &Node4, report: &mut LaneReport) -> Result<(), String> {
    let lanes = lanes_match_scalar(imp, node, LANE_REL, LANE_ABS_IMPORTANCE)
        .map_err(|e| format!("{e} ({node:?})"))?;
    let (w4, sc4) = imp.eval4_with_integrals(node);
    let (w4, sc4) = (w4.to_array(), sc4.to_array());
    let albedo = f64::from(imp.albedo());
    for k in 0..4 {
        let b = node.bounds(k);
        let s = imp.eval(&b);
        let ctx = format!("lane {k} of {node:?} ({b:?}) at {imp:?}");
        ensure!(
            lanes[k].1.to_bits() == s.importance.to_bits(),
            "eval_slot {} ≠ eval's importance {}, {ctx}",
            lanes[k].1,
            s.importance
        );
        ensure!(
            w4[k] >= 0.0 && s.importance >= 0.0 && w4[k].is_finite() && s.importance.is_finite(),
            "importance eval4 {} / eval {} out of range, {ctx}",
            w4[k],
            s.importance
        );
        ensure!(
            sc4[k] >= 0.0 && s.cap_integral >= 0.0,
            "SC eval4 {} / eval {} negative or NaN, {ctx}",
            sc4[k],
            s.cap_integral
        );
        ensure!(
            f64::from(sc4[k].max(s.cap_integral)) <= albedo * SC_OVER_ALBEDO + 1e-30,
            "SC eval4 {} / eval {} above {SC_OVER_ALBEDO} × the albedo {albedo}, {ctx}",
            sc4[k],
            s.cap_integral
        );
        ensure!(
            lanes[k].0.to_bits() == w4[k].to_bits(),
            "eval4 {} ≠ eval4_with_integrals {}, {ctx}",
            lanes[k].0,
            w4[k]
        );
        let (wi, si) = (f64::from(w4[k]), f64::from(s.importance));
        let (wc, sc) = (f64::from(sc4[k]), f64::from(s.cap_integral));
        ensure!(
            close(wc, sc, LANE_REL, LANE_ABS_SC * albedo + 1e-37),
            "SC: eval4 {wc:e} vs eval {sc:e} (rel {:.2e}), {ctx}",
            rel_diff(wc, sc)
        );
        report.lanes += 1;
        if albedo > 0.0 {
            report.max_sc_over_albedo = report.max_sc_over_albedo.max(sc.max(wc) / albedo);
        }
        report.worst_importance = report.worst_importance.max(rel_diff(wi, si));
        report.worst_sc = report.worst_sc.max(rel_diff(wc, sc));
        report.differing += usize::from(wi != si || wc != sc);
        report.zero_sc_positive += usize::from(sc == 0.0 && si > 0.0);
    }
    Ok(())
}

/// Shading points that stress one node: inside a slot's bounding sphere (at its centre, at
/// random depths, on its surface, just outside), behind and in front of a one-sided emitter of
/// the scene, on a light, exactly at a point light, in the scene, far away.
fn stress_points(rng: &mut Rng, node: &Node4, lights: &[Light], half: f32) -> Vec<Vec3> {
    let mut xs = Vec::new();
    for k in 0..4 {
        if node.child(k) == Child::Empty {
            continue;
        }
        push_sphere_points(rng, &node.bounds(k), &mut xs);
    }
    push_emitter_points(rng, lights, half, &mut xs);
    xs.push(shading_point(rng, lights, half, Where::AtPointLight));
    xs.push(rng.in_cube(half));
    xs.push(rng.unit() * half * rng.log_range(10.0, 1e4));
    xs
}

/// Random nodes of the tree of `lights`, each at its stress points with three random
/// (normal, ωo, material) each.
fn check_tree_lanes(
    lights: &[Light],
    half: f32,
    rng: &mut Rng,
    max_nodes: usize,
    report: &mut LaneReport,
) -> Result<(), String> {
    let tree = LightTree::build(lights).map_err(|e| e.to_string())?;
    let nodes = tree.nodes();
    if nodes.is_empty() {
        return Ok(());
    }
    for _ in 0..max_nodes.min(nodes.len()) {
        let node = &nodes[rng.below(nodes.len())];
        for x in stress_points(rng, node, lights, half) {
            for _ in 0..3 {
                let (imp, _) = random_bl_at(rng, x);
                check_lanes(&imp, node, report)?;
            }
        }
    }
    Ok(())
}

/// Property 1 on random scenes of 1 to 2,000 lights of every style (mixed kinds, one kind,
/// every light at one point: clusters of zero extent) and scale, plus hand-made degenerate
/// clusters: lane k of `eval4_with_integrals` equals `eval` of slot k within [`LANE_REL`].
#[test]
fn eval4_matches_scalar_eval() {
    let mut rng = Rng::new(0xB1_1A4E);
    let mut report = LaneReport::default();
    for scene in 0..90u64 {
        let n = [1, 2, 3, 5, 16, 17, 60, 300, 2000][rng.below(9)];
        let (lights, half) = styled_scene(0xB1_0000 + scene, n);
        let max_nodes = if n > 100 { 12 } else { 6 };
        check_tree_lanes(&lights, half, &mut rng, max_nodes, &mut report)
            .unwrap_or_else(|e| panic!("styled_scene(0x{:x}, {n}): {e}", 0xB1_0000 + scene));
    }
    // Degenerate clusters: all lights at one point, the shading point exactly there, at a
    // tiny offset, and far.
    for case in 0..20u64 {
        let count = 1 + rng.below(40);
        let mut lights = common::random_scene(&mut rng, count, &SceneSpec::default());
        let c = rng.in_cube(10.0);
        for l in &mut lights {
            common::move_to(l, c);
        }
        let Ok(tree) = LightTree::build(&lights) else {
            continue;
        };
        for node in tree.nodes() {
            for x in [c, c + rng.unit() * 1e-6, c + rng.unit() * 1e3] {
                for _ in 0..4 {
                    let (imp, _) = random_bl_at(&mut rng, x);
                    check_lanes(&imp, node, &mut report)
                        .unwrap_or_else(|e| panic!("degenerate case {case}: {e}"));
                }
            }
        }
    }
    eprintln!(
        "scalar vs 4-wide: {} lanes, worst relative difference importance {:.3e}, SC {:.3e}; \
         {} lanes differ at all; {} lanes with SC = 0 and a positive importance; max SC / \
         albedo {:.5}",
        report.lanes,
        report.worst_importance,
        report.worst_sc,
        report.differing,
        report.zero_sc_positive,
        report.max_sc_over_albedo
    );
    assert!(report.lanes > 50_000, "only {} lanes", report.lanes);
}

/// Property 1 on the synthetic nodes TL's lane test uses (`tests/importance.rs`,
/// [`common::random_nodes`]: any axis and angle bits, radii from 0 to huge, energies over 40
/// decades, empty slots), three random (normal, ωo, material) each.
#[test]
fn eval4_matches_scalar_on_random_nodes() {
    let mut rng = Rng::new(0xB1_5EED);
    let mut report = LaneReport::default();
    for (i, (x, node)) in random_nodes(20_000).into_iter().enumerate() {
        for _ in 0..3 {
            let (imp, _) = random_bl_at(&mut rng, x);
            check_lanes(&imp, &node, &mut report)
                .unwrap_or_else(|e| panic!("random node {i}: {e}"));
        }
    }
    eprintln!(
        "scalar vs 4-wide on random nodes: {} lanes, worst relative difference importance \
         {:.3e}, SC {:.3e}; {} lanes differ at all",
        report.lanes, report.worst_importance, report.worst_sc, report.differing
    );
    assert_eq!(report.lanes, 4 * 3 * 20_000);
}

// ---------------------------------------------------------------------------------------------
// 2. Conservativeness of BL alone
// ---------------------------------------------------------------------------------------------

/// A cap integral this small is far below the defensive share (1/(2π) · cos θ' over Ω ≥ the
/// cap's solid angle) for every cap the tests draw.
const NEGLIGIBLE_SC: f32 = 1e-12;

/// What a conservativeness check saw.
#[derive(Clone, Copy, Debug, Default)]
struct ConservativeReport {
    /// (light, point) pairs where the light reaches the point.
    contributing: usize,
    /// Of those, pairs where the light's own leaf slot has a negligible SC (below
    /// [`NEGLIGIBLE_SC`]): only the defensive share keeps them. Lights of zero extent (points,
    /// spots) have a leaf sphere of the quantisation's size, so a tiny cap …
    zero_sc: usize,
    /// … so these are the pairs of a light of positive extent (sphere, disk, triangle) whose
    /// leaf SC is 0: the SPTD (or the form factor) rounds a cap it subtends to nothing.
    zero_sc_extended: usize,
}

/// SC of the leaf slot holding `light`, if any.
fn leaf_sc(tree: &LightTree, imp: &BlImportance, light: u32) -> Option<f32> {
    let path = tree.path(light);
    let (node, k) = tree.slot_at(path)?;
    Some(
        imp.eval(&tree.nodes()[node as usize].bounds(k))
            .cap_integral,
    )
}

/// At one shading point: every light that reaches x has `tree.pmf > 0` and, through a BL cut
/// for each of `opts`, `cut.pmf > 0` and a positive `pmf_in`.
fn check_conservative_at(
    tree: &LightTree,
    lights: &[Light],
    imp: &BlImportance,
    opts: &[BlCutOptions],
    report: &mut ConservativeReport,
) -> Result<(), String> {
    let cuts: Vec<LightCut> = opts
        .iter()
        .map(|o| LightCut::build_bl(tree, imp, o))
        .collect();
    for (l, light) in lights.iter().enumerate() {
        if !reaches(light, imp) {
            continue;
        }
        report.contributing += 1;
        let l = l as u32;
        let sc = leaf_sc(tree, imp, l);
        report.zero_sc += usize::from(sc.is_some_and(|sc| sc < NEGLIGIBLE_SC));
        let extended = !matches!(light, Light::Point { .. } | Light::Spot { .. });
        report.zero_sc_extended += usize::from(sc == Some(0.0) && extended);
        let p = tree.pmf(imp, l);
        ensure!(
            p > 0.0,
            "light {l} {light:?} reaches the point but tree.pmf = {p} (leaf SC {sc:?}) at {imp:?}"
        );
        for (cut, o) in cuts.iter().zip(opts) {
            let pc = cut.pmf(tree, imp, l);
            let pin = cut.pmf_in(tree, imp, l);
            ensure!(
                pc > 0.0 && matches!(pin, Some((_, q)) if q > 0.0),
                "light {l} {light:?} reaches the point but cut.pmf = {pc}, pmf_in = {pin:?} \
                 (leaf SC {sc:?}) with {o:?} at {imp:?}; cut {:?}",
                cut.clusters()
            );
        }
    }
    Ok(())
}

/// Random cut options: δ from [`DELTAS`], `max_size` 4..=64 (and sometimes below 4),
/// `split_sin` from [`SPLIT_SINS`].
fn random_cut_options(rng: &mut Rng) -> BlCutOptions {
    BlCutOptions {
        split_sin: SPLIT_SINS[rng.below(SPLIT_SINS.len())],
        delta: DELTAS[rng.below(DELTAS.len())],
        max_size: match rng.below(5) {
            0 => rng.below(MIN_CUT_SIZE + 1),
            1 => MAX_CUT_SIZE,
            _ => MIN_CUT_SIZE + rng.below(MAX_CUT_SIZE - MIN_CUT_SIZE + 1),
        },
    }
}

/// Property 2 on random scenes of every style, shading points of every kind and random
/// materials (including α = 0.005), through the tree and through BL cuts of random options.
#[test]
fn contributing_lights_have_positive_bl_pmf() {
    let mut rng = Rng::new(0xC0_45E7);
    let mut report = ConservativeReport::default();
    for scene in 0..70u64 {
        let n = [1, 4, 20, 64, 200, 1500][rng.below(6)];
        let (lights, half) = styled_scene(0xC0_0000 + scene, n);
        let tree = LightTree::build(&lights).unwrap();
        let points = if n > 500 { 3 } else { 10 };
        for _ in 0..points {
            let (imp, _) = bl_point(&mut rng, &tree, &lights, half);
            let opts = [
                random_cut_options(&mut rng),
                BlCutOptions::default(),
                BlCutOptions {
                    delta: 0.0,
                    max_size: MAX_CUT_SIZE,
                    split_sin: 1.0,
                },
            ];
            check_conservative_at(&tree, &lights, &imp, &opts, &mut report)
                .unwrap_or_else(|e| panic!("styled_scene(0x{:x}, {n}): {e}", 0xC0_0000 + scene));
        }
    }
    eprintln!("random scenes: {report:?}");
    assert!(
        report.contributing > 20_000,
        "only {} contributing pairs",
        report.contributing
    );
}

/// Property 2 where SC is 0 or negligible: a mirror-like GGX lobe (α = 0.005, specular 1) and
/// tiny lights (spheres and one-sided disks of radius 1e-4 to 1e-2, points and spots) in
/// tight groups of four scattered over the upper hemisphere at distances 10 to 10^4 (caps down
/// to 1e-8 rad), most of them far from the mirror direction, a quarter within 0.01 rad of the
/// horizon; views from
/// the normal to grazing, the normal given either way up. Every light that reaches x keeps a
/// positive pmf through the tree and through cuts of every δ. Asserts that many contributing
/// lights have a leaf SC of exactly 0 (so the defensive share is what keeps them) and reports
/// how many of those are lights of positive extent (where the SPTD itself rounds the cap to 0;
/// none in the current implementation: its SC stays positive, if tiny, down to these caps).
#[test]
fn glossy_tiny_caps_far_from_the_mirror_keep_a_positive_pmf() {
    let mut rng = Rng::new(0x6105_5700);
    let mut report = ConservativeReport::default();
    let mut near_horizon = 0usize;
    for scene in 0..12 {
        let mut lights = Vec::new();
        // Lights come in tight groups of four (1e-5 of their distance apart), so that a leaf
        // node's quantisation frame, and with it the decoded leaf spheres, stays as small as
        // the lights themselves: caps down to 1e-8 rad reach the importance.
        let mut base = Vec3::ZERO;
        for i in 0..200 {
            // Directions over the upper hemisphere of +z, every fourth group within 0.01 rad of
            // the horizon (above it).
            if i % 4 == 0 {
                let dir = if i % 16 == 0 {
                    let phi = 2.0 * std::f32::consts::PI * rng.f32();
                    let e = rng.range(1e-3, 1e-2);
                    Vec3::new(e.cos() * phi.cos(), e.cos() * phi.sin(), e.sin())
                } else {
                    let u = rng.unit();
                    Vec3::new(u.x, u.y, u.z.abs())
                };
                base = dir * rng.log_range(10.0, 1e4);
            }
            let p = base + rng.unit() * (base.length() * 1e-5);
            let light = match rng.below(4) {
                0 => Light::Sphere {
                    center: p,
                    radius: rng.log_range(1e-4, 1e-2),
                    radiance: Rgb::grey(rng.log_range(0.1, 10.0)),
                },
                1 => Light::Disk {
                    center: p,
                    normal: -p, // facing x
                    radius: rng.log_range(1e-4, 1e-2),
                    radiance: Rgb::grey(rng.log_range(0.1, 10.0)),
                    two_sided: false,
                },
                2 => Light::Point {
                    position: p,
                    intensity: Rgb::grey(rng.log_range(0.1, 10.0)),
                },
                _ => Light::Spot {
                    position: p,
                    direction: -p + rng.unit() * p.length() * 0.1,
                    intensity: Rgb::grey(rng.log_range(0.1, 10.0)),
                    half_angle: 0.5,
                    falloff_start: 0.2,
                },
            };
            lights.push(light);
        }
        let tree = LightTree::build(&lights).unwrap();
        for view in 0..8 {
            let theta_o: f32 = [0.0, 0.3, 0.8, 1.2, 1.5, 1.56, 1.5706, 0.6][view];
            let phi = 2.0 * std::f32::consts::PI * rng.f32();
            let wo = Vec3::new(
                theta_o.sin() * phi.cos(),
                theta_o.sin() * phi.sin(),
                theta_o.cos(),
            );
            // Half the time the normal is given upside down (the importance turns it to ωo's
            // side).
            let normal = if rng.chance(0.5) { Vec3::Z } else { -Vec3::Z };
            let sp = ShadingPoint {
                position: Vec3::ZERO,
                normal,
                wo,
                material: Material::Ggx {
                    alpha: 0.005,
                    specular: 1.0,
                },
            };
            let imp = BlImportance::new(&sp).unwrap();
            let opts: Vec<BlCutOptions> = DELTAS
                .iter()
                .map(|&delta| BlCutOptions {
                    delta,
                    max_size: [4, 16, 64][rng.below(3)],
                    split_sin: SPLIT_SINS[rng.below(SPLIT_SINS.len())],
                })
                .collect();
            let before = report.contributing;
            check_conservative_at(&tree, &lights, &imp, &opts, &mut report)
                .unwrap_or_else(|e| panic!("scene {scene}, view {view} ({sp:?}): {e}"));
            near_horizon += lights
                .iter()
                .filter(|l| {
                    reaches(l, &imp) && (light_center(l).z / light_center(l).length()).abs() < 1e-2
                })
                .count();
            assert!(
                report.contributing > before,
                "view {view}: nothing reaches x"
            );
        }
    }
    eprintln!(
        "glossy α = 0.005: {report:?}, {near_horizon} contributing lights within 0.01 rad of \
         the horizon"
    );
    assert!(
        near_horizon > 1_000,
        "only {near_horizon} lights near the horizon"
    );
    assert!(report.contributing > 10_000, "{report:?}");
    assert!(
        report.zero_sc > 100,
        "only {} contributing lights with a negligible leaf SC: the test does not reach the \
         case it is for",
        report.zero_sc
    );
}

// ---------------------------------------------------------------------------------------------
// 3. Sampling through the tree and through the cut
// ---------------------------------------------------------------------------------------------

/// Through the tree at one shading point: `sample(u)` returns a light with the pmf `pmf()`
/// gives it (1e-5 relative), never a zero-energy light; `pmf` is 0 for zero-energy lights and
/// out-of-range indices; Σ pmf = 1 (1e-4) when a light is returned, 0 otherwise.
fn check_tree_sampling(
    tree: &LightTree,
    lights: &[Light],
    imp: &BlImportance,
    us: &[f32],
) -> Result<bool, String> {
    let pmfs: Vec<f64> = (0..lights.len() as u32)
        .map(|l| f64::from(tree.pmf(imp, l)))
        .collect();
    let sum: f64 = pmfs.iter().sum();
    for (l, light) in lights.iter().enumerate() {
        ensure!(
            pmfs[l].is_finite() && (0.0..=1.0 + 1e-6).contains(&pmfs[l]),
            "light {l}: pmf {} at {imp:?}",
            pmfs[l]
        );
        if common::zero_energy(light) {
            ensure!(pmfs[l] == 0.0, "zero-energy light {l} has pmf {}", pmfs[l]);
        }
    }
    ensure!(
        tree.pmf(imp, lights.len() as u32) == 0.0 && tree.pmf(imp, u32::MAX) == 0.0,
        "pmf of an index out of range"
    );
    let mut some = false;
    for &u in us {
        let Some(s) = tree.sample(imp, u) else {
            ensure!(
                sum == 0.0,
                "sample(u={u}) is None but Σ pmf = {sum} at {imp:?}"
            );
            continue;
        };
        some = true;
        let l = s.light as usize;
        ensure!(l < lights.len(), "sample returned {s:?}");
        ensure!(
            !common::zero_energy(&lights[l]),
            "sample(u={u}) returned zero-energy light {l} at {imp:?}"
        );
        ensure!(
            s.pmf > 0.0 && close(f64::from(s.pmf), pmfs[l], 1e-5, 0.0),
            "sample(u={u}) light {l}: pmf {} vs pmf() {} at {imp:?}",
            s.pmf,
            pmfs[l]
        );
    }
    if some {
        ensure!(
            (sum - 1.0).abs() <= 1e-4,
            "Σ pmf = {sum} although a light is returned at {imp:?}"
        );
    }
    Ok(some)
}

/// Property 3 through the tree, on random scenes, points and materials.
#[test]
fn bl_tree_sample_matches_pmf_and_pmfs_sum_to_one() {
    let mut rng = Rng::new(0x7A3E);
    let mut nonempty = 0usize;
    for scene in 0..60u64 {
        let n = [1, 3, 10, 64, 300, 1000][rng.below(6)];
        let (lights, half) = styled_scene(0x7A_0000 + scene, n);
        let tree = LightTree::build(&lights).unwrap();
        for _ in 0..8 {
            let (imp, _) = bl_point(&mut rng, &tree, &lights, half);
            let us = u_values(&mut rng, 10);
            nonempty += usize::from(
                check_tree_sampling(&tree, &lights, &imp, &us).unwrap_or_else(|e| {
                    panic!("styled_scene(0x{:x}, {n}): {e}", 0x7A_0000 + scene)
                }),
            );
        }
    }
    assert!(
        nonempty > 300,
        "only {nonempty} points with a light sampled"
    );
}

/// Pearson's chi-square (level 0.001, bins of expected count < 5 merged, Wilson–Hilferty
/// critical value) of 10^6 `cut.sample` draws against `cut.pmf`, at three shading points of a
/// 64-light scene (fixed seed) with BL cuts of several clusters (GGX α = 0.2, plastic, Lambert).
/// Lights of pmf 0 (zero-energy lights among them) must never be drawn; Σ pmf = 1 within 1e-4.
/// The test has power: the same counts against the pmfs with the largest one 5 % too big
/// (renormalised) are rejected.
#[test]
fn bl_cut_chi_square_against_pmf() {
    let spec = SceneSpec {
        half: 10.0,
        zero_energy: 0.05,
        power: (0.5, 5.0),
        ..SceneSpec::default()
    };
    let mut rng = Rng::new(0xB1C4);
    let lights = common::random_scene(&mut rng, 64, &spec);
    assert!(lights.iter().any(common::zero_energy));
    let tree = LightTree::build(&lights).unwrap();
    let sp = |x: Vec3, normal: Vec3, wo: Vec3, material| {
        BlImportance::new(&ShadingPoint {
            position: x,
            normal,
            wo,
            material,
        })
        .unwrap()
    };
    let cases = [
        (
            sp(
                Vec3::new(0.5, -1.0, 0.2),
                Vec3::new(0.2, 0.3, 1.0),
                Vec3::new(0.6, -0.2, 0.5),
                Material::Ggx {
                    alpha: 0.2,
                    specular: 1.0,
                },
            ),
            BlCutOptions {
                delta: 0.1,
                max_size: 8,
                ..BlCutOptions::default()
            },
        ),
        (
            sp(
                Vec3::new(3.0, 2.0, -4.0),
                Vec3::X,
                Vec3::new(-1.0, 0.1, 0.05), // below the normal: turned over
                Material::Plastic {
                    albedo: Rgb::grey(0.5),
                    specular: 0.5,
                    alpha: 0.05,
                },
            ),
            BlCutOptions {
                delta: 0.01,
                max_size: 32,
                ..BlCutOptions::default()
            },
        ),
        (
            sp(
                Vec3::ZERO,
                Vec3::Y,
                Vec3::Y,
                Material::Lambert {
                    albedo: Rgb::grey(0.8),
                },
            ),
            BlCutOptions {
                delta: 0.0,
                max_size: 64,
                ..BlCutOptions::default()
            },
        ),
    ];
    let samples = 1_000_000usize;
    for (case, (imp, opts)) in cases.iter().enumerate() {
        let cut = LightCut::build_bl(&tree, imp, opts);
        assert!(cut.len() >= 4, "case {case}: only {} clusters", cut.len());
        let pmfs = cut_pmfs(&cut, &tree, imp, lights.len());
        let total: f64 = pmfs.iter().sum();
        assert!((total - 1.0).abs() <= 1e-4, "case {case}: Σ pmf = {total}");
        let (counts, none) = cut_sample_counts(&cut, &tree, imp, lights.len(), samples, &mut rng);
        assert_eq!(
            none, 0,
            "case {case}: sample returned no light {none} times"
        );
        let (mut obs, mut exp) = (Vec::new(), Vec::new());
        let mut zero_pmf = 0;
        for l in 0..lights.len() {
            if pmfs[l] == 0.0 {
                zero_pmf += 1;
                assert_eq!(counts[l], 0, "case {case}: light {l} of pmf 0 drawn");
            } else {
                obs.push(counts[l]);
                exp.push(samples as f64 * pmfs[l] / total);
            }
        }
        let (stat, dof) = chi2_statistic(&obs, &exp);
        let crit = chi2_critical(dof, Z_999);
        eprintln!(
            "case {case}: {} clusters, IB = {}, {zero_pmf} lights of pmf 0, chi2 = {stat:.2}, \
             critical {crit:.2}, dof {dof}",
            cut.len(),
            cut.max_score()
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
// 4. Cut properties (and 3 through the cut)
// ---------------------------------------------------------------------------------------------

/// What one checked cut found.
#[derive(Clone, Copy, Debug, Default)]
struct CutReport {
    clusters: usize,
    contributing: usize,
    /// Clusters all of whose lights have pmf 0.
    dead: usize,
    /// Σ over all lights of `cut.pmf`.
    pmf_sum: f64,
    /// Largest `max_score()` seen, and over energy-conserving materials (ρd + ks ≤ 1).
    max_ib: f32,
    max_ib_conserving: f32,
}

/// Builds the BL cut of `tree` at `imp` with `opts` and checks it:
///
/// - size: at most `max_size` clamped to 4..=64 clusters; empty only for an empty tree or a
///   point no cluster reaches;
/// - every cluster: a non-empty slot its path leads to; weight > 0, finite, and score, both
///   equal to lane k of `eval4_with_integrals` of its node (what `build` evaluates);
///   `total_weight` = Σ weights, `max_score` = max score;
/// - IB(x) = `max_score()` ∈ [0, 1.05 × albedo] (see [`SC_OVER_ALBEDO`]), and for an
///   energy-conserving material (ρd + ks ≤ 1) at most 1.05;
/// - every proper ancestor slot of a cluster contains x or has SC > δ;
/// - disjoint: no cluster's path is a prefix of another's, no light under two clusters;
/// - coverage: every slot of positive importance of an opened node is a cluster, an ancestor
///   of one, or holds no path of positive importances down to a light;
/// - the inside-sphere and SC > δ rules: a cluster that is an inner node with x inside its
///   sphere or SC > δ was kept only because its children would not have fitted (the accounting
///   of `tests/cut.rs`: `len + drops + n_children > max_size + 1`); with room for every light,
///   no such cluster exists;
/// - `pmf_in` finds exactly the owning cluster; per cluster the `pmf_in`s sum to 1 (1e-4) or
///   are all 0; `sample_in` agrees with `pmf_in` (1e-5 relative); `pmf = weight/total · pmf_in`;
///   `sample` reports `pmf()` (1e-5) and never returns a zero-energy light; Σ pmf = 1 (1e-4)
///   for a non-empty cut;
/// - property 2: every light that reaches x has positive `pmf_in` and `pmf`.
fn check_bl_cut(
    tree: &LightTree,
    lights: &[Light],
    imp: &BlImportance,
    material: Option<Material>,
    opts: &BlCutOptions,
    us: &[f32],
) -> Result<(LightCut, CutReport), String> {
    let cut = LightCut::build_bl(tree, imp, opts);
    let ctx = format!("at {imp:?} with {opts:?}");
    let x = imp.position();
    let n = lights.len();
    let nodes = tree.nodes();
    let clusters = cut.clusters();
    let delta = opts.delta;
    let mut report = CutReport {
        clusters: clusters.len(),
        ..CutReport::default()
    };

    // Size.
    let cap = opts.max_size.clamp(MIN_CUT_SIZE, MAX_CUT_SIZE);
    ensure!(cut.len() == clusters.len(), "len ≠ clusters().len()");
    ensure!(
        cut.len() <= cap,
        "{} clusters > max_size {} clamped to {cap} {ctx}",
        cut.len(),
        opts.max_size
    );
    if tree.is_empty() {
        ensure!(cut.is_empty(), "empty tree, {} clusters", cut.len());
    }
    // (A cut may be empty although the root's importance is positive: every slot it opened
    // had children of importance 0 only, and was dropped. No light under them reaches x, which
    // property 2 below checks.)

    // Each cluster.
    let mut members: Vec<Vec<u32>> = Vec::with_capacity(clusters.len());
    let mut weight_sum = 0.0f64;
    let mut max_score = 0.0f32;
    for (i, c) in clusters.iter().enumerate() {
        check_cluster_slot(tree, i, c, &ctx)?;
        let node = &nodes[c.node as usize];
        let k = usize::from(c.slot);
        let (w, sc) = imp.eval4_with_integrals(node);
        let (w, sc) = (w.to_array()[k], sc.to_array()[k]);
        ensure!(
            c.weight > 0.0 && c.weight.is_finite() && c.weight == w,
            "cluster {i} {c:?}: weight {} vs importance of its slot {w} {ctx}",
            c.weight
        );
        ensure!(
            c.score == sc,
            "cluster {i} {c:?}: score {} vs SC of its slot {sc} {ctx}",
            c.score
        );
        weight_sum += f64::from(c.weight);
        max_score = max_score.max(c.score);

        // Ancestors were split: their caps wide or SC > δ.
        for up in 1..levels(c.path) {
            let p = c.path >> (2 * up);
            let (an, ak) = tree
                .slot_at(p)
                .ok_or_else(|| format!("ancestor {p:#b} of {c:?} not in the tree"))?;
            let anode = &nodes[an as usize];
            let asc = imp.eval4_with_integrals(anode).1.to_array()[ak];
            ensure!(
                wide(anode, ak, x, opts.split_sin) || asc > delta,
                "cluster {i} {c:?}: ancestor slot ({an}, {ak}) was split, but its cap is not \
                 wide and its SC {asc} ≤ δ {ctx}"
            );
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
        "max_score {} vs max over the clusters {max_score} {ctx}",
        cut.max_score()
    );
    let ib = cut.max_score();
    ensure!(
        ib >= 0.0 && f64::from(ib) <= f64::from(imp.albedo()) * SC_OVER_ALBEDO,
        "IB(x) = {ib} outside [0, {SC_OVER_ALBEDO} × albedo {}] {ctx}",
        imp.albedo()
    );
    report.max_ib = ib;
    if let Some(m) = material {
        let (rd, ks, _) = m.lobes();
        if rd + ks <= 1.0 {
            ensure!(
                ib <= 1.05,
                "IB(x) = {ib} > 1.05 for the energy-conserving {m:?} {ctx}"
            );
            report.max_ib_conserving = ib;
        }
    }

    // Disjoint.
    let owner = check_disjoint(clusters, &members, n, &ctx)?;

    // Coverage, then the inside-sphere and SC > δ rules (see `tests/cut.rs` for the
    // accounting of dropped slots).
    if !cut.is_empty() {
        let drops = check_coverage(tree, imp, clusters, &ctx)?;
        let room = tree.stats().sampled_lights as usize <= cap;
        for (i, c) in clusters.iter().enumerate() {
            let node = &nodes[c.node as usize];
            let k = usize::from(c.slot);
            let Child::Node(child) = node.child(k) else {
                continue;
            };
            let is_inside = inside(node, k, x);
            if !(is_inside || c.score > delta) {
                continue;
            }
            let why = if is_inside {
                "x is inside its sphere"
            } else {
                "its SC exceeds δ"
            };
            ensure!(
                !room,
                "cluster {i} {c:?} is an inner node and {why}, with room for every light \
                 ({} lights, max_size {cap}) {ctx}",
                tree.stats().sampled_lights
            );
            let n_c = positive_slots(imp, &nodes[child as usize]);
            ensure!(
                cut.len() + drops + n_c > cap + 1,
                "cluster {i} {c:?}: {why} and its {n_c} children fit: {} clusters, {drops} \
                 dropped, max_size {cap} {ctx}",
                cut.len()
            );
        }
    }

    // pmf_in: the owner, a pmf in [0, 1].
    let pmf_in = check_pmf_in(&cut, tree, imp, &owner, &ctx)?;
    for bad in [n as u32, u32::MAX] {
        ensure!(
            cut.pmf_in(tree, imp, bad).is_none() && cut.pmf(tree, imp, bad) == 0.0,
            "pmf_in / pmf of index {bad}"
        );
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
                    "cluster {i}: sample_in(u={u}) is None but its pmfs sum to {sum} {ctx}"
                ),
                Some(s) => {
                    ensure!(
                        owner.get(s.light as usize) == Some(&Some(i)),
                        "cluster {i}: sample_in(u={u}) returned light {} outside it {ctx}",
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

    // pmf = weight / total · pmf_in; sample reports pmf(); Σ pmf = 1.
    for (l, light) in lights.iter().enumerate() {
        let p = check_light_pmf(&cut, tree, imp, &owner, &pmf_in, l, &ctx)?;
        if common::zero_energy(light) {
            ensure!(p == 0.0, "zero-energy light {l} has cut pmf {p} {ctx}");
        }
        report.pmf_sum += f64::from(p);
    }
    if !cut.is_empty() {
        ensure!(
            (report.pmf_sum - 1.0).abs() <= 1e-4,
            "Σ cut.pmf = {} on a cut of {} clusters ({} dead) {ctx}",
            report.pmf_sum,
            cut.len(),
            report.dead
        );
    }
    for &u in us {
        match cut.sample(tree, imp, u) {
            Some(s) => {
                let l = s.light as usize;
                ensure!(
                    l < n && owner[l].is_some(),
                    "sample(u={u}) returned {s:?} outside the cut {ctx}"
                );
                ensure!(
                    !common::zero_energy(&lights[l]),
                    "sample(u={u}) returned zero-energy light {l} {ctx}"
                );
                let p = cut.pmf(tree, imp, s.light);
                ensure!(
                    s.pmf > 0.0 && close(f64::from(s.pmf), f64::from(p), 1e-5, 0.0),
                    "sample(u={u}) light {l}: pmf {} vs pmf() {p} {ctx}",
                    s.pmf
                );
            }
            None => ensure!(
                cut.is_empty(),
                "sample(u={u}) is None on a cut of {} clusters {ctx}",
                cut.len()
            ),
        }
    }

    // Property 2 through the cut.
    for (l, light) in lights.iter().enumerate() {
        if reaches(light, imp) {
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

/// Properties 3 (through the cut) and 4 on random scenes of 1 to 2,000 lights of every style,
/// shading points of every kind (inside clusters, on lights, at point lights, far), random
/// materials and views, every δ of [`DELTAS`] with random `max_size` (and the default options).
/// Reports the largest IB(x) seen.
#[test]
fn bl_cut_invariants_on_random_scenes() {
    let mut rng = Rng::new(0xB1_C075);
    let mut total = CutReport::default();
    let mut nonempty = 0usize;
    for scene in 0..80u64 {
        let n = [1, 2, 3, 4, 5, 16, 17, 64, 65, 200, 2000][rng.below(11)];
        let (lights, half) = styled_scene(0xB1C_0000 + scene, n);
        let tree = LightTree::build(&lights).unwrap();
        let points = if n > 500 { 2 } else { 6 };
        for _ in 0..points {
            let (imp, material) = bl_point(&mut rng, &tree, &lights, half);
            let us = u_values(&mut rng, 4);
            let mut all: Vec<BlCutOptions> = DELTAS
                .iter()
                .map(|&delta| BlCutOptions {
                    delta,
                    max_size: MIN_CUT_SIZE + rng.below(MAX_CUT_SIZE - MIN_CUT_SIZE + 1),
                    split_sin: SPLIT_SINS[rng.below(SPLIT_SINS.len())],
                })
                .collect();
            all.push(BlCutOptions::default());
            all.push(random_cut_options(&mut rng));
            for opts in &all {
                let (cut, r) = check_bl_cut(&tree, &lights, &imp, Some(material), opts, &us)
                    .unwrap_or_else(|e| {
                        panic!("styled_scene(0x{:x}, {n}): {e}", 0xB1C_0000 + scene)
                    });
                nonempty += usize::from(!cut.is_empty());
                total.clusters += r.clusters;
                total.contributing += r.contributing;
                total.dead += r.dead;
                total.max_ib = total.max_ib.max(r.max_ib);
                total.max_ib_conserving = total.max_ib_conserving.max(r.max_ib_conserving);
            }
        }
    }
    eprintln!("random scenes: {nonempty} non-empty cuts, {total:?}");
    assert!(nonempty > 1_000, "only {nonempty} non-empty cuts");
    assert!(total.contributing > 20_000, "{total:?}");
}

/// δ = 0 splits everything that fits: on scenes of at most 64 lights with max_size 64 every
/// cluster is a single light or has SC exactly 0 with x outside it. δ = ∞ (and NaN) splits only
/// slots that contain x: every ancestor of every cluster contains x, and a point far outside
/// the scene gets the root's slots.
#[test]
fn bl_cut_delta_zero_and_infinite() {
    let mut rng = Rng::new(0xD0);
    let mut singles = 0usize;
    let mut below_root = 0usize;
    for scene in 0..50u64 {
        let n = 1 + rng.below(64);
        let (lights, half) = styled_scene(0xD0_0000 + scene, n);
        let tree = LightTree::build(&lights).unwrap();
        for i in 0..8 {
            let imp = if i == 0 {
                let x = Vec3::splat(1e4 * half);
                BlImportance::new(&ShadingPoint {
                    position: x,
                    normal: -x,
                    wo: -x,
                    material: Material::Lambert {
                        albedo: Rgb::grey(1.0),
                    },
                })
                .unwrap()
            } else {
                bl_point(&mut rng, &tree, &lights, half).0
            };
            let us = u_values(&mut rng, 2);
            let zero = BlCutOptions {
                delta: 0.0,
                max_size: 64,
                split_sin: SPLIT_SINS[rng.below(SPLIT_SINS.len())],
            };
            let (cut, _) = check_bl_cut(&tree, &lights, &imp, None, &zero, &us)
                .unwrap_or_else(|e| panic!("scene {scene}: {e}"));
            for c in cut.clusters() {
                let node = &tree.nodes()[c.node as usize];
                let k = usize::from(c.slot);
                match tree.slot(node, k) {
                    Slot::Light(_) => singles += 1,
                    _ => assert!(
                        c.score == 0.0 && !wide(node, k, imp.position(), zero.split_sin),
                        "scene {scene}: δ = 0 left {c:?} unsplit at {imp:?}"
                    ),
                }
            }
            for delta in [f32::INFINITY, f32::NAN] {
                let opts = BlCutOptions {
                    delta,
                    max_size: rng.below(MAX_CUT_SIZE + 1),
                    split_sin: SPLIT_SINS[rng.below(SPLIT_SINS.len())],
                };
                let (cut, _) = check_bl_cut(&tree, &lights, &imp, None, &opts, &us)
                    .unwrap_or_else(|e| panic!("scene {scene}: {e}"));
                let x = imp.position();
                for c in cut.clusters() {
                    let l = levels(c.path);
                    below_root += usize::from(l > 1);
                    for up in 1..l {
                        let (an, ak) = tree.slot_at(c.path >> (2 * up)).unwrap();
                        assert!(
                            wide(&tree.nodes()[an as usize], ak, x, opts.split_sin),
                            "scene {scene} {opts:?}: ancestor ({an}, {ak}) of {c:?} was split \
                             without a wide cap"
                        );
                    }
                }
                // A far point sees only narrow caps (unless every cap is wide: split_sin ≤ 0).
                if let (0, false, Some(root)) = (i, opts.split_sin <= 0.0, tree.nodes().first()) {
                    let root_slots = positive_slots(&imp, root);
                    assert_eq!(cut.len(), root_slots, "scene {scene}: far point {opts:?}");
                }
            }
        }
    }
    assert!(singles > 3_000, "only {singles} single-light clusters");
    assert!(
        below_root > 200,
        "only {below_root} clusters below the root"
    );
}

/// `max_size` is clamped to 4..=64: 0..4 build what 4 builds, anything above 64 what 64 builds.
#[test]
fn bl_cut_max_size_is_clamped() {
    let mut rng = Rng::new(0xC1A5);
    for scene in 0..15u64 {
        let (lights, half) = styled_scene(0xC1A5_0000 + scene, 1 + rng.below(1500));
        let tree = LightTree::build(&lights).unwrap();
        for _ in 0..6 {
            let (imp, _) = bl_point(&mut rng, &tree, &lights, half);
            let delta = DELTAS[rng.below(DELTAS.len())];
            let build = |max_size| {
                let opts = BlCutOptions {
                    delta,
                    max_size,
                    ..BlCutOptions::default()
                };
                LightCut::build_bl(&tree, &imp, &opts)
            };
            for small in 0..MIN_CUT_SIZE {
                assert_eq!(build(small).clusters(), build(MIN_CUT_SIZE).clusters());
            }
            assert_eq!(build(65).clusters(), build(64).clusters());
            assert_eq!(build(usize::MAX).clusters(), build(64).clusters());
        }
    }
}

/// Edges: an empty tree gives an empty cut for every option; a cut never exceeds its clamped
/// size for every max_size 0..=70 on random scenes.
#[test]
fn bl_cut_edges() {
    let imp = BlImportance::new(&ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::Z,
        material: Material::Lambert {
            albedo: Rgb::grey(0.5),
        },
    })
    .unwrap();
    let zero = vec![Light::Point {
        position: Vec3::ONE,
        intensity: Rgb::grey(0.0),
    }];
    for lights in [Vec::new(), zero] {
        let tree = LightTree::build(&lights).unwrap();
        for delta in DELTAS {
            for max_size in [0, 1, 4, 64, 1000] {
                let opts = BlCutOptions {
                    delta,
                    max_size,
                    ..BlCutOptions::default()
                };
                let cut = LightCut::build_bl(&tree, &imp, &opts);
                assert!(cut.is_empty());
                assert_eq!(cut.max_score(), 0.0);
                assert_eq!(cut.sample(&tree, &imp, 0.5), None);
                for l in 0..lights.len() as u32 + 1 {
                    assert_eq!(cut.pmf(&tree, &imp, l), 0.0);
                }
            }
        }
    }
    let mut rng = Rng::new(0xED6E);
    for scene in 0..20u64 {
        let (lights, half) = styled_scene(0xED6E_0000 + scene, [5, 50, 800][rng.below(3)]);
        let tree = LightTree::build(&lights).unwrap();
        for _ in 0..3 {
            let (imp, _) = bl_point(&mut rng, &tree, &lights, half);
            for max_size in 0..=70 {
                let delta = DELTAS[rng.below(DELTAS.len())];
                let opts = BlCutOptions {
                    delta,
                    max_size,
                    split_sin: SPLIT_SINS[rng.below(SPLIT_SINS.len())],
                };
                let cut = LightCut::build_bl(&tree, &imp, &opts);
                assert!(
                    cut.len() <= max_size.clamp(MIN_CUT_SIZE, MAX_CUT_SIZE),
                    "scene {scene}: {} clusters for max_size {max_size}",
                    cut.len()
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 5. SC against ground truth
// ---------------------------------------------------------------------------------------------

/// `∫_{C∩H} cos θ dω` for the cap of half-angle σ (given as `sin σ`, `1 − cos σ`) whose axis
/// makes angle ω with the normal, by quadrature in f64: around the cap axis, the integral over
/// the azimuth φ of `max(0, cos ω cos θ + sin ω sin θ cos φ)` is closed-form, leaving a 1-D
/// integral over θ ∈ [0, σ], split at the kinks θ = |π/2 − ω| (where the horizon starts to
/// clip) and done by composite Simpson with 2·4096 panels per piece: ~1e-12 relative.
fn lambert_quadrature(cos_w: f64, sigma: f64) -> f64 {
    let cos_w = cos_w.clamp(-1.0, 1.0);
    let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
    let inner = |t: f64| {
        let a = cos_w * t.cos();
        let b = sin_w * t.sin();
        let ring = if a >= b {
            2.0 * PI * a
        } else if a <= -b {
            0.0
        } else {
            let p0 = (-a / b).clamp(-1.0, 1.0).acos();
            2.0 * (a * p0 + b * p0.sin())
        };
        ring * t.sin()
    };
    let omega = cos_w.acos();
    let mut cuts = vec![0.0, sigma];
    let kink = (PI / 2.0 - omega).abs();
    if kink > 0.0 && kink < sigma {
        cuts.push(kink);
    }
    cuts.sort_by(f64::total_cmp);
    let mut total = 0.0;
    for w in cuts.windows(2) {
        let (lo, hi) = (w[0], w[1]);
        let m = 8192;
        let h = (hi - lo) / m as f64;
        let mut s = inner(lo) + inner(hi);
        for i in 1..m {
            s += inner(lo + h * i as f64) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        total += s * h / 3.0;
    }
    total
}

/// `∫_{C∩H} g dω` by MIS (balance heuristic) of uniform-in-cap sampling and, when `vndf` is
/// given, GGX VNDF sampling, over `grid²` stratified pairs; `g(wi)` must vanish below the
/// horizon. Returns (estimate, standard error as if unstratified: an upper bound).
fn cap_mc(
    cap: &Cap64,
    g: impl Fn(DVec3) -> f64,
    vndf: Option<(&Ggx, DVec3)>,
    grid: usize,
    rng: &mut Rng,
) -> (f64, f64) {
    let area = cap.area();
    let p_cap = |w: DVec3| if cap.contains(w) { 1.0 / area } else { 0.0 };
    let (mut s, mut s2) = (0.0, 0.0);
    for i in 0..grid {
        for j in 0..grid {
            let u1 = (i as f64 + rng.f64()) / grid as f64;
            let u2 = (j as f64 + rng.f64()) / grid as f64;
            let w1 = cap.sample(u1, u2);
            let mut pair = match vndf {
                None => g(w1) * area,
                Some((ggx, wo)) => {
                    let p = p_cap(w1) + ggx.pdf_vndf(wo, w1);
                    g(w1) / p
                }
            };
            if let Some((ggx, wo)) = vndf {
                let w2 = ggx.sample_vndf(wo, rng.f64(), rng.f64());
                if cap.contains(w2) {
                    let p = p_cap(w2) + ggx.pdf_vndf(wo, w2);
                    if p > 0.0 {
                        pair += g(w2) / p;
                    }
                }
            }
            s += pair;
            s2 += pair * pair;
        }
    }
    let n = (grid * grid) as f64;
    let mean = s / n;
    let var = (s2 / n - mean * mean).max(0.0);
    (mean, (var / n).sqrt())
}

/// One light at `center` (radius `r`), seen from the origin with normal +z and ωo: the slot's
/// bounds in a one-light tree, the BL importance, and the cap the slot subtends in the local
/// frame (t, b, n) with ωo in the x-z plane (x = +X, n = +Z: the world frame itself).
fn single_sphere(
    center: Vec3,
    r: f32,
    wo: Vec3,
    material: Material,
) -> (BlImportance, manylights::tree::SlotBounds, Cap64, f32) {
    let lights = [Light::Sphere {
        center,
        radius: r,
        radiance: Rgb::grey(1.0),
    }];
    let tree = LightTree::build(&lights).unwrap();
    let node = &tree.nodes()[0];
    let k = (0..4)
        .find(|&k| tree.slot(node, k) == Slot::Light(0))
        .unwrap();
    let b = node.bounds(k);
    let imp = BlImportance::new(&ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo,
        material,
    })
    .unwrap();
    let c = b.center.as_dvec3();
    let d = c.length();
    let cap = Cap64::from_sine(c / d, f64::from(b.radius) / d);
    // The 4-wide lane too.
    let wide = imp.eval4_with_integrals(node).1.to_array()[k];
    (imp, b, cap, wide)
}

/// Property 5, Lambert: SC of one sphere light (its leaf slot's cap) from the origin, over
/// distances giving σ from 1e-4 to 1.3 rad and axes from the normal to below the horizon,
/// equals `(ρ/π) ∫_{C∩H} cos` by f64 quadrature within 1e-4 relative plus 1e-6·sin²σ·π
/// absolute (the implementation is exact; the tolerance covers f32 rounding of its inputs and
/// of the cap near the horizon, where the integral is a small difference) — and a
/// 256²-stratified Monte Carlo estimate within 4.5 standard errors, which validates the
/// quadrature. x inside the sphere gives the whole hemisphere, ρ. Reports the worst errors.
#[test]
fn lambert_cap_integral_matches_ground_truth() {
    let mut rng = Rng::new(0x1A3B);
    let albedo = 0.7f32;
    let material = Material::Lambert {
        albedo: albedo.into(),
    };
    let rho = f64::from(albedo);
    let (mut worst_q, mut worst_mc, mut worst_mc_se) = (0.0f64, 0.0f64, 0.0f64);
    let mut cases = 0;
    for &sigma in &[1e-4f64, 1e-3, 0.01, 0.1, 0.3, 0.7, 1.0, 1.3] {
        for &elev_deg in &[
            90.0f64, 60.0, 30.0, 10.0, 1.0, 0.0, -0.5, -5.0, -30.0, -70.0,
        ] {
            // Axis at elevation `elev_deg` above the horizon; sin σ = r/d with d = 10.
            let e = elev_deg.to_radians();
            let phi = 2.0 * PI * rng.f64();
            let axis = DVec3::new(e.cos() * phi.cos(), e.cos() * phi.sin(), e.sin());
            let d = 10.0;
            let center = (axis * d).as_vec3();
            let r = (d * sigma.sin()) as f32;
            let wo = Vec3::new(0.3, -0.2, 1.0);
            let (imp, b, cap, wide) = single_sphere(center, r, wo, material);
            let sc = f64::from(imp.eval(&b).cap_integral);
            assert_eq!(sc, f64::from(wide), "scalar and 4-wide SC differ");
            let exact = rho / PI * lambert_quadrature(cap.axis.z, cap.sigma);
            let s2 = cap.sigma.sin().powi(2);
            let tol = 1e-4 * exact + 1e-6 * s2 * PI * rho / PI;
            let err = (sc - exact).abs();
            assert!(
                err <= tol,
                "σ = {sigma}, elevation {elev_deg}°: SC {sc:e} vs quadrature {exact:e} \
                 (error {err:e} > tol {tol:e})"
            );
            if exact > 0.0 {
                worst_q = worst_q.max(err / exact);
            }
            let (mc, se) = cap_mc(
                &cap,
                |w| if w.z > 0.0 { rho / PI * w.z } else { 0.0 },
                None,
                256,
                &mut rng,
            );
            assert!(
                (mc - exact).abs() <= 4.5 * se + 1e-12 * s2,
                "σ = {sigma}, elevation {elev_deg}°: MC {mc:e} ± {se:e} vs quadrature {exact:e}"
            );
            if exact > 0.0 {
                worst_mc = worst_mc.max((sc - mc).abs() / exact);
            }
            if se > 0.0 {
                worst_mc_se = worst_mc_se.max((mc - exact).abs() / se);
            }
            cases += 1;
        }
    }
    // Inside the sphere: the whole hemisphere.
    let (imp, b, _, _) = single_sphere(Vec3::new(0.1, 0.0, 0.0), 1.0, Vec3::Z, material);
    let sc = imp.eval(&b).cap_integral;
    assert!(
        (f64::from(sc) - rho).abs() <= 1e-6,
        "inside: SC {sc} vs ρ {rho}"
    );
    eprintln!(
        "Lambert SC, {cases} caps: worst relative error vs quadrature {worst_q:.2e}, vs Monte \
         Carlo {worst_mc:.2e}; worst |MC − quadrature| {worst_mc_se:.2} standard errors"
    );
}

/// One GGX case: SC of the sphere light at distance 100 along the unit `axis` subtending a cap
/// of half-angle σ, seen from the origin (n = +z, ωo = `wo`, GGX α, specular 1), against the
/// MIS ground truth of `grid²` pairs. Also checks the 4-wide lane and that plastic is exactly
/// the weighted sum of its lobes. Returns (SC, truth, its standard error, cap area).
fn ggx_case(
    ggx: &Ggx,
    wo: DVec3,
    axis: DVec3,
    sigma: f64,
    grid: usize,
    rng: &mut Rng,
) -> (f64, f64, f64, f64) {
    let alpha = ggx.alpha as f32;
    let material = Material::Ggx {
        alpha,
        specular: 1.0,
    };
    let d = 100.0;
    let center = (axis * d).as_vec3();
    let r = (d * sigma.sin()) as f32;
    let wo32 = wo.as_vec3();
    let (imp, b, cap, wide) = single_sphere(center, r, wo32, material);
    let sc = f64::from(imp.eval(&b).cap_integral);
    assert!(
        close(sc, f64::from(wide), LANE_REL, 1e-12),
        "SC scalar {sc} vs 4-wide {wide}"
    );
    let plastic = Material::Plastic {
        albedo: Rgb::grey(0.25),
        specular: 0.5,
        alpha,
    };
    let (ip, bp, _, _) = single_sphere(center, r, wo32, plastic);
    let (il, bl, _, _) = single_sphere(
        center,
        r,
        wo32,
        Material::Lambert {
            albedo: Rgb::grey(1.0),
        },
    );
    let sum = 0.25 * f64::from(il.eval(&bl).cap_integral) + 0.5 * sc;
    let got = f64::from(ip.eval(&bp).cap_integral);
    assert!(
        close(got, sum, 1e-5, 1e-12),
        "plastic SC {got} vs 0.25·Lambert + 0.5·GGX {sum}"
    );
    let (truth, se) = cap_mc(&cap, |w| ggx.eval_cos(wo, w), Some((ggx, wo)), grid, rng);
    (sc, truth, se, cap.area())
}

/// Accuracy figures of SC against the truth, as `mlmeasure sptd-accuracy` defines them: a case
/// counts for relative errors when its cap-averaged truth exceeds 1e-6 of the hemisphere
/// average ρ/2π (here also: when the Monte Carlo standard error is under 10 % of it); a false
/// zero is SC = 0 where the truth exceeds 1e-6 ρ; Spearman over the cases where either is
/// positive.
#[derive(Debug, Default)]
struct Accuracy {
    /// (relative error, description) of the cases that count.
    errors: Vec<(f64, String)>,
    /// (SC, truth) where either is positive.
    pairs: Vec<(f64, f64)>,
    false_zero: Vec<String>,
}

impl Accuracy {
    fn add(&mut self, sc: f64, truth: f64, se: f64, area: f64, rho: f64, ctx: String) {
        if truth > 1e-6 * rho && sc == 0.0 {
            self.false_zero.push(ctx.clone());
        }
        if truth / area > 1e-6 * rho / (2.0 * PI) && se < 0.1 * truth {
            self.errors.push(((sc - truth).abs() / truth, ctx));
        }
        if sc > 0.0 || truth > 0.0 {
            self.pairs.push((sc, truth));
        }
    }

    /// (median, 90th percentile, Spearman).
    fn summary(&mut self) -> (f64, f64, f64) {
        self.errors.sort_by(|a, b| a.0.total_cmp(&b.0));
        let q = |p: f64| self.errors[((self.errors.len() - 1) as f64 * p).round() as usize].0;
        (q(0.5), q(0.9), spearman(&self.pairs))
    }

    fn report(&mut self, name: &str) -> (f64, f64, f64) {
        let (median, p90, rank) = self.summary();
        eprintln!(
            "{name}: {} cases count: median relative error {median:.3}, p90 {p90:.3}, max \
             {:.3}, Spearman {rank:.4}, false zeros {}",
            self.errors.len(),
            self.errors.last().map_or(0.0, |e| e.0),
            self.false_zero.len()
        );
        for (e, ctx) in self.errors.iter().rev().take(4) {
            eprintln!("  worst: {e:.3} at {ctx}");
        }
        (median, p90, rank)
    }
}

/// Property 5, GGX, on the random caps of the issue's accuracy report (`mlmeasure
/// sptd-accuracy`): √α uniform in [0.1, 1], θo uniform in [0°, 85°], σ log-uniform in
/// [1e-3, 1.2] rad, cap axis uniform on the sphere (so caps straddle and fall below the
/// horizon) — here each cap is the bounding sphere of one sphere light and SC comes through
/// `BlImportance::eval`. Ground truth: MIS of cap and VNDF sampling, 128² stratified pairs
/// (f64 GGX, height-correlated Smith, no Fresnel).
///
/// The model is an approximation. Its targets over these caps are a median relative error
/// ≤ 0.05, a 90th percentile ≤ 0.25, Spearman ≥ 0.97 and no false zeros (the published SPTD
/// fit alone: median ≈ 0.25). Asserted here for 300 cases and 128² pairs (whose standard error
/// adds a few % to each case): median ≤ 0.05, p90 ≤ 0.25, Spearman ≥ 0.97, no false zeros, and
/// SC = 0 for every cap wholly below the horizon. Reports every figure.
#[test]
fn ggx_cap_integral_on_random_caps() {
    let mut rng = Rng::new(0x66C5_0001);
    let mut acc = Accuracy::default();
    let mut false_nonzero = Vec::new();
    for case in 0..300 {
        let u = rng.range(0.1, 1.0);
        let alpha = f64::from(u * u);
        let to = f64::from(rng.range(0.0, 85.0)).to_radians();
        let sigma = f64::from(rng.log_range(1e-3, 1.2));
        let axis = rng.unit().as_dvec3().normalize();
        let ggx = Ggx::new(f64::from(alpha as f32));
        let wo = DVec3::new(to.sin(), 0.0, to.cos());
        let (sc, truth, se, area) = ggx_case(&ggx, wo, axis, sigma, 128, &mut rng);
        let rho = ggx.albedo(wo, 64).0;
        let ctx = format!(
            "case {case}: α = {alpha:.4}, θo = {:.1}°, σ = {sigma:.2e}, axis {axis:.3}: SC \
             {sc:.4e}, truth {truth:.4e} ± {se:.1e}",
            to.to_degrees()
        );
        if axis.z <= -sigma.sin() && sc > 0.0 {
            false_nonzero.push(ctx.clone());
        }
        acc.add(sc, truth, se, area, rho, ctx);
    }
    let (median, p90, rank) = acc.report("GGX SC vs MIS MC, random caps");
    assert!(
        acc.errors.len() > 150,
        "only {} cases count",
        acc.errors.len()
    );
    assert!(
        acc.false_zero.is_empty(),
        "SC = 0 where the truth is above 1e-6 of the albedo:\n{}",
        acc.false_zero.join("\n")
    );
    assert!(
        false_nonzero.is_empty(),
        "SC > 0 for caps wholly below the horizon:\n{}",
        false_nonzero.join("\n")
    );
    assert!(median <= 0.05, "median relative error {median}");
    assert!(p90 <= 0.25, "90th percentile relative error {p90}");
    assert!(rank >= 0.97, "Spearman rank correlation {rank}");
}

/// Property 5, GGX, at grazing views, on the grazing stratum of `mlmeasure sptd-accuracy`:
/// `√α` uniform in [0.1, 0.7], θo uniform in [70°, 89°], small caps off the mirror direction
/// (the axis `k α` off it, k uniform in [1, 4], in a direction uniform around it; σ = `s α`,
/// s log-uniform in [0.01, 0.5]), one in four moved onto the horizon (elevation uniform in
/// `(−σ, σ)`, azimuth kept); caps wholly below the horizon are drawn again. There the GGX
/// lobe is a narrow ridge along the plane of incidence, which an SPTD (round level sets)
/// overestimates away from it by up to a thousandfold. Ground truth as above, 128² pairs.
///
/// Asserted: every case that counts (its standard error under 10 % of the truth, so the
/// truth is known within ±40 % at 4σ) within a factor of 3 of the truth, a 90th percentile
/// relative error ≤ 0.5, Spearman ≥ 0.97 and no false zeros. Reports every figure.
#[test]
fn ggx_cap_integral_at_grazing_views() {
    let mut rng = Rng::new(0x66C5_0002);
    let mut acc = Accuracy::default();
    let mut far = Vec::new();
    let mut case = 0;
    while case < 200 {
        let u = f64::from(rng.range(0.1, 0.7));
        let alpha = u * u;
        let to = f64::from(rng.range(70.0, 89.0)).to_radians();
        let k = f64::from(rng.range(1.0, 4.0));
        let psi = f64::from(rng.range(0.0, 2.0 * std::f32::consts::PI));
        let sigma = alpha * f64::from(rng.log_range(0.01, 0.5));
        let mirror = DVec3::new(-to.sin(), 0.0, to.cos());
        let e1 = DVec3::new(to.cos(), 0.0, to.sin());
        let d = k * alpha;
        let axis =
            (mirror * d.cos() + (e1 * psi.cos() + DVec3::Y * psi.sin()) * d.sin()).normalize();
        let axis = if rng.below(4) == 0 {
            let e = sigma * f64::from(rng.range(-1.0, 1.0));
            let h = DVec3::new(axis.x, axis.y, 0.0).normalize();
            h * e.cos() + DVec3::Z * e.sin()
        } else {
            axis
        };
        if axis.z <= -sigma.sin() {
            continue;
        }
        let ggx = Ggx::new(f64::from(alpha as f32));
        let wo = DVec3::new(to.sin(), 0.0, to.cos());
        let (sc, truth, se, area) = ggx_case(&ggx, wo, axis, sigma, 128, &mut rng);
        let rho = ggx.albedo(wo, 64).0;
        let ctx = format!(
            "case {case}: α = {alpha:.4}, θo = {:.1}°, σ = {sigma:.2e}, axis {axis:.4}: SC \
             {sc:.4e}, truth {truth:.4e} ± {se:.1e}",
            to.to_degrees()
        );
        if truth / area > 1e-6 * rho / (2.0 * PI) && se < 0.1 * truth {
            let ratio = sc / truth;
            if !(1.0 / 3.0..=3.0).contains(&ratio) {
                far.push(format!("S/T {ratio:.3} at {ctx}"));
            }
        }
        acc.add(sc, truth, se, area, rho, ctx);
        case += 1;
    }
    let (_, p90, rank) = acc.report("GGX SC vs MIS MC, grazing views");
    assert!(
        acc.errors.len() > 150,
        "only {} cases count",
        acc.errors.len()
    );
    assert!(
        far.is_empty(),
        "cases off by more than 3×:\n{}",
        far.join("\n")
    );
    assert!(
        acc.false_zero.is_empty(),
        "SC = 0 where the truth is above 1e-6 of the albedo:\n{}",
        acc.false_zero.join("\n")
    );
    assert!(p90 <= 0.5, "90th percentile relative error {p90}");
    assert!(rank >= 0.97, "Spearman rank correlation {rank}");
}

/// Property 5, GGX, on chosen configurations: α ∈ {0.005, 0.05, 0.2, 0.6, 1}, θo ∈ {0°, 30°,
/// 60°, 80°}, caps of σ ∈ {1e-3, 0.03, 0.3, 1} rad centred on the mirror direction, 5°, 20° and
/// 60° off it, 2° above the horizon, and 1° below it (straddling). x inside the sphere gives
/// the SPTD's albedo, which must match the directional albedo within 2 % (the issue's
/// requirement). The tails of the narrowest lobes (α = 0.005 at θo = 80°, caps off the mirror
/// direction) are where an SPTD is known to be poor; only loose bounds are asserted: no false
/// zeros, Spearman ≥ 0.95, and for the caps that hold much of the lobe (truth ≥ 10 % of the
/// albedo) a relative error ≤ 1 (within a factor of 2; the documented 90th percentile over
/// random caps is 0.5, and wide caps 60° off the mirror at θo ≥ 60° reach ~0.55). Reports the
/// figures per α.
#[test]
fn ggx_cap_integral_on_chosen_configurations() {
    let mut rng = Rng::new(0x66C5);
    let mut all = Accuracy::default();
    let mut albedo_worst = 0.0f64;
    let mut heavy = Vec::new();
    for &alpha in &ALPHAS {
        let ggx = Ggx::new(f64::from(alpha));
        let mut per_alpha = Accuracy::default();
        for &theta_o_deg in &[0.0f64, 30.0, 60.0, 80.0] {
            let to = theta_o_deg.to_radians();
            let wo = DVec3::new(to.sin(), 0.0, to.cos());
            let material = Material::Ggx {
                alpha,
                specular: 1.0,
            };
            // Inside the sphere: SC = the SPTD's albedo ≈ the directional albedo.
            let (imp, b, _, _) =
                single_sphere(Vec3::new(0.0, 0.1, 0.0), 1.0, wo.as_vec3(), material);
            let sc_in = f64::from(imp.eval(&b).cap_integral);
            let rho = ggx.albedo(wo, 256).0;
            let rel = (sc_in - rho).abs() / rho;
            albedo_worst = albedo_worst.max(rel);
            assert!(
                rel <= 0.02,
                "α = {alpha}, θo = {theta_o_deg}°: SC inside {sc_in} vs directional albedo \
                 {rho} (relative error {rel:.3})"
            );
            assert!(
                (f64::from(imp.albedo()) - sc_in).abs() <= 1e-6,
                "albedo() {} vs SC inside {sc_in}",
                imp.albedo()
            );
            let mirror = DVec3::new(-to.sin(), 0.0, to.cos());
            let mut axes: Vec<(String, DVec3)> = vec![("mirror".into(), mirror)];
            for off in [5.0f64, 20.0, 60.0] {
                // The mirror direction rotated sideways (out of the plane of incidence).
                let o = off.to_radians();
                let sideways = (mirror * o.cos() + DVec3::Y * o.sin()).normalize();
                axes.push((format!("{off}° sideways"), sideways));
            }
            let e = 2f64.to_radians();
            axes.push((
                "2° above the horizon".into(),
                DVec3::new(-e.cos(), 0.0, e.sin()),
            ));
            let e = 1f64.to_radians();
            axes.push((
                "1° below the horizon".into(),
                DVec3::new(0.0, -e.cos(), -e.sin()),
            ));
            for (name, axis) in &axes {
                for &sigma in &[1e-3f64, 0.03, 0.3, 1.0] {
                    let (sc, truth, se, area) = ggx_case(&ggx, wo, *axis, sigma, 128, &mut rng);
                    let ctx = format!(
                        "α = {alpha}, θo = {theta_o_deg}°, axis {name}, σ = {sigma}: SC \
                         {sc:.4e}, truth {truth:.4e} ± {se:.1e}"
                    );
                    if truth >= 0.1 * rho && se < 0.05 * truth {
                        let rel = (sc - truth).abs() / truth;
                        if rel > 1.0 {
                            heavy.push(format!("{rel:.3} at {ctx}"));
                        }
                    }
                    per_alpha.add(sc, truth, se, area, rho, ctx.clone());
                    all.add(sc, truth, se, area, rho, ctx);
                }
            }
        }
        per_alpha.report(&format!("GGX SC, chosen configurations, α = {alpha}"));
    }
    let (_, _, rank) = all.report("GGX SC, chosen configurations, all");
    eprintln!("worst hemisphere albedo error {albedo_worst:.4}");
    assert!(
        all.false_zero.is_empty(),
        "SC = 0 where the truth is above 1e-6 of the albedo:\n{}",
        all.false_zero.join("\n")
    );
    assert!(
        heavy.is_empty(),
        "caps holding ≥ 10 % of the albedo with a relative error above 1:\n{}",
        heavy.join("\n")
    );
    assert!(rank >= 0.95, "Spearman rank correlation {rank}");
}

/// Spearman's rank correlation of the pairs (average ranks for ties).
fn spearman(pairs: &[(f64, f64)]) -> f64 {
    fn ranks(v: &[f64]) -> Vec<f64> {
        let mut idx: Vec<usize> = (0..v.len()).collect();
        idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
        let mut r = vec![0.0; v.len()];
        let mut i = 0;
        while i < idx.len() {
            let mut j = i;
            while j + 1 < idx.len() && v[idx[j + 1]] == v[idx[i]] {
                j += 1;
            }
            let avg = (i + j) as f64 / 2.0;
            for &k in &idx[i..=j] {
                r[k] = avg;
            }
            i = j + 1;
        }
        r
    }
    let a = ranks(&pairs.iter().map(|p| p.0).collect::<Vec<_>>());
    let b = ranks(&pairs.iter().map(|p| p.1).collect::<Vec<_>>());
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(&b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

// ---------------------------------------------------------------------------------------------
// 6. Bad input
// ---------------------------------------------------------------------------------------------

/// `BlImportance::new` rejects every bad field with a `ShadingError` naming it (in `field` and
/// in its message), never panics, and accepts the edges of the valid ranges (α = 1, α just
/// above 0, weights 0 and 1, ωo in the tangent plane or below the surface), whose importances
/// are then finite and non-negative.
#[test]
fn bad_shading_points_are_rejected_with_the_field() {
    let good = ShadingPoint {
        position: Vec3::new(1.0, 2.0, 3.0),
        normal: Vec3::Z,
        wo: Vec3::new(0.3, 0.0, 1.0),
        material: Material::Plastic {
            albedo: Rgb::grey(0.5),
            specular: 0.5,
            alpha: 0.2,
        },
    };
    assert!(BlImportance::new(&good).is_ok());
    let nan = f32::NAN;
    let inf = f32::INFINITY;
    let with_material = |material| ShadingPoint { material, ..good };
    let mut cases: Vec<(ShadingPoint, ShadingField)> = Vec::new();
    for bad in [nan, inf, -inf] {
        for axis in 0..3 {
            let mut v = Vec3::ZERO;
            v[axis] = bad;
            cases.push((
                ShadingPoint {
                    position: good.position + v,
                    ..good
                },
                ShadingField::Position,
            ));
            cases.push((
                ShadingPoint {
                    normal: good.normal + v,
                    ..good
                },
                ShadingField::Normal,
            ));
            cases.push((
                ShadingPoint {
                    wo: good.wo + v,
                    ..good
                },
                ShadingField::Wo,
            ));
        }
    }
    cases.push((
        ShadingPoint {
            normal: Vec3::ZERO,
            ..good
        },
        ShadingField::Normal,
    ));
    cases.push((
        ShadingPoint {
            normal: Vec3::splat(-0.0),
            ..good
        },
        ShadingField::Normal,
    ));
    cases.push((
        ShadingPoint {
            wo: Vec3::ZERO,
            ..good
        },
        ShadingField::Wo,
    ));
    for alpha in [0.0, -0.0, -0.1, 1.0 + f32::EPSILON, 2.0, nan, inf, -inf] {
        cases.push((
            with_material(Material::Ggx {
                alpha,
                specular: 1.0,
            }),
            ShadingField::Alpha,
        ));
        cases.push((
            with_material(Material::Plastic {
                albedo: Rgb::grey(0.5),
                specular: 0.5,
                alpha,
            }),
            ShadingField::Alpha,
        ));
    }
    for v in [-1e-6, -1.0, 1.0 + f32::EPSILON, 1.5, nan, inf, -inf] {
        cases.push((
            with_material(Material::Lambert {
                albedo: Rgb::grey(v),
            }),
            ShadingField::Albedo,
        ));
        cases.push((
            with_material(Material::Plastic {
                albedo: Rgb::grey(v),
                specular: 0.5,
                alpha: 0.5,
            }),
            ShadingField::Albedo,
        ));
        cases.push((
            with_material(Material::Ggx {
                alpha: 0.5,
                specular: v,
            }),
            ShadingField::Specular,
        ));
        cases.push((
            with_material(Material::Plastic {
                albedo: Rgb::grey(0.5),
                specular: v,
                alpha: 0.5,
            }),
            ShadingField::Specular,
        ));
    }
    for (sp, field) in &cases {
        let got = std::panic::catch_unwind(|| BlImportance::new(sp));
        let got = got.unwrap_or_else(|_| panic!("BlImportance::new panicked on {sp:?}"));
        match got {
            Ok(imp) => panic!("{sp:?} accepted: {imp:?}"),
            Err(e) => {
                assert_eq!(e.field, *field, "{sp:?}: {e}");
                let msg = e.to_string();
                assert!(
                    msg.contains(field.name()),
                    "{sp:?}: message {msg:?} does not name `{}`",
                    field.name()
                );
            }
        }
    }

    // The edges of the valid ranges are accepted and give finite, non-negative values.
    let (lights, _) = styled_scene(0xBAD, 200);
    let tree = LightTree::build(&lights).unwrap();
    let mut ok = vec![
        with_material(Material::Ggx {
            alpha: 1.0,
            specular: 1.0,
        }),
        with_material(Material::Ggx {
            alpha: f32::from_bits(1),
            specular: 1.0,
        }),
        with_material(Material::Ggx {
            alpha: 1e-6,
            specular: 0.0,
        }),
        with_material(Material::Plastic {
            albedo: Rgb::grey(0.0),
            specular: 0.0,
            alpha: 0.5,
        }),
        with_material(Material::Lambert {
            albedo: Rgb::grey(1.0),
        }),
        with_material(Material::Lambert {
            albedo: Rgb::grey(0.0),
        }),
    ];
    for wo in [
        Vec3::X,
        -Vec3::Z,
        Vec3::new(1.0, 0.0, -1e-7),
        Vec3::splat(1e-20),
    ] {
        ok.push(ShadingPoint { wo, ..good });
    }
    ok.push(ShadingPoint {
        normal: Vec3::splat(1e-20),
        ..good
    });
    ok.push(ShadingPoint {
        position: Vec3::splat(1e15),
        ..good
    });
    for sp in &ok {
        let imp = BlImportance::new(sp).unwrap_or_else(|e| panic!("{sp:?} rejected: {e}"));
        assert!(imp.albedo().is_finite() && imp.albedo() >= 0.0, "{sp:?}");
        for node in tree.nodes() {
            let (w, sc) = imp.eval4_with_integrals(node);
            for (w, sc) in w.to_array().into_iter().zip(sc.to_array()) {
                assert!(w.is_finite() && w >= 0.0, "{sp:?}: importance {w}");
                assert!(sc.is_finite() && sc >= 0.0, "{sp:?}: SC {sc}");
            }
        }
        let cut = LightCut::build_bl(&tree, &imp, &BlCutOptions::default());
        if imp.albedo() == 0.0 {
            // Nothing is reflected: no light matters.
            assert!(
                cut.is_empty(),
                "{sp:?}: albedo 0 but {} clusters",
                cut.len()
            );
        }
        let _ = tree.sample(&imp, 0.5);
    }
    // The defensive share is what the module documents.
    const { assert!(DEFENSIVE > 0.0 && DEFENSIVE < 1.0) };
}

// ---------------------------------------------------------------------------------------------
// Regressions (these tests fail until `src/importance/bl.rs` is fixed)
// ---------------------------------------------------------------------------------------------

/// BL of a cluster of zero extent must be the limit of BL for a shrinking cluster. docs/formulas.md
/// section 7: `B_C = (1/|Ω_C ∩ H|) ∫_{Ω_C ∩ H} f cos`, whose limit as the cap shrinks to the
/// direction ω is `f(ω) cos θ`. `BlImportance::eval` computes `avg = sc / omega` and sets it to
/// 0 when `omega = 0`, which is the case for every point and spot light (radius 0, so
/// `sin σ = 0`: SC = 0 and |Ω_C ∩ H| = 0) and every cluster of coincident lights: their BL is
/// then only the defensive TL share, `DEFENSIVE · ρ/π · cos θi'`, whatever the BRDF.
///
/// Reproduction: x = 0, n = +z, ωo = (−0.5, 0, 1), light at 10·normalize(0.5, 0, 1) (the mirror
/// direction). A point light of intensity 1 and a sphere light of radius 1e-3 and the same
/// power (radiance 1/(π r²)): BL(point)/BL(sphere) is 0.0476 for Lambert (ρ = 0.8) — exactly
/// DEFENSIVE/(1 + DEFENSIVE) — and 0.0058 for GGX α = 0.2 (it should be ≈ 1 for both; TL gives
/// 1). So with BL, point lights are sampled up to ~170× less often than an equally bright tiny
/// sphere at the same spot, and BL sampling among point lights ignores the BRDF lobe entirely
/// (it ranks them by TL alone).
#[test]
fn bl_of_a_point_light_is_the_limit_of_a_shrinking_sphere() {
    let mut failures = Vec::new();
    for material in [
        Material::Lambert {
            albedo: Rgb::grey(0.8),
        },
        Material::Ggx {
            alpha: 0.2,
            specular: 1.0,
        },
        Material::Plastic {
            albedo: Rgb::grey(0.3),
            specular: 0.7,
            alpha: 0.05,
        },
    ] {
        let wo = Vec3::new(-0.5, 0.0, 1.0);
        let imp = BlImportance::new(&ShadingPoint {
            position: Vec3::ZERO,
            normal: Vec3::Z,
            wo,
            material,
        })
        .unwrap();
        for dir in [
            Vec3::new(0.5, 0.0, 1.0),
            Vec3::new(0.2, 0.3, 1.0),
            Vec3::new(-0.3, 0.6, 0.4),
        ] {
            let c = dir.normalize() * 10.0;
            let r = 1e-3f32;
            let point = LightTree::build(&[Light::Point {
                position: c,
                intensity: Rgb::grey(1.0),
            }])
            .unwrap();
            let sphere = LightTree::build(&[Light::Sphere {
                center: c,
                radius: r,
                radiance: Rgb::grey(1.0 / (std::f32::consts::PI * r * r)),
            }])
            .unwrap();
            let a = imp.eval(&point.nodes()[0].bounds(0));
            let b = imp.eval(&sphere.nodes()[0].bounds(0));
            let ratio = a.importance / b.importance;
            if !(0.9..=1.1).contains(&ratio) {
                failures.push(format!(
                    "{material:?}, light at {c}: BL(point) = {:e}, BL(sphere r = 1e-3) = {:e}, \
                     ratio {ratio:.4}",
                    a.importance, b.importance
                ));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "BL of a point light is not the limit of a shrinking sphere light (expected ratio 1 ± \
         0.1):\n{}",
        failures.join("\n")
    );
}

/// Regression: BL must stay finite wherever TL is. `TlImportance` relies on `MIN_DISTANCE2` and
/// the build's energy caps (MAX_LIGHT_ENERGY = 1e24) to keep `E / d²` below f32's range, but BL
/// multiplies it by the cap-averaged `f cos`, up to ~1/(4πα²) ≈ 3,000 for α = 0.005 at normal
/// view (more at grazing view). It used to overflow to +∞, so the root's sum was not finite,
/// `LightTree::sample` returned `None`, every `pmf` was 0 and the BL cut was empty — although
/// the light reaches x.
///
/// Reproduction: a sphere light of radius 1e-8 and radiance 8e23/(4π² r²) (energy 8e23 ≤ 1e24,
/// accepted by the build) centred at (0, 0, 1e-6); x = 0, n = +z, ωo = +z, GGX α = 0.005,
/// specular 1. TL = 8.0e35; BL = +∞ (SC = 0.446 over a cap of 3.1e-4 sr); `tree.sample(u)` is
/// `None`. The same at θo = 1.2, 1.5, 1.55 rad (with the light in the mirror direction).
#[test]
fn bl_importance_stays_finite_where_tl_is() {
    let mut failures = Vec::new();
    for theta_o in [0.0f32, 1.2, 1.5, 1.55] {
        let wo = Vec3::new(theta_o.sin(), 0.0, theta_o.cos());
        let mirror = Vec3::new(-theta_o.sin(), 0.0, theta_o.cos());
        let imp = BlImportance::new(&ShadingPoint {
            position: Vec3::ZERO,
            normal: Vec3::Z,
            wo,
            material: Material::Ggx {
                alpha: 0.005,
                specular: 1.0,
            },
        })
        .unwrap();
        let r = 1e-8f32;
        let radiance = 8e23 / (4.0 * std::f32::consts::PI * std::f32::consts::PI * r * r);
        let lights = [Light::Sphere {
            center: mirror * 1e-6,
            radius: r,
            radiance: radiance.into(),
        }];
        let tree = LightTree::build(&lights).unwrap();
        assert!(reaches(&lights[0], &imp));
        let b = tree.nodes()[0].bounds(0);
        let tl = manylights::TlImportance::new(Vec3::ZERO, Vec3::Z).eval(&b);
        let bl = imp.eval(&b);
        let sample = tree.sample(&imp, 0.5);
        let cut = LightCut::build_bl(&tree, &imp, &BlCutOptions::default());
        if !(bl.importance.is_finite() && sample.is_some() && cut.pmf(&tree, &imp, 0) > 0.0) {
            failures.push(format!(
                "θo = {theta_o}: energy {:e}, TL {tl:e}, BL {bl:?}, tree.sample {sample:?}, \
                 tree.pmf {}, cut of {} clusters",
                b.energy,
                tree.pmf(&imp, 0),
                cut.len()
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "BL overflows where TL is finite (the light reaches x but cannot be sampled):\n{}",
        failures.join("\n")
    );
}

/// The glossy part of the cap integrals, which sizes the BRDF-aware budget: 0 for Lambert,
/// all of SC for pure GGX, SC minus the Lambert part for plastic, lane by lane; a BL cut's
/// `max_glossy_score` is the largest over its clusters and `brdf_budget` follows it.
#[test]
fn glossy_part_of_the_cap_integrals() {
    let lights: Vec<Light> = (0..300)
        .map(|i| {
            let t = i as f32 * 0.37;
            Light::Sphere {
                center: Vec3::new(3.0 * t.cos(), 3.0 * t.sin(), 0.5 + (i % 7) as f32 * 0.4),
                radius: 0.05 + 0.01 * (i % 5) as f32,
                radiance: Rgb::grey(1.0 + (i % 3) as f32),
            }
        })
        .collect();
    let tree = LightTree::build(&lights).unwrap();
    let at = |material| {
        BlImportance::new(&ShadingPoint {
            position: Vec3::ZERO,
            normal: Vec3::Z,
            wo: Vec3::new(0.3, 0.0, 1.0).normalize(),
            material,
        })
        .unwrap()
    };
    let (rho, ks, alpha) = (0.5, 0.4, 0.15);
    let lambert = at(Material::Lambert {
        albedo: Rgb::grey(rho),
    });
    let ggx = at(Material::Ggx {
        alpha,
        specular: ks,
    });
    let plastic = at(Material::Plastic {
        albedo: Rgb::grey(rho),
        specular: ks,
        alpha,
    });
    for node in tree.nodes() {
        let (_, sc_l, g_l) = lambert.eval4_with_lobe_integrals(node);
        let (_, sc_g, g_g) = ggx.eval4_with_lobe_integrals(node);
        let (_, sc_p, g_p) = plastic.eval4_with_lobe_integrals(node);
        let (w2, sc2) = plastic.eval4_with_integrals(node);
        assert_eq!(sc2.to_array(), sc_p.to_array());
        assert_eq!(w2.to_array(), plastic.eval4(node).to_array());
        for k in 0..4 {
            assert_eq!(g_l.to_array()[k], 0.0);
            assert_eq!(g_g.to_array()[k], sc_g.to_array()[k]);
            let (s, g) = (sc_p.to_array()[k], g_p.to_array()[k]);
            assert!(g >= 0.0 && g <= s, "{g} > {s}");
            // The glossy part is the GGX material's integral; the rest is the Lambert part.
            let tol = 1e-5 * s.max(1e-20);
            assert!(
                (g - g_g.to_array()[k]).abs() <= tol,
                "{g} vs {}",
                g_g.to_array()[k]
            );
            assert!(
                (s - g - sc_l.to_array()[k]).abs() <= tol,
                "{s} − {g} vs {}",
                sc_l.to_array()[k]
            );
        }
    }
    for imp in [&lambert, &ggx, &plastic] {
        let cut = LightCut::build_bl(&tree, imp, &BlCutOptions::default());
        let max = cut
            .clusters()
            .iter()
            .map(|c| c.glossy_score)
            .fold(0.0f32, f32::max);
        assert_eq!(cut.max_glossy_score(), max);
        assert!(cut.max_glossy_score() <= cut.max_score());
        assert_eq!(
            manylights::internals::mis::brdf_budget(&cut, 50),
            manylights::internals::mis::sample_budget(max, 50)
        );
    }
    assert_eq!(
        LightCut::build_bl(&tree, &lambert, &BlCutOptions::default()).max_glossy_score(),
        0.0
    );
}

/// Regression: `BlImportance::new` normalised the normal and ωo in f32, so a component above
/// about 1.8e19 (squared length +∞, which passed the "> 0" check) gave the zero vector. With
/// ωo = (0.3e30, 0, −1e30) the normal was then not turned to the viewer's side and a light
/// below the surface, which contributes, got pmf 0. Both are now normalised in f64 when f32
/// would overflow or underflow: any finite non-zero length gives the direction of the unit
/// vector (to f32 rounding), and so the same pmfs.
#[test]
fn huge_normal_and_wo_keep_their_direction() {
    let lights = [
        Light::Point {
            position: Vec3::new(0.5, 0.0, -2.0),
            intensity: Rgb::grey(1.0),
        },
        Light::Sphere {
            center: Vec3::new(-1.0, 1.0, -1.5),
            radius: 0.3,
            radiance: Rgb::grey(2.0),
        },
        Light::Point {
            position: Vec3::new(0.0, 0.5, 2.0),
            intensity: Rgb::grey(3.0),
        },
    ];
    let tree = LightTree::build(&lights).unwrap();
    let material = Material::Plastic {
        albedo: Rgb::grey(0.5),
        specular: 0.5,
        alpha: 0.3,
    };
    let at = |normal: Vec3, wo: Vec3| {
        BlImportance::new(&ShadingPoint {
            position: Vec3::ZERO,
            normal,
            wo,
            material,
        })
        .unwrap()
    };
    // The issue's case: the viewer is below the surface, so the normal turns to −z.
    let imp = at(Vec3::Z, Vec3::new(0.3e30, 0.0, -1e30));
    assert_eq!(imp.normal(), -Vec3::Z);
    let reference = at(Vec3::Z, Vec3::new(0.3, 0.0, -1.0));
    for (normal, wo) in [
        (Vec3::Z, Vec3::new(0.3e30, 0.0, -1e30)),
        (Vec3::new(0.0, 0.0, 1e20), Vec3::new(0.3, 0.0, -1.0)),
        (Vec3::new(0.0, 0.0, 3e38), Vec3::new(3e37, 0.0, -1e38)),
        (Vec3::new(0.0, 0.0, f32::MAX), Vec3::new(0.3e20, 0.0, -1e20)),
    ] {
        let imp = at(normal, wo);
        assert!(
            (imp.normal() - reference.normal()).length() <= 1e-6,
            "normal {normal} wo {wo}: BL normal {}",
            imp.normal()
        );
        // The unit vectors differ by f32 rounding (an ulp or two), which moves these pmfs far
        // less than 1e-4.
        for l in 0..lights.len() as u32 {
            let (p, want) = (tree.pmf(&imp, l), tree.pmf(&reference, l));
            assert!(
                close(f64::from(p), f64::from(want), 1e-4, 0.0),
                "normal {normal} wo {wo}: light {l} has pmf {p}, {want} with unit vectors"
            );
        }
        assert!(tree.pmf(&imp, 0) > 0.0, "normal {normal} wo {wo}");
    }
}

/// Regression: a tiny normal such as `(0, 0, 1e-30)` was rejected with "field `normal` has
/// zero length (got 0)" (its f32 squared length underflows) although the vector is not zero.
/// Tiny finite non-zero normals and ωo are now accepted and normalised in f64, as `Light` and
/// `TlImportance` do; only the zero vector is rejected as having zero length.
#[test]
fn tiny_normal_and_wo_are_accepted() {
    let sp = |normal: Vec3, wo: Vec3| ShadingPoint {
        position: Vec3::ZERO,
        normal,
        wo,
        material: Material::Lambert {
            albedo: Rgb::grey(0.8),
        },
    };
    for (normal, wo) in [
        (Vec3::new(0.0, 0.0, 1e-30), Vec3::new(0.3, 0.0, 1.0)),
        (Vec3::Z, Vec3::new(0.3e-30, 0.0, 1e-30)),
        (
            Vec3::new(0.0, 0.0, f32::from_bits(1)),
            Vec3::new(1e-45, 0.0, 3e-45),
        ),
    ] {
        let imp = BlImportance::new(&sp(normal, wo))
            .unwrap_or_else(|e| panic!("normal {normal} wo {wo}: {e}"));
        assert!(
            (imp.normal() - Vec3::Z).length() <= 1e-6,
            "normal {normal} wo {wo}: BL normal {}",
            imp.normal()
        );
    }
    for (normal, wo, field) in [
        (Vec3::ZERO, Vec3::Z, ShadingField::Normal),
        (Vec3::Z, Vec3::new(-0.0, 0.0, 0.0), ShadingField::Wo),
    ] {
        let e = BlImportance::new(&sp(normal, wo)).unwrap_err();
        assert_eq!(e.field, field);
        assert!(format!("{e}").contains("zero length"), "{e}");
    }
}

/// Found by the `sptd` fuzz target (`fuzz/regressions/sptd/crash-d332…`): `SptdGgx::oriented`
/// took the f32 length of the normal and ωo, so a tiny normal such as `(−1.3e-35, …)` (whose
/// squared length underflows) gave a zero lobe, albedo 0, although the vector is not zero;
/// a huge one (whose length overflows) did the same. Both are now normalised in f64, as
/// `BlImportance` does, and give the lobe of the unit vectors.
#[test]
fn sptd_oriented_keeps_the_lobe_of_tiny_and_huge_vectors() {
    let alpha = 0.52156866;
    let wo = Vec3::new(-0.66107404, -0.09010743, 0.74489045);
    let tiny = Vec3::new(-1.2550414e-35, -1.2556307e-35, -1.2556307e-35);
    let unit = -Vec3::ONE.normalize();
    for (normal, wo) in [
        (tiny, wo),
        (unit * 1e30, wo),
        (unit, wo * 1e-30),
        (unit * f32::MAX, wo * 3e38),
    ] {
        let g = SptdGgx::oriented(alpha, normal, wo);
        // The lobe of the unit vectors, normalised here in f64.
        let f64_unit = |v: Vec3| v.as_dvec3().normalize().as_vec3();
        let reference = SptdGgx::oriented(alpha, f64_unit(normal), f64_unit(wo));
        assert!(reference.albedo() > 0.0);
        assert!(
            (g.albedo() - reference.albedo()).abs() <= 1e-6 * reference.albedo(),
            "normal {normal} wo {wo}: albedo {} against {}",
            g.albedo(),
            reference.albedo()
        );
        for (axis, sin) in [(-unit, 0.3), (Vec3::new(0.6, 0.0, -0.8), 0.05)] {
            let (a, b) = (g.integral(axis, sin), reference.integral(axis, sin));
            assert!(
                (a - b).abs() <= 1e-4 * b + 1e-30,
                "normal {normal} wo {wo}: {a} against {b}"
            );
        }
    }
    // Only the zero vector and non-finite ones give the zero lobe.
    for normal in [Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 1.0), Vec3::INFINITY] {
        assert_eq!(SptdGgx::oriented(alpha, normal, wo).albedo(), 0.0);
    }
}

/// Found by the `sptd` fuzz target (`fuzz/regressions/sptd/crash-c13f…`): a cluster closer to
/// the shading point than 1e-6 (d² below `MIN_DISTANCE2`) had its direction x → cluster
/// divided by the floored distance, not the true one, so the cap axis was no longer a unit
/// vector (here of length 1e-11) and SC was 13.7 against an albedo of 0.38; TL's cosines came
/// from the same short vector. The direction and θu now come from the true distance: SC is
/// that of the same cluster seen from afar, at the same angle and r/d.
#[test]
fn a_cluster_a_femtometre_away_keeps_its_cap() {
    let sp = |position: Vec3| ShadingPoint {
        position,
        normal: Vec3::new(-0.9885642, -0.13474585, -0.067708194),
        wo: Vec3::new(-1.2556307e-35, -1.2556307e-35, -1.2556307e-35),
        material: Material::Ggx {
            alpha: 1.0,
            specular: 0.9981384,
        },
    };
    let bounds = SlotBounds {
        center: Vec3::new(-1.4254985e-17, -1.9430202e-18, -9.763446e-19),
        radius: 9.193633e-20,
        axis: Vec3::new(-0.81778926, -0.5062899, -0.2736631),
        cos_o: -0.27366307,
        sin_o: 0.9618256,
        cos_e: 0.6026346,
        energy: 1.0,
    };
    let position = Vec3::new(0.0, 0.0, -1.406094e-35);
    let imp = BlImportance::new(&sp(position)).unwrap();
    let near = imp.eval(&bounds);
    // The same cluster 1e16 times farther and larger.
    let far = BlImportance::new(&sp(Vec3::ZERO))
        .unwrap()
        .eval(&SlotBounds {
            center: bounds.center * 1e16,
            radius: bounds.radius * 1e16,
            ..bounds
        });
    assert!(
        near.cap_integral <= imp.albedo(),
        "SC {} above the albedo {}",
        near.cap_integral,
        imp.albedo()
    );
    assert!(
        (near.cap_integral - far.cap_integral).abs() <= 1e-4 * far.cap_integral,
        "SC {} near, {} far",
        near.cap_integral,
        far.cap_integral
    );
    // The 4-wide twin agrees through a tree holding a sphere light there.
    let lights = [Light::Sphere {
        center: bounds.center,
        radius: bounds.radius,
        radiance: Rgb::grey(1.0),
    }];
    let tree = LightTree::build(&lights).unwrap();
    let node = &tree.nodes()[0];
    let (w, sc) = imp.eval4_with_integrals(node);
    let e = imp.eval(&node.bounds(0));
    for (four, one) in [(w, e.importance), (sc, e.cap_integral)] {
        let four = four.to_array()[0];
        assert!(
            (four - one).abs() <= 1e-4 * four.max(one) + 1e-30,
            "4-wide {four} against scalar {one}"
        );
    }
    assert!(e.cap_integral <= imp.albedo(), "{e:?}");
}

/// Found by the `sptd` fuzz target (`fuzz/regressions/sptd/crash-8526…`): an infinite cap
/// axis (no unit vector: outside the evaluators' domain) made the Lambert part of
/// `cap_integrals` NaN (`s² · cos ω` with `s = 0`, `cos ω = ∞`), against the module's promise
/// of no NaN. `cos ω` is now clamped to 1 there, as `lambert_visible` clamps it.
#[test]
fn sptd_cap_integrals_of_an_infinite_axis_are_not_nan() {
    let g = SptdGgx::oriented(
        0.52156866,
        Vec3::new(-0.9885642, -0.13474585, -0.067708194),
        Vec3::new(8.662181e-8, 1.1806951e-8, -1.0),
    );
    let axis = Vec3::new(f32::NEG_INFINITY, -8.229016e-31, 6.770577e22);
    for sin in [-1.2544506e-35, 0.0, 0.5] {
        let c = g.cap_integrals(axis, sin);
        assert!(
            !(c.ggx.is_nan() || c.lambert.is_nan() || c.visible.is_nan()),
            "sin σ {sin}: {c:?}"
        );
        let c4 = g.cap_integrals4(
            f32x4::splat(axis.x),
            f32x4::splat(axis.y),
            f32x4::splat(axis.z),
            f32x4::splat(sin),
        );
        for v in [c4.ggx, c4.lambert, c4.visible] {
            assert!(
                v.to_array().iter().all(|x| !x.is_nan()),
                "sin σ {sin}: {c4:?}"
            );
        }
    }
}

/// `LightCut::rebuild_bl` and `rebuild_split` are `build_bl` and `build_split`, whatever
/// the cut held before: a cut rebuilt at each of a chain of points (of random options) has
/// the clusters, totals and scores of a new one there and samples and queries bit for bit
/// as it does.
#[test]
fn rebuilt_cuts_are_new_cuts() {
    let mut rng = Rng::new(0xB1_0777);
    for scene in 0..4 {
        let (lights, half) = styled_scene(0xB1_0700 + scene, 300);
        let tree = LightTree::build(&lights).unwrap();
        let mut bl = LightCut::new();
        let mut split = LightCut::new();
        for _ in 0..60 {
            let (imp, _) = bl_point(&mut rng, &tree, &lights, half);
            let opts = random_cut_options(&mut rng);
            bl.rebuild_bl(&tree, &imp, &opts);
            let fresh = LightCut::build_bl(&tree, &imp, &opts);
            let tl = TlImportance::new(imp.position(), imp.normal());
            let split_opts = SplitCutOptions {
                threshold: [0.0, 1e-3, 1.0][rng.below(3)],
                max_size: opts.max_size,
            };
            split.rebuild_split(&tree, &tl, &split_opts);
            let fresh_split = LightCut::build_split(&tree, &tl, &split_opts);
            for (cut, fresh) in [(&bl, &fresh), (&split, &fresh_split)] {
                assert_eq!(cut.clusters(), fresh.clusters());
                assert_eq!(cut.total_weight().to_bits(), fresh.total_weight().to_bits());
                assert_eq!(cut.max_score().to_bits(), fresh.max_score().to_bits());
                assert_eq!(
                    cut.max_glossy_score().to_bits(),
                    fresh.max_glossy_score().to_bits()
                );
                for &u in &u_values(&mut rng, 16) {
                    let (a, b) = (cut.sample(&tree, &imp, u), fresh.sample(&tree, &imp, u));
                    assert_eq!(a, b);
                    if let Some(s) = a {
                        let (p, q) = (
                            cut.pmf(&tree, &imp, s.light),
                            fresh.pmf(&tree, &imp, s.light),
                        );
                        assert_eq!(p.to_bits(), q.to_bits());
                    }
                }
            }
        }
    }
}
