//! `mlmeasure selection`: how well the light choice of the BRDF-oriented cut (BL) and of the
//! tree's classic descent (TL) follows the lights' contributions at a scene's shading points,
//! without the noise of rendering, and how far each is from the best choice that ignores
//! visibility and from the best choice that knows it.
//!
//! At `points` shading points seen through jittered pixel positions (the primary hits of the
//! jittered protocol, [`primary_at`]), each light's terms ([`light_terms`]) are computed from
//! four stratified points on it ([`sample_point`]), each giving `Y_k = f L cos θ / pdf`: its
//! shadowed contribution `c_l` (the mean of `Y_k · visibility_k`, a shadow ray through the
//! scene for each point), its unshadowed contribution `u_l` (the mean of `Y_k`, no shadow
//! rays) and `m_l`, the mean of `(Y_k · visibility_k)²` (the second moment of the one-light
//! estimate given light l). Each light's probability `p_l` is queried from the technique at
//! the point, as the estimators draw it: [`CutSampler`] (the BRDF-oriented cut built with the
//! given options; `Params::bl_cut` in the CLI, the cut the default `bl-mis` draws its light
//! samples from) and [`TreeSampler`] (the TL descent), lights at infinity chosen at the root
//! by each. Distant lights are measured as the other lights (their `c_l` from the same point
//! sampling); an environment light, whose radiance is the host's, is left out. The variance
//! of the light choice is
//!
//! ```text
//! V  = Σ_l c_l² / p_l − (Σ_l c_l)²
//! V1 = Σ_l m_l  / p_l − (Σ_l c_l)²
//! ```
//!
//! `V` is the variance of `c_L / p_L` for the light L drawn with probabilities p: the part of a
//! one-light-sample estimate's variance that comes from which light it takes. `V1` is the
//! variance of the one-sample estimate itself, one point on the drawn light with its shadow
//! ray: it adds the variance within each light (`V1 ≥ V`). A light with `c_l > 0` and
//! `p_l = 0` makes both infinite (conservativeness rules that out; the report counts such
//! points). Their means over the points are those parts of the image's mean squared error per
//! estimate. A few points where a light carrying most of the light gets a small probability
//! dominate them: the report gives the share of the mean `V` from the worst 1 % of the points,
//! the mean cut size and how many cuts ran out of room (reached `max_size`).
//!
//! Two floors are measured at the same points ([`unshadowed_floor`], [`shadowed_floor`]):
//! `p_l ∝ u_l`, each light's exact unshadowed contribution, the best any choice blind to
//! visibility can do; and `p_l ∝ c_l`, its shadowed contribution, whose `V` is 0 by
//! construction and whose `V1` is the variance left within the lights. The report gives the
//! default's (the BL cut's) `V` and `V1` over the unshadowed floor's (what a better importance
//! could still win) and the unshadowed floor's `V1` over the shadowed floor's (what learning
//! visibility can win).
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

/// The light choice's variance of one technique (or floor) over the points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Choice {
    /// Mean over the points of `V` (infinite if it is at some point).
    pub mean_variance: f64,
    /// Mean over the points of the one-sample variance `V1` (infinite where `V` is).
    pub mean_variance_one_sample: f64,
    /// Share of `Σ V` from the 1 % of the points with the largest `V` (1 when `Σ V` is
    /// infinite).
    pub worst_1pc_share: f64,
    /// Points where `V` is infinite: a light with `c_l > 0` has `p_l = 0`.
    pub infinite_points: usize,
}

/// The report.
#[derive(Clone, Debug, PartialEq)]
pub struct SelectionReport {
    /// Points with a primary hit and some light.
    pub points: usize,
    /// Mean over the points of `Σ_l c_l`.
    pub mean_light: f64,
    /// Mean over the points of `Σ_l u_l` (the unshadowed contributions).
    pub mean_unshadowed_light: f64,
    /// The BRDF-oriented cut.
    pub bl: Choice,
    /// The TL descent.
    pub tl: Choice,
    /// One descent with the BL importance at every node.
    pub bl_descent: Choice,
    /// One descent with the TL importance at the nodes with a wide child's cap, BL elsewhere.
    pub bl_descent_tl_near: Choice,
    /// The unshadowed floor: `p_l ∝ u_l`.
    pub unshadowed_floor: Choice,
    /// The shadowed floor: `p_l ∝ c_l` (its `V` is 0).
    pub shadowed_floor: Choice,
    /// Mean number of clusters of the cut.
    pub mean_cut: f64,
    /// Share of the points whose cut reached `max_size`.
    pub cut_full: f64,
}

/// One light's terms at a shading point, from four stratified points on it (`Y_k = f L cos θ /
/// pdf`, each with a shadow ray for `c` and `m`, without for `u`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightTerms {
    /// The light's index in the scene's light set.
    pub light: u32,
    /// Its shadowed contribution `c_l`: the mean of the four `Y_k · visibility_k`.
    pub c: f64,
    /// Its unshadowed contribution `u_l`: the mean of the four `Y_k`.
    pub u: f64,
    /// The second moment `m_l` of the one-light estimate: the mean of the four
    /// `(Y_k · visibility_k)²`.
    pub m: f64,
}

/// The terms of every light with `u_l > 0` at `sp` (`c_l ≤ u_l`, and `m_l > 0` exactly when
/// `c_l > 0`); an environment light is left out.
#[must_use]
pub fn light_terms(scene: &RenderScene, sp: &ShadingPoint) -> Vec<LightTerms> {
    let Some(frame) = Frame::from_normal(sp.normal) else {
        return Vec::new();
    };
    let wo = frame.to_local(sp.wo.normalize());
    let mut out = Vec::new();
    for (l, light) in scene.lights.lights().iter().enumerate() {
        if matches!(light, Light::Environment { .. }) {
            continue;
        }
        let (mut sum, mut unshadowed, mut square) = (0.0f64, 0.0f64, 0.0f64);
        for u in [[0.25f32, 0.25f32], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]] {
            let Some(p) = sample_point(light, sp.position, u) else {
                continue;
            };
            let wi = frame.to_local(p.direction);
            if wi.z <= 0.0 || p.radiance.is_black() {
                continue;
            }
            let g = f64::from(sp.material.eval(wo, wi) * wi.z) * f64::from(p.radiance.luminance());
            if g > 0.0 {
                let y = g / f64::from(p.pdf);
                unshadowed += y;
                if !manylights::Occluder::occluded(
                    &scene.geometry,
                    sp.position,
                    p.direction,
                    p.distance,
                ) {
                    sum += y;
                    square += y * y;
                }
            }
        }
        if unshadowed > 0.0 {
            out.push(LightTerms {
                light: l as u32,
                c: sum / 4.0,
                u: unshadowed / 4.0,
                m: square / 4.0,
            });
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

/// The selection variance `V = Σ c_l² / p_l − (Σ c_l)²` and the one-sample variance
/// `V1 = Σ m_l / p_l − (Σ c_l)²` of the light choice with probabilities `pmf` (both infinite
/// when a light with `c_l > 0` has `p_l = 0`).
#[must_use]
pub fn variances(ts: &[LightTerms], pmf: impl Fn(&LightTerms) -> f64) -> [f64; 2] {
    let total: f64 = ts.iter().map(|t| t.c).sum();
    let (mut second, mut second_one) = (0.0f64, 0.0f64);
    for t in ts.iter().filter(|t| t.c > 0.0) {
        let p = pmf(t);
        if p > 0.0 {
            second += t.c * t.c / p;
            second_one += t.m / p;
        } else {
            return [f64::INFINITY; 2];
        }
    }
    [second - total * total, second_one - total * total]
}

/// [`variances`] of the unshadowed floor: `p_l = u_l / Σ u` (the best a choice blind to
/// visibility can do).
#[must_use]
pub fn unshadowed_floor(ts: &[LightTerms]) -> [f64; 2] {
    let total: f64 = ts.iter().map(|t| t.u).sum();
    variances(ts, |t| t.u / total)
}

/// [`variances`] of the shadowed floor, `p_l = c_l / Σ c`: its `V` is 0 (`Σ c_l · Σ c − (Σ c)²`,
/// given as 0 rather than as the rounding of that difference); its `V1` is the variance within
/// the lights alone.
#[must_use]
pub fn shadowed_floor(ts: &[LightTerms]) -> [f64; 2] {
    let total: f64 = ts.iter().map(|t| t.c).sum();
    [0.0, variances(ts, |t| t.c / total)[1]]
}

/// The summary of per-point `V` (`v`) and `V1` (`v1`).
fn choice(v: &[f64], v1: &[f64]) -> Choice {
    let mut sorted = v.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    let sum: f64 = sorted.iter().sum();
    let worst = sorted[..sorted.len().div_ceil(100)].iter().sum::<f64>();
    let n = v.len().max(1) as f64;
    Choice {
        mean_variance: sum / n,
        mean_variance_one_sample: v1.iter().sum::<f64>() / n,
        worst_1pc_share: if sum == f64::INFINITY {
            1.0
        } else if sum > 0.0 {
            worst / sum
        } else {
            0.0
        },
        infinite_points: v.iter().filter(|x| x.is_infinite()).count(),
    }
}

/// `a / b` where both are finite and `b > 0`; infinite where `a` is infinite and `b` finite;
/// NaN otherwise (`null` in JSON).
fn ratio(a: f64, b: f64) -> f64 {
    if b.is_finite() && b > 0.0 && !a.is_nan() {
        a / b
    } else {
        f64::NAN
    }
}

/// A number of the text table: `inf` when infinite, `–` when undefined.
fn fmt_num(x: f64, digits: usize) -> String {
    if x.is_nan() {
        "–".into()
    } else if x.is_infinite() {
        "inf".into()
    } else {
        format!("{x:.digits$e}")
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
    // Per point: Σ c, Σ u, [V, V1] of each choice, the cut's size and whether it is full.
    type Row = (f64, f64, [[f64; 2]; 6], usize, bool);
    let rows: Vec<Row> = pts
        .par_iter()
        .filter_map(|sp| {
            let ts = light_terms(scene, sp);
            let total: f64 = ts.iter().map(|t| t.c).sum();
            if total <= 0.0 {
                return None;
            }
            let unshadowed: f64 = ts.iter().map(|t| t.u).sum();
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
                variances(&ts, |t| f64::from(bl.pmf(t.light))),
                variances(&ts, |t| f64::from(tl.pmf(t.light))),
                variances(&ts, |t| f64::from(tree.pmf(&imp, t.light))),
                variances(&ts, |t| f64::from(tree.pmf(&near, t.light))),
                unshadowed_floor(&ts),
                shadowed_floor(&ts),
            ];
            let n = bl.cut().len();
            let full = bl.cut().tree_clusters().len()
                >= cfg.cut.max_size.clamp(4, manylights::cut::MAX_CUT_SIZE);
            Some((total, unshadowed, v, n, full))
        })
        .collect();
    let n = rows.len().max(1) as f64;
    let of = |i: usize| {
        let v = |k: usize| rows.iter().map(|r| r.2[i][k]).collect::<Vec<f64>>();
        choice(&v(0), &v(1))
    };
    SelectionReport {
        points: rows.len(),
        mean_light: rows.iter().map(|r| r.0).sum::<f64>() / n,
        mean_unshadowed_light: rows.iter().map(|r| r.1).sum::<f64>() / n,
        bl: of(0),
        tl: of(1),
        bl_descent: of(2),
        bl_descent_tl_near: of(3),
        unshadowed_floor: of(4),
        shadowed_floor: of(5),
        mean_cut: rows.iter().map(|r| r.3 as f64).sum::<f64>() / n,
        cut_full: rows.iter().filter(|r| r.4).count() as f64 / n,
    }
}

impl SelectionReport {
    /// The choices of the table and the JSON: their names in the table and key prefixes.
    fn choices(&self) -> [(&'static str, &'static str, &Choice); 6] {
        [
            ("BL cut (default)", "bl", &self.bl),
            ("TL descent", "tl", &self.tl),
            ("BL descent", "bl_descent", &self.bl_descent),
            (
                "BL descent, TL near",
                "bl_descent_tl_near",
                &self.bl_descent_tl_near,
            ),
            (
                "unshadowed floor, p ∝ u",
                "unshadowed_floor",
                &self.unshadowed_floor,
            ),
            (
                "shadowed floor, p ∝ c",
                "shadowed_floor",
                &self.shadowed_floor,
            ),
        ]
    }

    /// The default's (the BL cut's) `V` and `V1` over the unshadowed floor's: what a better
    /// importance could still win.
    #[must_use]
    pub fn default_vs_unshadowed_floor(&self) -> [f64; 2] {
        [
            ratio(self.bl.mean_variance, self.unshadowed_floor.mean_variance),
            ratio(
                self.bl.mean_variance_one_sample,
                self.unshadowed_floor.mean_variance_one_sample,
            ),
        ]
    }

    /// The unshadowed floor's `V1` over the shadowed floor's: what learning visibility can win.
    #[must_use]
    pub fn unshadowed_vs_shadowed_floor(&self) -> f64 {
        ratio(
            self.unshadowed_floor.mean_variance_one_sample,
            self.shadowed_floor.mean_variance_one_sample,
        )
    }

    /// The table printed by `mlmeasure selection`.
    pub fn table(&self, scene: &str, cfg: &SelectionConfig) -> String {
        let mut s = format!(
            "{scene}: {} points, mean light Σc {:.4e} (unshadowed Σu {:.4e}); BRDF-oriented cut (δ {}, max {}, split_sin {})\n\
             | choice | mean V | mean V1 | worst 1 % share of V | points with V = inf |\n|---|---:|---:|---:|---:|\n",
            self.points,
            self.mean_light,
            self.mean_unshadowed_light,
            cfg.cut.delta,
            cfg.cut.max_size,
            cfg.cut.split_sin,
        );
        for (name, _, c) in self.choices() {
            s.push_str(&format!(
                "| {name} | {} | {} | {:.3} | {} |\n",
                fmt_num(c.mean_variance, 4),
                fmt_num(c.mean_variance_one_sample, 4),
                c.worst_1pc_share,
                c.infinite_points,
            ));
        }
        let [dv, dv1] = self.default_vs_unshadowed_floor();
        s.push_str(&format!(
            "BL / TL {:.4} (descents {:.4}, {:.4}); cut {:.1} clusters on average, {:.2} % of the cuts full\n\
             default / unshadowed floor: V {:.3}, V1 {:.3} (what a better importance could still win); \
             unshadowed / shadowed floor: V1 {:.3} (what learning visibility can win)\n",
            self.bl.mean_variance / self.tl.mean_variance,
            self.bl_descent.mean_variance / self.tl.mean_variance,
            self.bl_descent_tl_near.mean_variance / self.tl.mean_variance,
            self.mean_cut,
            100.0 * self.cut_full,
            dv,
            dv1,
            self.unshadowed_vs_shadowed_floor(),
        ));
        s
    }

    /// The JSON object of `--json` (a number that is not finite is `null`: an infinite mean
    /// has `*_infinite_points` above 0).
    pub fn json(&self, scene: &str, cfg: &SelectionConfig) -> serde_json::Value {
        let mut o = json!({
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
        });
        let [dv, dv1] = self.default_vs_unshadowed_floor();
        let m = o.as_object_mut().expect("an object");
        m.insert(
            "mean_unshadowed_light".into(),
            json!(self.mean_unshadowed_light),
        );
        for (_, key, c) in self.choices() {
            m.insert(format!("{key}_mean_variance"), json!(c.mean_variance));
            m.insert(
                format!("{key}_mean_variance_one_sample"),
                json!(c.mean_variance_one_sample),
            );
            m.insert(format!("{key}_worst_1pc_share"), json!(c.worst_1pc_share));
            m.insert(format!("{key}_infinite_points"), json!(c.infinite_points));
        }
        m.insert("bl_vs_unshadowed_floor".into(), json!(dv));
        m.insert("bl_vs_unshadowed_floor_one_sample".into(), json!(dv1));
        m.insert(
            "unshadowed_vs_shadowed_floor_one_sample".into(),
            json!(self.unshadowed_vs_shadowed_floor()),
        );
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Terms with `m = c²` (each light's four points give the same value), `u = 2c` for light
    /// 0 and `u = c` otherwise, plus a light hidden at every point (`c = 0`, `u = 2`).
    fn terms() -> Vec<LightTerms> {
        let t = |light, c: f64, u| LightTerms {
            light,
            c,
            u,
            m: c * c,
        };
        vec![
            t(0, 1.0, 2.0),
            t(1, 3.0, 3.0),
            t(2, 4.0, 4.0),
            t(3, 0.0, 2.0),
        ]
    }

    #[test]
    fn variance_is_zero_for_probabilities_proportional_to_contributions() {
        let ts = terms();
        let [v, v1] = variances(&ts, |t| {
            f64::from([0.125f32, 0.375, 0.5, 0.0][t.light as usize])
        });
        assert!(v.abs() < 1e-12 && v1.abs() < 1e-12, "{v} {v1}");
        // Uniform over the first three: Σ c²/(1/3) − (Σ c)² = 3 · 26 − 64 = 14.
        let [u, u1] = variances(&ts, |_| 1.0 / 3.0);
        assert!(
            (u - 14.0).abs() < 1e-12 && (u1 - 14.0).abs() < 1e-12,
            "{u} {u1}"
        );
        // A contributing light that is never chosen makes both infinite.
        assert_eq!(
            variances(&ts, |t| if t.light == 0 { 0.0 } else { 0.5 }),
            [f64::INFINITY; 2]
        );
        // The floors: p ∝ c gives 0; p ∝ u (Σ u = 11) gives Σ c² · 11 / u − 64
        // = 11 · (1/2 + 3 + 4) − 64 = 18.5.
        let [s, s1] = shadowed_floor(&ts);
        assert!(s.abs() < 1e-12 && s1.abs() < 1e-12, "{s} {s1}");
        let [f, f1] = unshadowed_floor(&ts);
        assert!(
            (f - 18.5).abs() < 1e-12 && (f1 - 18.5).abs() < 1e-12,
            "{f} {f1}"
        );
        // The second moment within a light adds to V1 alone: m_0 = 2 (c_0 = 1) adds
        // (2 − 1) / p_0 to it.
        let mut spread = ts.clone();
        spread[0].m = 2.0;
        let [g, g1] = unshadowed_floor(&spread);
        assert_eq!(g, f);
        assert!((g1 - (f1 + 11.0 / 2.0)).abs() < 1e-12, "{g1}");
        let [h, h1] = shadowed_floor(&spread);
        assert!(h.abs() < 1e-12 && (h1 - 8.0).abs() < 1e-12, "{h} {h1}");
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

    /// A point where `V` is infinite makes the mean infinite, is counted, and its share is 1.
    #[test]
    fn an_infinite_point_is_reported() {
        let mut v = vec![1.0; 99];
        v.push(f64::INFINITY);
        let c = choice(&v, &v);
        assert_eq!(c.mean_variance, f64::INFINITY);
        assert_eq!(c.mean_variance_one_sample, f64::INFINITY);
        assert_eq!((c.infinite_points, c.worst_1pc_share), (1, 1.0));
        assert_eq!(fmt_num(c.mean_variance, 4), "inf");
        assert!(ratio(c.mean_variance, 2.0).is_infinite() && ratio(1.0, 0.0).is_nan());
    }

    #[test]
    fn worst_share_is_the_top_percent() {
        let mut v = vec![1.0; 199];
        v.push(801.0);
        let c = choice(&v, &v);
        assert_eq!(c.mean_variance, 1000.0 / 200.0);
        assert_eq!(c.infinite_points, 0);
        // The worst 1 % of 200 points: the two largest, 801 + 1.
        assert!((c.worst_1pc_share - 802.0 / 1000.0).abs() < 1e-12);
    }
}
