//! `mlmeasure selection` on a small scene: finite, non-negative variances (the cut's, TL's and the
//! two descents'), the BRDF-oriented cut's below TL's, and a cut that cannot split beyond the
//! root as large as the root's slots allow.

use manylights::BlCutOptions;
use manylights_instruments::selection::{run, SelectionConfig};
use manylights_render::scene;

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
