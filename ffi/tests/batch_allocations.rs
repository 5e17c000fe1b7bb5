//! The batch exports allocate nothing: after a warm-up call, each of
//! `ml_tree_sample_tl_batch`, `ml_tree_pmf_tl_batch`, `ml_tree_sample_bl_batch`,
//! `ml_tree_pmf_bl_batch` and `ml_light_sample_point_batch` makes no heap allocation on the
//! calling thread (a host calls them millions of times). The counting allocator of this test
//! binary counts the allocations of each thread; the batches run on the calling thread.

mod common;
use common::{mixed_light, ok};

use manylights_ffi::*;
use manylights_testkit::SplitMix64 as Rng;
use std::cell::Cell;
use std::ptr;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

/// Counts an allocation (or reallocation) of this thread.
fn count() {
    // A thread being torn down has no counter: its allocations are not this test's.
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

#[global_allocator]
static COUNTING: common::counting::Counting = common::counting::Counting(count);

/// The allocations this thread makes in `f`.
fn allocations(f: impl FnOnce()) -> u64 {
    let before = ALLOCATIONS.with(Cell::get);
    f();
    ALLOCATIONS.with(Cell::get) - before
}

fn v3(x: f32, y: f32, z: f32) -> ml_vec3 {
    ml_vec3 { x, y, z }
}

/// More points than one chunk of the batches holds, so that several chunks run.
const N: usize = 2500;

/// A tree of 500 lights of several kinds, with (`sky`) or without lights at infinity.
fn tree(r: &mut Rng, sky: bool) -> *mut ml_tree {
    let mut ls: Vec<ml_light> = (0..500)
        .map(|i| {
            let p = v3(r.range(-4.0, 4.0), r.range(-4.0, 4.0), r.range(0.5, 4.0));
            let e = ml_rgb {
                r: r.range(0.5, 3.0),
                g: r.range(0.5, 3.0),
                b: r.range(0.5, 3.0),
            };
            mixed_light(i, p, e, r)
        })
        .collect();
    if sky {
        ls.push(
            ml_distant_light {
                kind: ml_light_kind::Distant as u32,
                direction: v3(0.2, 0.1, 1.0),
                angular_radius: 0.0,
                irradiance: ml_rgb {
                    r: 2.0,
                    g: 2.0,
                    b: 2.0,
                },
            }
            .into(),
        );
    }
    let mut t = ptr::null_mut();
    ok(ml_tree_build(
        ls.as_ptr(),
        ls.len(),
        ptr::null(),
        ptr::null(),
        &mut t,
    ));
    t
}

fn tl_points(r: &mut Rng) -> Vec<ml_tl_point> {
    (0..N)
        .map(|_| ml_tl_point {
            position: v3(r.range(-3.0, 3.0), r.range(-3.0, 3.0), 0.0),
            normal: v3(r.range(-0.3, 0.3), r.range(-0.3, 0.3), 1.0),
            ..ml_tl_point::default()
        })
        .collect()
}

fn shading_points(r: &mut Rng) -> Vec<ml_shading_point> {
    (0..N)
        .map(|_| ml_shading_point {
            position: v3(r.range(-3.0, 3.0), r.range(-3.0, 3.0), 0.0),
            normal: v3(r.range(-0.3, 0.3), r.range(-0.3, 0.3), 1.0),
            wo: v3(r.range(-0.8, 0.8), r.range(-0.8, 0.8), 1.0),
            material: ml_material {
                kind: ml_material_kind::Plastic as u32,
                albedo: ml_rgb {
                    r: 0.5,
                    g: 0.4,
                    b: 0.3,
                },
                specular: 0.5,
                alpha: r.range(0.05, 1.0),
            },
        })
        .collect()
}

/// The batch call of `call` (which returns the allocations the call itself made) allocates
/// nothing once warmed up, on trees with and without lights at infinity.
fn no_allocations(name: &str, call: impl Fn(*const ml_tree, &mut Rng) -> u64) {
    for sky in [false, true] {
        let mut r = Rng(44);
        let t = tree(&mut r, sky);
        // The warm-up: whatever the first call sets up once (thread-locals) may allocate.
        call(t, &mut r);
        let n = call(t, &mut r);
        assert_eq!(
            n, 0,
            "{name} (lights at infinity: {sky}): {n} allocations per call"
        );
        ok(ml_tree_free(t));
    }
}

#[test]
fn tl_batches_allocate_nothing() {
    no_allocations("ml_tree_sample_tl_batch", |t, r| {
        let pts = tl_points(r);
        let us: Vec<f32> = (0..N).map(|_| r.f32()).collect();
        let mut out = vec![ml_sampled_light::default(); N];
        allocations(|| {
            ok(ml_tree_sample_tl_batch(
                t,
                pts.as_ptr(),
                us.as_ptr(),
                N,
                out.as_mut_ptr(),
            ));
        })
    });
    no_allocations("ml_tree_pmf_tl_batch", |t, r| {
        let pts = tl_points(r);
        let lights: Vec<u32> = (0..N as u32).map(|j| j % 500).collect();
        let mut out = vec![0.0f32; N];
        allocations(|| {
            ok(ml_tree_pmf_tl_batch(
                t,
                pts.as_ptr(),
                lights.as_ptr(),
                N,
                out.as_mut_ptr(),
            ));
        })
    });
}

#[test]
fn bl_batches_allocate_nothing() {
    no_allocations("ml_tree_sample_bl_batch", |t, r| {
        let pts = shading_points(r);
        let us: Vec<f32> = (0..N).map(|_| r.f32()).collect();
        let mut out = vec![ml_sampled_light::default(); N];
        allocations(|| {
            ok(ml_tree_sample_bl_batch(
                t,
                pts.as_ptr(),
                us.as_ptr(),
                N,
                out.as_mut_ptr(),
            ));
        })
    });
    no_allocations("ml_tree_pmf_bl_batch", |t, r| {
        let pts = shading_points(r);
        let lights: Vec<u32> = (0..N as u32).map(|j| j % 500).collect();
        let mut out = vec![0.0f32; N];
        allocations(|| {
            ok(ml_tree_pmf_bl_batch(
                t,
                pts.as_ptr(),
                lights.as_ptr(),
                N,
                out.as_mut_ptr(),
            ));
        })
    });
}

#[test]
fn light_point_batches_allocate_nothing() {
    no_allocations("ml_light_sample_point_batch", |t, r| {
        let lights: Vec<u32> = (0..N as u32).map(|j| j % 500).collect();
        let xs: Vec<ml_vec3> = (0..N)
            .map(|_| v3(r.range(-3.0, 3.0), r.range(-3.0, 3.0), 0.0))
            .collect();
        let u0s: Vec<f32> = (0..N).map(|_| r.f32()).collect();
        let u1s: Vec<f32> = (0..N).map(|_| r.f32()).collect();
        let mut out = vec![ml_light_point::default(); N];
        allocations(|| {
            ok(ml_light_sample_point_batch(
                t,
                lights.as_ptr(),
                xs.as_ptr(),
                u0s.as_ptr(),
                u1s.as_ptr(),
                N,
                out.as_mut_ptr(),
            ));
        })
    });
}
