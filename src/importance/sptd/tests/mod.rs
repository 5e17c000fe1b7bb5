//! Tests of the SPTD pieces: exact identities, f64 references, Monte Carlo, scalar vs 4-wide.
//! All deterministic (fixed seeds); Monte Carlo tolerances are stated in standard errors.

extern crate std;

use super::*;
use core::f64::consts::PI as PI64;
use glam::{DVec3, Vec3};
use wide::f32x4;

use manylights_testkit::SplitMix64 as Rng;

/// A random pivot of norm up to 0.995, including ones parallel to a given axis sometimes.
fn random_pivot(rng: &mut Rng) -> Pivot {
    let r = 1.0 - rng.log_range64(0.005, 1.0);
    Pivot::new(rng.unit() * r as f32)
}

// ---------------------------------------------------------------------------------------------
// f64 references, transcribed from docs/formulas.md, section 8.

fn p64(rp: DVec3, w: DVec3) -> DVec3 {
    let t = 2.0 * (1.0 - w.dot(rp)) / (w - rp).length_squared();
    w + t * (rp - w)
}

/// `(axis', z', 1 − z')` of P(C) with the textbook `m` and `w`, in f64, for a cap given by
/// `1 − z`. `1 − z'` is taken from `|m|² − w² = k² sin²σ` when `w < 0` (the naive
/// `(|m| + w)/|m|` cancels even in f64 for the tiniest images).
fn map_cap64(rp: DVec3, c: DVec3, omz: f64) -> (DVec3, f64, f64) {
    let z = 1.0 - omz;
    let k = 1.0 - rp.length_squared();
    let q = c.dot(rp);
    let h = z - q;
    let m = k * c - 2.0 * h * rp;
    let w = k * q - h * (1.0 + rp.length_squared());
    let ml = m.length();
    let zp = -w / ml;
    let omzp = if w < 0.0 {
        k * k * omz * (2.0 - omz) / (ml * (ml - w))
    } else {
        (ml + w) / ml
    };
    (-m / ml, zp, omzp)
}

/// The two-cap area of docs/formulas.md, with its four cases, in f64.
fn area64(c1: DVec3, r1: f64, c2: DVec3, r2: f64) -> f64 {
    let d = c1.dot(c2).clamp(-1.0, 1.0).acos();
    let (z1, z2) = (r1.cos(), r2.cos());
    let (s1, s2) = (r1.sin(), r2.sin());
    if d >= r1 + r2 {
        0.0
    } else if d <= (r1 - r2).abs() {
        2.0 * PI64 * (1.0 - z1.max(z2))
    } else if r1 + r2 >= 2.0 * PI64 - d {
        2.0 * PI64 * (1.0 - z1) + 2.0 * PI64 * (1.0 - z2) - 4.0 * PI64
    } else {
        let acos = |x: f64| x.clamp(-1.0, 1.0).acos();
        2.0 * (PI64
            - acos((d.cos() - z1 * z2) / (s1 * s2))
            - z1 * acos((z2 - z1 * d.cos()) / (s1 * d.sin()))
            - z2 * acos((z1 - z2 * d.cos()) / (s2 * d.sin())))
    }
}

/// The two-segment form of the lens area used by the implementation, in f64 (caps at most
/// hemispheres, given by unit axes and `a = 1 − cos`). Checked against [`area64`] where that
/// one is accurate; used as the reference for tiny caps, where [`area64`] cancels even in f64.
fn lens64(c1: DVec3, a1: f64, c2: DVec3, a2: f64) -> f64 {
    let (z1, z2) = (1.0 - a1, 1.0 - a2);
    let cd = c1.dot(c2);
    let e = 0.5 * (c1 - c2).length_squared();
    let sd2 = c1.cross(c2).length_squared();
    let x1 = (e - a2) + a1 * cd;
    let x2 = (e - a1) + a2 * cd;
    let gram = if a1 <= a2 {
        a1 * (1.0 + z1) * sd2 - x1 * x1
    } else {
        a2 * (1.0 + z2) * sd2 - x2 * x2
    };
    if gram <= 0.0 {
        // No crossing: contained or disjoint, by the distance of the axes against r1 + r2.
        let u = a1 + a2 - a1 * a2 + (a1 * (1.0 + z1)).sqrt() * (a2 * (1.0 + z2)).sqrt();
        return if e < u { 2.0 * PI64 * a1.min(a2) } else { 0.0 };
    }
    let d = gram.sqrt();
    let phi1 = d.atan2(x1);
    let phi2 = d.atan2(x2);
    let psi1 = (a1 * d * x1).atan2(x1 * x1 + z1 * d * d);
    let psi2 = (a2 * d * x2).atan2(x2 * x2 + z2 * d * d);
    2.0 * ((a1 * phi1 - psi1) + (a2 * phi2 - psi2))
}

/// Any two caps through complements, in f64, with [`lens64`].
fn cap_area64(p: &Cap, q: &Cap) -> f64 {
    let norm = |c: &Cap| -> (DVec3, f64, bool) {
        let axis = c.axis.as_dvec3().normalize();
        if c.cos < 0.0 {
            (-axis, f64::from(c.one_plus_cos), true)
        } else {
            (axis, f64::from(c.one_minus_cos), false)
        }
    };
    let (c1, a1, f1) = norm(p);
    let (c2, a2, f2) = norm(q);
    let l = lens64(c1, a1, c2, a2);
    let (s1, s2) = (2.0 * PI64 * a1, 2.0 * PI64 * a2);
    match (f1, f2) {
        (false, false) => l,
        (true, false) => s2 - l,
        (false, true) => s1 - l,
        (true, true) => 4.0 * PI64 - s1 - s2 + l,
    }
}

/// The half-angle of an f32 cap, from its most accurate field.
fn radius64(c: &Cap) -> f64 {
    if c.cos >= 0.0 {
        2.0 * (0.5 * f64::from(c.one_minus_cos)).sqrt().asin()
    } else {
        PI64 - 2.0 * (0.5 * f64::from(c.one_plus_cos)).sqrt().asin()
    }
}

/// Snyder's piecewise Lambert cap integral of docs/formulas.md, section 7, in f64.
fn snyder64(omega: f64, sigma: f64) -> f64 {
    let (s, c) = (sigma.sin(), sigma.cos());
    if omega <= PI64 / 2.0 - sigma {
        return PI64 * omega.cos() * s * s;
    }
    if omega >= PI64 / 2.0 + sigma {
        return 0.0;
    }
    let g = (c / omega.sin()).clamp(-1.0, 1.0).asin();
    let big_g = -2.0 * omega.sin() * c * g.cos() + PI64 / 2.0 - g + g.sin() * g.cos();
    let hs = omega.cos()
        * (g.cos() * (s * s - g.cos() * g.cos()).max(0.0).sqrt()
            + s * s * (g.cos() / s).clamp(-1.0, 1.0).asin());
    if omega < PI64 / 2.0 {
        PI64 * omega.cos() * s * s + big_g - hs
    } else {
        big_g + hs
    }
}

// ---------------------------------------------------------------------------------------------
// Pivot transform.

#[test]
fn pivot_transform_is_an_involution() {
    let mut rng = Rng(1);
    let mut worst = 0.0f32;
    let mut worst64 = 0.0f64;
    for _ in 0..20_000 {
        let p = random_pivot(&mut rng);
        let w = rng.unit();
        // The identity, in f64.
        let (rp, w64) = (
            (p.direction().as_dvec3() * f64::from(p.norm())),
            w.as_dvec3().normalize(),
        );
        worst64 = worst64.max((p64(rp, p64(rp, w64)) - w64).length());
        // The f32 transform: P stretches by up to (1+R)/(1−R), so rounding in one application
        // is amplified by it in the round trip.
        let back = p.transform(p.transform(w));
        let stretch = (1.0 + p.point().length()) / (1.0 - p.point().length());
        worst = worst.max((back - w).length() / stretch);
        assert!(
            (p.transform(w).length() - 1.0).abs() < 1e-4,
            "P(w) leaves the sphere"
        );
    }
    std::println!("involution: f64 {worst64:.2e}, f32 {worst:.2e} per unit stretch");
    assert!(worst64 < 1e-10, "f64 P(P(w)) - w = {worst64:e}");
    assert!(
        worst < 1e-5,
        "f32 P(P(w)) - w = {worst:e} (per unit stretch)"
    );
}

#[test]
fn jacobian_matches_finite_differences() {
    let mut rng = Rng(2);
    for _ in 0..2000 {
        let p = random_pivot(&mut rng);
        let rp = p.direction().as_dvec3() * f64::from(p.norm());
        let w = rng.unit().as_dvec3();
        // Scale of variation of the Jacobian: the distance to the pivot.
        let h = 1e-4 * (w - rp).length();
        let t1 = w.any_orthonormal_vector();
        let t2 = w.cross(t1);
        let at = |a: f64, b: f64| p64(rp, (w + a * t1 + b * t2).normalize());
        let du = (at(h, 0.0) - at(-h, 0.0)) / (2.0 * h);
        let dv = (at(0.0, h) - at(0.0, -h)) / (2.0 * h);
        let fd = du.cross(dv).length();
        let got = f64::from(p.jacobian(w.as_vec3()));
        assert!(
            (got - fd).abs() <= 1e-4 * fd + 1e-30,
            "jacobian {got:e} vs finite differences {fd:e} at rp = {rp}, w = {w}"
        );
    }
}

#[test]
fn sptd_density_integrates_to_one() {
    // Importance sampling by the pivot itself: w = P(uniform) has density Dp, so
    // E_uniform[Dp(w)/(1/4π)] over uniform w is ∫ Dp = 1. Use 400k stratified-in-z samples.
    let mut rng = Rng(3);
    for _ in 0..8 {
        let p = Pivot::new(rng.unit() * rng.range64(0.0, 0.9) as f32);
        let n = 400_000;
        let mut sum = 0.0f64;
        let mut sum2 = 0.0f64;
        for i in 0..n {
            let z = -1.0 + 2.0 * (i as f64 + rng.f64()) / n as f64;
            let phi = rng.range64(0.0, 2.0 * PI64);
            let s = (1.0 - z * z).sqrt();
            let w = DVec3::new(s * phi.cos(), s * phi.sin(), z).as_vec3();
            let v = f64::from(p.density(w)) * 4.0 * PI64;
            sum += v;
            sum2 += v * v;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - 1.0).abs() < 5.0 * se + 1e-4, "∫Dp = {mean} ± {se}");
    }
}

#[test]
fn point_in_cap_iff_image_in_image_cap() {
    let mut rng = Rng(4);
    let mut checked = 0;
    for _ in 0..4000 {
        let p = random_pivot(&mut rng);
        let cap = Cap::new(rng.unit(), rng.range64(-1.0, 1.0) as f32);
        let img = p.map_cap(&cap);
        for _ in 0..50 {
            let w = rng.unit();
            let margin = (w.dot(cap.axis) - cap.cos).abs();
            let pw = p.transform(w);
            let margin2 = (pw.dot(img.axis) - img.cos).abs();
            if margin < 1e-3 || margin2 < 1e-3 {
                continue;
            }
            checked += 1;
            assert_eq!(
                w.dot(cap.axis) >= cap.cos,
                pw.dot(img.axis) >= img.cos,
                "w = {w}, cap = {cap:?}, P(C) = {img:?}"
            );
        }
    }
    assert!(checked > 100_000);
}

#[test]
fn mapped_cap_is_stable_down_to_tiny_caps() {
    // 1 − z' (and 1 + z') of P(C) against the f64 naive formula, σ log-uniform down to 1e-4,
    // including axes parallel (and antiparallel) to the pivot.
    let mut rng = Rng(5);
    let mut worst_omc = 0.0f64;
    let mut worst_axis = 0.0f64;
    for i in 0..50_000 {
        let p = random_pivot(&mut rng);
        let rp = p.direction().as_dvec3() * f64::from(p.norm());
        let axis = match i % 5 {
            0 => p.point().normalize(),
            1 => -p.point().normalize(),
            _ => rng.unit(),
        };
        let sigma = rng.log_range64(1e-4, 1.5);
        let cap = Cap::from_sin(axis, sigma.sin() as f32);
        let img = p.map_cap(&cap);
        let omz64 = f64::from(cap.one_minus_cos);
        let (ax64, _z, omc64) = map_cap64(rp, axis.as_dvec3().normalize(), omz64);
        let opc64 = 2.0 - omc64;
        let (got, want) = if omc64 <= 1.0 {
            (f64::from(img.one_minus_cos), omc64)
        } else {
            (f64::from(img.one_plus_cos), opc64)
        };
        let rel = (got - want).abs() / want;
        // Conditioning: near the pivot's direction `m` is a difference of terms ~k that leaves
        // ~(1 − R)² ≈ k²/4, so f32 rounding of cos σ and c·rp (~6e-8) gives ~2.4e-7/k².
        let k = f64::from(p.k());
        worst_omc = worst_omc.max(rel * k * k);
        assert!(
            rel < 5e-7 / (k * k) + 1e-5,
            "σ = {sigma:e}: 1 ∓ z' = {got:e}, f64 {want:e} (k = {k})"
        );
        // The axis matters at the scale of the image cap. An f32 unit vector's norm is off by
        // up to ~1e-7, which moves the image axis by a fraction of its radius that grows near
        // the pivot: bound it at 0.5 % of the radius (the importance cannot see that).
        let r = radius64(&img).min(1.0);
        let ad = (img.axis.as_dvec3() - ax64).length();
        worst_axis = worst_axis.max(ad / r);
        assert!(
            ad < 5e-3 * r + 1e-6,
            "axis off by {ad:e} for image radius {r:e} (k = {k})"
        );
    }
    std::println!("map_cap: worst k²·rel(1∓z') = {worst_omc:.2e}, worst axis error / image radius = {worst_axis:.2e}");
}

// ---------------------------------------------------------------------------------------------
// Cap areas.

/// A random cap: half-angle log-uniform in [1e-4, π − 1e-4] mixed with uniform ones.
fn random_cap(rng: &mut Rng) -> Cap {
    let axis = rng.unit();
    let sigma = if rng.f64() < 0.5 {
        rng.log_range64(1e-4, PI64 - 1e-4)
    } else {
        rng.range64(0.0, PI64)
    };
    if sigma <= PI64 / 2.0 {
        Cap::from_sin(axis, sigma.sin() as f32)
    } else {
        Cap::from_sin(-axis, (PI64 - sigma).sin() as f32).complement()
    }
}

#[test]
fn segment_form_equals_the_textbook_formula_in_f64() {
    // Where the textbook form of docs/formulas.md is accurate in f64 (no cap below 0.01 rad), the
    // two-segment form used here is the same function.
    let mut rng = Rng(12);
    for _ in 0..200_000 {
        let (r1, r2) = (
            rng.range64(0.01, PI64 - 0.01),
            rng.range64(0.01, PI64 - 0.01),
        );
        let c1 = rng.unit64();
        let c2 = rng.unit64();
        let p = Cap::new(c1.as_vec3(), r1.cos() as f32);
        let q = Cap::new(c2.as_vec3(), r2.cos() as f32);
        let (r1, r2) = (radius64(&p), radius64(&q));
        let want = area64(
            p.axis.as_dvec3().normalize(),
            r1,
            q.axis.as_dvec3().normalize(),
            r2,
        );
        let got = cap_area64(&p, &q);
        assert!(
            (got - want).abs() < 1e-9,
            "segments {got} vs textbook {want} (r = {r1}, {r2})"
        );
    }
}

#[test]
fn intersection_area_matches_the_f64_formula() {
    let mut rng = Rng(6);
    let mut worst = 0.0f64;
    for i in 0..200_000 {
        let a = random_cap(&mut rng);
        let mut b = random_cap(&mut rng);
        if i % 7 == 0 {
            // Straddling: b's axis near a's boundary.
            let r = radius64(&a);
            let t = a.axis.any_orthonormal_vector();
            let off = r + rng.range64(-1.0, 1.0) * radius64(&b).min(0.5);
            b.axis = (a.axis * off.cos() as f32 + t * off.sin() as f32).normalize();
        }
        if i % 11 == 0 {
            b.axis = a.axis; // coaxial
        }
        let (r1, r2) = (radius64(&a), radius64(&b));
        let want = cap_area64(&a, &b);
        let got = f64::from(intersection_area(&a, &b));
        // Error relative to the smaller cap (the scale of the answer), with a floor for
        // the conditioning of the inputs (axes carry ~6e-8 rad of rounding).
        let small = f64::from(a.area().min(b.area()));
        let scale = small.max(1e-30);
        let rmin = r1.min(r2).min(PI64 - r1.max(r2)).max(1e-30);
        let tol = 2e-5 * scale + 2e-7 * scale / rmin.min(1.0);
        let err = (got - want).abs();
        worst = worst.max(err / scale);
        assert!(
            err <= tol.max(4e-6 * want),
            "area({a:?}, {b:?}) = {got:e}, f64 {want:e}, r = ({r1:e}, {r2:e})"
        );
        let sym = f64::from(intersection_area(&b, &a));
        assert!(
            (sym - got).abs() <= 1e-5 * scale + 1e-12,
            "asymmetric: {got:e} vs {sym:e}"
        );
    }
    std::println!("intersection_area: worst error / smaller cap = {worst:.2e}");
}

#[test]
fn intersection_area_matches_monte_carlo() {
    let mut rng = Rng(7);
    let n = 100_000;
    for _ in 0..60 {
        // Caps large enough for Monte Carlo to see them.
        let a = Cap::new(rng.unit(), rng.range64(-0.9, 0.9) as f32);
        let b = Cap::new(rng.unit(), rng.range64(-0.9, 0.9) as f32);
        let mut hits = 0usize;
        for _ in 0..n {
            let w = rng.unit();
            if a.contains(w) && b.contains(w) {
                hits += 1;
            }
        }
        let p = hits as f64 / n as f64;
        let mc = 4.0 * PI64 * p;
        let se = 4.0 * PI64 * (p * (1.0 - p) / n as f64).sqrt();
        let got = f64::from(intersection_area(&a, &b));
        assert!(
            (got - mc).abs() <= 5.0 * se + 1e-3,
            "{got} vs MC {mc} ± {se}"
        );
    }
}

#[test]
fn intersection_area_edge_cases() {
    let z = Vec3::Z;
    let h = Cap::hemisphere(z);
    // Two hemispheres at angle d: 2(π − d).
    for d in [0.0f32, 0.3, 1.0, 2.0, 3.0, core::f32::consts::PI] {
        let b = Cap::hemisphere(Vec3::new(d.sin(), 0.0, d.cos()));
        let want = 2.0 * (core::f32::consts::PI - d);
        let got = intersection_area(&h, &b);
        assert!(
            (got - want).abs() < 2e-4,
            "hemispheres at {d}: {got} vs {want}"
        );
    }
    // Identical caps, contained caps, whole sphere, empty cap.
    let c = Cap::from_sin(z, 1e-3);
    assert!((intersection_area(&c, &c) / c.area() - 1.0).abs() < 1e-5);
    assert!((intersection_area(&Cap::SPHERE, &c) / c.area() - 1.0).abs() < 1e-5);
    assert_eq!(intersection_area(&Cap::EMPTY, &h), 0.0);
    assert!(
        (intersection_area(&Cap::SPHERE, &Cap::SPHERE) - 4.0 * core::f32::consts::PI).abs() < 1e-5
    );
    // Complementary caps: disjoint.
    let a = Cap::new(Vec3::X, 0.3);
    assert!(intersection_area(&a, &a.complement()) < 1e-5);
    // Union covers the sphere: |A| + |B| − 4π.
    let a = Cap::new(Vec3::X, -0.8);
    let b = Cap::new(-Vec3::X, -0.8);
    let want = a.area() + b.area() - 4.0 * core::f32::consts::PI;
    assert!((intersection_area(&a, &b) - want).abs() < 1e-4);
    // NaN in: 0 out.
    let nan = Cap::new(Vec3::new(f32::NAN, 0.0, 1.0), 0.5);
    assert_eq!(intersection_area(&nan, &h), 0.0);
    let nan = Cap::new(Vec3::Z, f32::NAN);
    assert!(!intersection_area(&nan, &h).is_nan());
}

// ---------------------------------------------------------------------------------------------
// Lambert.

#[test]
fn lambert_cap_matches_snyder_and_monte_carlo() {
    let mut rng = Rng(8);
    for _ in 0..100_000 {
        let omega = rng.range64(0.0, PI64);
        let sigma = rng.log_range64(1e-3, PI64 / 2.0 - 1e-3);
        let (c32, s32) = (omega.cos() as f32, sigma.sin() as f32);
        // The reference sees the f32-rounded inputs (sin σ near 1 is ill-conditioned).
        let want = snyder64(f64::from(c32).acos(), f64::from(s32).asin());
        let got = f64::from(lambert_cap(c32, s32));
        // Relative to the cap's full projected scale, sin²σ.
        let scale = sigma.sin().powi(2);
        assert!(
            (got - want).abs() <= 2e-5 * scale + 1e-7 * sigma.sin() + 1e-12,
            "lambert(ω = {omega}, σ = {sigma}) = {got:e}, Snyder {want:e}"
        );
    }
    // Monte Carlo for a few straddling caps.
    for &(omega, sigma) in &[
        (1.4f64, 0.5f64),
        (1.7, 0.4),
        (0.9, 1.2),
        (2.0, 1.0),
        (1.5, 0.08),
    ] {
        let axis = DVec3::new(omega.sin(), 0.0, omega.cos());
        let n = 400_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        let (t1, t2) = axis.any_orthonormal_pair();
        let omc = 1.0 - sigma.cos();
        for _ in 0..n {
            let ct = 1.0 - rng.f64() * omc;
            let phi = rng.range64(0.0, 2.0 * PI64);
            let st = (1.0 - ct * ct).max(0.0).sqrt();
            let w = axis * ct + (t1 * phi.cos() + t2 * phi.sin()) * st;
            let v = w.z.max(0.0) * 2.0 * PI64 * omc;
            sum += v;
            sum2 += v * v;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        let got = f64::from(lambert_cap(omega.cos() as f32, sigma.sin() as f32));
        assert!(
            (got - mean).abs() < 5.0 * se + 1e-6,
            "ω {omega} σ {sigma}: {got} vs MC {mean} ± {se}"
        );
    }
    // Inside the sphere: the whole hemisphere; tiny cap at the zenith; NaN.
    assert_eq!(lambert_cap(0.3, 1.0), core::f32::consts::PI);
    let tiny = lambert_cap(1.0, 1e-4);
    assert!((tiny / (core::f32::consts::PI * 1e-8) - 1.0).abs() < 1e-5);
    assert_eq!(lambert_cap(f32::NAN, 0.5), 0.0);
    assert_eq!(lambert_cap(0.5, f32::NAN), 0.0);
}

#[test]
fn lambert_cap_tiny_caps_at_the_horizon_keep_their_digits() {
    // σ = 1e-3, axis within σ of the horizon: compare with an f64 integral of the
    // planar-limit form, the exact formula evaluated in f64 through the same segments.
    let sigma = 1e-3f64;
    for k in -9..=9 {
        let omega = PI64 / 2.0 + sigma * k as f64 / 10.0;
        let (c32, s32) = (omega.cos() as f32, sigma.sin() as f32);
        let want = snyder64(f64::from(c32).acos(), f64::from(s32).asin());
        let got = f64::from(lambert_cap(c32, s32));
        // Snyder's form itself cancels in f64 here (terms O(1), result 1e-9): allow 1e-6 of
        // the result plus its f64 noise.
        assert!(
            (got - want).abs() <= 2e-3 * want + 1e-14,
            "ω = π/2 + {k}σ/10: {got:e} vs {want:e}"
        );
    }
}

#[test]
fn lambert_visible_matches_lambert_cap_and_the_lens_with_the_hemisphere() {
    let mut rng = Rng(13);
    let h = Cap::hemisphere(Vec3::Z);
    for i in 0..100_000 {
        let axis = if i % 3 == 0 {
            // near the horizon
            let e = rng.range64(-0.05, 0.05);
            Vec3::new(e.cos() as f32, 0.0, e.sin() as f32)
        } else {
            rng.unit()
        };
        let sigma = rng.log_range64(1e-4, PI64 / 2.0 - 1e-4);
        let s32 = sigma.sin() as f32;
        let (l, v) = lambert_visible(axis.z, s32);
        assert_eq!(l, lambert_cap(axis.z, s32), "L differs from lambert_cap");
        let cap = Cap::from_sin(axis, s32);
        // The lens with the hemisphere, in f64 (the general two-cap formula).
        let want = lens64(
            axis.as_dvec3().normalize(),
            f64::from(cap.one_minus_cos),
            DVec3::Z,
            1.0,
        );
        // ... and through the f32 general code.
        let general = f64::from(intersection_area(&cap, &h));
        let scale = f64::from(cap.area());
        assert!(
            (general - want).abs() <= 1e-5 * scale + 2e-7 * scale / sigma.min(1.0),
            "general lens {general:e} vs {want:e} (σ = {sigma:e}, axis.z = {})",
            axis.z
        );
        assert!(
            (f64::from(v) - want).abs() <= 1e-5 * scale + 2e-7 * scale / sigma.min(1.0),
            "|C ∩ H| = {v:e}, lens {want:e} (σ = {sigma:e}, axis.z = {})",
            axis.z
        );
        assert!(
            f64::from(l) <= f64::from(v) * 1.000_01 + 1e-30,
            "mean cosine above 1"
        );
    }
    assert_eq!(
        lambert_visible(0.2, 1.0),
        (core::f32::consts::PI, 2.0 * core::f32::consts::PI)
    );
    assert_eq!(lambert_visible(f32::NAN, 0.3), (0.0, 0.0));
    assert_eq!(lambert_visible(0.3, f32::NAN), (0.0, 0.0));
}

// ---------------------------------------------------------------------------------------------
// Scalar vs 4-wide.

fn close(a: f32, b: f32, rel: f32) -> bool {
    a == b || (a - b).abs() <= rel * a.abs().max(b.abs()) || (a.is_nan() && b.is_nan())
}

fn caps4(rng: &mut Rng, pivot: &Pivot) -> ([Vec3; 4], [f32; 4]) {
    let mut axes = [Vec3::Z; 4];
    let mut sins = [0.0f32; 4];
    for l in 0..4 {
        axes[l] = match rng.next_u64() % 6 {
            0 => pivot.point().normalize_or(Vec3::Z),
            1 => -pivot.point().normalize_or(Vec3::Z),
            2 => {
                // near the horizon
                let t = rng.range64(-0.02, 0.02);
                let phi = rng.range64(0.0, 2.0 * PI64);
                Vec3::new(
                    (phi.cos() * t.cos()) as f32,
                    (phi.sin() * t.cos()) as f32,
                    t.sin() as f32,
                )
                .normalize()
            }
            _ => rng.unit(),
        };
        sins[l] = match rng.next_u64() % 8 {
            0 => 1.0,
            1 => 0.0,
            _ => rng.log_range64(1e-4, 1.0) as f32,
        };
    }
    (axes, sins)
}

#[test]
fn four_wide_equals_scalar() {
    let mut rng = Rng(9);
    for _ in 0..50_000 {
        let pivot = random_pivot(&mut rng);
        let (axes, sins) = caps4(&mut rng, &pivot);
        let (ax, ay, az) = (
            f32x4::new([axes[0].x, axes[1].x, axes[2].x, axes[3].x]),
            f32x4::new([axes[0].y, axes[1].y, axes[2].y, axes[3].y]),
            f32x4::new([axes[0].z, axes[1].z, axes[2].z, axes[3].z]),
        );
        let s4 = f32x4::new(sins);
        let caps = Cap4::from_sin(ax, ay, az, s4);
        let mapped = pivot.map_cap4(&caps);
        let other = random_cap(&mut rng);
        let areas = intersection_area4(&mapped, &Cap4::splat(&other)).to_array();
        let lam = lambert_cap4(az, s4).to_array();
        let (lv4, vv4) = lambert_visible4(az, s4);
        let (lv4, vv4) = (lv4.to_array(), vv4.to_array());
        for l in 0..4 {
            let c = Cap::from_sin(axes[l], sins[l]);
            assert_eq!(caps.lane(l), c, "from_sin lane {l}");
            let m = pivot.map_cap(&c);
            let m4 = mapped.lane(l);
            assert!(
                close(m.cos, m4.cos, 1e-6)
                    && close(m.one_minus_cos, m4.one_minus_cos, 1e-6)
                    && close(m.one_plus_cos, m4.one_plus_cos, 1e-6)
                    && (m.axis - m4.axis).length() <= 1e-6,
                "map_cap lane {l}: {m:?} vs {m4:?}"
            );
            let a = intersection_area(&m, &other);
            assert!(
                close(a, areas[l], 1e-6),
                "area lane {l}: {a:e} vs {:e}",
                areas[l]
            );
            let lm = lambert_cap(axes[l].z, sins[l]);
            assert!(
                close(lm, lam[l], 1e-6),
                "lambert lane {l}: {lm:e} vs {:e}",
                lam[l]
            );
            let (lv, vv) = lambert_visible(axes[l].z, sins[l]);
            assert!(
                close(lv, lv4[l], 1e-6) && close(vv, vv4[l], 1e-6),
                "lambert_visible lane {l}: ({lv:e}, {vv:e}) vs ({:e}, {:e})",
                lv4[l],
                vv4[l]
            );
            assert!(!areas[l].is_nan() && !lam[l].is_nan());
        }
    }
}

#[test]
fn sptd_ggx_four_wide_equals_scalar_and_handles_bad_input() {
    let mut rng = Rng(10);
    for _ in 0..20_000 {
        let alpha = rng.range64(0.0, 1.2) as f32;
        let n = rng.unit();
        let wo = rng.unit();
        let g = SptdGgx::oriented(alpha, n, wo);
        let (axes, sins) = caps4(&mut rng, g.pivot());
        let v4 = g
            .integral4(
                f32x4::new([axes[0].x, axes[1].x, axes[2].x, axes[3].x]),
                f32x4::new([axes[0].y, axes[1].y, axes[2].y, axes[3].y]),
                f32x4::new([axes[0].z, axes[1].z, axes[2].z, axes[3].z]),
                f32x4::new(sins),
            )
            .to_array();
        let parts4 = g.cap_integrals4(
            f32x4::new([axes[0].x, axes[1].x, axes[2].x, axes[3].x]),
            f32x4::new([axes[0].y, axes[1].y, axes[2].y, axes[3].y]),
            f32x4::new([axes[0].z, axes[1].z, axes[2].z, axes[3].z]),
            f32x4::new(sins),
        );
        assert_eq!(parts4.ggx.to_array(), v4);
        let (l4, vis4) = (parts4.lambert.to_array(), parts4.visible.to_array());
        for l in 0..4 {
            let v = g.integral(axes[l], sins[l]);
            assert!(close(v, v4[l], 1e-6), "lane {l}: {v:e} vs {:e}", v4[l]);
            let parts = g.cap_integrals(axes[l], sins[l]);
            let cos_omega = axes[l].dot(g.normal());
            assert_eq!(
                parts.lambert,
                lambert_cap(cos_omega, sins[l]),
                "lambert part"
            );
            assert_eq!(
                (parts.lambert, parts.visible),
                lambert_visible(cos_omega, sins[l])
            );
            assert!(close(parts.lambert, l4[l], 1e-6), "lane {l} lambert");
            assert!(close(parts.visible, vis4[l], 1e-6), "lane {l} visible");
            assert!(
                v >= 0.0 && v <= g.albedo() * 1.0001 + 1e-7,
                "{v} outside [0, ρ = {}]",
                g.albedo()
            );
        }
    }
    // Bad input: NaN/inf/zero vectors, NaN sines.
    let bad = [f32::NAN, f32::INFINITY, 0.0];
    for &b in &bad {
        let g = SptdGgx::oriented(0.3, Vec3::new(b, 0.0, 0.0), Vec3::Z);
        assert!(!g.integral(Vec3::Z, 0.5).is_nan());
        let g = SptdGgx::oriented(b, Vec3::Z, Vec3::new(0.3, 0.0, 1.0));
        assert!(!g.integral(Vec3::Z, 0.5).is_nan());
        let g = SptdGgx::new(0.3, b);
        assert!(!g.integral(Vec3::Z, b).is_nan());
        let v = g.integral4(f32x4::splat(b), f32x4::ZERO, f32x4::ONE, f32x4::splat(b));
        assert!(v.to_array().iter().all(|x| !x.is_nan()));
    }
    let g = SptdGgx::new(0.3, 0.5);
    assert_eq!(g.integral(Vec3::new(f32::NAN, 0.0, 1.0), 0.1), 0.0);
    assert_eq!(g.integral(Vec3::Z, f32::NAN), 0.0);
}

// ---------------------------------------------------------------------------------------------
// GGX: the table against an independent albedo, and exactness of the horizon handling.

mod ggx;
