//! Importance evaluation per `Node4`: the four children of a node at once in f32x4 lanes
//! (`Importance::eval4`, what the descents call) against the scalar twin, one slot at a time
//! from its decoded bounds (`Importance::eval_slot(&node.bounds(k))` for each filled slot), for
//! the TL and the BL importance over the same nodes and shading points.
//! Scene: the random scene of `mlmeasure bench` (fixed seed); an element is one node evaluated
//! at one shading point.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use manylights::tree::{Child, Node4};
use manylights::Rgb;
use manylights::{BlImportance, Importance, LightTree, Material, TlImportance};
use manylights_testkit as random_scene;
use std::hint::black_box;

/// Nodes evaluated, spread evenly over the tree (root to leaves).
const NODES: usize = 4096;
/// Shading points each node is evaluated at.
const POINTS: usize = 8;

/// Scalar evaluation of a node's filled slots.
#[inline]
fn scalar<I: Importance>(imp: &I, node: &Node4) -> f32 {
    let mut sum = 0.0f32;
    for k in 0..4 {
        if node.child(k) != Child::Empty {
            sum += imp.eval_slot(&node.bounds(k));
        }
    }
    sum
}

fn bench_pair<I: Importance>(c: &mut Criterion, name: &str, imps: &[I], nodes: &[Node4]) {
    let mut group = c.benchmark_group("importance");
    group.throughput(Throughput::Elements((imps.len() * nodes.len()) as u64));
    group.bench_function(format!("{name} scalar"), |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for imp in imps {
                for node in nodes {
                    acc += scalar(black_box(imp), black_box(node));
                }
            }
            acc
        })
    });
    group.bench_function(format!("{name} 4-wide"), |b| {
        b.iter(|| {
            let mut acc = manylights::importance::f32x4::ZERO;
            for imp in imps {
                for node in nodes {
                    acc += black_box(imp).eval4(black_box(node));
                }
            }
            acc.reduce_add()
        })
    });
    group.finish();
}

fn importance(c: &mut Criterion) {
    let lights = random_scene::lights(100_000, 11);
    let tree = LightTree::build(&lights).unwrap();
    let all = tree.nodes();
    let nodes: Vec<Node4> = (0..NODES).map(|i| all[i * all.len() / NODES]).collect();
    let tl: Vec<TlImportance> = random_scene::shading_points(POINTS, 11)
        .iter()
        .map(|p| TlImportance::new(p.position, p.normal))
        .collect();
    let plastic = Material::Plastic {
        albedo: Rgb::grey(0.5),
        specular: 0.5,
        alpha: 0.2,
    };
    let bl: Vec<BlImportance> = random_scene::surface_points(POINTS, 11, plastic)
        .iter()
        .map(|sp| BlImportance::new(sp).unwrap())
        .collect();
    bench_pair(c, "TL", &tl, &nodes);
    bench_pair(c, "BL plastic 0.2", &bl, &nodes);
}

criterion_group!(benches, importance);
criterion_main!(benches);
