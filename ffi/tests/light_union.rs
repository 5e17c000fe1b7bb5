//! `ml_light`, the union of one struct per kind: the descriptor `ml_light::from(&Light)` gives
//! for every kind builds, through `ml_tree_build`, the tree `LightTree::build` builds from the
//! same lights, byte for byte; errors name the kind's member and field.

mod common;
use common::{message, ok};

use glam::Vec3;
use manylights::{Light, LightTree, Rgb};
use manylights_ffi::*;
use manylights_testkit::SplitMix64 as Rng;
use std::ptr;

fn point(r: &mut Rng) -> Vec3 {
    Vec3::new(r.range(-5.0, 5.0), r.range(-5.0, 5.0), r.range(-5.0, 5.0))
}

fn colour(r: &mut Rng) -> Rgb {
    Rgb::new(r.range(0.1, 2.0), r.range(0.1, 2.0), r.range(0.1, 2.0))
}

/// Light `i` of a seeded set: every kind in turn (a distant light one in 7, 4 at most).
fn light(r: &mut Rng, i: usize) -> Light {
    let p = point(r);
    match i % 7 {
        0 => Light::Point {
            position: p,
            intensity: colour(r),
        },
        1 => {
            let half_angle = r.range(0.1, 3.0);
            Light::Spot {
                position: p,
                direction: point(r),
                intensity: colour(r),
                half_angle,
                falloff_start: half_angle * r.range(0.0, 1.0),
            }
        }
        2 => Light::Sphere {
            center: p,
            radius: r.range(0.01, 0.5),
            radiance: colour(r),
        },
        3 => Light::Disk {
            center: p,
            normal: point(r),
            radius: r.range(0.01, 0.5),
            radiance: colour(r),
            two_sided: i % 2 == 0,
        },
        4 => Light::Triangle {
            vertices: [
                p,
                p + Vec3::new(0.3, 0.0, 0.1),
                p + Vec3::new(0.0, 0.2, r.range(0.0, 0.1)),
            ],
            radiance: colour(r),
            two_sided: i % 2 == 1,
        },
        5 => Light::Vpl {
            position: p,
            normal: point(r),
            intensity: colour(r),
        },
        _ => Light::Distant {
            direction: point(r),
            angular_radius: if i < 20 { 0.0 } else { r.range(0.0, 0.2) },
            irradiance: colour(r),
        },
    }
}

fn serialize(t: *const ml_tree) -> Vec<u8> {
    let mut size = 0;
    ok(ml_tree_serialized_size(t, &mut size));
    let mut bytes = vec![0u8; size];
    let mut written = 0;
    ok(ml_tree_serialize(t, bytes.as_mut_ptr(), size, &mut written));
    assert_eq!(written, size);
    bytes
}

#[test]
fn every_kind_round_trips_through_ml_tree_build() {
    let mut r = Rng(44);
    for n in [1usize, 7, 28, 200] {
        let lights: Vec<Light> = (0..n)
            .map(|i| light(&mut r, i))
            .filter(|l| !matches!(l, Light::Distant { .. }) || n <= 28)
            .collect();
        let descs: Vec<ml_light> = lights.iter().map(ml_light::from).collect();
        // Each descriptor holds its light in the member its kind names.
        for (l, d) in lights.iter().zip(&descs) {
            let kind = match l {
                Light::Point { .. } => ml_light_kind::Point,
                Light::Spot { .. } => ml_light_kind::Spot,
                Light::Sphere { .. } => ml_light_kind::Sphere,
                Light::Disk { .. } => ml_light_kind::Disk,
                Light::Triangle { .. } => ml_light_kind::Triangle,
                Light::Vpl { .. } => ml_light_kind::Vpl,
                _ => ml_light_kind::Distant,
            };
            assert_eq!(d.kind(), kind as u32);
            assert_eq!(*d, ml_light::from(l));
        }
        let mut t = ptr::null_mut();
        ok(ml_tree_build(
            descs.as_ptr(),
            descs.len(),
            ptr::null(),
            ptr::null(),
            &mut t,
        ));
        let core = LightTree::build(&lights).expect("the core builds the same lights");
        assert_eq!(serialize(t), core.as_bytes(), "{n} lights");
        ok(ml_tree_free(t));
    }
}

#[test]
fn the_union_is_zeroed_by_default_and_reads_the_member_of_its_kind() {
    assert_eq!(
        std::mem::size_of::<ml_light>(),
        std::mem::size_of::<ml_triangle_light>()
    );
    let z = ml_light::default();
    assert_eq!(z.kind(), ml_light_kind::Point as u32);
    assert_eq!(z, ml_point_light::default().into());
    let s = ml_light::from(ml_sphere_light {
        kind: ml_light_kind::Sphere as u32,
        center: ml_vec3 {
            x: 1.0,
            y: 2.0,
            z: 3.0,
        },
        radius: 0.5,
        radiance: ml_rgb {
            r: 1.0,
            g: 1.0,
            b: 1.0,
        },
    });
    assert_eq!(s.kind(), ml_light_kind::Sphere as u32);
    assert_ne!(s, z);
    assert!(format!("{s:?}").contains("radius: 0.5"));
    let mut unknown = ml_light::default();
    unknown.kind = 99;
    assert_eq!(format!("{unknown:?}"), "ml_light { kind: 99 }");
}

#[test]
fn errors_name_the_member_and_field() {
    let cases: [(Light, &str); 6] = [
        (
            Light::Sphere {
                center: Vec3::ZERO,
                radius: -1.0,
                radiance: Rgb::grey(1.0),
            },
            "lights[0].sphere.radius must be positive (got -1)",
        ),
        (
            Light::Spot {
                position: Vec3::ZERO,
                direction: Vec3::ZERO,
                intensity: Rgb::grey(1.0),
                half_angle: 1.0,
                falloff_start: 0.5,
            },
            "lights[0].spot.axis has zero length",
        ),
        (
            Light::Disk {
                center: Vec3::ZERO,
                normal: Vec3::Z,
                radius: 1.0,
                radiance: Rgb::new(1.0, -2.0, 1.0),
                two_sided: false,
            },
            "lights[0].disk.radiance is negative (got -2)",
        ),
        (
            Light::Triangle {
                vertices: [Vec3::ZERO, Vec3::X, Vec3::new(0.0, f32::NAN, 0.0)],
                radiance: Rgb::grey(1.0),
                two_sided: false,
            },
            "lights[0].triangle.v2 is NaN or infinite",
        ),
        (
            Light::Vpl {
                position: Vec3::ZERO,
                normal: Vec3::ZERO,
                intensity: Rgb::grey(1.0),
            },
            "lights[0].vpl.normal has zero length",
        ),
        (
            Light::Distant {
                direction: Vec3::Z,
                angular_radius: 2.0,
                irradiance: Rgb::grey(1.0),
            },
            "lights[0].distant.angular_radius must be in [0, pi/2] (got 2)",
        ),
    ];
    for (l, want) in cases {
        let d = ml_light::from(&l);
        let mut t = ptr::null_mut();
        let s = ml_tree_build(&d, 1, ptr::null(), ptr::null(), &mut t);
        assert_eq!(s, ML_ERR_INVALID_ARGUMENT);
        assert!(t.is_null());
        let m = message();
        assert!(m.contains(want), "{m:?} does not contain {want:?}");
    }
    let mut d = ml_light::from(&Light::Disk {
        center: Vec3::ZERO,
        normal: Vec3::Z,
        radius: 1.0,
        radiance: Rgb::grey(1.0),
        two_sided: false,
    });
    d.disk.two_sided = 3;
    let mut t = ptr::null_mut();
    assert_eq!(
        ml_tree_build(&d, 1, ptr::null(), ptr::null(), &mut t),
        ML_ERR_INVALID_ARGUMENT
    );
    assert!(message().contains("lights[0].disk.two_sided must be 0 or 1 (got 3)"));
}
