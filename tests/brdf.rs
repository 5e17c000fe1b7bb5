//! BRDF helpers: sampled pdfs equal queried ones, pdfs integrate to the probability of a sample,
//! the directional albedo from uniform hemisphere samples matches the VNDF estimate, χ² of the
//! sampled directions against the pdf, reciprocity, white furnace, degenerate inputs, and the
//! shading frame.
//!
//! Statistical tolerances are `K_SIGMA` standard errors computed from the samples (stratified
//! samples use the i.i.d. formula, which overestimates their error: conservative), plus a
//! 1e-4 absolute slack for f32 rounding. Seeds are fixed.

mod common;

use common::{Rng, Stats};
use glam::{DVec3, Vec3};
use manylights::internals::brdf::schlick;
use manylights::material::MIN_ALPHA;
use manylights::Rgb;
use manylights::{Brdf, Frame, Ggx, Lambert, Material};
use std::f64::consts::PI;

const K_SIGMA: f64 = 5.0;
const ALPHAS: [f32; 4] = [0.05, 0.2, 0.6, 1.0];
/// View angles in degrees.
const VIEWS: [f64; 6] = [0.0, 30.0, 60.0, 75.0, 85.0, 89.5];
const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// The upper-hemisphere direction with cos θ = z and azimuth 2π·v (uniform in solid angle for
/// z, v uniform).
fn hemisphere(z: f64, v: f64) -> Vec3 {
    let s = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * v;
    DVec3::new(s * phi.cos(), s * phi.sin(), z)
        .normalize()
        .as_vec3()
}

/// Uniform direction on the upper hemisphere.
fn upper(rng: &mut Rng) -> Vec3 {
    hemisphere(rng.f64(), rng.f64())
}

/// The view direction at `deg` degrees from the normal, at an arbitrary azimuth.
fn view(deg: f64) -> Vec3 {
    let t = deg.to_radians();
    DVec3::new(t.sin() * 0.7f64.cos(), t.sin() * 0.7f64.sin(), t.cos())
        .normalize()
        .as_vec3()
}

/// `∫ g(wi) dwi` over the upper hemisphere by `m`×`m` stratified uniform samples.
fn stratified(m: usize, rng: &mut Rng, mut g: impl FnMut(Vec3) -> f64) -> Stats {
    let mut st = Stats::default();
    for i in 0..m {
        for j in 0..m {
            let z = (i as f64 + rng.f64()) / m as f64;
            let v = (j as f64 + rng.f64()) / m as f64;
            st.add(g(hemisphere(z, v)) * 2.0 * PI);
        }
    }
    st
}

fn materials() -> Vec<(String, Box<dyn Brdf>)> {
    let mut v: Vec<(String, Box<dyn Brdf>)> = Vec::new();
    for a in [MIN_ALPHA, 0.05, 0.2, 0.6, 1.0] {
        v.push((format!("ggx α={a}"), Box::new(Ggx::new(a))));
    }
    v.push(("lambert".into(), Box::new(Lambert::new(0.8))));
    v.push((
        "plastic".into(),
        Box::new(Material::Plastic {
            albedo: Rgb::grey(0.5),
            specular: 0.3,
            alpha: 0.1,
        }),
    ));
    v.push((
        "material ggx".into(),
        Box::new(Material::Ggx {
            alpha: 0.3,
            specular: 0.9,
        }),
    ));
    v
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(f64::MIN_POSITIVE)
}

// ---------------------------------------------------------------------------------------------
// Sampling and pdfs
// ---------------------------------------------------------------------------------------------

#[test]
fn sampled_pdf_equals_pdf() {
    let mut rng = Rng::new(1);
    for (name, brdf) in materials() {
        for deg in VIEWS {
            let wo = view(deg);
            for i in 0..20_000 {
                let u = match i {
                    0 => [0.0, 0.0],
                    1 => [ONE_MINUS_EPS, ONE_MINUS_EPS],
                    2 => [0.0, ONE_MINUS_EPS],
                    3 => [ONE_MINUS_EPS, 0.0],
                    _ => rng.u2(),
                };
                let Some((wi, pdf)) = brdf.sample(wo, u) else {
                    continue;
                };
                assert!(
                    (wi.length() - 1.0).abs() < 1e-5 && wi.z > 0.0,
                    "{name} θo={deg}: {wi}"
                );
                assert!(pdf > 0.0 && pdf.is_finite(), "{name} θo={deg}: {pdf}");
                let q = brdf.pdf(wo, wi);
                assert!(
                    rel(f64::from(pdf), f64::from(q)) <= 1e-4,
                    "{name} θo={deg}: sampled pdf {pdf} vs pdf() {q}"
                );
                let f = brdf.eval(wo, wi);
                assert!(f.is_finite() && f >= 0.0, "{name}: f = {f}");
            }
        }
    }
}

/// ∫ pdf(wo, wi) dwi over the upper hemisphere equals the probability that `sample` returns a
/// direction (1 for Lambert; GGX loses the directions reflected below the horizon).
#[test]
fn pdf_integrates_to_probability_of_a_sample() {
    let mut rng = Rng::new(2);
    for (name, brdf) in materials() {
        if name.contains(&format!("{}", MIN_ALPHA)) {
            continue; // a 1e-4 sr lobe: uniform samples cannot resolve it (see white_furnace)
        }
        for deg in VIEWS {
            let wo = view(deg);
            let integral = stratified(512, &mut rng, |wi| f64::from(brdf.pdf(wo, wi)));
            let mut hits = Stats::default();
            for _ in 0..200_000 {
                hits.add(brdf.sample(wo, rng.u2()).is_some() as u8 as f64);
            }
            let (a, b) = (integral.mean(), hits.mean());
            let tol = K_SIGMA * (integral.se().powi(2) + hits.se().powi(2)).sqrt() + 1e-4;
            assert!(
                (a - b).abs() <= tol,
                "{name} θo={deg}: ∫pdf = {a} ± {}, P(sample) = {b} ± {}",
                integral.se(),
                hits.se()
            );
            if name == "lambert" {
                assert_eq!(b, 1.0);
            }
        }
    }
}

/// The directional albedo ∫ f cos θi dwi from stratified uniform hemisphere samples matches the
/// importance-sampled estimate E[f cos θi / pdf] (a draw without a direction counts 0).
#[test]
fn albedo_uniform_matches_importance_sampled() {
    let mut rng = Rng::new(3);
    for (name, brdf) in materials() {
        if name.contains(&format!("{}", MIN_ALPHA)) {
            continue;
        }
        for deg in VIEWS {
            let wo = view(deg);
            let uniform = stratified(512, &mut rng, |wi| {
                f64::from(brdf.eval(wo, wi)) * f64::from(wi.z)
            });
            let mut sampled = Stats::default();
            for _ in 0..200_000 {
                sampled.add(brdf.sample(wo, rng.u2()).map_or(0.0, |(wi, pdf)| {
                    f64::from(brdf.eval(wo, wi)) * f64::from(wi.z) / f64::from(pdf)
                }));
            }
            let (a, b) = (uniform.mean(), sampled.mean());
            let tol = K_SIGMA * (uniform.se().powi(2) + sampled.se().powi(2)).sqrt() + 1e-4;
            assert!(
                (a - b).abs() <= tol,
                "{name} θo={deg}: uniform {a} ± {}, sampled {b} ± {}",
                uniform.se(),
                sampled.se()
            );
        }
    }
}

/// Pearson χ² of VNDF (and cosine) samples in 16 × 16 cells of (cos θ, φ) plus a "no sample"
/// cell, against probabilities integrated from `pdf` (32 × 32 midpoints per cell).
#[test]
fn sampled_directions_follow_pdf() {
    let mut rng = Rng::new(4);
    let (nz, nphi, sub) = (16usize, 16usize, 32usize);
    let n = 200_000u64;
    for (name, brdf) in materials() {
        if name.contains("0.05") || name.contains(&format!("{}", MIN_ALPHA)) {
            continue; // lobes narrower than a cell
        }
        for deg in [0.0, 45.0, 80.0] {
            let wo = view(deg);
            let mut expected = vec![0.0f64; nz * nphi + 1];
            let cell = (1.0 / nz as f64) * (2.0 * PI / nphi as f64) / (sub * sub) as f64;
            for iz in 0..nz {
                for ip in 0..nphi {
                    let mut p = 0.0;
                    for a in 0..sub {
                        for b in 0..sub {
                            let z = (iz as f64 + (a as f64 + 0.5) / sub as f64) / nz as f64;
                            let v = (ip as f64 + (b as f64 + 0.5) / sub as f64) / nphi as f64;
                            p += f64::from(brdf.pdf(wo, hemisphere(z, v))) * cell;
                        }
                    }
                    expected[iz * nphi + ip] = p * n as f64;
                }
            }
            let total: f64 = expected.iter().sum();
            expected[nz * nphi] = (n as f64 - total).max(0.0);
            let mut counts = vec![0u64; nz * nphi + 1];
            for _ in 0..n {
                match brdf.sample(wo, rng.u2()) {
                    Some((wi, _)) => {
                        let iz = ((f64::from(wi.z) * nz as f64) as usize).min(nz - 1);
                        let phi = f64::from(wi.y).atan2(f64::from(wi.x)).rem_euclid(2.0 * PI);
                        let ip = ((phi / (2.0 * PI) * nphi as f64) as usize).min(nphi - 1);
                        counts[iz * nphi + ip] += 1;
                    }
                    None => counts[nz * nphi] += 1,
                }
            }
            let (mut chi2, mut k, mut so, mut se) = (0.0, 0usize, 0.0, 0.0);
            for (&o, &e) in counts.iter().zip(&expected) {
                if e < 5.0 {
                    so += o as f64;
                    se += e;
                } else {
                    chi2 += (o as f64 - e).powi(2) / e;
                    k += 1;
                }
            }
            if se > 0.0 || so > 0.0 {
                chi2 += (so - se).powi(2) / se.max(1.0);
                k += 1;
            }
            let dof = (k - 1) as f64;
            let a = 2.0 / (9.0 * dof);
            let crit = dof * (1.0 - a + 4.0 * a.sqrt()).powi(3);
            assert!(chi2 <= crit, "{name} θo={deg}: χ² = {chi2:.1} > {crit:.1}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Values
// ---------------------------------------------------------------------------------------------

#[test]
fn eval_is_symmetric() {
    let mut rng = Rng::new(5);
    for (name, brdf) in materials() {
        for _ in 0..20_000 {
            let (wo, wi) = (upper(&mut rng), upper(&mut rng));
            let (a, b) = (brdf.eval(wo, wi), brdf.eval(wi, wo));
            assert!(
                rel(f64::from(a), f64::from(b)) <= 1e-5,
                "{name}: f({wo}, {wi}) = {a}, f({wi}, {wo}) = {b}"
            );
        }
    }
}

/// The GGX value against the textbook form in f64: D with tan θh, Λ with tan θ, and
/// f = D G2 / (4 cos θo cos θi); D normalised: ∫ D(h) cos θh dh = 1.
#[test]
fn ggx_matches_textbook_form() {
    let mut rng = Rng::new(6);
    for alpha in ALPHAS {
        let ggx = Ggx::new(alpha);
        let a = f64::from(alpha);
        let lambda = |w: DVec3| {
            let tan2 = (w.x * w.x + w.y * w.y) / (w.z * w.z);
            ((1.0 + a * a * tan2).sqrt() - 1.0) / 2.0
        };
        for _ in 0..20_000 {
            let (wo, wi) = (upper(&mut rng), upper(&mut rng));
            if wo.z < 0.01 || wi.z < 0.01 {
                continue;
            }
            let (o, i) = (wo.as_dvec3(), wi.as_dvec3());
            let h = (o + i).normalize();
            let tan2h = (h.x * h.x + h.y * h.y) / (h.z * h.z);
            let d = 1.0 / (PI * a * a * h.z.powi(4) * (1.0 + tan2h / (a * a)).powi(2));
            let g2 = 1.0 / (1.0 + lambda(o) + lambda(i));
            let f = d * g2 / (4.0 * o.z * i.z);
            let got = f64::from(ggx.eval(wo, wi));
            assert!(rel(got, f) <= 1e-4, "α={alpha}: {got} vs {f}");
            assert!(rel(f64::from(ggx.d(h.as_vec3())), d) <= 1e-4);
            assert!(rel(f64::from(ggx.g2(wo, wi)), g2) <= 1e-4);
            assert!(rel(f64::from(ggx.g1(wo)), 1.0 / (1.0 + lambda(o))) <= 1e-4);
        }
        let norm = stratified(1024, &mut rng, |h| f64::from(ggx.d(h)) * f64::from(h.z));
        assert!(
            (norm.mean() - 1.0).abs() <= K_SIGMA * norm.se() + 1e-4,
            "α={alpha}: ∫D cos = {} ± {}",
            norm.mean(),
            norm.se()
        );
    }
}

/// White furnace: no lobe reflects more than it receives, at any roughness and view angle;
/// at normal incidence a smooth GGX lobe reflects almost everything (G2/G1 ≈ 1).
#[test]
fn white_furnace() {
    let mut rng = Rng::new(7);
    for (name, brdf) in materials() {
        for deg in VIEWS.iter().copied().chain([89.9]) {
            let wo = view(deg);
            let mut st = Stats::default();
            for _ in 0..100_000 {
                st.add(brdf.sample(wo, rng.u2()).map_or(0.0, |(wi, pdf)| {
                    f64::from(brdf.eval(wo, wi)) * f64::from(wi.z) / f64::from(pdf)
                }));
            }
            assert!(
                st.mean() <= 1.0 + K_SIGMA * st.se() + 1e-4,
                "{name} θo={deg}: albedo {} ± {}",
                st.mean(),
                st.se()
            );
            if name == "lambert" {
                assert!((st.mean() - 0.8).abs() < 1e-5, "{}", st.mean());
            }
        }
    }
    let smooth = Ggx::new(MIN_ALPHA);
    let mut st = Stats::default();
    for _ in 0..10_000 {
        let (wi, pdf) = smooth.sample(Vec3::Z, rng.u2()).unwrap();
        st.add(f64::from(smooth.eval(Vec3::Z, wi)) * f64::from(wi.z) / f64::from(pdf));
    }
    assert!((st.mean() - 1.0).abs() < 1e-3, "{}", st.mean());
}

#[test]
fn schlick_fresnel() {
    assert_eq!(schlick(0.04, 1.0), 0.04);
    assert_eq!(schlick(0.04, 0.0), 1.0);
    assert_eq!(schlick(0.04, -3.0), 1.0);
    let mid = schlick(0.04, 0.5);
    assert!((f64::from(mid) - (0.04 + 0.96 * 0.5f64.powi(5))).abs() < 1e-7);
}

// ---------------------------------------------------------------------------------------------
// Degenerate inputs
// ---------------------------------------------------------------------------------------------

#[test]
fn degenerate_inputs_give_none_or_zero() {
    let mut rng = Rng::new(8);
    let mut brdfs = materials();
    for a in [0.0, -1.0, f32::NAN, f32::INFINITY, 1e-9, 2.0] {
        let g = Ggx::new(a);
        assert!(
            (MIN_ALPHA..=1.0).contains(&g.alpha()),
            "{a} → {}",
            g.alpha()
        );
        brdfs.push((format!("ggx new({a})"), Box::new(g)));
    }
    for a in [f32::NAN, -1.0, 3.0] {
        let l = Lambert::new(a);
        assert!((0.0..=1.0).contains(&l.albedo()));
        brdfs.push((format!("lambert new({a})"), Box::new(l)));
    }
    brdfs.push((
        "black".into(),
        Box::new(Material::Plastic {
            albedo: Rgb::grey(0.0),
            specular: 0.0,
            alpha: 0.5,
        }),
    ));
    brdfs.push((
        "nan material".into(),
        Box::new(Material::Plastic {
            albedo: Rgb::grey(f32::NAN),
            specular: f32::NAN,
            alpha: f32::NAN,
        }),
    ));
    let tiny = 1e-7f32;
    let wos = [
        Vec3::Z,
        Vec3::new((1.0 - tiny * tiny).sqrt(), 0.0, tiny),
        Vec3::new(0.0, 1.0, 1e-30),
        Vec3::X,
        Vec3::new(0.6, 0.0, -0.8),
        -Vec3::Z,
        Vec3::ZERO,
        Vec3::new(f32::NAN, 0.0, 1.0),
        Vec3::new(0.0, 0.0, f32::INFINITY),
    ];
    let us = [
        [0.0, 0.0],
        [ONE_MINUS_EPS, ONE_MINUS_EPS],
        [1.0, 1.0],
        [-1.0, 2.0],
        [f32::NAN, 0.5],
        [0.5, f32::NAN],
        [0.5, f32::INFINITY],
    ];
    for (name, brdf) in &brdfs {
        for &wo in &wos {
            let below = !(wo.z > 0.0 && wo.is_finite());
            for u in us.iter().copied().chain((0..200).map(|_| rng.u2())) {
                if let Some((wi, pdf)) = brdf.sample(wo, u) {
                    assert!(!below, "{name}: sampled for wo = {wo}");
                    assert!(
                        !u[0].is_nan() && !u[1].is_nan(),
                        "{name}: sampled for u = {u:?}"
                    );
                    assert!(
                        wi.is_finite() && wi.z > 0.0 && pdf > 0.0 && pdf.is_finite(),
                        "{name} wo={wo}: {wi} {pdf}"
                    );
                    assert_eq!(pdf, brdf.pdf(wo, wi), "{name} wo={wo}");
                    let f = brdf.eval(wo, wi);
                    assert!(f.is_finite() && f >= 0.0, "{name} wo={wo}: f = {f}");
                }
            }
            for wi in wos.iter().copied().chain((0..50).map(|_| upper(&mut rng))) {
                let (f, p) = (brdf.eval(wo, wi), brdf.pdf(wo, wi));
                assert!(f.is_finite() && f >= 0.0, "{name} {wo} {wi}: f = {f}");
                assert!(p.is_finite() && p >= 0.0, "{name} {wo} {wi}: pdf = {p}");
                if below || !(wi.z > 0.0 && wi.is_finite()) {
                    assert_eq!((f, p), (0.0, 0.0), "{name} {wo} {wi}");
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Frame
// ---------------------------------------------------------------------------------------------

#[test]
fn frame_is_orthonormal_and_round_trips() {
    let mut rng = Rng::new(9);
    let mut normals = vec![
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        -Vec3::Y,
        Vec3::new(0.0, 0.0, 1e-30),
        Vec3::new(1e30, 1e30, -1e30),
        Vec3::new(1e-3, 0.0, -1.0),
        Vec3::new(-1e-7, 1e-7, -1.0),
    ];
    normals.extend(
        (0..1000).map(|_| Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5) * 10.0),
    );
    for n in normals {
        let Some(f) = Frame::from_normal(n) else {
            assert!(n.length_squared() == 0.0, "{n}");
            continue;
        };
        let nn = n.as_dvec3().normalize().as_vec3();
        assert!((f.normal - nn).length() < 1e-6, "{n}: {f:?}");
        for (a, b) in [
            (f.tangent, f.bitangent),
            (f.bitangent, f.normal),
            (f.normal, f.tangent),
        ] {
            assert!(a.dot(b).abs() < 1e-6, "{n}: {f:?}");
            assert!((a.length() - 1.0).abs() < 1e-6, "{n}: {f:?}");
        }
        assert!((f.tangent.cross(f.bitangent) - f.normal).length() < 1e-5);
        assert!((f.to_local(f.normal) - Vec3::Z).length() < 1e-6);
        let v = Vec3::new(rng.f32(), rng.f32() - 0.5, rng.f32() * 2.0);
        assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5 * v.length().max(1.0));
    }
    for bad in [
        Vec3::ZERO,
        Vec3::new(f32::NAN, 0.0, 1.0),
        Vec3::new(0.0, f32::INFINITY, 0.0),
    ] {
        assert!(Frame::from_normal(bad).is_none(), "{bad}");
    }
}
