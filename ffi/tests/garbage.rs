//! Arbitrary bit patterns through the C ABI, called from Rust: every call returns `ML_OK` or
//! `ML_ERR_INVALID_ARGUMENT` (never `ML_ERR_INTERNAL`, a caught panic), an error leaves the
//! outputs untouched and names the function, and a success never gives a NaN or a light of
//! pmf 0. Seeded, so deterministic.

mod common;
use common::message;

use manylights::Rgb;
use manylights_ffi::*;
use manylights_testkit::SplitMix64;
use std::ptr;

/// Bit patterns from testkit's SplitMix64 (from a raw state).
struct Bits(SplitMix64);

impl Bits {
    fn next(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// A float that is often ordinary and sometimes anything at all (NaN, ±∞, subnormal,
    /// huge, negative).
    fn f32(&mut self) -> f32 {
        let r = self.next();
        match r % 8 {
            0 => f32::from_bits((r >> 32) as u32),
            1 => [
                f32::NAN,
                f32::INFINITY,
                -f32::INFINITY,
                0.0,
                -0.0,
                1e30,
                -1e30,
                1e-40,
            ][(r >> 8) as usize % 8],
            _ => ((r >> 40) as f32 / (1u64 << 24) as f32) * 8.0 - 4.0,
        }
    }

    /// Uniform in [lo, hi), or one time in `wild` anything at all.
    fn val(&mut self, lo: f32, hi: f32, wild: u64) -> f32 {
        if wild > 0 && self.next() % wild == 0 {
            return self.f32();
        }
        lo + (hi - lo) * ((self.next() >> 40) as f32 / (1u64 << 24) as f32)
    }

    fn vec3(&mut self) -> ml_vec3 {
        ml_vec3 {
            x: self.f32(),
            y: self.f32(),
            z: self.f32(),
        }
    }

    fn small(&mut self, n: u64) -> u32 {
        if self.next() % 10 == 0 {
            self.next() as u32
        } else {
            (self.next() % n) as u32
        }
    }
}

fn expect_ok_or_invalid(s: ml_status, function: &str) -> bool {
    assert!(
        s == ML_OK || s == ML_ERR_INVALID_ARGUMENT,
        "{function} returned {s}: {}",
        message()
    );
    if s != ML_OK {
        assert!(
            message().starts_with(&format!("{function}: ")),
            "{}",
            message()
        );
    }
    s == ML_OK
}

/// A uniform environment of radiance 1.
extern "C" fn env_sample(
    _: *mut core::ffi::c_void,
    u0: f32,
    u1: f32,
    d: *mut ml_vec3,
    r: *mut ml_rgb,
    pdf: *mut f32,
) -> i32 {
    let z = 1.0 - 2.0 * u0;
    let s = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u1;
    // SAFETY: the library passes valid out-pointers.
    unsafe {
        *d = ml_vec3 {
            x: s * phi.cos(),
            y: s * phi.sin(),
            z,
        };
        *r = ml_rgb {
            r: 1.0,
            g: 1.0,
            b: 1.0,
        };
        *pdf = 0.25 / std::f32::consts::PI;
    }
    1
}

extern "C" fn env_eval(_: *mut core::ffi::c_void, _: ml_vec3, r: *mut ml_rgb, pdf: *mut f32) {
    // SAFETY: the library passes valid out-pointers.
    unsafe {
        *r = ml_rgb {
            r: 1.0,
            g: 1.0,
            b: 1.0,
        };
        *pdf = 0.25 / std::f32::consts::PI;
    }
}

fn sample_ok(s: &ml_sampled_light, n: usize) {
    if s.light == ML_NO_LIGHT {
        assert_eq!(s.pmf, 0.0);
    } else {
        assert!((s.light as usize) < n);
        assert!(s.pmf > 0.0 && s.pmf <= 1.0, "pmf {}", s.pmf);
    }
}

#[test]
fn arbitrary_lights_points_and_numbers() {
    let mut b = Bits(SplitMix64(0x5eed));
    let mut built = 0;
    for round in 0..1000 {
        let n = 1 + (b.next() % 40) as usize;
        // Half the rounds have one wild value in about 100, the others none.
        let wild = if round % 2 == 0 { 100 } else { 0 };
        let lights: Vec<ml_light> = (0..n)
            .map(|_| {
                let v3 = |b: &mut Bits| ml_vec3 {
                    x: b.val(-4.0, 4.0, wild),
                    y: b.val(-4.0, 4.0, wild),
                    z: b.val(-4.0, 4.0, wild),
                };
                let half = b.val(0.1, 3.0, wild);
                // Distant lights one in 128 (a set holds at most 16 lights at infinity).
                // In the wild rounds one kind in ten is any number.
                let kind = if wild > 0 && b.next() % 10 == 0 {
                    b.next() as u32
                } else {
                    match (b.next() % 128) as u32 {
                        126 => 6,
                        k => k % 6,
                    }
                };
                let two_sided = (b.next() % 2) as u32;
                let (p, d, v2) = (v3(&mut b), v3(&mut b), v3(&mut b));
                let e = {
                    let v = b.val(0.0, 2.0, wild);
                    ml_rgb { r: v, g: v, b: v }
                };
                let radius = b.val(0.01, 1.0, wild);
                let falloff_start = half * b.val(0.0, 1.0, wild);
                match kind {
                    0 => ml_point_light {
                        kind,
                        position: p,
                        intensity: e,
                    }
                    .into(),
                    1 => ml_spot_light {
                        kind,
                        position: p,
                        axis: d,
                        intensity: e,
                        half_angle: half,
                        falloff_start,
                    }
                    .into(),
                    2 => ml_sphere_light {
                        kind,
                        center: p,
                        radius,
                        radiance: e,
                    }
                    .into(),
                    3 => ml_disk_light {
                        kind,
                        center: p,
                        normal: d,
                        radius,
                        radiance: e,
                        two_sided,
                    }
                    .into(),
                    4 => ml_triangle_light {
                        kind,
                        v0: p,
                        v1: d,
                        v2,
                        radiance: e,
                        two_sided,
                    }
                    .into(),
                    5 => ml_vpl_light {
                        kind,
                        position: p,
                        normal: d,
                        intensity: e,
                    }
                    .into(),
                    6 => ml_distant_light {
                        kind,
                        direction: d,
                        angular_radius: half,
                        irradiance: e,
                    }
                    .into(),
                    _ => {
                        let mut l = ml_light::default();
                        l.kind = kind;
                        l
                    }
                }
            })
            .collect();
        // One set in four has an environment (light n), its bounds as wild as the lights.
        let env = (b.next() % 4 == 0).then(|| ml_environment {
            sample: Some(env_sample),
            eval: Some(env_eval),
            user_data: ptr::null_mut(),
            irradiance_bounds: [b.val(0.0, 2.0, wild); 6],
        });
        let env_p = env.as_ref().map_or(ptr::null(), |e| e as *const _);
        let mut tree: *mut ml_tree = ptr::null_mut();
        let s = ml_tree_build(lights.as_ptr(), n, env_p, ptr::null(), &mut tree);
        if !expect_ok_or_invalid(s, "ml_tree_build") {
            assert!(tree.is_null(), "round {round}: an output on failure");
            continue;
        }
        built += 1;
        // The lights of the tree, the environment's included.
        let n = n + usize::from(env.is_some());
        for _ in 0..50 {
            // Points: ordinary ones, and now and then anything at all.
            let w = 20;
            let v3 = |b: &mut Bits| {
                if b.next() % w == 0 {
                    b.vec3()
                } else {
                    ml_vec3 {
                        x: b.val(-5.0, 5.0, 0),
                        y: b.val(-5.0, 5.0, 0),
                        z: b.val(-5.0, 5.0, 0),
                    }
                }
            };
            let p = ml_tl_point {
                position: v3(&mut b),
                normal: v3(&mut b),
                receiver: b.small(4),
            };
            let sp = ml_shading_point {
                position: v3(&mut b),
                normal: v3(&mut b),
                wo: v3(&mut b),
                material: ml_material {
                    kind: b.small(3),
                    albedo: Rgb::grey(b.val(0.0, 1.0, w)).into(),
                    specular: b.val(0.0, 1.0, w),
                    alpha: b.val(0.0, 1.0, w),
                },
            };
            let u = b.val(0.0, 1.0, w);
            let light = b.small(n as u64 + 1);
            let mut out = ml_sampled_light {
                light: 77,
                pmf: -1.0,
            };
            let mut q = -1.0f32;
            if expect_ok_or_invalid(
                ml_tree_sample_tl(tree, &p, u, &mut out),
                "ml_tree_sample_tl",
            ) {
                sample_ok(&out, n);
            } else {
                assert_eq!((out.light, out.pmf), (77, -1.0));
            }
            if expect_ok_or_invalid(ml_tree_pmf_tl(tree, &p, light, &mut q), "ml_tree_pmf_tl") {
                assert!((0.0..=1.0).contains(&q));
            }
            if expect_ok_or_invalid(
                ml_tree_sample_bl(tree, &sp, u, &mut out),
                "ml_tree_sample_bl",
            ) {
                sample_ok(&out, n);
            }
            if expect_ok_or_invalid(ml_tree_pmf_bl(tree, &sp, light, &mut q), "ml_tree_pmf_bl") {
                assert!((0.0..=1.0).contains(&q));
            }
            let mut lp = ml_light_point::default();
            if expect_ok_or_invalid(
                ml_light_sample_point(tree, light, p.position, u, b.val(0.0, 1.0, w), &mut lp),
                "ml_light_sample_point",
            ) && lp.pdf > 0.0
            {
                assert!(
                    lp.pdf.is_finite()
                        && manylights::Rgb::from(lp.radiance).is_finite()
                        && lp.distance > 0.0
                );
            }
            let mut d = ml_brdf_draw::default();
            if expect_ok_or_invalid(
                ml_brdf_sample(&sp, u, b.val(0.0, 1.0, w), &mut d),
                "ml_brdf_sample",
            ) {
                let v = manylights::Rgb::from(d.value);
                assert!(d.pdf.is_finite() && d.pdf >= 0.0 && v.is_finite());
                assert!(v.r >= 0.0 && v.g >= 0.0 && v.b >= 0.0);
            }
            let mut cut: *mut ml_cut = ptr::null_mut();
            assert_eq!(ml_cut_create(&mut cut), ML_OK);
            if expect_ok_or_invalid(
                ml_cut_build_bl(cut, tree, &sp, ptr::null()),
                "ml_cut_build_bl",
            ) {
                let mut ib = -1.0;
                assert_eq!(ml_cut_ib(cut, &mut ib), ML_OK);
                assert!(ib.is_finite() && ib >= 0.0);
                if expect_ok_or_invalid(ml_cut_sample(cut, u, &mut out), "ml_cut_sample") {
                    sample_ok(&out, n);
                }
            }
            assert_eq!(ml_cut_free(cut), ML_OK);
        }
        assert_eq!(ml_tree_free(tree), ML_OK);
    }
    eprintln!("{built} of 1000 random light sets were valid");
    assert!(
        built > 300,
        "only {built} of 1000 random light sets were valid"
    );
}
