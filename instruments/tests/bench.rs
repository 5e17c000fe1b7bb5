//! `mlmeasure bench` in miniature: the build-only report has the build's figures (its peak heap
//! measured by the counting allocator installed here, as in `mlmeasure`) and no sampling ones;
//! the full report has both; the points-only scene is points only. The allocator's counters
//! are global, so the tests that measure them run one at a time.

use manylights::Light;
use manylights_instruments::alloc_count::{self, CountingAlloc};
use manylights_instruments::bench::{run, table, BenchConfig, SceneKinds};

#[global_allocator]
static ALLOC: CountingAlloc = CountingAlloc;

/// Held by every test that runs the bench: another test's allocations would be counted in
/// its peak heap, and its reset of the peak would cut this one's short.
static COUNTERS: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn counters() -> std::sync::MutexGuard<'static, ()> {
    COUNTERS.lock().unwrap_or_else(|e| e.into_inner())
}

fn config(kinds: SceneKinds, build_only: bool) -> BenchConfig {
    BenchConfig {
        lights: 3000,
        points: 2000,
        seed: 5,
        repeats: 2,
        kinds,
        build_only,
    }
}

#[test]
fn build_only_reports_the_build() {
    let _serial = counters();
    assert!(alloc_count::installed());
    for kinds in [SceneKinds::Mixed, SceneKinds::Point] {
        let r = run(&config(kinds, true));
        assert_eq!(r.run.kinds, kinds);
        assert_eq!(r.to_json()["kinds"], kinds.name());
        assert!(r.build.build_ms > 0.0);
        let bpl = f64::from(r.shape.bytes_per_light);
        let peak = r.build.build_peak_bytes_per_light.unwrap();
        // Everything the build allocates is counted, the finished tree included.
        assert!(peak >= bpl, "{kinds:?}: peak {peak} < tree {bpl}");
        assert!(peak < 1000.0, "{kinds:?}: peak {peak}");
        assert!(r.build.baseline_build_peak_bytes_per_light.unwrap() > 0.0);
        assert!(r.shape.nodes > 0 && r.shape.depth > 0);
        assert!(r.sampling.is_none());
        assert!(r.to_json().get("tl_msamples_per_s").is_none());
        let t = table(&r);
        assert!(
            t.contains("build peak heap") && !t.contains("Msamples"),
            "{t}"
        );
    }
}

#[test]
fn full_report_has_build_and_sampling() {
    let _serial = counters();
    let mut cfg = config(SceneKinds::Point, false);
    cfg.repeats = 1;
    let r = run(&cfg);
    assert!(r.build.build_peak_bytes_per_light.is_some());
    let s = r.sampling.expect("a full run samples");
    assert!(s.single.tl_msamples_per_s > 0.0);
    assert!(s.exactness.pmf_max_rel_err < 1e-3);
}

#[test]
fn point_scene_is_points_in_the_cube() {
    let _serial = counters();
    let lights = manylights_testkit::point_lights(500, 3);
    assert_eq!(lights.len(), 500);
    assert_eq!(lights, manylights_testkit::point_lights(500, 3));
    for l in &lights {
        match *l {
            Light::Point {
                position,
                intensity,
            } => {
                assert!(position.abs().max_element() <= manylights_testkit::HALF_EXTENT);
                let power = intensity.luminance() * 4.0 * std::f32::consts::PI;
                assert!((0.099..=10.001).contains(&power), "{power}");
            }
            _ => panic!("not a point light: {l:?}"),
        }
    }
}
