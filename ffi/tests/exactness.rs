//! What is exact between the one call and the lower level driven by a host through the ABI
//! with the library's own BRDF (`ml_brdf_sample`, `ml_brdf_eval`, `ml_brdf_pdf`), as
//! `ffi/README.md` states it:
//!
//! - exact: the steps (lights, points, pmfs, BSDF uniform numbers) for the same uniform
//!   numbers; `ml_brdf_eval` and `ml_brdf_pdf` of a light step's `point.direction` are the
//!   one call's f and BSDF pdf bit for bit; `ml_brdf_sample`'s draw is the one call's BSDF
//!   sample (its pdf and value bit for bit);
//! - not exact: the host's own arithmetic (its cos θi, its products with `scale`, its sum)
//!   rounds differently from the one call's, and `ml_brdf_pdf` of a draw's world-space `wi`
//!   recomputes the pdf after a round trip through the shading frame.
//!
//! The bounds checked are the f32 rounding those differences allow (derived below).

mod common;
use common::{mixed_light, ok, uniforms};

use manylights_ffi::*;
// The host's generator.
use manylights_testkit::SplitMix64 as Rng;
use std::ffi::c_void;
use std::ptr;

fn v3(x: f32, y: f32, z: f32) -> ml_vec3 {
    ml_vec3 { x, y, z }
}

/// A grey colour.
fn grey(v: f32) -> ml_rgb {
    ml_rgb { r: v, g: v, b: v }
}

fn dot(a: ml_vec3, b: ml_vec3) -> f32 {
    a.x * b.x + a.y * b.y + a.z * b.z
}

fn lights(r: &mut Rng) -> Vec<ml_light> {
    (0..300)
        .map(|i| {
            let p = v3(r.range(-4.0, 4.0), r.range(-4.0, 4.0), r.range(0.5, 4.0));
            let e = grey(r.range(0.5, 3.0));
            mixed_light(i, p, e, r)
        })
        .collect()
}

fn shading_point(r: &mut Rng) -> ml_shading_point {
    let n = v3(r.range(-0.3, 0.3), r.range(-0.3, 0.3), 1.0);
    let alpha = [0.005, 0.02, 0.1, 0.4, 1.0][(r.next_u64() % 5) as usize];
    ml_shading_point {
        position: v3(r.range(-2.0, 2.0), r.range(-2.0, 2.0), 0.0),
        normal: n,
        wo: v3(r.range(-0.8, 0.8), r.range(-0.8, 0.8), 1.0),
        material: ml_material {
            kind: ml_material_kind::Plastic as u32,
            albedo: grey(0.4),
            specular: 0.6,
            alpha,
        },
    }
}

/// The channels of a colour.
fn channels(c: ml_rgb) -> [f32; 3] {
    [c.r, c.g, c.b]
}

/// What the host's hit callback adds up, per channel.
struct Hits {
    sum: [f64; 3],
    f: ml_rgb,
    cos: f32,
}

unsafe extern "C" fn on_hit(user: *mut c_void, hit: *const ml_light_hit) {
    let h = &mut *(user as *mut Hits);
    let hit = &*hit;
    let (f, radiance) = (channels(h.f), channels(hit.point.radiance));
    for c in 0..3 {
        let value = f[c] * radiance[c] * h.cos;
        if value > 0.0 {
            h.sum[c] += f64::from(value * hit.weighted.scale);
        }
    }
}

/// The host's estimate through the lower level with the library's BRDF, per channel: its own
/// cos θi (the dot product with its unit normal), products and sums. Checks that
/// `ml_brdf_eval` and `ml_brdf_pdf` of each light step's direction, and `ml_brdf_sample`'s
/// draw, are the core material's (`Material::eval_rgb`, `Brdf::pdf`) bit for bit.
fn host_estimate(
    est: *mut ml_estimator,
    sp: &ml_shading_point,
    n: ml_vec3,
    u: &ml_uniforms,
    light_checks: &mut (u32, u32),
) -> [f64; 3] {
    ok(ml_estimator_start(est));
    let mut sum = [0.0f64; 3];
    loop {
        let mut s = ml_step::default();
        ok(ml_estimator_next(est, u, &mut s));
        if s.kind == ml_step_kind::Done as u32 {
            return sum;
        }
        if s.kind == ml_step_kind::Light as u32 {
            let d = s.point.direction;
            let c = dot(n, d);
            let radiance = channels(s.point.radiance);
            if c <= 0.0 || radiance.iter().all(|&l| l <= 0.0) {
                continue;
            }
            let mut f = ml_rgb::default();
            ok(ml_brdf_eval(sp, d, &mut f));
            let mut pdf = 0.0;
            ok(ml_brdf_pdf(sp, d, &mut pdf));
            // Bit for bit the one call's f (each channel) and BSDF pdf of the light point.
            let (core_f, core_pdf) = core_value(sp, d);
            assert_eq!(
                (channels(f).map(f32::to_bits), pdf.to_bits()),
                (
                    [core_f.r, core_f.g, core_f.b].map(f32::to_bits),
                    core_pdf.to_bits()
                )
            );
            if s.needs_bsdf_pdf == 0 {
                pdf = 0.0;
            }
            light_checks.1 += 1;
            let value = [0, 1, 2].map(|k| channels(f)[k] * radiance[k] * c);
            if value.iter().all(|&v| v <= 0.0) {
                continue;
            }
            let mut w = ml_weighted::default();
            ok(ml_estimator_weigh(est, pdf, &mut w));
            for k in 0..3 {
                if value[k] > 0.0 {
                    sum[k] += f64::from(value[k] * w.scale);
                }
            }
        } else {
            let mut d = ml_brdf_draw::default();
            ok(ml_brdf_sample(sp, s.u0, s.u1, &mut d));
            // Bit for bit the core material's draw: its pdf, and f in every channel.
            let (core_pdf, core_f) = core_draw(sp, s.u0, s.u1);
            assert_eq!(
                (d.pdf.to_bits(), channels(d.value).map(f32::to_bits)),
                (
                    core_pdf.to_bits(),
                    [core_f.r, core_f.g, core_f.b].map(f32::to_bits)
                )
            );
            if d.pdf <= 0.0 {
                continue;
            }
            let mut h = Hits {
                sum: [0.0; 3],
                f: d.value,
                cos: dot(n, d.wi),
            };
            let mut any = 0;
            ok(ml_estimator_bsdf_hits(
                est,
                d.wi,
                d.pdf,
                f32::INFINITY,
                Some(on_hit),
                &mut h as *mut Hits as *mut c_void,
                &mut any,
            ));
            light_checks.0 += 1;
            for (total, hit) in sum.iter_mut().zip(h.sum) {
                *total += hit;
            }
        }
    }
}

fn vec(v: ml_vec3) -> glam::Vec3 {
    glam::Vec3::new(v.x, v.y, v.z)
}

/// The core's material of a (plastic) shading point, its shading frame and ωo in it, as
/// `Estimator::estimate` sets them up.
fn core_material(sp: &ml_shading_point) -> (manylights::Material, manylights::Frame, glam::Vec3) {
    use manylights::{Frame, Material};
    let m = &sp.material;
    let material = Material::Plastic {
        albedo: m.albedo.into(),
        specular: m.specular,
        alpha: m.alpha,
    };
    let frame = Frame::from_normal(vec(sp.normal)).unwrap();
    let wo = frame.to_local(vec(sp.wo).normalize());
    (material, frame, wo)
}

/// The one call's f (per channel, `Material::eval_rgb`) and BSDF pdf of a light point's
/// direction, computed with the core as `Estimator::estimate` computes them (the light
/// point's direction into the shading frame, unnormalised).
fn core_value(sp: &ml_shading_point, d: ml_vec3) -> (manylights::Rgb, f32) {
    use manylights::Brdf;
    let (material, frame, wo) = core_material(sp);
    let wi = frame.to_local(vec(d));
    (material.eval_rgb(wo, wi), material.pdf(wo, wi))
}

/// The one call's BSDF sample for `u0`, `u1`: its pdf and f per channel (0 and black when
/// there is none).
fn core_draw(sp: &ml_shading_point, u0: f32, u1: f32) -> (f32, manylights::Rgb) {
    use manylights::Brdf;
    let (material, _, wo) = core_material(sp);
    match material.sample(wo, [u0, u1]) {
        Some((wi, pdf)) => (pdf, material.eval_rgb(wo, wi)),
        None => (0.0, manylights::Rgb::grey(0.0)),
    }
}

fn unit(v: ml_vec3) -> ml_vec3 {
    let l = dot(v, v).sqrt();
    v3(v.x / l, v.y / l, v.z / l)
}

/// The host's estimates through the lower level against the one call's, channel by channel,
/// at 300 shading points of albedo `albedo` (every technique, 10 estimates each); returns the
/// worst relative difference and the largest relative spread of a light step's f over the
/// channels (0 for a grey albedo).
fn lower_level_against_one_call(albedo: ml_rgb) -> (f64, f32) {
    let mut r = Rng(2027);
    let ls = lights(&mut r);
    let mut tree = ptr::null_mut();
    ok(ml_tree_build(
        ls.as_ptr(),
        ls.len(),
        ptr::null(),
        ptr::null(),
        &mut tree,
    ));
    let mut est = ptr::null_mut();
    ok(ml_estimator_create(tree, &mut est));
    let mut worst = 0.0f64;
    let mut counts = (0u32, 0u32);
    let mut compared = 0;
    let mut spread = 0.0f32;
    for k in 0..300 {
        let mut sp = shading_point(&mut r);
        sp.material.albedo = albedo;
        let n = unit(sp.normal);
        let technique = (k % 9) as u32;
        ok(ml_estimator_set_point(est, &sp, technique, ptr::null()));
        for _ in 0..10 {
            let seed = r.next_u64();
            let (mut a, mut b) = (Rng(seed), Rng(seed));
            let (ua, ub) = (uniforms(&mut a), uniforms(&mut b));
            let mut one = ml_rgb64::default();
            ok(ml_estimator_estimate(est, ptr::null(), &ua, &mut one));
            let host = host_estimate(est, &sp, n, &ub, &mut counts);
            // The same uniform numbers were drawn.
            assert_eq!(a.0, b.0, "technique {technique}");
            let lo = host.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = host.iter().copied().fold(0.0, f64::max);
            if lo > 0.0 {
                spread = spread.max((hi / lo - 1.0) as f32);
            }
            for (c, (host, one)) in host.into_iter().zip([one.r, one.g, one.b]).enumerate() {
                let rel = (host - one).abs() / one.abs().max(1e-30);
                if one > 0.0 {
                    worst = worst.max(rel);
                    compared += 1;
                }
                // Per term: f, the pdfs and the weights are the one call's; the host's cos θi
                // (its own unit normal and dot product) and its two f32 products differ from
                // the one call's by a few units in the last place each: 1e-5 relative leaves
                // a wide margin over 2⁻²⁴ ≈ 6e-8 per rounding, except where a term's cos θi
                // is itself tiny (grazing light), which the margin covers.
                assert!(
                    rel <= 1e-5 || (host - one).abs() <= 1e-9,
                    "technique {technique}, channel {c}: one call {one}, host {host} (rel {rel:e})"
                );
            }
        }
    }
    eprintln!(
        "{compared} estimates: worst relative difference host vs one call {worst:e} ({} BSDF hits reported, {} light steps)",
        counts.0, counts.1
    );
    ok(ml_estimator_free(est));
    ok(ml_tree_free(tree));
    (worst, spread)
}

#[test]
fn the_lower_level_with_the_librarys_brdf_is_the_one_call_up_to_the_hosts_rounding() {
    // Grey lights and albedo: every channel is the same estimate.
    let (_, spread) = lower_level_against_one_call(grey(0.4));
    assert_eq!(spread, 0.0);
}

#[test]
fn an_rgb_albedo_gives_each_channels_f_through_the_lower_level() {
    // Each light step's f from `ml_brdf_eval` and each draw's `value` are
    // `Material::eval_rgb`'s channels bit for bit (checked in `host_estimate`), and the host's
    // estimate of each channel is the one call's.
    let albedo = ml_rgb {
        r: 0.8,
        g: 0.3,
        b: 0.05,
    };
    let (_, spread) = lower_level_against_one_call(albedo);
    // The channels differ: red reflects more than blue wherever the diffuse lobe counts.
    assert!(
        spread > 0.5,
        "the channels' estimates differ by at most {spread}"
    );
}

#[test]
fn brdf_sample_pdf_against_brdf_pdf_of_its_direction() {
    let mut r = Rng(99);
    let mut worst = [0.0f64; 5];
    for _ in 0..40_000 {
        let sp = shading_point(&mut r);
        let mut d = ml_brdf_draw::default();
        ok(ml_brdf_sample(&sp, r.f32(), r.f32(), &mut d));
        if d.pdf <= 0.0 {
            continue;
        }
        let (mut q, mut f) = (0.0, ml_rgb::default());
        ok(ml_brdf_pdf(&sp, d.wi, &mut q));
        ok(ml_brdf_eval(&sp, d.wi, &mut f));
        let (f, value) = (f.g, d.value.g);
        let i = [0.005, 0.02, 0.1, 0.4, 1.0]
            .iter()
            .position(|&a| a == sp.material.alpha)
            .unwrap();
        let rel = (f64::from(q) / f64::from(d.pdf) - 1.0).abs();
        worst[i] = worst[i].max(rel);
        // The round trip world → local moves wi by a few ulp; the pdf of a GGX lobe of
        // roughness α changes by about |∂ ln D / ∂θ| · δθ ≈ (2θ/α²) · δθ near the peak, which
        // at α = 0.005 and δθ ≈ 1e-7 is up to 1e-2·θ: bounded here by 1e-3 overall.
        assert!(rel <= 1e-3, "alpha {}: {} vs {q}", sp.material.alpha, d.pdf);
        assert!((f64::from(f) / f64::from(value) - 1.0).abs() <= 1e-3);
    }
    eprintln!("worst relative pdf difference by alpha [0.005, 0.02, 0.1, 0.4, 1]: {worst:?}");
}
