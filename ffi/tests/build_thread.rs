//! `ml_tree_build_parallel` with `threads = 1` builds on the calling thread: no other thread
//! allocates during the call (the build allocates its tree, so a build handed to a worker
//! thread shows as allocations made off the calling thread), and the tree is `ml_tree_build`'s
//! byte for byte. The counting allocator of this test binary counts the allocations made off
//! the thread that watches; the binary runs without the test harness (`harness = false`), so
//! that no other thread of its own allocates meanwhile.

mod common;
use common::ok;

use manylights_ffi::*;
use manylights_testkit::SplitMix64 as Rng;
use std::cell::Cell;
use std::ptr;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Whether allocations off the watching thread are counted.
static WATCHING: AtomicBool = AtomicBool::new(false);
/// The allocations made off the watching thread while watching.
static ELSEWHERE: AtomicU64 = AtomicU64::new(0);

thread_local! {
    static WATCHER: Cell<bool> = const { Cell::new(false) };
}

fn count() {
    if WATCHING.load(Ordering::SeqCst) && !WATCHER.try_with(Cell::get).unwrap_or(false) {
        ELSEWHERE.fetch_add(1, Ordering::SeqCst);
    }
}

#[global_allocator]
static COUNTING: common::counting::Counting = common::counting::Counting(count);

fn bytes(t: *const ml_tree) -> Vec<u8> {
    let mut n = 0;
    ok(ml_tree_serialized_size(t, &mut n));
    let mut b = vec![0u8; n];
    let mut written = 0;
    ok(ml_tree_serialize(t, b.as_mut_ptr(), n, &mut written));
    b
}

fn main() {
    one_thread_builds_on_the_calling_thread();
    // The harness's closing line, so that CI's summary counts this test too.
    println!("test one_thread_builds_on_the_calling_thread ... ok");
    println!("\ntest result: ok. 1 passed; 0 failed; 0 ignored; 0 measured; 0 filtered out");
}

fn one_thread_builds_on_the_calling_thread() {
    let mut r = Rng(7);
    let lights: Vec<ml_light> = (0..3000)
        .map(|_| {
            ml_point_light {
                kind: ml_light_kind::Point as u32,
                position: ml_vec3 {
                    x: r.range(-10.0, 10.0),
                    y: r.range(-10.0, 10.0),
                    z: r.range(-10.0, 10.0),
                },
                intensity: ml_rgb {
                    r: r.range(0.1, 2.0),
                    g: 1.0,
                    b: 1.0,
                },
            }
            .into()
        })
        .collect();
    let mut serial = ptr::null_mut();
    ok(ml_tree_build(
        lights.as_ptr(),
        lights.len(),
        ptr::null(),
        ptr::null(),
        &mut serial,
    ));
    let mut one = ptr::null_mut();
    WATCHER.with(|w| w.set(true));
    WATCHING.store(true, Ordering::SeqCst);
    let status = ml_tree_build_parallel(
        lights.as_ptr(),
        lights.len(),
        ptr::null(),
        ptr::null(),
        1,
        &mut one,
    );
    WATCHING.store(false, Ordering::SeqCst);
    ok(status);
    let elsewhere = ELSEWHERE.load(Ordering::SeqCst);
    assert_eq!(
        elsewhere, 0,
        "threads = 1: {elsewhere} allocations off the calling thread during the build"
    );
    assert!(bytes(one) == bytes(serial), "not ml_tree_build's tree");
    ok(ml_tree_free(one));
    ok(ml_tree_free(serial));
}
