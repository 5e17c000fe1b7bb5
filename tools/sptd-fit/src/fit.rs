//! The fit of the SPTD parameters of GGX (docs/formulas.md, section 8, "GGX fit"), written as
//! the generated Rust source `src/importance/sptd/table.rs` of the core.
//!
//! Per table node `(i, j)` — `u = √α = i/63`, `v = 2θo/π = j/63`, clamped as
//! [`manylights::internals::sptd::table_node`] says:
//!
//! 1. `ρ` (directional albedo) and the mean reflected direction, from 256² stratified VNDF
//!    samples (f64).
//! 2. A fixed set of test caps, half with axes uniform on the sphere (as the accuracy report
//!    draws them: the tails, where most clusters are) and half with axes drawn from the BRDF
//!    lobe (where the important clusters are), half-angles log-uniform in `[1e-3, 1.5]` rad,
//!    caps entirely below the horizon rejected; ground truth `∫_C f cos` of each by MIS of
//!    uniform-in-cap and VNDF sampling (16² stratified pairs).
//! 3. The model's SPTD part `S_sptd(C)` (SPTD + Lambert share + masking correction, amplitude
//!    tied to the albedo so the whole hemisphere is exact; `SptdGgx::sptd_integral_cap`, see
//!    the core's `sptd/ggx.rs`: the part the model takes for caps that are not small against
//!    their distance from the pivot) is computed with the core's own f32 code, and the
//!    objective is the mean pseudo-Huber loss (5 % knee) of the log ratio
//!    `ln((S_sptd + ε)/(T + ε))` (T: the truth), `ε = 1e-6 ρ |C|/2π`: relative errors, robust
//!    to the few caps the model cannot follow, which is what ranking clusters needs.
//! 4. Nelder–Mead over `x = (ln(1 − R), Gθ, logit β, ln c_ref)`, minimising the objective
//!    plus a small smoothness term `1e-3 Σ wₖ (xₖ − nₖ)²` towards the already fitted
//!    neighbours `n` at `(i − 1, j)` and `(i, j − 1)` (weights 1, 1, 0.3, 0.3): it only decides
//!    directions in which the objective is flat (`Gθ` when `R ≈ 0`, `c_ref` when no test cap
//!    grazes the horizon), which keeps the table smooth for bilinear filtering. Started from
//!    each neighbour (as stored in f32) and from the data-driven guess `R = 0.5 + 0.49(1 − α)`,
//!    `Gθ` = elevation of the mean reflected direction, `β = 0.02`, `c_ref = 0.2`; the best
//!    result is kept.
//!
//! Everything is seeded from the node's (α, θo); the nodes are fitted anti-diagonal by
//! anti-diagonal, in parallel within one, so the result does not depend on threads.
//! `--check K` re-fits K nodes spread over the table from their committed neighbours and
//! compares them with the committed values (bit-identical on the same platform).

use glam::{DVec3, Vec3};
use manylights::internals::sptd::{self, table, Cap, GgxParams, SptdGgx, TABLE_SIZE};
use manylights_testkit::ggx::{cap_integral, Cap64, Ggx};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::fmt::Write as _;

/// Settings of a fit (recorded in the generated file, and read back by `--check`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FitConfig {
    /// Test caps per node.
    pub caps: usize,
    /// Ground truth of each cap from `truth_grid²` stratified MIS pairs.
    pub truth_grid: usize,
    /// Base seed.
    pub seed: u64,
}

impl Default for FitConfig {
    fn default() -> FitConfig {
        FitConfig {
            caps: 384,
            truth_grid: 16,
            seed: 2019,
        }
    }
}

impl FitConfig {
    /// The settings the committed table was fitted with, read from its `Settings:` line (they
    /// are a comment of the generated file, not constants of the core's API).
    pub fn committed() -> FitConfig {
        FitConfig::from_table_source(COMMITTED_TABLE)
            .expect("the committed table records its settings on a `//! Settings:` line")
    }

    /// The settings a generated table ([`table_source`]) records on its `Settings:` line.
    pub fn from_table_source(src: &str) -> Option<FitConfig> {
        let line = src.lines().find_map(|l| l.strip_prefix("//! Settings: "))?;
        let mut it = line.split(';').next()?.split(", ");
        let caps = it.next()?.strip_suffix(" caps per node")?.parse().ok()?;
        let truth_grid = it.next()?.strip_suffix("² MIS pairs per cap")?;
        let seed = it.next()?.strip_prefix("seed ")?.parse().ok()?;
        Some(FitConfig {
            caps,
            truth_grid: truth_grid.parse().ok()?,
            seed,
        })
    }

    /// The command that regenerates a table with these settings (recorded in the file).
    pub fn command(&self) -> String {
        let mut command = String::from("cargo run --release -p manylights-sptd-fit");
        if self.caps != FitConfig::default().caps {
            command.push_str(&format!(" -- --caps {}", self.caps));
        }
        command
    }
}

/// The source of the committed table, as the core compiles it.
const COMMITTED_TABLE: &str = include_str!("../../../src/importance/sptd/table.rs");

/// Smallest and largest test-cap half-angle (radians).
const SIGMA_RANGE: (f64, f64) = (1e-3, 1.5);
/// Albedo from `ALBEDO_GRID²` stratified VNDF samples.
const ALBEDO_GRID: usize = 256;
/// Knee of the pseudo-Huber loss on log ratios.
const HUBER: f64 = 0.05;
/// Relative floor of the cap-averaged `f cos` (see the module docs).
const FLOOR: f64 = 1e-6;
/// Bounds of `1 − R`.
const GAP_RANGE: (f64, f64) = (1.0 - sptd::MAX_NORM as f64, 1.0);

/// A test cap of one node.
struct TestCap {
    cap: Cap,
    truth: f64,
    eps: f64,
}

/// What one node's fit uses.
struct NodeData {
    alpha: f64,
    theta_o: f64,
    albedo: f64,
    mean_dir: DVec3,
    caps: Vec<TestCap>,
}

/// One fitted node.
#[derive(Clone, Copy, Debug)]
pub struct NodeFit {
    /// Row (α).
    pub i: usize,
    /// Column (θo).
    pub j: usize,
    /// The parameters, as stored.
    pub params: GgxParams,
    /// Final objective.
    pub loss: f64,
    /// Median relative error over the node's test caps (diagnostics).
    pub median_rel_err: f64,
    /// Objective evaluations.
    pub evals: usize,
}

fn node_seed(alpha: f32, theta: f32, seed: u64) -> u64 {
    let x = (u64::from(alpha.to_bits()) << 32) | u64::from(theta.to_bits());
    x.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ seed.rotate_left(17)
}

fn core_cap(axis: DVec3, sigma: f64) -> Cap {
    let a = axis.as_vec3().normalize();
    if sigma <= PI / 2.0 {
        Cap::from_sin(a, sigma.sin() as f32)
    } else {
        Cap::from_sin(-a, (PI - sigma).sin() as f32).complement()
    }
}

fn node_data(i: usize, j: usize, cfg: &FitConfig) -> NodeData {
    let (alpha32, theta32) = sptd::table_node(i, j);
    let (alpha, theta_o) = (f64::from(alpha32), f64::from(theta32));
    let ggx = Ggx::new(alpha);
    let wo = manylights_testkit::ggx::wo_local(theta_o);
    let (albedo, dir) = ggx.albedo(wo, ALBEDO_GRID);
    let mut rng = Pcg64Mcg::seed_from_u64(node_seed(alpha32, theta32, cfg.seed));
    let mut caps = Vec::with_capacity(cfg.caps);
    let (ls0, ls1) = (SIGMA_RANGE.0.ln(), SIGMA_RANGE.1.ln());
    let mut k = 0usize;
    while caps.len() < cfg.caps {
        let sigma = (ls0 + (ls1 - ls0) * rng.random::<f64>()).exp();
        let axis = if k % 2 == 0 {
            let z: f64 = rng.random_range(-1.0..1.0);
            let phi: f64 = rng.random_range(0.0..2.0 * PI);
            let s = (1.0 - z * z).max(0.0).sqrt();
            DVec3::new(s * phi.cos(), s * phi.sin(), z)
        } else {
            let w = ggx.sample_vndf(wo, rng.random(), rng.random());
            if w.z <= 0.0 {
                continue;
            }
            w
        };
        k += 1;
        // Entirely below the horizon: both the truth and the SPTD are exactly 0.
        if axis.z <= -sigma.sin() {
            continue;
        }
        let c64 = Cap64::new(axis, sigma);
        let t = cap_integral(&ggx, wo, &c64, cfg.truth_grid, rng.random());
        let cc = core_cap(axis, sigma);
        caps.push(TestCap {
            cap: cc,
            truth: t.value,
            eps: FLOOR * albedo * c64.area() / (2.0 * PI),
        });
    }
    NodeData {
        alpha,
        theta_o,
        albedo,
        mean_dir: dir,
        caps,
    }
}

/// The parameters from the optimiser's unconstrained coordinates
/// `(ln(1 − R), Gθ, logit β, ln c_ref)`.
fn decode(x: &[f64; 4], albedo: f64) -> GgxParams {
    let gap = x[0].exp().clamp(GAP_RANGE.0, GAP_RANGE.1);
    GgxParams {
        pivot_norm: (1.0 - gap) as f32,
        pivot_elevation: x[1].clamp(-PI / 2.0, PI / 2.0) as f32,
        albedo: albedo as f32,
        lambert_weight: (1.0 / (1.0 + (-x[2]).exp())) as f32,
        masking_cos: x[3].exp().clamp(1e-3, 1.0) as f32,
    }
}

/// The optimiser's coordinates of stored parameters.
fn encode(p: &GgxParams) -> [f64; 4] {
    let gap = (1.0 - f64::from(p.pivot_norm)).clamp(GAP_RANGE.0, GAP_RANGE.1);
    let b = f64::from(p.lambert_weight).clamp(1e-6, 1.0 - 1e-6);
    [
        gap.ln(),
        f64::from(p.pivot_elevation),
        (b / (1.0 - b)).ln(),
        f64::from(p.masking_cos).clamp(1e-3, 1.0).ln(),
    ]
}

fn objective(d: &NodeData, p: &GgxParams) -> f64 {
    let sptd = SptdGgx::with_params(d.alpha as f32, d.theta_o.cos() as f32, *p, Vec3::Z, Vec3::X);
    let mut loss = 0.0;
    for c in &d.caps {
        let s = f64::from(sptd.sptd_integral_cap(&c.cap));
        let lr = ((s + c.eps) / (c.truth + c.eps)).ln();
        loss += (lr * lr + HUBER * HUBER).sqrt() - HUBER;
    }
    loss / d.caps.len() as f64
}

/// Median relative error over the node's caps with meaningful truth (diagnostics).
fn median_err(d: &NodeData, p: &GgxParams) -> f64 {
    let sptd = SptdGgx::with_params(d.alpha as f32, d.theta_o.cos() as f32, *p, Vec3::Z, Vec3::X);
    let mut e: Vec<f64> = d
        .caps
        .iter()
        .filter(|c| c.truth > c.eps)
        .map(|c| (f64::from(sptd.sptd_integral_cap(&c.cap)) - c.truth).abs() / c.truth)
        .collect();
    e.sort_by(f64::total_cmp);
    e.get(e.len() / 2).copied().unwrap_or(0.0)
}

/// Nelder–Mead minimisation (standard coefficients 1, 2, ½, ½). Returns the best point, its
/// value and the number of evaluations.
pub fn nelder_mead<const N: usize>(
    mut f: impl FnMut(&[f64; N]) -> f64,
    x0: [f64; N],
    step: [f64; N],
    tol: f64,
    max_evals: usize,
) -> ([f64; N], f64, usize) {
    let mut pts: Vec<([f64; N], f64)> = Vec::with_capacity(N + 1);
    let mut evals = 0;
    let mut eval = |x: &[f64; N], evals: &mut usize| {
        *evals += 1;
        f(x)
    };
    pts.push((x0, eval(&x0, &mut evals)));
    for k in 0..N {
        let mut x = x0;
        x[k] += step[k];
        let v = eval(&x, &mut evals);
        pts.push((x, v));
    }
    while evals < max_evals {
        pts.sort_by(|a, b| a.1.total_cmp(&b.1));
        let (best, worst) = (pts[0].1, pts[N].1);
        let size = pts[1..]
            .iter()
            .map(|p| {
                (0..N)
                    .map(|k| (p.0[k] - pts[0].0[k]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        if (worst - best).abs() <= tol * (best.abs() + 1e-12) && size < 1e-6 {
            break;
        }
        if size < 1e-9 {
            break;
        }
        let mut centroid = [0.0; N];
        for p in &pts[..N] {
            for (c, x) in centroid.iter_mut().zip(&p.0) {
                *c += x / N as f64;
            }
        }
        let along = |t: f64| {
            let mut x = [0.0; N];
            for k in 0..N {
                x[k] = centroid[k] + t * (pts[N].0[k] - centroid[k]);
            }
            x
        };
        let xr = along(-1.0);
        let fr = eval(&xr, &mut evals);
        if fr < pts[0].1 {
            let xe = along(-2.0);
            let fe = eval(&xe, &mut evals);
            pts[N] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < pts[N - 1].1 {
            pts[N] = (xr, fr);
        } else {
            let (xc, fc) = if fr < pts[N].1 {
                let x = along(-0.5);
                (x, eval(&x, &mut evals))
            } else {
                let x = along(0.5);
                (x, eval(&x, &mut evals))
            };
            if fc < pts[N].1.min(fr) {
                pts[N] = (xc, fc);
            } else {
                let b = pts[0].0;
                for p in pts.iter_mut().skip(1) {
                    for (x, bk) in p.0.iter_mut().zip(&b) {
                        *x = bk + 0.5 * (*x - bk);
                    }
                    p.1 = eval(&p.0, &mut evals);
                }
            }
        }
    }
    pts.sort_by(|a, b| a.1.total_cmp(&b.1));
    (pts[0].0, pts[0].1, evals)
}

/// Weight of the smoothness term and of each coordinate in it (see the module docs).
const SMOOTH: f64 = 1e-3;
const SMOOTH_WEIGHTS: [f64; 4] = [1.0, 1.0, 0.3, 0.3];

fn minimise(d: &NodeData, start: [f64; 4], neighbours: &[[f64; 4]]) -> ([f64; 4], f64, usize) {
    let f = |x: &[f64; 4]| {
        let mut v = objective(d, &decode(x, d.albedo));
        for nb in neighbours {
            for k in 0..4 {
                v += SMOOTH * SMOOTH_WEIGHTS[k] * (x[k] - nb[k]).powi(2);
            }
        }
        v
    };
    let (x, v, n1) = nelder_mead(f, start, [0.25, 0.08, 1.0, 0.5], 1e-7, 1200);
    // One restart at the optimum, the usual guard against a collapsed simplex.
    let (x2, v2, n2) = nelder_mead(f, x, [0.05, 0.02, 0.3, 0.2], 1e-7, 600);
    if v2 < v {
        (x2, v2, n1 + n2)
    } else {
        (x, v, n1 + n2)
    }
}

/// Fits node `(i, j)` given the stored parameters of its already fitted neighbours
/// `(i − 1, j)` and `(i, j − 1)` (those that exist): each is a starting point and a
/// smoothness anchor; the data-driven guess is a further starting point.
pub fn fit_node(i: usize, j: usize, neighbours: &[GgxParams], cfg: &FitConfig) -> NodeFit {
    let d = node_data(i, j, cfg);
    let guess = GgxParams {
        pivot_norm: (0.5 + 0.49 * (1.0 - d.alpha)) as f32,
        pivot_elevation: d.mean_dir.x.atan2(d.mean_dir.z) as f32,
        albedo: d.albedo as f32,
        lambert_weight: 0.02,
        masking_cos: 0.2,
    };
    let anchors: Vec<[f64; 4]> = neighbours.iter().map(encode).collect();
    let mut best = ([0.0; 4], f64::INFINITY, 0);
    let mut evals = 0;
    for a in std::iter::once(&encode(&guess)).chain(&anchors) {
        let r = minimise(&d, *a, &anchors);
        evals += r.2;
        if r.1 < best.1 {
            best = r;
        }
    }
    let params = decode(&best.0, d.albedo);
    NodeFit {
        i,
        j,
        params,
        loss: objective(&d, &params),
        median_rel_err: median_err(&d, &params),
        evals,
    }
}

/// The stored neighbours of `(i, j)` that a fit anchors to, from any table of parameters.
pub fn neighbours_in(i: usize, j: usize, at: impl Fn(usize, usize) -> GgxParams) -> Vec<GgxParams> {
    let mut v = Vec::with_capacity(2);
    if i > 0 {
        v.push(at(i - 1, j));
    }
    if j > 0 {
        v.push(at(i, j - 1));
    }
    v
}

/// Fits the whole table, anti-diagonal by anti-diagonal (`i + j` constant): the nodes of one
/// diagonal run in parallel, each anchored to its fitted neighbours `(i − 1, j)` and
/// `(i, j − 1)`, so the result does not depend on threads. Returns `table[i][j]`.
pub fn fit_table(cfg: &FitConfig, progress: bool) -> Vec<Vec<NodeFit>> {
    let n = TABLE_SIZE;
    let mut t: Vec<Vec<Option<NodeFit>>> = vec![vec![None; n]; n];
    for diag in 0..(2 * n - 1) {
        let nodes: Vec<(usize, usize)> = (0..n)
            .filter(|&i| diag >= i && diag - i < n)
            .map(|i| (i, diag - i))
            .collect();
        let fits: Vec<NodeFit> = nodes
            .par_iter()
            .map(|&(i, j)| {
                let nb = neighbours_in(i, j, |a, b| {
                    t[a][b].expect("fitted on an earlier diagonal").params
                });
                fit_node(i, j, &nb, cfg)
            })
            .collect();
        for f in fits {
            t[f.i][f.j] = Some(f);
        }
        if progress {
            eprintln!("sptd-fit: diagonal {}/{}", diag + 1, 2 * n - 1);
        }
    }
    t.into_iter()
        .map(|row| {
            row.into_iter()
                .map(|f| f.expect("every node is fitted"))
                .collect()
        })
        .collect()
}

fn array(
    out: &mut String,
    name: &str,
    doc: &str,
    t: &[Vec<NodeFit>],
    f: impl Fn(&GgxParams) -> f32,
) {
    let _ = writeln!(out, "/// {doc}");
    let _ = writeln!(out, "#[rustfmt::skip]");
    let _ = writeln!(out, "pub const {name}: [[f32; SIZE]; SIZE] = [");
    for row in t {
        out.push_str("    [");
        for (j, n) in row.iter().enumerate() {
            if j > 0 {
                out.push_str(if j % 8 == 0 { ",\n     " } else { ", " });
            }
            let _ = write!(out, "{:?}", f(&n.params));
        }
        out.push_str("],\n");
    }
    out.push_str("];\n");
}

/// The generated source of the table.
pub fn table_source(t: &[Vec<NodeFit>], cfg: &FitConfig, command: &str) -> String {
    let mut out = String::new();
    let loss: f64 =
        t.iter().flatten().map(|n| n.loss).sum::<f64>() / (TABLE_SIZE * TABLE_SIZE) as f64;
    let _ = write!(
        out,
        "//! SPTD parameters of GGX (height-correlated Smith, no Fresnel): pivot norm `R`, pivot
//! elevation `Gθ`, directional albedo `ρ`, Lambert share `β` and masking cosine `c_ref` per
//! node `[i][j]` (the model is documented in the core's `sptd/ggx.rs`), `u = √α = i/{m}`,
//! `v = 2θo/π = j/{m}` (clamped as `table_node` says).
//!
//! @generated by `sptd-fit` (tools/sptd-fit/src/fit.rs); do not edit by hand.
//! Command: `{command}`
//! Settings: {caps} caps per node, {grid}² MIS pairs per cap, seed {seed}; mean objective
//! {loss:.5}.
//! Re-check a few nodes with `cargo run --release -p manylights-sptd-fit -- --check 8`.

/// Nodes per axis.
pub const SIZE: usize = {size};

",
        m = TABLE_SIZE - 1,
        size = TABLE_SIZE,
        caps = cfg.caps,
        grid = cfg.truth_grid,
        seed = cfg.seed,
    );
    array(&mut out, "PIVOT_NORM", "Pivot norm `R`.", t, |p| {
        p.pivot_norm
    });
    out.push('\n');
    array(
        &mut out,
        "PIVOT_ELEVATION",
        "Pivot elevation `Gθ` (radians; negative leans towards the mirror direction).",
        t,
        |p| p.pivot_elevation,
    );
    out.push('\n');
    array(
        &mut out,
        "ALBEDO",
        "Directional albedo `ρ` (the amplitude follows from it).",
        t,
        |p| p.albedo,
    );
    out.push('\n');
    array(
        &mut out,
        "LAMBERT_WEIGHT",
        "Share `β` of the Lambert lobe.",
        t,
        |p| p.lambert_weight,
    );
    out.push('\n');
    array(
        &mut out,
        "MASKING_COS",
        "`c_ref` of the masking correction.",
        t,
        |p| p.masking_cos,
    );
    out
}

/// The nodes `--check K` re-fits: spread over the table (a low-discrepancy walk).
pub fn check_nodes(k: usize) -> Vec<(usize, usize)> {
    let n = TABLE_SIZE - 1;
    (0..k)
        .map(|m| {
            let i = ((m as f64 + 0.5) / k as f64 * n as f64).round() as usize;
            let j = ((m as f64 * 0.618_033_988_749_895).fract() * n as f64).round() as usize;
            (i.min(n), j.min(n))
        })
        .collect()
}

/// One node of a check.
#[derive(Clone, Copy, Debug)]
pub struct CheckRow {
    /// The re-fit.
    pub fit: NodeFit,
    /// The committed parameters.
    pub committed: GgxParams,
    /// Whether they agree within the tolerances.
    pub ok: bool,
}

/// The committed parameters of node `(i, j)`.
pub fn committed_node(i: usize, j: usize) -> GgxParams {
    GgxParams {
        pivot_norm: table::PIVOT_NORM[i][j],
        pivot_elevation: table::PIVOT_ELEVATION[i][j],
        albedo: table::ALBEDO[i][j],
        lambert_weight: table::LAMBERT_WEIGHT[i][j],
        masking_cos: table::MASKING_COS[i][j],
    }
}

/// Whether a re-fit agrees with the committed values. The fit is deterministic, so the
/// tolerances only absorb differences of floating-point libraries between platforms:
/// 2e-4 in `R`, 2e-3 rad in `Gθ`, 1e-4 relative in `ρ`, 2e-3 in `β` and 2e-3 relative in
/// `c_ref`.
pub fn agrees(a: &GgxParams, b: &GgxParams) -> bool {
    (a.pivot_norm - b.pivot_norm).abs() <= 2e-4
        && (a.pivot_elevation - b.pivot_elevation).abs() <= 2e-3
        && (a.albedo - b.albedo).abs() <= 1e-4 * b.albedo.max(1e-3)
        && (a.lambert_weight - b.lambert_weight).abs() <= 2e-3
        && (a.masking_cos - b.masking_cos).abs() <= 2e-3 * b.masking_cos.max(1e-3)
}

/// Re-fits the nodes of [`check_nodes`] from their committed neighbours and compares.
pub fn check(k: usize) -> Vec<CheckRow> {
    let cfg = FitConfig::committed();
    check_nodes(k)
        .into_par_iter()
        .map(|(i, j)| {
            let fit = fit_node(i, j, &neighbours_in(i, j, committed_node), &cfg);
            let committed = committed_node(i, j);
            let ok = agrees(&fit.params, &committed);
            CheckRow { fit, committed, ok }
        })
        .collect()
}

/// Where the generated table lives in the repository.
pub fn default_table_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../src/importance/sptd/table.rs")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nelder_mead_finds_the_minimum_of_a_bowl() {
        let (x, v, _) = nelder_mead(
            |x: &[f64; 2]| (x[0] - 1.0).powi(2) + 10.0 * (x[1] + 0.5).powi(2),
            [0.0, 0.0],
            [0.3, 0.3],
            1e-12,
            1000,
        );
        assert!((x[0] - 1.0).abs() < 1e-4 && (x[1] + 0.5).abs() < 1e-4 && v < 1e-8);
    }

    /// The generator writes the committed file: everything but the mean objective (which the
    /// table does not store) is reproduced from the committed parameters, and the settings
    /// `--check` reads back are the ones written.
    #[test]
    fn table_source_reproduces_the_committed_table() {
        let cfg = FitConfig::committed();
        let t: Vec<Vec<NodeFit>> = (0..TABLE_SIZE)
            .map(|i| {
                (0..TABLE_SIZE)
                    .map(|j| NodeFit {
                        i,
                        j,
                        params: committed_node(i, j),
                        loss: 0.0,
                        median_rel_err: 0.0,
                        evals: 0,
                    })
                    .collect()
            })
            .collect();
        let src = table_source(&t, &cfg, &cfg.command());
        let is_objective = |l: &str| {
            l.strip_prefix("//! ")
                .and_then(|x| x.strip_suffix('.'))
                .is_some_and(|x| x.parse::<f64>().is_ok())
        };
        let ours: Vec<&str> = src.lines().filter(|l| !is_objective(l)).collect();
        let committed: Vec<&str> = COMMITTED_TABLE
            .lines()
            .filter(|l| !is_objective(l))
            .collect();
        assert!(
            ours == committed,
            "the generator no longer writes the committed table"
        );
        assert_eq!(src.lines().count(), COMMITTED_TABLE.lines().count());
        let other = FitConfig {
            caps: 96,
            truth_grid: 8,
            seed: 7,
        };
        let src = table_source(&t, &other, &other.command());
        assert_eq!(FitConfig::from_table_source(&src), Some(other));
    }

    /// The default output is the file the core compiles.
    #[test]
    fn default_table_path_is_the_committed_table() {
        let on_disk = std::fs::read_to_string(default_table_path()).expect("the table is there");
        assert!(on_disk == COMMITTED_TABLE);
    }

    /// CI's guard on the committed table: two nodes re-fitted here must match it.
    #[test]
    fn committed_table_matches_a_refit_of_two_nodes() {
        for row in check(2) {
            assert!(
                row.ok,
                "node ({}, {}): re-fit {:?} vs committed {:?}",
                row.fit.i, row.fit.j, row.fit.params, row.committed
            );
        }
    }
}
