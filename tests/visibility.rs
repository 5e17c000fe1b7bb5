//! The learned visibility cache ([`VisibilityCache`]): the pmfs of a cut scaled by it stay
//! exact (sampled = queried, bit for bit, summing to 1, no light that could be chosen without
//! it at 0); a cache with nothing learned changes nothing; the estimators stay unbiased on an
//! occluded scene and learning lowers their variance there; bad options are named.

mod common;

use common::Rng;
use glam::Vec3;
use manylights::direct::{LightSampler, Step, VisibilityCache, VisibilityField, VisibilityOptions};
use manylights::{
    DirectError, Estimator, Frame, Light, LightSet, Material, Occluder, Params, Rgb, ShadingPoint,
    Technique, MIN_PMF,
};
use manylights_testkit::TestUniforms;

fn random_lights(seed: u64, n: usize) -> Vec<Light> {
    let mut rng = Rng::new(seed);
    let spec = common::SceneSpec::default();
    common::random_scene(&mut rng, n, &spec)
}

fn point(rng: &mut Rng, lights: &[Light]) -> ShadingPoint {
    let normal = common::random_normal(rng);
    ShadingPoint {
        position: common::random_shading_point(rng, lights, 5.0),
        normal,
        wo: (normal + rng.unit() * 0.5).normalize(),
        material: Material::Plastic {
            albedo: Rgb::grey(0.5),
            specular: 0.5,
            alpha: 0.2,
        },
    }
}

/// Trains `cache` at `points` through the lower level: every light sample is recorded
/// visible with probability `p_visible` (a made-up visibility: the cache cannot tell), then
/// committed.
fn train(cache: &VisibilityCache, set: &LightSet, points: &[ShadingPoint], rng: &mut Rng) {
    let mut u = TestUniforms::new(rng.next_u64());
    for sp in points {
        let p_visible = rng.f64();
        let Ok(mut est) =
            Estimator::with_visibility(set, cache, sp, Technique::BlMis, &Params::default())
        else {
            continue;
        };
        for _ in 0..8 {
            est.start();
            while let Ok(step) = est.next(&mut u) {
                match step {
                    Step::Done => break,
                    Step::Light(d) => est.record(&d, rng.chance(p_visible)),
                    Step::Bsdf(_) => {}
                }
            }
        }
    }
    cache.commit();
}

proptest::proptest! {
    #![proptest_config(common::proptest_config(48, 0x7669_7331))]

    /// With any learned state, the BRDF-oriented cut's sampler keeps its contract exactly, and
    /// each light keeps at least `floor` times the probability it had without the cache.
    #[test]
    fn learned_pmfs_stay_exact(seed in proptest::prelude::any::<u64>(), n in 1usize..300, floor in 0.01f32..1.0) {
        let lights = random_lights(seed, n);
        let set = LightSet::build(lights.clone()).unwrap();
        let mut rng = Rng::new(seed ^ 0x55);
        let options = VisibilityOptions { cell_size: 2.0, cells: 16, slots: 64, floor };
        let cache = VisibilityCache::new(&set, options).unwrap();
        let points: Vec<ShadingPoint> = (0..24).map(|_| point(&mut rng, &lights)).collect();
        train(&cache, &set, &points, &mut rng);
        train(&cache, &set, &points, &mut rng);
        proptest::prop_assert!(cache.stats().samples > 0 || set.tree().is_empty());
        let count = set.tree().light_count();
        for sp in &points[..6] {
            let (Ok(plain), Ok(learned)) = (
                Estimator::new(&set, sp, Technique::BlMis, &Params::default()),
                Estimator::with_visibility(&set, &cache, sp, Technique::BlMis, &Params::default()),
            ) else {
                continue;
            };
            let (a, b) = (plain.cut_sampler().unwrap(), learned.cut_sampler().unwrap());
            let mut sum = 0.0f64;
            let mut any = false;
            for l in 0..count {
                let (p, q) = (a.pmf(l), b.pmf(l));
                sum += f64::from(q);
                any |= q > 0.0;
                if p * floor >= 4.0 * MIN_PMF {
                    proptest::prop_assert!(q >= p * floor * 0.999, "light {l}: {q} < {floor} · {p}");
                }
            }
            if any {
                proptest::prop_assert!((sum - 1.0).abs() < 1e-4, "pmfs sum to {sum}");
            }
            for _ in 0..200 {
                if let Some(s) = b.sample(rng.f32()) {
                    proptest::prop_assert!(s.pmf > 0.0);
                    proptest::prop_assert_eq!(s.pmf.to_bits(), b.pmf(s.light).to_bits());
                }
            }
        }
    }
}

/// A cache with nothing committed (new, or cleared) gives bit for bit the estimates of an
/// estimator without one, for every technique.
#[test]
fn an_empty_cache_changes_nothing() {
    let lights = random_lights(11, 200);
    let set = LightSet::build(lights.clone()).unwrap();
    let mut rng = Rng::new(12);
    let cache = VisibilityCache::new(&set, VisibilityOptions::with_cell_size(1.0)).unwrap();
    let points: Vec<ShadingPoint> = (0..8).map(|_| point(&mut rng, &lights)).collect();
    train(&cache, &set, &points, &mut rng);
    assert!(cache.stats().samples > 0);
    cache.clear();
    assert_eq!(cache.stats().samples, 0);
    struct Half;
    impl Occluder for Half {
        fn occluded(&self, _x: Vec3, d: Vec3, _t: f32) -> bool {
            d.x < 0.0
        }
    }
    for t in Technique::ALL {
        for sp in &points {
            let (Ok(mut a), Ok(mut b)) = (
                Estimator::new(&set, sp, t, &Params::default()),
                Estimator::with_visibility(&set, &cache, sp, t, &Params::default()),
            ) else {
                continue;
            };
            let (mut ua, mut ub) = (TestUniforms::new(5), TestUniforms::new(5));
            for _ in 0..20 {
                let x = a.estimate(&Half, &mut ua).unwrap();
                let y = b.estimate(&Half, &mut ub).unwrap();
                assert_eq!(x.map(f64::to_bits), y.map(f64::to_bits), "{t}");
            }
        }
    }
}

/// Blocks every ray towards −x.
struct HalfSpace;

impl Occluder for HalfSpace {
    fn occluded(&self, _x: Vec3, d: Vec3, _t: f32) -> bool {
        d.x < 0.0
    }
}

/// Point lights above the origin, half of them (x < 0) behind `HalfSpace`.
fn occluded_scene() -> (Vec<Light>, ShadingPoint) {
    let mut rng = Rng::new(21);
    let lights = (0..400)
        .map(|_| Light::Point {
            position: Vec3::new(
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
                rng.range(0.5, 3.0),
            ),
            intensity: Rgb::grey(rng.range(0.5, 2.0)),
        })
        .collect();
    let sp = ShadingPoint {
        position: Vec3::ZERO,
        normal: Vec3::Z,
        wo: Vec3::new(0.3, 0.0, 1.0).normalize(),
        material: Material::Plastic {
            albedo: Rgb::grey(0.6),
            specular: 0.3,
            alpha: 0.3,
        },
    };
    (lights, sp)
}

/// The exact reflected radiance (red channel) of point lights at `sp` behind `HalfSpace`.
fn exact(set: &LightSet, sp: &ShadingPoint) -> f64 {
    let frame = Frame::from_normal(sp.normal).unwrap();
    let wo = frame.to_local(sp.wo);
    (0..set.tree().light_count())
        .map(|l| {
            let p = set
                .sample_point(l, sp.position, [0.5, 0.5])
                .unwrap()
                .unwrap();
            if HalfSpace.occluded(sp.position, p.direction, p.distance) {
                return 0.0;
            }
            let wi = frame.to_local(p.direction);
            if wi.z <= 0.0 {
                return 0.0;
            }
            let g = sp.material.eval_rgb(wo, wi) * p.radiance * wi.z;
            f64::from(g.to_array()[0]) / f64::from(p.pdf)
        })
        .sum()
}

/// Mean and standard error of `n` one-call estimates (red channel).
fn mean_se(est: &mut Estimator<'_>, n: usize, seed: u64) -> (f64, f64) {
    let mut u = TestUniforms::new(seed);
    let (mut s, mut s2) = (0.0, 0.0);
    for _ in 0..n {
        let x = est.estimate(&HalfSpace, &mut u).unwrap()[0];
        s += x;
        s2 += x * x;
    }
    let m = s / n as f64;
    let var = (s2 / n as f64 - m * m) * n as f64 / (n as f64 - 1.0);
    (m, (var / n as f64).sqrt())
}

/// On a scene whose lights are half hidden, the learned estimator converges to the exact
/// value (within 5 standard errors) before and after learning, and learning lowers the
/// variance of `bl` and `bl-mis`.
#[test]
fn learning_is_unbiased_and_lowers_the_variance_where_lights_are_hidden() {
    let (lights, sp) = occluded_scene();
    let set = LightSet::build(lights).unwrap();
    let truth = exact(&set, &sp);
    for t in [
        Technique::Bl,
        Technique::BlMis,
        Technique::MisEqual,
        Technique::Full,
    ] {
        let cache = VisibilityCache::new(&set, VisibilityOptions::with_cell_size(1.0)).unwrap();
        let mut plain = Estimator::new(&set, &sp, t, &Params::default()).unwrap();
        let (m0, se0) = mean_se(&mut plain, 20_000, 1);
        for pass in 0..4 {
            let mut est =
                Estimator::with_visibility(&set, &cache, &sp, t, &Params::default()).unwrap();
            let (m, se) = mean_se(&mut est, 2_000, 10 + pass);
            assert!(
                (m - truth).abs() <= 5.0 * se,
                "{t} pass {pass}: {m} ± {se} vs {truth}"
            );
            cache.commit();
        }
        let mut learned =
            Estimator::with_visibility(&set, &cache, &sp, t, &Params::default()).unwrap();
        let (m1, se1) = mean_se(&mut learned, 20_000, 2);
        assert!(
            (m0 - truth).abs() <= 5.0 * se0,
            "{t} plain: {m0} ± {se0} vs {truth}"
        );
        assert!(
            (m1 - truth).abs() <= 5.0 * se1,
            "{t} learned: {m1} ± {se1} vs {truth}"
        );
        if matches!(t, Technique::Bl | Technique::BlMis) {
            // Standard errors of the same sample count: their ratio is the ratio of the
            // standard deviations.
            assert!(se1 < 0.9 * se0, "{t}: learned se {se1} vs plain {se0}");
        }
    }
}

/// Each option out of its range is refused, naming it; a cache of another light set is
/// refused by the estimator.
#[test]
fn bad_options_and_a_foreign_cache_are_named() {
    let set = LightSet::build(random_lights(3, 50)).unwrap();
    let good = VisibilityOptions::with_cell_size(1.0);
    let cases = [
        (
            VisibilityOptions {
                cell_size: 0.0,
                ..good
            },
            VisibilityField::CellSize,
        ),
        (
            VisibilityOptions {
                cell_size: f32::NAN,
                ..good
            },
            VisibilityField::CellSize,
        ),
        (
            VisibilityOptions { cells: 3, ..good },
            VisibilityField::Cells,
        ),
        (
            VisibilityOptions { cells: 0, ..good },
            VisibilityField::Cells,
        ),
        (
            VisibilityOptions {
                slots: 1 << 13,
                ..good
            },
            VisibilityField::Slots,
        ),
        (
            VisibilityOptions { floor: 0.0, ..good },
            VisibilityField::Floor,
        ),
        (
            VisibilityOptions { floor: 1.5, ..good },
            VisibilityField::Floor,
        ),
    ];
    for (o, field) in cases {
        let e = VisibilityCache::new(&set, o).unwrap_err();
        assert_eq!(e.field, field);
        assert!(e.to_string().contains(field.name()), "{e}");
    }
    let other = LightSet::build(random_lights(4, 70)).unwrap();
    let cache = VisibilityCache::new(&other, good).unwrap();
    let (_, sp) = occluded_scene();
    let e = Estimator::with_visibility(&set, &cache, &sp, Technique::BlMis, &Params::default())
        .unwrap_err();
    assert_eq!(e, DirectError::VisibilityCache);
}

/// Recording off keeps nothing; the stats and the byte count say what the cache holds.
#[test]
fn recording_can_be_turned_off() {
    let (lights, sp) = occluded_scene();
    let set = LightSet::build(lights).unwrap();
    let options = VisibilityOptions {
        cells: 8,
        slots: 32,
        ..VisibilityOptions::with_cell_size(1.0)
    };
    let cache = VisibilityCache::new(&set, options).unwrap();
    assert_eq!(cache.bytes(), 8 * (32 * 17 + 1));
    cache.set_recording(false);
    let mut est =
        Estimator::with_visibility(&set, &cache, &sp, Technique::BlMis, &Params::default())
            .unwrap();
    mean_se(&mut est, 100, 1);
    cache.commit();
    assert_eq!(cache.stats().samples, 0);
    cache.set_recording(true);
    mean_se(&mut est, 100, 1);
    cache.commit();
    let s = cache.stats();
    assert!(
        s.samples > 0 && s.visible > 0 && s.visible < s.samples,
        "{s:?}"
    );
    assert_eq!(cache.commits(), 2);
}
