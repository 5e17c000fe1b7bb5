//! The batches for wavefront hosts are the single calls, bit for bit: points on lights for
//! many (light, x, u) triples equal `sample_point`, and `estimate_each` equals the per-point
//! set-up and its estimates made one after the other, for every technique, drawing the same
//! uniform numbers; bad input is an error naming the element, before any estimate.

mod common;

use common::Rng;
use glam::Vec3;
use manylights::direct::{DirectError, Estimator, Params, Technique, Unoccluded};
use manylights::light::sample_point;
use manylights::wavefront::{estimate_each, sample_points, BatchError};
use manylights::{LengthMismatch, LightSet, Material, Rgb, ShadingPoint};
use manylights_testkit::TestUniforms;

fn scene() -> LightSet {
    let mut rng = Rng::new(31);
    let spec = common::SceneSpec {
        half: 5.0,
        kinds: [1, 1, 1, 1, 1, 1],
        ..common::SceneSpec::default()
    };
    LightSet::build(common::random_scene(&mut rng, 200, &spec)).unwrap()
}

fn points(rng: &mut Rng, m: usize) -> Vec<ShadingPoint> {
    (0..m)
        .map(|i| ShadingPoint {
            position: rng.in_cube(5.0),
            normal: rng.unit(),
            wo: rng.unit(),
            material: if i % 2 == 0 {
                Material::Lambert {
                    albedo: Rgb::grey(0.6),
                }
            } else {
                Material::Plastic {
                    albedo: Rgb::grey(0.3),
                    specular: 0.7,
                    alpha: rng.range(0.05, 0.9),
                }
            },
        })
        .collect()
}

#[test]
fn points_on_lights_in_a_batch_are_the_single_calls() {
    let set = scene();
    let mut rng = Rng::new(5);
    let n = 1000;
    let which: Vec<u32> = (0..n).map(|_| rng.below(210) as u32).collect(); // some out of range
    let xs: Vec<Vec3> = (0..n).map(|_| rng.in_cube(6.0)).collect();
    let us: Vec<[f32; 2]> = (0..n).map(|_| rng.u2()).collect();
    let mut out = vec![None; n];
    sample_points(set.lights(), &which, &xs, &us, &mut out).unwrap();
    let mut some = 0;
    for j in 0..n {
        let single = set
            .lights()
            .get(which[j] as usize)
            .and_then(|l| sample_point(l, xs[j], us[j]));
        assert_eq!(out[j], single, "{j}");
        some += usize::from(single.is_some());
    }
    assert!(some > n / 2);
    assert_eq!(
        sample_points(set.lights(), &which, &xs[1..], &us, &mut out),
        Err(LengthMismatch {
            what: "xs",
            expected: n,
            got: n - 1
        })
    );
}

#[test]
fn estimates_in_a_batch_are_the_set_up_and_estimates_one_after_the_other() {
    let set = scene();
    let mut rng = Rng::new(6);
    let pts = points(&mut rng, 30);
    let params = Params::default();
    for t in Technique::ALL {
        for per_point in [1, 4] {
            let seed = rng.next_u64();
            let mut batch = vec![[-1.0; 3]; pts.len() * per_point];
            let mut ub = TestUniforms::new(seed);
            estimate_each(
                &set,
                &pts,
                per_point,
                t,
                &params,
                &Unoccluded,
                &mut ub,
                &mut batch,
            )
            .unwrap();
            let mut us = TestUniforms::new(seed);
            for (j, sp) in pts.iter().enumerate() {
                let mut est = Estimator::new(&set, sp, t, &params).unwrap();
                for i in 0..per_point {
                    let e = est.estimate(&Unoccluded, &mut us).unwrap();
                    assert_eq!(
                        e.map(f64::to_bits),
                        batch[j * per_point + i].map(f64::to_bits),
                        "{t}"
                    );
                }
            }
            assert_eq!(
                ub.0.next_u64(),
                us.0.next_u64(),
                "{t}: the same numbers drawn"
            );
        }
    }
}

#[test]
fn a_bad_batch_names_the_element_before_any_estimate() {
    let set = scene();
    let mut rng = Rng::new(7);
    let mut pts = points(&mut rng, 5);
    let mut out = vec![[0.0; 3]; 10];
    let mut u = TestUniforms::new(1);
    let t = Technique::DEFAULT;
    let p = Params::default();
    assert!(matches!(
        estimate_each(&set, &pts, 3, t, &p, &Unoccluded, &mut u, &mut out),
        Err(BatchError::Length(_))
    ));
    assert!(matches!(
        estimate_each(&set, &pts, 0, t, &p, &Unoccluded, &mut u, &mut []),
        Err(BatchError::Length(_))
    ));
    pts[3].normal = Vec3::ZERO;
    let before = u.0.clone();
    let e = estimate_each(&set, &pts, 2, t, &p, &Unoccluded, &mut u, &mut out).unwrap_err();
    assert!(
        matches!(
            e,
            BatchError::Point {
                index: 3,
                error: DirectError::Shading(_)
            }
        ),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .starts_with("points[3]: shading point: field `normal`"),
        "{e}"
    );
    assert_eq!(u.0.next_u64(), before.clone().next_u64(), "no number drawn");
}
