//! Tests of the GGX side of the SPTD: the fitted table, the directional albedo it reproduces,
//! the lateral rule, the lobe and its limits.

extern crate std;

use super::super::*;
use super::Rng;
use core::f64::consts::PI as PI64;
use glam::{DVec3, Vec3};
use wide::f32x4;

/// Height-correlated Smith GGX, f·cos θi, in the local frame (f64; test-only).
fn ggx_albedo(alpha: f64, cos_o: f64, n: usize) -> f64 {
    // ρ = E_vndf[G2/G1] (Heitz 2018 VNDF sampling), n×n stratified.
    let wo = DVec3::new((1.0 - cos_o * cos_o).max(0.0).sqrt(), 0.0, cos_o);
    let lambda = |w: DVec3| {
        let c2 = w.z * w.z;
        let t2 = (1.0 - c2).max(0.0) / c2;
        0.5 * (-1.0 + (1.0 + alpha * alpha * t2).sqrt())
    };
    let vh = DVec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let t1 = if vh.x * vh.x + vh.y * vh.y > 0.0 {
        DVec3::new(-vh.y, vh.x, 0.0).normalize()
    } else {
        DVec3::X
    };
    let t2v = vh.cross(t1);
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let u1 = (i as f64 + 0.5) / n as f64;
            let u2 = (j as f64 + 0.5) / n as f64;
            let r = u1.sqrt();
            let phi = 2.0 * PI64 * u2;
            let a = r * phi.cos();
            let mut b = r * phi.sin();
            let s = 0.5 * (1.0 + vh.z);
            b = (1.0 - s) * (1.0 - a * a).max(0.0).sqrt() + s * b;
            let nh = a * t1 + b * t2v + (1.0 - a * a - b * b).max(0.0).sqrt() * vh;
            let m = DVec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize();
            let wi = 2.0 * wo.dot(m) * m - wo;
            if wi.z > 0.0 {
                sum += (1.0 + lambda(wo)) / (1.0 + lambda(wo) + lambda(wi));
            }
        }
    }
    sum / (n * n) as f64
}

#[test]
fn whole_hemisphere_reproduces_the_directional_albedo() {
    let mut rng = Rng(11);
    for i in 0..40 {
        // Off the grid, to include the bilinear filtering.
        let u = rng.range64(0.08, 1.0);
        let alpha = (u * u) as f32;
        let theta = if i == 0 {
            0.0
        } else {
            rng.range64(0.0, 85f64.to_radians())
        };
        let cos_o = theta.cos() as f32;
        let g = SptdGgx::new(alpha, cos_o);
        let want = ggx_albedo(f64::from(alpha), f64::from(cos_o), 256);
        let hemi = f64::from(g.integral_cap(&Cap::hemisphere(Vec3::Z)));
        let inside = f64::from(g.integral(Vec3::X, 1.0));
        let sphere = f64::from(g.integral_cap(&Cap::SPHERE));
        for (what, got) in [("hemisphere", hemi), ("inside", inside), ("sphere", sphere)] {
            assert!(
                (got / want - 1.0).abs() < 0.02,
                "α = {alpha}, θo = {theta}: {what} {got} vs albedo {want}"
            );
        }
        // Caps below the horizon are exactly 0.
        let below = g.integral(Vec3::new(0.3, 0.1, -0.95).normalize(), 0.2);
        assert_eq!(below, 0.0);
        // integral_cap agrees with integral for caps up to a hemisphere.
        let axis = Vec3::new(0.2, -0.4, 0.8).normalize();
        let a = g.integral_cap(&Cap::from_sin(axis, 0.6));
        let b = g.integral(axis, 0.6);
        assert!(
            (a - b).abs() <= 1e-6 * b,
            "integral_cap {a} vs integral {b}"
        );
    }
}

#[test]
fn table_is_finite_and_in_range() {
    for i in 0..TABLE_SIZE {
        for j in 0..TABLE_SIZE {
            let (r, g, a) = (
                table::PIVOT_NORM[i][j],
                table::PIVOT_ELEVATION[i][j],
                table::ALBEDO[i][j],
            );
            assert!((0.0..1.0).contains(&r), "R[{i}][{j}] = {r}");
            assert!(g.abs() <= core::f32::consts::PI, "Gθ[{i}][{j}] = {g}");
            assert!(a > 0.0 && a <= 1.0 + 1e-4, "ρ[{i}][{j}] = {a}");
        }
    }
    for (i, row) in table::LAMBERT_WEIGHT.iter().enumerate() {
        for (j, &b) in row.iter().enumerate() {
            let c = table::MASKING_COS[i][j];
            assert!((0.0..=1.0).contains(&b), "β[{i}][{j}] = {b}");
            assert!(c > 0.0 && c <= 1.0, "c_ref[{i}][{j}] = {c}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// GGX: the lateral rule for small caps and the exact lobe.

/// ωo in the local frame for the f32 `cos θo` an `SptdGgx::new` gets (θo clamped to
/// `THETA_O_MAX`): its sine is `√(1 − cos²θo)` of that cosine, as `new` takes it.
fn view64(cos_o: f32) -> DVec3 {
    let c = f64::from(cos_o.max(crate::math::cos(THETA_O_MAX)).min(1.0));
    DVec3::new((1.0 - c * c).max(0.0).sqrt(), 0.0, c)
}

/// `f(ωi, ωo) cos θi` of isotropic GGX with height-correlated Smith masking-shadowing, no
/// Fresnel, in the local frame (`n = +z`), f64.
fn ggx_f_cos64(alpha: f64, wo: DVec3, wi: DVec3) -> f64 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let lambda = |w: DVec3| {
        let c2 = w.z * w.z;
        0.5 * (-1.0 + (1.0 + alpha * alpha * (1.0 - c2).max(0.0) / c2).sqrt())
    };
    let h = (wo + wi).normalize();
    let a2 = alpha * alpha;
    let t = h.z * h.z * (a2 - 1.0) + 1.0;
    let d = a2 / (PI64 * t * t);
    d / (4.0 * wo.z * (1.0 + lambda(wo) + lambda(wi)))
}

/// `∫₀^π sin²θ g(R cos θ) dθ / (π/2)`: the mean of `g(t)` over `t ∈ [−R, R]` weighted by
/// `√(R² − t²)`, by adaptive Simpson in θ split at `peak` (where g may be a narrow spike).
fn chord_mean64(g: &dyn Fn(f64) -> f64, r: f64, peak: f64) -> f64 {
    fn simpson(
        f: &dyn Fn(f64) -> f64,
        a: f64,
        b: f64,
        fa: f64,
        fm: f64,
        fb: f64,
        depth: u32,
    ) -> f64 {
        let m = 0.5 * (a + b);
        let (lm, rm) = (0.5 * (a + m), 0.5 * (m + b));
        let (flm, frm) = (f(lm), f(rm));
        let whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
        let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
        let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
        if depth == 0 || (left + right - whole).abs() <= 1e-11 * (left + right).abs() {
            left + right
        } else {
            simpson(f, a, m, fa, flm, fm, depth - 1) + simpson(f, m, b, fm, frm, fb, depth - 1)
        }
    }
    if r == 0.0 {
        return g(0.0);
    }
    let f = |th: f64| th.sin().powi(2) * g(r * th.cos());
    let split = if (peak / r).abs() < 1.0 {
        std::vec![0.0, (peak / r).acos(), PI64]
    } else {
        std::vec![0.0, PI64]
    };
    let mut sum = 0.0;
    for w in split.windows(2) {
        let (a, b) = (w[0], w[1]);
        sum += simpson(&f, a, b, f(a), f(0.5 * (a + b)), f(b), 40);
    }
    sum / (PI64 / 2.0)
}

/// The lateral rule of `sptd/ggx.rs` (module docs) for the cap `(axis, sin σ = s)`, in f64 with
/// the chord's mean by quadrature, given the cap's visible solid angle and cosine integral.
fn lateral_rule64(alpha: f64, wo: DVec3, axis: DVec3, s: f64, lambert: f64, visible: f64) -> f64 {
    if visible <= 0.0 {
        return 0.0;
    }
    let (so, co) = (wo.x, wo.z);
    let cos_w = axis.z;
    let crossing = s * s > cos_w * cos_w;
    let cbar = if crossing {
        (lambert / visible).min(1.0)
    } else {
        cos_w * (1.0 + (1.0 - s * s).sqrt()) / 2.0
    };
    let (hn, r2) = if crossing {
        let lift = cbar - cos_w;
        (co + cbar, (s * s - lift * lift).max(0.0))
    } else {
        (co + cos_w, s * s)
    };
    let x = axis.x + so;
    let y = axis.y;
    let a2 = alpha * alpha;
    let g = |t: f64| {
        let u = y + t;
        let ht2 = x * x + u * u;
        let r = (hn * hn + ht2) / (a2 * hn * hn + ht2);
        r * r
    };
    let mean = chord_mean64(&g, r2.sqrt(), -y);
    let lambda = |c: f64| 0.5 * (-1.0 + (1.0 + a2 * (1.0 - c * c) / (c * c)).sqrt());
    let g2 = if cbar > 0.0 {
        1.0 / (1.0 + lambda(co) + lambda(cbar))
    } else {
        0.0
    };
    visible * g2 * a2 / (4.0 * PI64 * co) * mean
}

/// A cap for the lateral rule's tests: near the lobe (off the mirror direction by up to a few
/// α, across the plane of incidence or along it), near the horizon or anywhere, of half-angle
/// from 1e-5 rad to a few α (but below 0.3 rad).
fn lateral_case(rng: &mut Rng, alpha: f64, theta_o: f64) -> (DVec3, f64) {
    let mirror = DVec3::new(-theta_o.sin(), 0.0, theta_o.cos());
    let e1 = DVec3::new(theta_o.cos(), 0.0, theta_o.sin());
    let sigma = rng.log_range64(1e-5, (3.0 * alpha).min(0.3));
    let axis = match rng.below(4) {
        0 => rng.unit64(),
        1 => {
            let e = rng.range64(-0.05, 0.2);
            let phi = rng.range64(0.0, 2.0 * PI64);
            DVec3::new(phi.cos() * e.cos(), phi.sin() * e.cos(), e.sin())
        }
        2 => {
            let d = alpha * rng.range64(0.0, 5.0);
            let psi = rng.range64(0.0, 2.0 * PI64);
            (mirror * d.cos() + (e1 * psi.cos() + DVec3::Y * psi.sin()) * d.sin()).normalize()
        }
        _ => {
            // Along the plane of incidence, the cap across it.
            let d = alpha * rng.range64(-3.0, 3.0);
            let y = sigma * rng.range64(-1.0, 1.0);
            (mirror * d.cos() + e1 * d.sin() + DVec3::Y * y).normalize()
        }
    };
    (axis, sigma.sin())
}

/// The lateral rule (the cap integral of every cap small against its distance from the pivot)
/// against its f64 definition with the chord's mean by adaptive quadrature: the closed form of
/// the mean and its f32 evaluation, in both of its branches (a chord that holds the plane of
/// incidence and one that does not), for views up to 89°, α down to `MIN_ALPHA` and caps from
/// 1e-5 rad, across the horizon included. Within 5e-4 relative: the inputs are f32 (the
/// axis, the cap, the Lambert pair), and near the peak of the sharpest lobes the integrand
/// amplifies their rounding by up to ~1/α.
#[test]
fn lateral_rule_matches_its_quadrature() {
    let mut rng = Rng(21);
    let mut worst = 0.0f64;
    let (mut tested, mut holding) = (0, 0);
    for _ in 0..4000 {
        let u = rng.range64(0.0, 1.0);
        let alpha = ((u * u) as f32).max(crate::material::MIN_ALPHA);
        let theta_o = rng.range64(0.0, 89f64.to_radians());
        let c32 = theta_o.cos() as f32;
        let g = SptdGgx::new(alpha, c32);
        let (axis, s) = lateral_case(&mut rng, f64::from(alpha), theta_o);
        let axis32 = axis.as_vec3();
        let s32 = s as f32;
        let cap = Cap::from_sin(axis32, s32);
        let d = f64::from(g.pivot().distance2(axis32)).min(1.0);
        // Clearly small (the rule's threshold is 2(1 − cos σ) < 0.49 d).
        if 2.0 * f64::from(cap.one_minus_cos) >= 0.4 * d {
            continue;
        }
        let parts = g.cap_integrals(axis32, s32);
        let want = lateral_rule64(
            f64::from(alpha),
            view64(c32),
            axis32.as_dvec3(),
            f64::from(s32),
            f64::from(parts.lambert),
            f64::from(parts.visible),
        );
        let got = f64::from(parts.ggx);
        if want == 0.0 {
            assert_eq!(got, 0.0);
            continue;
        }
        let rel = (got - want).abs() / want;
        worst = worst.max(rel);
        // Whether the chord holds the plane of incidence (`P < 0` in the closed form).
        let a = axis32.as_dvec3();
        let wo = view64(c32);
        holding += usize::from(a.y.abs() < f64::from(s32) && (a.x + wo.x).abs() < 0.1);
        assert!(
            rel <= 5e-4,
            "α {alpha}, θo {theta_o}, axis {axis}, sin σ {s}: {got:e} vs {want:e} ({rel:e})"
        );
        tested += 1;
    }
    assert!(
        tested > 2000 && holding > 200,
        "only {tested} small caps, {holding} holding the plane"
    );
    std::eprintln!(
        "lateral rule vs quadrature: {tested} caps ({holding} across the plane of incidence), \
         worst relative error {worst:.2e}"
    );
}

/// `lobe` is GGX's exact `f cos θi` (height-correlated Smith, no Fresnel), for views up to
/// 89° and directions anywhere above the horizon: within 1e-4 relative plus 1e-6 of the
/// albedo (the direction is f32; near the peak of a lobe of α = `MIN_ALPHA` the density's
/// relative slope is ~1/α per radian).
#[test]
fn lobe_is_the_exact_ggx_f_cos() {
    let mut rng = Rng(22);
    for i in 0..20_000 {
        let u = rng.range64(0.0, 1.0);
        let alpha = ((u * u) as f32).max(crate::material::MIN_ALPHA);
        let theta_o = rng.range64(0.0, 89f64.to_radians());
        let c32 = theta_o.cos() as f32;
        let g = SptdGgx::new(alpha, c32);
        let wo = view64(c32);
        let w = if i % 2 == 0 {
            rng.unit()
        } else {
            // Near the mirror direction.
            let m = DVec3::new(-wo.x, 0.0, wo.z);
            (m + rng.unit64() * rng.log_range64(1e-4, 0.3) * f64::from(alpha))
                .normalize()
                .as_vec3()
        };
        let got = f64::from(g.lobe(w));
        let want = ggx_f_cos64(f64::from(alpha), wo, w.as_dvec3());
        let tol = 1e-4 * want + 1e-6 * f64::from(g.albedo());
        assert!(
            (got - want).abs() <= tol,
            "α {alpha}, θo {theta_o}, w {w}: {got:e} vs {want:e}"
        );
        if w.z <= 0.0 {
            assert_eq!(got, 0.0);
        }
    }
}

/// A vanishing cap's average `integral / visible` tends to `lobe` at its axis: the limit the
/// BRDF-oriented importance takes for points (caps of σ ≤ 1e-6 rad, a relative error of
/// order (σ/scale)² from the lobe's finite width, here below 1e-3).
#[test]
fn vanishing_caps_tend_to_the_lobe() {
    let mut rng = Rng(23);
    for _ in 0..5000 {
        let u = rng.range64(0.1, 1.0);
        let alpha = (u * u) as f32;
        let theta_o = rng.range64(0.0, 89f64.to_radians());
        let g = SptdGgx::new(alpha, theta_o.cos() as f32);
        let w = rng.unit();
        if w.z < 1e-3 {
            continue;
        }
        let s = rng.log_range64(1e-7, 1e-6) as f32;
        let c = g.cap_integrals(w, s);
        let lobe = f64::from(g.lobe(w));
        let avg = f64::from(c.ggx) / f64::from(c.visible);
        assert!(
            (avg - lobe).abs() <= 1e-3 * lobe + 1e-30,
            "α {alpha}, θo {theta_o}, w {w}, sin σ {s}: {avg:e} vs lobe {lobe:e}"
        );
    }
}

/// A cap with a visible part (its axis above `−sin σ`) has a positive integral, tiny caps and
/// slivers across the horizon included: the true integrand is positive all over the visible
/// part, and a light there can contribute. Caps wholly below the horizon give 0.
#[test]
fn visible_caps_have_a_positive_integral() {
    let mut rng = Rng(24);
    for _ in 0..50_000 {
        let alpha = rng.log_range64(5e-3, 1.0) as f32;
        let n = rng.unit();
        let wo = rng.unit();
        let g = SptdGgx::oriented(alpha, n, wo);
        let nn = g.normal();
        let s = rng.log_range64(1e-5, 1.0) as f32;
        let axis = match rng.below(3) {
            0 => rng.unit(),
            1 => {
                // Across the horizon.
                let t = (rng.unit() - nn * rng.unit().dot(nn)).normalize_or(Vec3::X);
                let t = (t - nn * t.dot(nn)).normalize();
                (t + nn * (s * rng.range64(-0.999, 0.999) as f32)).normalize()
            }
            _ => (nn * 2.0 * nn.dot(wo.normalize()) - wo.normalize()).normalize(),
        };
        let c = g.cap_integrals(axis, s);
        let v = g.integral(axis, s);
        if c.visible > 0.0 && c.lambert > 0.0 {
            assert!(
                v > 0.0,
                "α {alpha}, n {n}, ωo {wo}, axis {axis}, sin σ {s}: {c:?}"
            );
        }
        if axis.dot(nn) <= -s {
            assert_eq!(v, 0.0);
        }
    }
}

/// `atan2_upper4` (y ≥ +0) and `atan2_first4` (x, y ≥ +0) are `atan2_4`, bit for bit, on
/// their domains: random magnitudes over the whole f32 range, +0, subnormals, ∞, and every
/// sign of x for the first.
#[test]
fn atan2_for_non_negative_arguments_is_atan2_4() {
    use super::trig::{atan2_4, atan2_first4, atan2_upper4};
    let mut rng = Rng::new(0xA7A2);
    let special = [
        0.0,
        f32::from_bits(1),
        f32::MIN_POSITIVE,
        1.0,
        f32::MAX,
        f32::INFINITY,
    ];
    let magnitude = |rng: &mut Rng| match rng.next_u64() % 4 {
        0 => special[(rng.next_u64() % special.len() as u64) as usize],
        1 => rng.f32(),
        _ => f32::from_bits((rng.next_u64() % 0x7F80_0000) as u32),
    };
    for _ in 0..200_000 {
        let y = f32x4::new([0; 4].map(|_: i32| magnitude(&mut rng)));
        let ax = f32x4::new([0; 4].map(|_: i32| magnitude(&mut rng)));
        let sign =
            f32x4::new([0; 4].map(|_: i32| if rng.next_u64() & 1 == 0 { 1.0 } else { -1.0 }));
        let x = ax * sign;
        let bits = |v: f32x4| v.to_array().map(f32::to_bits);
        assert_eq!(bits(atan2_upper4(y, x)), bits(atan2_4(y, x)), "{y:?} {x:?}");
        assert_eq!(
            bits(atan2_first4(y, ax)),
            bits(atan2_4(y, ax)),
            "{y:?} {ax:?}"
        );
    }
}
