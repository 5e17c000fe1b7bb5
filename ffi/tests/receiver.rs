//! `ml_tl_point.receiver`: the C point's kind of receiver is the core's `Receiver`, in every
//! call that takes an `ml_tl_point` (TL sample and pmf, their batches, the split cut), and a
//! value that is no `ml_receiver` is an error naming `point.receiver`.

mod common;
use common::{message, ok};

use glam::Vec3;
use manylights::importance::Receiver;
use manylights::{Light, LightTree, Rgb, TlImportance};
use manylights_ffi::*;
use manylights_testkit::SplitMix64 as Rng;
use std::ptr;

fn v3(x: f32, y: f32, z: f32) -> ml_vec3 {
    ml_vec3 { x, y, z }
}

/// The core's receiver of each `ml_receiver`.
const RECEIVERS: [(ml_receiver, Receiver); 3] = [
    (ml_receiver::Reflective, Receiver::Reflective),
    (ml_receiver::Transmissive, Receiver::Transmissive),
    (ml_receiver::Omnidirectional, Receiver::Omnidirectional),
];

fn build(lights: &[Light]) -> *mut ml_tree {
    let descs: Vec<ml_light> = lights.iter().map(ml_light::from).collect();
    let mut t = ptr::null_mut();
    ok(ml_tree_build(
        descs.as_ptr(),
        descs.len(),
        ptr::null(),
        ptr::null(),
        &mut t,
    ));
    t
}

#[test]
fn a_transmissive_point_gets_the_light_below_it_and_a_reflective_one_does_not() {
    // One point light below a surface facing up.
    let lights = [Light::Point {
        position: Vec3::new(0.2, 0.1, -1.0),
        intensity: Rgb::grey(1.0),
    }];
    let tree = build(&lights);
    let mut p = ml_tl_point {
        position: v3(0.0, 0.0, 0.0),
        normal: v3(0.0, 0.0, 1.0),
        receiver: ml_receiver::Reflective as u32,
    };
    let mut s = ml_sampled_light::default();
    ok(ml_tree_sample_tl(tree, &p, 0.5, &mut s));
    assert_eq!(s.light, ML_NO_LIGHT, "a reflective point facing away");
    let mut q = -1.0;
    ok(ml_tree_pmf_tl(tree, &p, 0, &mut q));
    assert_eq!(q, 0.0);
    for r in [ml_receiver::Transmissive, ml_receiver::Omnidirectional] {
        p.receiver = r as u32;
        ok(ml_tree_sample_tl(tree, &p, 0.5, &mut s));
        assert_eq!((s.light, s.pmf), (0, 1.0), "{r:?}");
        ok(ml_tree_pmf_tl(tree, &p, 0, &mut q));
        assert_eq!(q, 1.0, "{r:?}");
    }
    // The split cut holds it too.
    let mut cut = ptr::null_mut();
    ok(ml_cut_create(&mut cut));
    p.receiver = ml_receiver::Transmissive as u32;
    ok(ml_cut_build_split(cut, tree, &p, ptr::null()));
    let mut size = 0;
    ok(ml_cut_size(cut, &mut size));
    assert_eq!(size, 1);
    p.receiver = ml_receiver::Reflective as u32;
    ok(ml_cut_build_split(cut, tree, &p, ptr::null()));
    ok(ml_cut_size(cut, &mut size));
    assert_eq!(size, 0);
    ok(ml_cut_free(cut));
    ok(ml_tree_free(tree));
}

#[test]
fn tl_samples_pmfs_and_cuts_are_the_cores_with_the_same_receiver_bit_for_bit() {
    let mut r = Rng(11);
    let lights: Vec<Light> = (0..400)
        .map(|i| {
            let position = Vec3::new(r.range(-3.0, 3.0), r.range(-3.0, 3.0), r.range(-3.0, 3.0));
            let power = Rgb::grey(r.range(0.2, 2.0));
            if i % 2 == 0 {
                Light::Point {
                    position,
                    intensity: power,
                }
            } else {
                Light::Sphere {
                    center: position,
                    radius: r.range(0.05, 0.3),
                    radiance: power,
                }
            }
        })
        .collect();
    let core = LightTree::build(&lights).unwrap();
    let tree = build(&lights);
    let n = 600;
    let mut points = Vec::with_capacity(n);
    let mut us = Vec::with_capacity(n);
    let mut which = Vec::with_capacity(n);
    for j in 0..n {
        points.push(ml_tl_point {
            position: v3(r.range(-3.0, 3.0), r.range(-3.0, 3.0), r.range(-3.0, 3.0)),
            normal: v3(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0)),
            receiver: RECEIVERS[j % 3].0 as u32,
        });
        us.push(r.f32());
        which.push((r.next_u64() % 400) as u32);
    }
    let mut samples = vec![ml_sampled_light::default(); n];
    ok(ml_tree_sample_tl_batch(
        tree,
        points.as_ptr(),
        us.as_ptr(),
        n,
        samples.as_mut_ptr(),
    ));
    let mut pmfs = vec![0.0f32; n];
    ok(ml_tree_pmf_tl_batch(
        tree,
        points.as_ptr(),
        which.as_ptr(),
        n,
        pmfs.as_mut_ptr(),
    ));
    let mut cut = ptr::null_mut();
    ok(ml_cut_create(&mut cut));
    let mut differ = 0;
    for (j, p) in points.iter().enumerate() {
        let receiver = RECEIVERS[j % 3].1;
        let imp = TlImportance::with_receiver(p.position.into(), p.normal.into(), receiver);
        let (l, pmf) = core
            .sample(&imp, us[j])
            .map_or((ML_NO_LIGHT, 0), |s| (s.light, s.pmf.to_bits()));
        let mut s = ml_sampled_light::default();
        ok(ml_tree_sample_tl(tree, p, us[j], &mut s));
        assert_eq!(
            (s.light, s.pmf.to_bits()),
            (l, pmf),
            "sample at points[{j}]"
        );
        assert_eq!(samples[j], s, "batch sample at points[{j}]");
        let want = core.pmf(&imp, which[j]).to_bits();
        let mut q = -1.0;
        ok(ml_tree_pmf_tl(tree, p, which[j], &mut q));
        assert_eq!(q.to_bits(), want, "pmf at points[{j}]");
        assert_eq!(pmfs[j].to_bits(), want, "batch pmf at points[{j}]");
        let reflective = TlImportance::new(p.position.into(), p.normal.into());
        if core.pmf(&reflective, which[j]).to_bits() != want {
            differ += 1;
        }
        // The split cut: the core's cut at the same importance, cluster for cluster.
        ok(ml_cut_build_split(cut, tree, p, ptr::null()));
        let want =
            manylights::LightCut::build_split(&core, &imp, &manylights::SplitCutOptions::default());
        let mut size = 0;
        ok(ml_cut_size(cut, &mut size));
        assert_eq!(size, want.len(), "split cut at points[{j}]");
    }
    // The receivers changed the answers (the transmissive and omnidirectional thirds).
    assert!(
        differ > n / 4,
        "only {differ} pmfs differ from a reflective point's"
    );
    ok(ml_cut_free(cut));
    ok(ml_tree_free(tree));
}

#[test]
fn a_value_that_is_no_receiver_is_an_invalid_argument_naming_it() {
    let lights = [Light::Point {
        position: Vec3::new(0.0, 0.0, 1.0),
        intensity: Rgb::grey(1.0),
    }];
    let tree = build(&lights);
    let p = ml_tl_point {
        position: v3(0.0, 0.0, 0.0),
        normal: v3(0.0, 0.0, 1.0),
        receiver: 3,
    };
    let mut s = ml_sampled_light::default();
    assert_eq!(
        ml_tree_sample_tl(tree, &p, 0.5, &mut s),
        ML_ERR_INVALID_ARGUMENT
    );
    assert_eq!(
        message(),
        "ml_tree_sample_tl: point.receiver: 3 is not an ml_receiver (0 to 2)"
    );
    let mut q = 0.0;
    assert_eq!(ml_tree_pmf_tl(tree, &p, 0, &mut q), ML_ERR_INVALID_ARGUMENT);
    assert!(message().contains("point.receiver"), "{}", message());
    let pts = [ml_tl_point::default(), p];
    let mut out = [ml_sampled_light::default(); 2];
    assert_eq!(
        ml_tree_sample_tl_batch(
            tree,
            pts.as_ptr(),
            [0.5f32; 2].as_ptr(),
            2,
            out.as_mut_ptr()
        ),
        ML_ERR_INVALID_ARGUMENT
    );
    assert!(message().contains("points[1].receiver"), "{}", message());
    let mut pmfs = [0.0f32; 2];
    assert_eq!(
        ml_tree_pmf_tl_batch(tree, pts.as_ptr(), [0u32; 2].as_ptr(), 2, pmfs.as_mut_ptr()),
        ML_ERR_INVALID_ARGUMENT
    );
    assert!(message().contains("points[1].receiver"), "{}", message());
    let mut cut = ptr::null_mut();
    ok(ml_cut_create(&mut cut));
    assert_eq!(
        ml_cut_build_split(cut, tree, &p, ptr::null()),
        ML_ERR_INVALID_ARGUMENT
    );
    assert!(message().contains("point.receiver"), "{}", message());
    ok(ml_cut_free(cut));
    ok(ml_tree_free(tree));
}
