//! `mlmeasure selection` on a small scene: finite, non-negative variances (the cut's, TL's and the
//! two descents'), the BRDF-oriented cut's below TL's, and a cut that cannot split beyond the
//! root as large as the root's slots allow. The floors on a scene where occlusion is known (a
//! floor under a ceiling, one light below the ceiling and one above it): the shadowed floor's
//! `V` is 0, the unshadowed floor's `V` is its closed form and its `V1` is at least the
//! shadowed floor's; the JSON has the floors' keys.

use glam::Vec3;
use manylights::{BlCutOptions, Light, LightSet, Material, Rgb};
use manylights_instruments::selection::{
    light_terms, run, shadowed_floor, unshadowed_floor, SelectionConfig,
};
use manylights_render::render::primary;
use manylights_render::scene::{self, Camera, Geometry, RenderScene, Triangle};

#[test]
fn stairs_light_choice() {
    let s = scene::by_name("stairs", None).unwrap();
    let cfg = SelectionConfig {
        points: 60,
        width: 48,
        height: 48,
        seed: 3,
        cut: BlCutOptions::default(),
    };
    let r = run(&s, &cfg);
    assert!(r.points > 30, "{r:?}");
    for v in [
        r.bl.mean_variance,
        r.tl.mean_variance,
        r.bl_descent.mean_variance,
        r.bl_descent_tl_near.mean_variance,
        r.mean_light,
    ] {
        assert!(v.is_finite() && v >= 0.0, "{r:?}");
    }
    assert!(r.bl.mean_variance < r.tl.mean_variance, "{r:?}");
    assert!(
        (0.0..=1.0).contains(&r.cut_full) && r.mean_cut >= 1.0,
        "{r:?}"
    );
    // The same points with a cut of at most 4 clusters: never more than 4.
    let small = run(
        &s,
        &SelectionConfig {
            cut: BlCutOptions {
                max_size: 4,
                ..BlCutOptions::default()
            },
            ..cfg
        },
    );
    assert!(small.mean_cut <= 4.0, "{small:?}");
    assert_eq!(small.points, r.points);
}

/// The albedo of the floor and the ceiling.
const ALBEDO: f32 = 0.5;
/// The point light above the ceiling: hidden from every point of the floor.
const HIDDEN: Vec3 = Vec3::new(0.3, 3.5, 0.2);
/// Its intensity.
const HIDDEN_I: f32 = 2.0;

/// A 4 × 4 floor at y = 0 under a 40 × 40 ceiling at y = 2.5; a small sphere light at
/// (0, 1.5, 0) lights the floor, a point light at [`HIDDEN`] above the ceiling never does.
fn ceiling_scene() -> RenderScene {
    let m = Material::Lambert {
        albedo: Rgb::grey(ALBEDO),
    };
    let v = Vec3::new;
    let quad = |t: &mut Vec<Triangle>, y: f32, h: f32| {
        let (a, b, c, d) = (v(-h, y, -h), v(h, y, -h), v(h, y, h), v(-h, y, h));
        t.push(Triangle::new(a, b, c, m));
        t.push(Triangle::new(a, c, d, m));
    };
    let mut t = Vec::new();
    quad(&mut t, 0.0, 2.0);
    quad(&mut t, 2.5, 20.0);
    let lights = vec![
        Light::Sphere {
            center: v(0.0, 1.5, 0.0),
            radius: 0.05,
            radiance: Rgb::grey(30.0),
        },
        Light::Point {
            position: HIDDEN,
            intensity: Rgb::grey(HIDDEN_I),
        },
    ];
    RenderScene {
        name: "ceiling".into(),
        geometry: Geometry::new(t),
        lights: LightSet::build(lights).unwrap(),
        sky: None,
        camera: Camera {
            eye: v(0.0, 1.2, 3.0),
            target: v(0.0, 0.0, 0.0),
            up: v(0.0, 1.0, 0.0),
            fov_y: 50.0,
        },
    }
}

/// At points of the floor: the sphere light is seen whole (`c = u`, `m > c²`: its four
/// points differ), the point light not at all (`c = 0`, `u` its closed form
/// `ρ/π · I · cos θ / d²`); the unshadowed floor's `V` is `c_0 · u_1` (with `p_0 = u_0 /
/// (u_0 + u_1)` and `c_0 = u_0`), the shadowed floor's is 0, and the unshadowed floor's `V1`
/// is above the shadowed floor's.
#[test]
fn floors_at_points_of_a_floor_under_a_ceiling() {
    let s = ceiling_scene();
    let (w, h) = (16, 16);
    let mut checked = 0;
    for py in 0..h {
        for px in 0..w {
            let Some(sp) = primary(&s, px, py, w, h) else {
                continue;
            };
            if sp.position.y.abs() > 1e-3 {
                continue;
            }
            let ts = light_terms(&s, &sp);
            assert_eq!(ts.len(), 2, "{ts:?}");
            let (a, b) = (ts[0], ts[1]);
            assert_eq!((a.light, b.light), (0, 1));
            assert!(a.c > 0.0 && a.c == a.u && a.m > a.c * a.c, "{a:?}");
            let d = HIDDEN - sp.position;
            let cos = d.y / d.length();
            let u1 = f64::from(ALBEDO / std::f32::consts::PI * HIDDEN_I * cos / d.length_squared());
            assert!(b.c == 0.0 && b.m == 0.0, "{b:?}");
            assert!((b.u - u1).abs() <= 1e-5 * u1, "{} against {u1}", b.u);
            let [v, v1] = unshadowed_floor(&ts);
            let closed = a.c * u1;
            assert!((v - closed).abs() <= 1e-4 * closed, "{v} against {closed}");
            let [sv, sv1] = shadowed_floor(&ts);
            assert_eq!(sv, 0.0);
            // V1 of p ∝ c with one contributing light: m − c².
            assert!((sv1 - (a.m - a.c * a.c)).abs() <= 1e-9 * a.m, "{sv1}");
            assert!(v1 >= sv1 && v1 > v, "{v1} {sv1} {v}");
            checked += 1;
        }
    }
    assert!(checked > 50, "{checked}");
}

/// The report over the scene: the shadowed floor's mean `V` is 0, the unshadowed floor's `V1`
/// at least the shadowed floor's, every technique's `V1` at least its `V`, no infinite point;
/// the JSON keeps its keys and has the floors' and the ratios'.
#[test]
fn report_and_json_have_the_floors() {
    let s = ceiling_scene();
    let cfg = SelectionConfig {
        points: 80,
        width: 32,
        height: 32,
        seed: 5,
        cut: BlCutOptions::default(),
    };
    let r = run(&s, &cfg);
    assert!(r.points > 40, "{r:?}");
    assert!(r.mean_unshadowed_light > r.mean_light, "{r:?}");
    let scale = r.mean_light * r.mean_light;
    assert_eq!(r.shadowed_floor.mean_variance, 0.0);
    assert_eq!(r.shadowed_floor.worst_1pc_share, 0.0);
    assert!(r.unshadowed_floor.mean_variance > 1e-6 * scale, "{r:?}");
    assert!(
        r.unshadowed_floor.mean_variance_one_sample >= r.shadowed_floor.mean_variance_one_sample
            && r.shadowed_floor.mean_variance_one_sample > 0.0,
        "{r:?}"
    );
    for c in [
        r.bl,
        r.tl,
        r.bl_descent,
        r.bl_descent_tl_near,
        r.unshadowed_floor,
    ] {
        assert_eq!(c.infinite_points, 0);
        assert!(c.mean_variance_one_sample >= c.mean_variance, "{r:?}");
    }
    let [dv, dv1] = r.default_vs_unshadowed_floor();
    assert_eq!(dv, r.bl.mean_variance / r.unshadowed_floor.mean_variance);
    assert!(
        dv1.is_finite() && r.unshadowed_vs_shadowed_floor() >= 1.0,
        "{r:?}"
    );

    let j = r.json("ceiling", &cfg);
    for key in [
        // Kept.
        "bl_mean_variance",
        "bl_worst_1pc_share",
        "tl_mean_variance",
        "bl_vs_tl",
        "bl_descent_tl_near_vs_tl",
        "mean_cut",
        "cut_full",
        // New.
        "mean_unshadowed_light",
        "bl_mean_variance_one_sample",
        "tl_mean_variance_one_sample",
        "bl_descent_mean_variance_one_sample",
        "bl_descent_tl_near_mean_variance_one_sample",
        "bl_infinite_points",
        "unshadowed_floor_mean_variance",
        "unshadowed_floor_mean_variance_one_sample",
        "unshadowed_floor_worst_1pc_share",
        "shadowed_floor_mean_variance",
        "shadowed_floor_mean_variance_one_sample",
        "bl_vs_unshadowed_floor",
        "bl_vs_unshadowed_floor_one_sample",
        "unshadowed_vs_shadowed_floor_one_sample",
    ] {
        assert!(j[key].is_number(), "{key} missing from {j}");
    }
    assert_eq!(
        j["unshadowed_floor_mean_variance"].as_f64(),
        Some(r.unshadowed_floor.mean_variance)
    );
    let table = r.table("ceiling", &cfg);
    assert!(
        table.contains("| unshadowed floor, p ∝ u |")
            && table.contains("| shadowed floor, p ∝ c |"),
        "{table}"
    );
}
