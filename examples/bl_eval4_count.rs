//! A driver for counting the instructions of one BL `eval4` under callgrind: the random scene of
//! `mlmeasure bench` (100 000 lights, fixed seed), 4096 nodes spread evenly over the tree (root
//! to leaves), each evaluated at 16 shading points (views uniform in the normal's hemisphere),
//! for a GGX, a plastic (both α = 0.2) and (as the yardstick) the TL importance. Every loop is the
//! `#[inline(never)]` function `eval_loop`, so that
//!
//! ```sh
//! cargo build --release --example bl_eval4_count
//! valgrind --tool=callgrind --toggle-collect='*eval_loop*' \
//!     target/release/examples/bl_eval4_count ggx
//! ```
//!
//! counts only the evaluations: the total instructions divided by the `eval4` calls it prints.
//! The first argument picks the importance (`ggx`, `plastic`, `tl`, or `blpass` for what
//! `mlmeasure bench` times for BL: per point the set-up, the cut and the budget of samples,
//! counted with `--toggle-collect='*bl_pass_loop*'`), the second the roughness α (default
//! 0.2, the bench's).

use manylights::tree::Node4;
use manylights::Rgb;
use manylights::{
    BlCutOptions, BlImportance, Importance, LightCut, LightTree, Material, ShadingPoint,
    TlImportance,
};
use manylights_testkit as random_scene;
use std::hint::black_box;

const NODES: usize = 4096;
const POINTS: usize = 16;

#[inline(never)]
fn eval_loop<I: Importance>(imps: &[I], nodes: &[Node4]) -> f32 {
    let mut acc = manylights::importance::f32x4::ZERO;
    for imp in imps {
        for node in nodes {
            acc += black_box(imp).eval4(black_box(node));
        }
    }
    acc.reduce_add()
}

/// What `mlmeasure bench` times for BL: per shading point the set-up, the cut, then the budget
/// of samples drawn from it. Returns the number of samples.
#[inline(never)]
fn bl_pass_loop(tree: &LightTree, sps: &[ShadingPoint], us: &[f32]) -> (usize, f64) {
    let opts = BlCutOptions::default();
    let mut acc = 0.0f64;
    let mut n_samples = 0;
    for (sp, &u) in sps.iter().zip(us) {
        let imp = BlImportance::new(black_box(sp)).unwrap();
        let cut = LightCut::build_bl(tree, &imp, &opts);
        let n = manylights::internals::mis::sample_budget(
            cut.max_score(),
            manylights::internals::mis::N_MAX,
        );
        for j in 0..n {
            let uj = (u + j as f32 * 0.618_034).fract();
            if let Some(s) = cut.sample(tree, &imp, black_box(uj)) {
                acc += f64::from(s.pmf);
                n_samples += 1;
            }
        }
    }
    (n_samples, acc)
}

fn main() {
    let which = std::env::args().nth(1).unwrap_or_else(|| "ggx".into());
    let alpha: f32 = std::env::args()
        .nth(2)
        .map_or(0.2, |a| a.parse().expect("α is a number"));
    let lights = random_scene::lights(100_000, 11);
    let tree = LightTree::build(&lights).unwrap();
    let all = tree.nodes();
    let nodes: Vec<Node4> = (0..NODES).map(|i| all[i * all.len() / NODES]).collect();
    let material = match which.as_str() {
        "plastic" => Material::Plastic {
            albedo: Rgb::grey(0.5),
            specular: 0.5,
            alpha,
        },
        _ => Material::Ggx {
            alpha,
            specular: 1.0,
        },
    };
    if which == "blpass" {
        let sps = random_scene::surface_points(1024, 11, material);
        let us = random_scene::uniforms(1024, 11);
        let (n, acc) = bl_pass_loop(&tree, &sps, &us);
        println!("blpass: 1024 points, {n} samples, sum {acc:e}");
        return;
    }
    let sum = if which == "tl" {
        let tl: Vec<TlImportance> = random_scene::shading_points(POINTS, 11)
            .iter()
            .map(|p| TlImportance::new(p.position, p.normal))
            .collect();
        eval_loop(&tl, &nodes)
    } else {
        let bl: Vec<BlImportance> = random_scene::surface_points(POINTS, 11, material)
            .iter()
            .map(|sp| BlImportance::new(sp).unwrap())
            .collect();
        eval_loop(&bl, &nodes)
    };
    println!("{which}: {} eval4 calls, sum {sum:e}", NODES * POINTS);
}
