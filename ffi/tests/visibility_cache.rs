//! The visibility cache through the C ABI (`ml_visibility_cache_*`,
//! `ml_estimator_set_visibility_cache`, `ml_estimator_record`): what the C calls learn and
//! sample is bit for bit what the core's `VisibilityCache` and `Estimator::with_visibility`
//! give for the same records; bad options name their field; a cache of another tree is
//! refused; the estimator keeps the cache alive.

mod common;
use common::{message, ok, uniforms};

use glam::Vec3;
use manylights::direct::{
    Occluder, Params, Step, Technique, Uniforms, VisibilityCache, VisibilityOptions,
};
use manylights::{Estimator, Light, LightSet, Material, Rgb, ShadingPoint};
use manylights_ffi::*;
use manylights_testkit::SplitMix64 as Rng;
use std::ffi::c_void;
use std::ptr;

/// The host's generator as the core's uniform numbers (what `ml_uniforms` with both
/// callbacks gives).
struct CoreUniforms<'a>(&'a mut Rng);

impl Uniforms for CoreUniforms<'_> {
    fn next_f32(&mut self) -> f32 {
        self.0.f32()
    }
    fn next_f64(&mut self) -> f64 {
        self.0.f64()
    }
}

/// A wall: every direction with x > 0.2 is blocked.
fn blocked(d: Vec3) -> bool {
    d.x > 0.2
}

unsafe extern "C" fn occluded(_: *mut c_void, _x: ml_vec3, d: ml_vec3, _t: f32) -> i32 {
    i32::from(blocked(Vec3::new(d.x, d.y, d.z)))
}

struct Wall;
impl Occluder for Wall {
    fn occluded(&self, _x: Vec3, d: Vec3, _t: f32) -> bool {
        blocked(d)
    }
}

fn wall() -> ml_visibility {
    ml_visibility {
        occluded: Some(occluded),
        first_hit: None,
        user_data: ptr::null_mut(),
    }
}

/// 400 point and sphere lights above the plane z = 0, on both sides of the wall.
fn lights(seed: u64) -> Vec<Light> {
    let mut r = Rng::new(seed);
    (0..400)
        .map(|i| {
            let p = Vec3::new(r.range(-4.0, 4.0), r.range(-4.0, 4.0), r.range(0.5, 3.0));
            let e = Rgb::grey(r.range(0.5, 3.0));
            if i % 2 == 0 {
                Light::Point {
                    position: p,
                    intensity: e,
                }
            } else {
                Light::Sphere {
                    center: p,
                    radius: r.range(0.05, 0.3),
                    radiance: e,
                }
            }
        })
        .collect()
}

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

fn v3(v: Vec3) -> ml_vec3 {
    ml_vec3 {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

/// Shading point `i` of a grid on the plane, glossy, in both the C and the core's terms.
fn point(i: usize) -> (ml_shading_point, ShadingPoint) {
    let x = -1.5 + 0.5 * (i % 7) as f32;
    let y = -1.5 + 0.5 * ((i / 7) % 7) as f32;
    let (p, n, wo) = (
        Vec3::new(x, y, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.3, -0.2, 1.0),
    );
    let c = ml_shading_point {
        position: v3(p),
        normal: v3(n),
        wo: v3(wo),
        material: ml_material {
            kind: ml_material_kind::Plastic as u32,
            albedo: ml_rgb {
                r: 0.5,
                g: 0.4,
                b: 0.3,
            },
            specular: 0.5,
            alpha: 0.2,
        },
    };
    let core = ShadingPoint {
        position: p,
        normal: n,
        wo,
        material: Material::Plastic {
            albedo: Rgb::new(0.5, 0.4, 0.3),
            specular: 0.5,
            alpha: 0.2,
        },
    };
    (c, core)
}

const OPTIONS: ml_visibility_cache_options = ml_visibility_cache_options {
    cell_size: 0.75,
    cells: 256,
    slots: 64,
    floor: 0.1,
};

fn core_options() -> VisibilityOptions {
    VisibilityOptions {
        cell_size: OPTIONS.cell_size,
        cells: OPTIONS.cells,
        slots: OPTIONS.slots,
        floor: OPTIONS.floor,
    }
}

fn create(tree: *const ml_tree) -> *mut ml_visibility_cache {
    let mut c = ptr::null_mut();
    ok(ml_visibility_cache_create(tree, &OPTIONS, &mut c));
    c
}

fn stats(c: *const ml_visibility_cache) -> ml_visibility_cache_counts {
    let mut s = ml_visibility_cache_counts::default();
    ok(ml_visibility_cache_stats(c, &mut s));
    s
}

const POINTS: usize = 49;
const PER_POINT: usize = 8;

/// One pass through the C one call: `PER_POINT` estimates at every point, seeds from `seed`.
fn c_pass(est: *mut ml_estimator, technique: Technique, seed: u64) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for i in 0..POINTS {
        let (sp, _) = point(i);
        ok(ml_estimator_set_point(
            est,
            &sp,
            technique as u32,
            ptr::null(),
        ));
        let mut r = Rng::new(seed ^ (i as u64) << 20);
        let u = uniforms(&mut r);
        for _ in 0..PER_POINT {
            let mut e = ml_rgb64::default();
            ok(ml_estimator_estimate(est, &wall(), &u, &mut e));
            out.push([e.r, e.g, e.b]);
        }
    }
    out
}

/// The same pass through the core.
fn core_pass(
    set: &LightSet,
    cache: &VisibilityCache,
    technique: Technique,
    seed: u64,
) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    let mut slot = None;
    for i in 0..POINTS {
        let (_, sp) = point(i);
        let est = Estimator::reuse_with_visibility(
            &mut slot,
            set,
            cache,
            &sp,
            technique,
            &Params::default(),
        )
        .unwrap();
        let mut r = Rng::new(seed ^ (i as u64) << 20);
        for _ in 0..PER_POINT {
            out.push(est.estimate(&Wall, &mut CoreUniforms(&mut r)).unwrap());
        }
    }
    out
}

/// The light steps (light, pmf bits) of one estimate at every point through the C step
/// loop, recording each light step's visibility with `ml_estimator_record` when `record`.
fn c_steps(est: *mut ml_estimator, seed: u64, record: bool) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for i in 0..POINTS {
        let (sp, _) = point(i);
        ok(ml_estimator_set_point(
            est,
            &sp,
            Technique::BlMis as u32,
            ptr::null(),
        ));
        let mut r = Rng::new(seed ^ (i as u64) << 20);
        let u = uniforms(&mut r);
        ok(ml_estimator_start(est));
        loop {
            let mut s = ml_step::default();
            ok(ml_estimator_next(est, &u, &mut s));
            if s.kind == ml_step_kind::Done as u32 {
                break;
            }
            if s.kind == ml_step_kind::Light as u32 {
                out.push((s.light, s.pmf.to_bits()));
                if record {
                    let d = s.point.direction;
                    let visible = !blocked(Vec3::new(d.x, d.y, d.z));
                    ok(ml_estimator_record(est, u32::from(visible)));
                }
            }
        }
    }
    out
}

/// The same steps through the core's lower level.
fn core_steps(set: &LightSet, cache: &VisibilityCache, seed: u64, record: bool) -> Vec<(u32, u32)> {
    let mut out = Vec::new();
    for i in 0..POINTS {
        let (_, sp) = point(i);
        let mut est =
            Estimator::with_visibility(set, cache, &sp, Technique::BlMis, &Params::default())
                .unwrap();
        let mut r = Rng::new(seed ^ (i as u64) << 20);
        est.start();
        loop {
            match est.next(&mut CoreUniforms(&mut r)).unwrap() {
                Step::Done => break,
                Step::Light(d) => {
                    out.push((d.light, d.pmf.to_bits()));
                    if record {
                        est.record(&d, !blocked(d.point.direction));
                    }
                }
                Step::Bsdf(_) => {}
            }
        }
    }
    out
}

fn bits(v: &[[f64; 3]]) -> Vec<[u64; 3]> {
    v.iter()
        .map(|e| [e[0].to_bits(), e[1].to_bits(), e[2].to_bits()])
        .collect()
}

#[test]
fn the_c_calls_learn_and_sample_bit_for_bit_as_the_core() {
    let ls = lights(7);
    let tree = build(&ls);
    let set = LightSet::build(ls.clone()).unwrap();
    for technique in [Technique::BlMis, Technique::Full, Technique::TlMis] {
        let cache = create(tree);
        let core = VisibilityCache::new(&set, core_options()).unwrap();
        let mut est = ptr::null_mut();
        ok(ml_estimator_create(tree, &mut est));
        ok(ml_estimator_set_visibility_cache(est, cache));
        for pass in 0..3u64 {
            let c = c_pass(est, technique, 100 + pass);
            let r = core_pass(&set, &core, technique, 100 + pass);
            assert_eq!(bits(&c), bits(&r), "{technique:?}, pass {pass}");
            ok(ml_visibility_cache_commit(cache));
            core.commit();
            let s = stats(cache);
            let t = core.stats();
            assert_eq!(
                (s.used, s.samples, s.visible),
                (t.used, t.samples, t.visible)
            );
            if technique == Technique::TlMis {
                // No BRDF-oriented cut: nothing to scale, nothing recorded.
                assert_eq!(s, ml_visibility_cache_counts::default());
            } else {
                assert!(s.samples > 0 && s.visible < s.samples, "{s:?}");
            }
        }
        ok(ml_estimator_free(est));
        ok(ml_visibility_cache_free(cache));
    }
    ok(ml_tree_free(tree));
}

#[test]
fn the_step_loop_records_and_its_pmfs_are_the_cores() {
    let ls = lights(11);
    let tree = build(&ls);
    let set = LightSet::build(ls.clone()).unwrap();
    let cache = create(tree);
    let core = VisibilityCache::new(&set, core_options()).unwrap();
    let mut est = ptr::null_mut();
    ok(ml_estimator_create(tree, &mut est));
    ok(ml_estimator_set_visibility_cache(est, cache));
    let before = c_steps(est, 5, true);
    assert_eq!(before, core_steps(&set, &core, 5, true));
    ok(ml_visibility_cache_commit(cache));
    core.commit();
    let s = stats(cache);
    let t = core.stats();
    assert_eq!(
        (s.used, s.samples, s.visible),
        (t.used, t.samples, t.visible)
    );
    assert!(s.samples > 0 && s.visible < s.samples, "{s:?}");
    // After the commit the pmfs follow what was learned, the same in C and Rust.
    let after = c_steps(est, 5, false);
    assert_eq!(after, core_steps(&set, &core, 5, false));
    assert_ne!(after, before, "learning changed no pmf");
    // The pmfs sampled are the pmfs queried: `bl` through the estimator's cut is checked by
    // the core; here every sampled pmf is positive.
    assert!(after.iter().all(|&(_, p)| f32::from_bits(p) > 0.0));
    ok(ml_estimator_free(est));
    ok(ml_visibility_cache_free(cache));
    ok(ml_tree_free(tree));
}

#[test]
fn a_cache_takes_effect_at_the_next_set_point_and_null_detaches_it() {
    let tree = build(&lights(3));
    let cache = create(tree);
    let mut est = ptr::null_mut();
    ok(ml_estimator_create(tree, &mut est));
    let (sp, _) = point(10);
    let mut r = Rng::new(1);
    let u = uniforms(&mut r);
    let mut e = ml_rgb64::default();
    ok(ml_estimator_set_point(
        est,
        &sp,
        ML_TECHNIQUE_DEFAULT,
        ptr::null(),
    ));
    ok(ml_estimator_set_visibility_cache(est, cache));
    for _ in 0..20 {
        ok(ml_estimator_estimate(est, &wall(), &u, &mut e));
    }
    ok(ml_visibility_cache_commit(cache));
    assert_eq!(stats(cache).samples, 0, "recorded before the next set-up");
    ok(ml_estimator_set_point(
        est,
        &sp,
        ML_TECHNIQUE_DEFAULT,
        ptr::null(),
    ));
    for _ in 0..20 {
        ok(ml_estimator_estimate(est, &wall(), &u, &mut e));
    }
    ok(ml_visibility_cache_commit(cache));
    let n = stats(cache).samples;
    assert!(n > 0);
    // Recording off: nothing more is counted.
    ok(ml_visibility_cache_set_recording(cache, 0));
    ok(ml_estimator_estimate(est, &wall(), &u, &mut e));
    ok(ml_visibility_cache_commit(cache));
    assert_eq!(stats(cache).samples, n);
    ok(ml_visibility_cache_set_recording(cache, 1));
    // Detached: the set-up still records until the next set_point.
    ok(ml_estimator_set_visibility_cache(est, ptr::null()));
    ok(ml_estimator_set_point(
        est,
        &sp,
        ML_TECHNIQUE_DEFAULT,
        ptr::null(),
    ));
    for _ in 0..20 {
        ok(ml_estimator_estimate(est, &wall(), &u, &mut e));
    }
    ok(ml_visibility_cache_commit(cache));
    assert_eq!(stats(cache).samples, n);
    // Clear forgets everything.
    ok(ml_visibility_cache_clear(cache));
    assert_eq!(stats(cache), ml_visibility_cache_counts::default());
    let mut bytes = 0usize;
    ok(ml_visibility_cache_bytes(cache, &mut bytes));
    assert_eq!(bytes, 256 * (64 * 17 + 1));
    ok(ml_estimator_free(est));
    ok(ml_visibility_cache_free(cache));
    ok(ml_tree_free(tree));
}

#[test]
fn freeing_the_cache_before_the_estimator_is_safe() {
    let tree = build(&lights(3));
    let (sp, _) = point(24);
    let run = |free_early: bool| {
        let cache = create(tree);
        let mut est = ptr::null_mut();
        ok(ml_estimator_create(tree, &mut est));
        ok(ml_estimator_set_visibility_cache(est, cache));
        ok(ml_estimator_set_point(
            est,
            &sp,
            ML_TECHNIQUE_DEFAULT,
            ptr::null(),
        ));
        let mut r = Rng::new(9);
        let u = uniforms(&mut r);
        let mut e = ml_rgb64::default();
        ok(ml_estimator_estimate(est, &wall(), &u, &mut e));
        ok(ml_visibility_cache_commit(cache));
        if free_early {
            ok(ml_visibility_cache_free(cache));
        }
        let mut out = Vec::new();
        for _ in 0..3 {
            ok(ml_estimator_set_point(
                est,
                &sp,
                ML_TECHNIQUE_DEFAULT,
                ptr::null(),
            ));
            ok(ml_estimator_estimate(est, &wall(), &u, &mut e));
            out.push([e.r, e.g, e.b]);
        }
        ok(ml_estimator_free(est));
        if !free_early {
            ok(ml_visibility_cache_free(cache));
        }
        out
    };
    assert_eq!(bits(&run(true)), bits(&run(false)));
    // The tree freed first too: the cache keeps it.
    let tree2 = build(&lights(3));
    let cache = create(tree2);
    ok(ml_tree_free(tree2));
    let mut s = ml_visibility_cache_counts::default();
    ok(ml_visibility_cache_stats(cache, &mut s));
    ok(ml_visibility_cache_free(cache));
    ok(ml_tree_free(tree));
}

#[test]
fn a_cache_of_another_tree_is_refused() {
    let ls = lights(3);
    let (a, b) = (build(&ls), build(&ls));
    let cache = create(b);
    let mut est = ptr::null_mut();
    ok(ml_estimator_create(a, &mut est));
    assert_eq!(
        ml_estimator_set_visibility_cache(est, cache),
        ML_ERR_INVALID_ARGUMENT
    );
    let m = message();
    assert!(
        m.starts_with("ml_estimator_set_visibility_cache: cache: made for another tree"),
        "{m}"
    );
    // The estimator is unchanged: it sets up and estimates without a cache.
    let (sp, _) = point(3);
    ok(ml_estimator_set_point(
        est,
        &sp,
        ML_TECHNIQUE_DEFAULT,
        ptr::null(),
    ));
    let mut r = Rng::new(2);
    let mut e = ml_rgb64::default();
    ok(ml_estimator_estimate(
        est,
        &wall(),
        &uniforms(&mut r),
        &mut e,
    ));
    ok(ml_visibility_cache_commit(cache));
    assert_eq!(stats(cache).samples, 0);
    ok(ml_estimator_free(est));
    ok(ml_visibility_cache_free(cache));
    ok(ml_tree_free(a));
    ok(ml_tree_free(b));
}

#[test]
fn bad_options_and_arguments_are_named_and_write_nothing() {
    let tree = build(&lights(3));
    let sentinel = 0x10 as *mut ml_visibility_cache;
    let bad = |o: ml_visibility_cache_options, status: ml_status, text: &str| {
        let mut c = sentinel;
        assert_eq!(
            ml_visibility_cache_create(tree, &o, &mut c),
            status,
            "{o:?}"
        );
        assert_eq!(c, sentinel, "written on error");
        let m = message();
        assert!(m.starts_with("ml_visibility_cache_create: "), "{m}");
        assert!(m.contains(text), "{m} lacks {text}");
    };
    let inv = ML_ERR_INVALID_ARGUMENT;
    for v in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let o = ml_visibility_cache_options {
            cell_size: v,
            ..OPTIONS
        };
        bad(o, inv, "options.cell_size must be finite and positive");
    }
    for v in [0, 3, 1 << 21] {
        let o = ml_visibility_cache_options {
            cells: v,
            ..OPTIONS
        };
        bad(o, inv, &format!("options.cells must be a power of two in [1, ML_MAX_VISIBILITY_CELLS] = [1, 1048576] (got {v})"));
    }
    for v in [0, 48, 8192] {
        let o = ml_visibility_cache_options {
            slots: v,
            ..OPTIONS
        };
        bad(o, inv, &format!("options.slots must be a power of two in [1, ML_MAX_VISIBILITY_SLOTS] = [1, 4096] (got {v})"));
    }
    for v in [0.0, -0.5, 1.5, f32::NAN] {
        let o = ml_visibility_cache_options {
            floor: v,
            ..OPTIONS
        };
        bad(o, inv, "options.floor must be in (0, 1]");
    }
    // NULLs.
    let mut c = sentinel;
    assert_eq!(
        ml_visibility_cache_create(ptr::null(), &OPTIONS, &mut c),
        ML_ERR_NULL
    );
    assert!(message().contains("`tree` is NULL"));
    assert_eq!(
        ml_visibility_cache_create(tree, ptr::null(), &mut c),
        ML_ERR_NULL
    );
    assert!(message().contains("`options` is NULL"));
    assert_eq!(
        ml_visibility_cache_create(tree, &OPTIONS, ptr::null_mut()),
        ML_ERR_NULL
    );
    assert_eq!(c, sentinel);
    assert_eq!(
        ml_visibility_cache_options_default(1.0, ptr::null_mut()),
        ML_ERR_NULL
    );
    assert_eq!(ml_visibility_cache_commit(ptr::null_mut()), ML_ERR_NULL);
    assert!(message().contains("`cache` is NULL"));
    assert_eq!(ml_visibility_cache_clear(ptr::null_mut()), ML_ERR_NULL);
    assert_eq!(
        ml_visibility_cache_set_recording(ptr::null_mut(), 1),
        ML_ERR_NULL
    );
    let mut s = ml_visibility_cache_counts::default();
    assert_eq!(ml_visibility_cache_stats(ptr::null(), &mut s), ML_ERR_NULL);
    let mut n = 0usize;
    assert_eq!(ml_visibility_cache_bytes(ptr::null(), &mut n), ML_ERR_NULL);
    ok(ml_visibility_cache_free(ptr::null_mut()));
    assert_eq!(
        ml_estimator_set_visibility_cache(ptr::null_mut(), ptr::null()),
        ML_ERR_NULL
    );
    assert_eq!(ml_estimator_record(ptr::null_mut(), 1), ML_ERR_NULL);
    // The defaults, and a tree without its lights.
    let mut o = OPTIONS;
    ok(ml_visibility_cache_options_default(0.25, &mut o));
    assert_eq!(
        o,
        ml_visibility_cache_options {
            cell_size: 0.25,
            cells: 4096,
            slots: 256,
            floor: 0.1
        }
    );
    let mut len = 0usize;
    ok(ml_tree_serialized_size(tree, &mut len));
    let mut bytes = vec![0u8; len];
    ok(ml_tree_serialize(tree, bytes.as_mut_ptr(), len, &mut len));
    let mut loaded = ptr::null_mut();
    ok(ml_tree_load(bytes.as_ptr(), len, &mut loaded));
    assert_eq!(
        ml_visibility_cache_create(loaded, &OPTIONS, &mut c),
        ML_ERR_STATE
    );
    assert!(
        message().contains("holds no light descriptors"),
        "{}",
        message()
    );
    assert_eq!(c, sentinel);
    // Flags other than 0 or 1; recording without a set-up or a light step.
    let cache = create(tree);
    assert_eq!(ml_visibility_cache_set_recording(cache, 2), inv);
    assert_eq!(
        message(),
        "ml_visibility_cache_set_recording: on must be 0 or 1 (got 2)"
    );
    let mut est = ptr::null_mut();
    ok(ml_estimator_create(tree, &mut est));
    ok(ml_estimator_set_visibility_cache(est, cache));
    assert_eq!(ml_estimator_record(est, 1), ML_ERR_STATE);
    assert!(message().contains("not set up"), "{}", message());
    let (sp, _) = point(0);
    ok(ml_estimator_set_point(
        est,
        &sp,
        ML_TECHNIQUE_DEFAULT,
        ptr::null(),
    ));
    assert_eq!(ml_estimator_record(est, 1), ML_ERR_STATE);
    assert_eq!(
        message(),
        "ml_estimator_record: est: no light step to record"
    );
    assert_eq!(ml_estimator_record(est, 7), inv);
    assert_eq!(
        message(),
        "ml_estimator_record: visible must be 0 or 1 (got 7)"
    );
    ok(ml_estimator_free(est));
    ok(ml_visibility_cache_free(cache));
    ok(ml_tree_free(loaded));
    ok(ml_tree_free(tree));
}

/// A tree or cache handle shared by threads (the ABI's contract: the tree's `const` calls
/// and every cache call are thread-safe).
struct Shared<T>(*mut T);
impl<T> Clone for Shared<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Shared<T> {}
// SAFETY: see above.
unsafe impl<T> Send for Shared<T> {}
// SAFETY: as above.
unsafe impl<T> Sync for Shared<T> {}

/// Estimates at points `range` with one estimator of `tree` using `cache`, seeds per point.
fn render(
    tree: Shared<ml_tree>,
    cache: Shared<ml_visibility_cache>,
    range: std::ops::Range<usize>,
    seed: u64,
) -> Vec<[f64; 3]> {
    let mut est = ptr::null_mut();
    ok(ml_estimator_create(tree.0, &mut est));
    ok(ml_estimator_set_visibility_cache(est, cache.0));
    let mut out = Vec::new();
    for i in range {
        let (sp, _) = point(i);
        ok(ml_estimator_set_point(
            est,
            &sp,
            ML_TECHNIQUE_DEFAULT,
            ptr::null(),
        ));
        let mut r = Rng::new(seed ^ (i as u64) << 20);
        let u = uniforms(&mut r);
        for _ in 0..PER_POINT {
            let mut e = ml_rgb64::default();
            ok(ml_estimator_estimate(est, &wall(), &u, &mut e));
            out.push([e.r, e.g, e.b]);
        }
    }
    ok(ml_estimator_free(est));
    out
}

#[test]
fn passes_committed_between_give_the_same_bits_on_one_two_or_three_threads() {
    let tree = Shared(build(&lights(5)));
    let run = |threads: usize| {
        let cache = Shared(create(tree.0));
        let mut all = Vec::new();
        for pass in 0..3u64 {
            let mut images = Vec::new();
            std::thread::scope(|s| {
                let per = POINTS.div_ceil(threads);
                let hs: Vec<_> = (0..threads)
                    .map(|t| {
                        let r = t * per..((t + 1) * per).min(POINTS);
                        s.spawn(move || render(tree, cache, r, 40 + pass))
                    })
                    .collect();
                for h in hs {
                    images.extend(h.join().unwrap());
                }
            });
            ok(ml_visibility_cache_commit(cache.0));
            all.push((bits(&images), stats(cache.0)));
        }
        ok(ml_visibility_cache_free(cache.0));
        all
    };
    let one = run(1);
    assert!(one[2].1.samples > 0);
    assert_eq!(one, run(2));
    assert_eq!(one, run(3));
    ok(ml_tree_free(tree.0));
}
