//! `mlmeasure selection`: how well the light choice of the BRDF-oriented cut (BL) and of the
//! tree's classic descent (TL) follows the lights' contributions at a scene's shading points,
//! without the noise of rendering.
//!
//! At `points` shading points seen through jittered pixel positions (the primary hits of the
//! jittered protocol, [`primary_at`]), each light's contribution `c_l = ∫_l f L cos θ dω` is
//! estimated from four stratified points on it ([`sample_point`]), each with a shadow ray
//! through the scene, and each light's probability `p_l` is queried from the technique at the
//! point, as the estimators draw it: [`CutSampler`] (the BRDF-oriented cut built with the
//! given options; `Params::bl_cut` in the CLI) and [`TreeSampler`] (the TL descent), lights at
//! infinity chosen at the root by each. An environment light, whose radiance is the host's, is
//! left out. The variance of the light choice is
//!
//! ```text
//! V = Σ_l c_l² / p_l − (Σ_l c_l)²
//! ```
//!
//! the variance of `c_L / p_L` for the light L drawn with probabilities p: the part of a
//! one-light-sample estimate's variance that comes from which light it takes (a light with
//! `c_l > 0` and `p_l = 0` makes it infinite; conservativeness rules that out). Its mean over
//! the points is that part of the image's mean squared error per estimate. A few points where
//! a light carrying most of the light gets a small probability dominate it: the report gives
//! the share of the mean from the worst 1 % of the points, the mean cut size and how many cuts
//! ran out of room (reached `max_size`).
//!
//! Two choices without a cut are measured beside them, as the levers they are for a cheaper
//! BRDF-oriented choice: one descent of the tree with the BL importance at every node
//! (`bl_descent`: what the tree's own sampler gives with [`BlImportance`]), and the same
//! descent taking the TL importance at every node where a child's cap is as wide as the cut's
//! `split_sin` would split (`bl_descent_tl_near`: the cut's own criterion decided per node, TL
//! where BL's distance to the cluster's centre misleads). Both pmfs are exact, from the walk
//! down each light's path.

use manylights::direct::{CutSampler, LightSampler, TreeSampler};
use manylights::importance::Importance;
use manylights::internals::tree::Node4Ext;
use manylights::light::sample_point;
use manylights::light_set::InfiniteLight;
use manylights::tree::{Node4, SlotBounds};
use manylights::{
    BlCutOptions, BlImportance, Brdf, Frame, Light, LightTree, ShadingPoint, TlImportance,
};
use manylights_render::render::primary_at;
use manylights_render::scene::RenderScene;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use serde_json::json;

/// What to measure.
#[derive(Clone, Copy, Debug)]
pub struct SelectionConfig {
    /// Shading points.
    pub points: usize,
    /// Image size the jittered pixel positions are drawn in.
    pub width: usize,
    /// See `width`.
    pub height: usize,
    /// Seed of the points.
    pub seed: u64,
    /// The BRDF-oriented cut's options.
    pub cut: BlCutOptions,
}

/// The light choice's variance of one technique over the points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Choice {
    /// Mean over the points of `V`.
    pub mean_variance: f64,
    /// Share of `Σ V` from the 1 % of the points with the largest `V`.
    pub worst_1pc_share: f64,
}

/// The report.
#[derive(Clone, Debug, PartialEq)]
pub struct SelectionReport {
    /// Points with a primary hit and some light.
    pub points: usize,
    /// Mean over the points of `Σ_l c_l`.
    pub mean_light: f64,
    /// The BRDF-oriented cut.
    pub bl: Choice,
    /// The TL descent.
    pub tl: Choice,
    /// One descent with the BL importance at every node.
    pub bl_descent: Choice,
    /// One descent with the TL importance at the nodes with a wide child's cap, BL elsewhere.
    pub bl_descent_tl_near: Choice,
    /// Mean number of clusters of the cut.
    pub mean_cut: f64,
    /// Share of the points whose cut reached `max_size`.
    pub cut_full: f64,
}

/// Each light's contribution at `sp` (4 stratified points, shadow rays), those above 0.
fn contributions(scene: &RenderScene, sp: &ShadingPoint) -> Vec<(u32, f64)> {
    let Some(frame) = Frame::from_normal(sp.normal) else {
        return Vec::new();
    };
    let wo = frame.to_local(sp.wo.normalize());
    let mut out = Vec::new();
    for (l, light) in scene.lights.lights().iter().enumerate() {
        if matches!(light, Light::Environment { .. }) {
            continue;
        }
        let mut sum = 0.0f64;
        for u in [[0.25f32, 0.25f32], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]] {
            let Some(p) = sample_point(light, sp.position, u) else {
                continue;
            };
            let wi = frame.to_local(p.direction);
            if wi.z <= 0.0 || p.radiance.is_black() {
                continue;
            }
            let g = f64::from(sp.material.eval(wo, wi) * wi.z) * f64::from(p.radiance.luminance());
            if g > 0.0
                && !manylights::Occluder::occluded(
                    &scene.geometry,
                    sp.position,
                    p.direction,
                    p.distance,
                )
            {
                sum += g / f64::from(p.pdf);
            }
        }
        if sum > 0.0 {
            out.push((l as u32, sum / 4.0));
        }
    }
    out
}

/// The importance of `bl_descent_tl_near`: at a node where some child's bounding sphere
/// (centre c, radius r) has `s²·|c − x|² ≤ r²`, the TL importance of its four slots, else the
/// BL importance; lights at infinity weighed by BL.
struct TlNear {
    bl: BlImportance,
    tl: TlImportance,
    position: glam::Vec3,
    s2: f32,
}

impl TlNear {
    /// Whether `node` takes TL: some child's cap is as wide as `s` would split.
    fn near(&self, node: &Node4) -> bool {
        (0..4).any(|k| {
            let s = node.sphere(k);
            s.radius > 0.0
                && self.s2 * (s.center - self.position).length_squared() <= s.radius * s.radius
        })
    }
}

impl Importance for TlNear {
    fn eval4(&self, node: &Node4) -> manylights::importance::f32x4 {
        if self.near(node) {
            self.tl.eval4(node)
        } else {
            self.bl.eval4(node)
        }
    }

    /// BL's: a slot alone does not say whether a sibling is near ([`Importance::eval_lane`]
    /// does, from the node).
    fn eval_slot(&self, b: &SlotBounds) -> f32 {
        self.bl.eval_slot(b)
    }

    fn eval_lane(&self, node: &Node4, k: usize) -> f32 {
        if self.near(node) {
            self.tl.eval_lane(node, k)
        } else {
            self.bl.eval_lane(node, k)
        }
    }

    fn eval_infinite(&self, light: &InfiniteLight) -> f32 {
        self.bl.eval_infinite(light)
    }
}

/// `Σ c² / p − (Σ c)²`.
fn variance(cs: &[(u32, f64)], pmf: impl Fn(u32) -> f32) -> f64 {
    let total: f64 = cs.iter().map(|c| c.1).sum();
    let second: f64 = cs
        .iter()
        .map(|&(l, c)| {
            let p = f64::from(pmf(l));
            if p > 0.0 {
                c * c / p
            } else {
                f64::INFINITY
            }
        })
        .sum();
    second - total * total
}

fn choice(v: &[f64]) -> Choice {
    let mut sorted = v.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    let sum: f64 = sorted.iter().sum();
    let worst = sorted[..sorted.len().div_ceil(100)].iter().sum::<f64>();
    Choice {
        mean_variance: sum / v.len().max(1) as f64,
        worst_1pc_share: if sum > 0.0 { worst / sum } else { 0.0 },
    }
}

/// Measures `scene` under `cfg` (in parallel; the result does not depend on threads).
pub fn run(scene: &RenderScene, cfg: &SelectionConfig) -> SelectionReport {
    let mut rng = Pcg64Mcg::seed_from_u64(cfg.seed);
    let (w, h) = (cfg.width.max(1), cfg.height.max(1));
    let mut pts = Vec::with_capacity(cfg.points);
    let mut tries = 0usize;
    while pts.len() < cfg.points && tries < 100 * cfg.points.max(1) {
        tries += 1;
        let (px, py) = (rng.random_range(0..w), rng.random_range(0..h));
        let off = [rng.random::<f32>(), rng.random::<f32>()];
        if let Some(sp) = primary_at(scene, px, py, w, h, off) {
            pts.push(sp);
        }
    }
    let tree: &LightTree = scene.lights.tree();
    let s = cfg.cut.split_sin.clamp(0.0, 1.0);
    let rows: Vec<(f64, [f64; 4], usize, bool)> = pts
        .par_iter()
        .filter_map(|sp| {
            let cs = contributions(scene, sp);
            let total: f64 = cs.iter().map(|c| c.1).sum();
            if total <= 0.0 {
                return None;
            }
            let bl = CutSampler::new(tree, sp, &cfg.cut).ok()?;
            let tl = TreeSampler::new(tree, sp.position, sp.normal);
            let imp = *bl.importance();
            let near = TlNear {
                bl: imp,
                tl: *tl.importance(),
                position: sp.position,
                s2: s * s,
            };
            let v = [
                variance(&cs, |l| bl.pmf(l)),
                variance(&cs, |l| tl.pmf(l)),
                variance(&cs, |l| tree.pmf(&imp, l)),
                variance(&cs, |l| tree.pmf(&near, l)),
            ];
            let n = bl.cut().len();
            let full = bl.cut().tree_clusters().len()
                >= cfg.cut.max_size.clamp(4, manylights::cut::MAX_CUT_SIZE);
            Some((total, v, n, full))
        })
        .collect();
    let n = rows.len().max(1) as f64;
    let of = |i: usize| choice(&rows.iter().map(|r| r.1[i]).collect::<Vec<f64>>());
    SelectionReport {
        points: rows.len(),
        mean_light: rows.iter().map(|r| r.0).sum::<f64>() / n,
        bl: of(0),
        tl: of(1),
        bl_descent: of(2),
        bl_descent_tl_near: of(3),
        mean_cut: rows.iter().map(|r| r.2 as f64).sum::<f64>() / n,
        cut_full: rows.iter().filter(|r| r.3).count() as f64 / n,
    }
}

impl SelectionReport {
    /// The table printed by `mlmeasure selection`.
    pub fn table(&self, scene: &str, cfg: &SelectionConfig) -> String {
        format!(
            "{scene}: {} points, mean light Σc {:.4e}; BRDF-oriented cut (δ {}, max {}, split_sin {})\n\
             | choice | mean V | worst 1 % share |\n|---|---:|---:|\n\
             | BL cut | {:.4e} | {:.3} |\n| TL descent | {:.4e} | {:.3} |\n\
             | BL descent | {:.4e} | {:.3} |\n| BL descent, TL near | {:.4e} | {:.3} |\n\
             BL / TL {:.4} (descents {:.4}, {:.4}); cut {:.1} clusters on average, {:.2} % of the cuts full\n",
            self.points,
            self.mean_light,
            cfg.cut.delta,
            cfg.cut.max_size,
            cfg.cut.split_sin,
            self.bl.mean_variance,
            self.bl.worst_1pc_share,
            self.tl.mean_variance,
            self.tl.worst_1pc_share,
            self.bl_descent.mean_variance,
            self.bl_descent.worst_1pc_share,
            self.bl_descent_tl_near.mean_variance,
            self.bl_descent_tl_near.worst_1pc_share,
            self.bl.mean_variance / self.tl.mean_variance,
            self.bl_descent.mean_variance / self.tl.mean_variance,
            self.bl_descent_tl_near.mean_variance / self.tl.mean_variance,
            self.mean_cut,
            100.0 * self.cut_full,
        )
    }

    /// The JSON object of `--json`.
    pub fn json(&self, scene: &str, cfg: &SelectionConfig) -> serde_json::Value {
        json!({
            "scene": scene,
            "points": self.points,
            "seed": cfg.seed,
            "cut": {"delta": cfg.cut.delta, "max_size": cfg.cut.max_size, "split_sin": cfg.cut.split_sin},
            "mean_light": self.mean_light,
            "bl_mean_variance": self.bl.mean_variance,
            "bl_worst_1pc_share": self.bl.worst_1pc_share,
            "tl_mean_variance": self.tl.mean_variance,
            "tl_worst_1pc_share": self.tl.worst_1pc_share,
            "bl_vs_tl": self.bl.mean_variance / self.tl.mean_variance,
            "bl_descent_mean_variance": self.bl_descent.mean_variance,
            "bl_descent_worst_1pc_share": self.bl_descent.worst_1pc_share,
            "bl_descent_vs_tl": self.bl_descent.mean_variance / self.tl.mean_variance,
            "bl_descent_tl_near_mean_variance": self.bl_descent_tl_near.mean_variance,
            "bl_descent_tl_near_worst_1pc_share": self.bl_descent_tl_near.worst_1pc_share,
            "bl_descent_tl_near_vs_tl": self.bl_descent_tl_near.mean_variance / self.tl.mean_variance,
            "mean_cut": self.mean_cut,
            "cut_full": self.cut_full,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variance_is_zero_for_probabilities_proportional_to_contributions() {
        let cs = [(0u32, 1.0f64), (1, 3.0), (2, 4.0)];
        let v = variance(&cs, |l| [0.125f32, 0.375, 0.5][l as usize]);
        assert!(v.abs() < 1e-12, "{v}");
        // Uniform over the three: Σ c²/(1/3) − (Σ c)² = 3 · 26 − 64 = 14.
        let u = variance(&cs, |_| 1.0 / 3.0);
        assert!((u - 14.0).abs() < 1e-5, "{u}");
        // A contributing light that is never chosen makes it infinite.
        assert_eq!(
            variance(&cs, |l| if l == 0 { 0.0 } else { 0.5 }),
            f64::INFINITY
        );
    }

    /// `bl_descent_tl_near`'s scalar twin follows its `eval4` lane by lane, on nodes that
    /// take TL and nodes that take BL alike.
    #[test]
    fn tl_near_lanes_match_their_scalar_twin() {
        let lights = manylights_testkit::lights(2000, 5);
        let tree = LightTree::build(&lights).expect("valid lights");
        let material = manylights::Material::Ggx {
            alpha: 0.3,
            specular: 1.0,
        };
        let (mut near_nodes, mut far_nodes) = (0, 0);
        for sp in manylights_testkit::surface_points(40, 5, material) {
            let imp = TlNear {
                bl: BlImportance::new(&sp).expect("valid point"),
                tl: TlImportance::new(sp.position, sp.normal),
                position: sp.position,
                s2: 0.81,
            };
            for node in tree.nodes() {
                if imp.near(node) {
                    near_nodes += 1;
                } else {
                    far_nodes += 1;
                }
                let w = imp.eval4(node).to_array();
                for (k, &wk) in w.iter().enumerate() {
                    let e = imp.eval_lane(node, k);
                    assert!(
                        (wk - e).abs() <= 1e-4 * e.abs() + 1e-30,
                        "lane {k}: {wk} against {e}"
                    );
                }
            }
        }
        assert!(near_nodes > 0 && far_nodes > 0, "{near_nodes} {far_nodes}");
    }

    #[test]
    fn worst_share_is_the_top_percent() {
        let mut v = vec![1.0; 199];
        v.push(801.0);
        let c = choice(&v);
        assert_eq!(c.mean_variance, 1000.0 / 200.0);
        // The worst 1 % of 200 points: the two largest, 801 + 1.
        assert!((c.worst_1pc_share - 802.0 / 1000.0).abs() < 1e-12);
    }
}
