//! The bound `ML_MIN_PMF`'s documentation gives: of two lights a point sees alike, the weaker
//! keeps pmf > 0 while E_strong / E_weak ≤ 2¹²⁶ and gets pmf 0 beyond it.

mod common;
use common::ok;

use manylights_ffi::*;
use std::ptr;

fn v3(x: f32, y: f32, z: f32) -> ml_vec3 {
    ml_vec3 { x, y, z }
}

/// A point light at (0, 0, 1) of energy `energy` (W; 4π times its intensity).
fn point(energy: f64) -> ml_light {
    let i = (energy / (4.0 * std::f64::consts::PI)) as f32;
    ml_point_light {
        kind: ml_light_kind::Point as u32,
        position: v3(0.0, 0.0, 1.0),
        intensity: ml_rgb { r: i, g: i, b: i },
    }
    .into()
}

/// The TL and BL pmfs of the weak light (index 1) of a tree of two point lights at one
/// position, the strong one of energy 1e20 W and the weak one `ratio` times weaker, seen from
/// (0, 0, 0) facing them.
fn weak_pmfs(ratio: f64) -> (f32, f32) {
    let strong = 1e20;
    let lights = [point(strong), point(strong / ratio)];
    let mut tree = ptr::null_mut();
    ok(ml_tree_build(
        lights.as_ptr(),
        2,
        ptr::null(),
        ptr::null(),
        &mut tree,
    ));
    let tl = ml_tl_point {
        position: v3(0.0, 0.0, 0.0),
        normal: v3(0.0, 0.0, 1.0),
        ..ml_tl_point::default()
    };
    let sp = ml_shading_point {
        position: tl.position,
        normal: tl.normal,
        wo: v3(0.3, 0.0, 1.0),
        material: ml_material {
            kind: ml_material_kind::Lambert as u32,
            albedo: ml_rgb {
                r: 0.5,
                g: 0.5,
                b: 0.5,
            },
            ..ml_material::default()
        },
    };
    let (mut p_tl, mut p_bl) = (-1.0, -1.0);
    ok(ml_tree_pmf_tl(tree, &tl, 1, &mut p_tl));
    ok(ml_tree_pmf_bl(tree, &sp, 1, &mut p_bl));
    ok(ml_tree_free(tree));
    (p_tl, p_bl)
}

#[test]
fn the_weaker_of_two_lights_seen_alike_keeps_its_pmf_up_to_the_stated_ratio() {
    let bound = 2f64.powi(126);
    // Just inside, by more than the rounding of the stored energies (2⁻¹¹ each) and of the
    // importances (a few units in the last place).
    let (tl, bl) = weak_pmfs(bound * (1.0 - 1.0 / 128.0));
    assert!(tl >= ML_MIN_PMF && bl >= ML_MIN_PMF, "TL {tl:e}, BL {bl:e}");
    // About 1/ratio: the share of the weak one.
    assert!((f64::from(tl) * bound - 1.0).abs() < 0.02, "TL {tl:e}");
    // Just outside: dropped.
    let (tl, bl) = weak_pmfs(bound * (1.0 + 1.0 / 128.0));
    assert_eq!((tl, bl), (0.0, 0.0));
    // Far inside, the ordinary share.
    let (tl, _) = weak_pmfs(1e30);
    assert!((f64::from(tl) * 1e30 - 1.0).abs() < 0.01, "TL {tl:e}");
}
