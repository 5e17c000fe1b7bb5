//! The GGX reference of the std side (f64): the isotropic GGX microfacet BRDF with
//! height-correlated Smith masking-shadowing and no Fresnel term (Heitz 2014, "Understanding
//! the Masking-Shadowing Function in Microfacet-Based BRDFs", Eqn. 99), sampling of the
//! distribution of visible normals (Heitz 2018, "Sampling the GGX Distribution of Visible
//! Normals") and its pdf, uniform sampling of a spherical cap, and the ground-truth cap
//! integral of docs/formulas.md, section 8 (MIS of both, balance heuristic, stratified).
//!
//! Local frame: `n = +z`, `ωo = (sin θo, 0, cos θo)`.

use glam::DVec3;
use std::f64::consts::PI;

/// Isotropic GGX with roughness α.
#[derive(Clone, Copy, Debug)]
pub struct Ggx {
    /// Roughness α (> 0).
    pub alpha: f64,
}

impl Ggx {
    /// GGX of roughness `alpha`.
    pub fn new(alpha: f64) -> Ggx {
        Ggx { alpha }
    }

    /// The normal distribution `D(m)`.
    pub fn d(&self, m: DVec3) -> f64 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let c2 = m.z * m.z;
        let t = c2 * (a2 - 1.0) + 1.0;
        a2 / (PI * t * t)
    }

    /// Smith's `Λ(ω)`.
    pub fn lambda(&self, w: DVec3) -> f64 {
        let c2 = w.z * w.z;
        if c2 <= 0.0 {
            return f64::INFINITY;
        }
        let t2 = (1.0 - c2).max(0.0) / c2;
        0.5 * (-1.0 + (1.0 + self.alpha * self.alpha * t2).sqrt())
    }

    /// `G1(ω) = 1/(1 + Λ(ω))`.
    pub fn g1(&self, w: DVec3) -> f64 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated `G2(ωo, ωi) = 1/(1 + Λ(ωo) + Λ(ωi))`.
    pub fn g2(&self, wo: DVec3, wi: DVec3) -> f64 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// `f(ωi, ωo) cos θi` (0 unless both are above the surface).
    pub fn eval_cos(&self, wo: DVec3, wi: DVec3) -> f64 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let h = wo + wi;
        let hl = h.length();
        if hl <= 0.0 {
            return 0.0;
        }
        let m = h / hl;
        self.d(m) * self.g2(wo, wi) / (4.0 * wo.z)
    }

    /// A reflected direction from the distribution of visible normals seen from `wo`
    /// (`wo.z > 0`), for uniform `(u1, u2)`. May point below the surface.
    pub fn sample_vndf(&self, wo: DVec3, u1: f64, u2: f64) -> DVec3 {
        let a = self.alpha;
        let vh = DVec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        let lensq = vh.x * vh.x + vh.y * vh.y;
        let t1 = if lensq > 0.0 {
            DVec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
        } else {
            DVec3::X
        };
        let t2 = vh.cross(t1);
        let r = u1.sqrt();
        let phi = 2.0 * PI * u2;
        let p1 = r * phi.cos();
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        let m = DVec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)).normalize();
        2.0 * wo.dot(m) * m - wo
    }

    /// The solid-angle pdf of [`Ggx::sample_vndf`] at `wi`: `G1(ωo) D(m) / (4 cos θo)`.
    pub fn pdf_vndf(&self, wo: DVec3, wi: DVec3) -> f64 {
        let h = wo + wi;
        let hl = h.length();
        if hl <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let m = h / hl;
        if wo.dot(m) <= 0.0 {
            return 0.0;
        }
        self.g1(wo) * self.d(m) / (4.0 * wo.z)
    }

    /// The directional albedo `ρ = ∫ f cos dωi = E_vndf[G2/G1]` from `n × n` stratified
    /// VNDF samples, with the (unnormalised) mean reflected direction weighted by `f cos`.
    pub fn albedo(&self, wo: DVec3, n: usize) -> (f64, DVec3) {
        let mut sum = 0.0;
        let mut dir = DVec3::ZERO;
        let g1o = self.g1(wo);
        for i in 0..n {
            for j in 0..n {
                let u1 = (i as f64 + 0.5) / n as f64;
                let u2 = (j as f64 + 0.5) / n as f64;
                let wi = self.sample_vndf(wo, u1, u2);
                if wi.z > 0.0 {
                    let w = self.g2(wo, wi) / g1o;
                    sum += w;
                    dir += w * wi;
                }
            }
        }
        let nn = (n * n) as f64;
        (sum / nn, dir / nn)
    }
}

/// A spherical cap for the std side: unit axis, half-angle σ, `1 − cos σ` kept exact.
#[derive(Clone, Copy, Debug)]
pub struct Cap64 {
    /// Unit axis.
    pub axis: DVec3,
    /// Half-angle σ in `[0, π]`.
    pub sigma: f64,
    /// `1 − cos σ`.
    pub one_minus_cos: f64,
}

impl Cap64 {
    /// The cap of half-angle `sigma` around the unit `axis`.
    pub fn new(axis: DVec3, sigma: f64) -> Cap64 {
        let s = (0.5 * sigma).sin();
        Cap64 {
            axis,
            sigma,
            one_minus_cos: 2.0 * s * s,
        }
    }

    /// The cap of a sphere seen under `sin σ = sin_sigma` (clamped to 1) around the unit
    /// `axis`, its `1 − cos σ = sin²σ / (1 + cos σ)` exact for tiny caps.
    pub fn from_sine(axis: DVec3, sin_sigma: f64) -> Cap64 {
        let s = sin_sigma.min(1.0);
        let c = (1.0 - s * s).max(0.0).sqrt();
        Cap64 {
            axis,
            sigma: s.asin(),
            one_minus_cos: s * s / (1.0 + c),
        }
    }

    /// Solid angle.
    pub fn area(&self) -> f64 {
        2.0 * PI * self.one_minus_cos
    }

    /// Whether unit `w` is inside (exact for tiny caps).
    pub fn contains(&self, w: DVec3) -> bool {
        0.5 * (w - self.axis).length_squared() <= self.one_minus_cos
    }

    /// A uniform direction in the cap for uniform `(u1, u2)`.
    pub fn sample(&self, u1: f64, u2: f64) -> DVec3 {
        // 1 − cos θ = u1 (1 − cos σ); sin θ from it without cancellation.
        let omc = u1 * self.one_minus_cos;
        let ct = 1.0 - omc;
        let st = (omc * (2.0 - omc)).max(0.0).sqrt();
        let phi = 2.0 * PI * u2;
        let (t1, t2) = self.axis.any_orthonormal_pair();
        self.axis * ct + (t1 * phi.cos() + t2 * phi.sin()) * st
    }
}

/// A ground-truth estimate of `∫_C f cos dω`.
#[derive(Clone, Copy, Debug)]
pub struct Truth {
    /// The estimate.
    pub value: f64,
    /// Its standard error (an upper bound: computed as if the samples were not stratified).
    pub std_err: f64,
}

/// The uniform numbers of an `n × n` jittered grid, cell `(i, j)`, with a cheap hash for the
/// jitter (deterministic).
fn jitter(seed: u64, i: usize, j: usize, n: usize) -> (f64, f64) {
    let mut z = seed ^ ((i as u64) << 32 | j as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    let mut next = || (crate::splitmix64(&mut z) >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
    let a = next();
    let b = next();
    ((i as f64 + a) / n as f64, (j as f64 + b) / n as f64)
}

/// `∫_C f cos dω` by multiple importance sampling of uniform-in-cap and VNDF sampling,
/// balance heuristic, `n × n` stratified pairs (docs/formulas.md, section 8, "Ground truth").
pub fn cap_integral(ggx: &Ggx, wo: DVec3, cap: &Cap64, n: usize, seed: u64) -> Truth {
    let area = cap.area();
    if area <= 0.0 || wo.z <= 0.0 {
        return Truth {
            value: 0.0,
            std_err: 0.0,
        };
    }
    let p_cap = 1.0 / area;
    let mut sum = 0.0;
    let mut sum2 = 0.0;
    let seed_v = seed ^ 0x5555_5555_5555_5555;
    for i in 0..n {
        for j in 0..n {
            let mut y = 0.0;
            // Uniform in the cap.
            let (u1, u2) = jitter(seed, i, j, n);
            let w = cap.sample(u1, u2);
            let f = ggx.eval_cos(wo, w);
            if f > 0.0 {
                y += f / (p_cap + ggx.pdf_vndf(wo, w));
            }
            // VNDF.
            let (u1, u2) = jitter(seed_v, i, j, n);
            let w = ggx.sample_vndf(wo, u1, u2);
            if w.z > 0.0 && cap.contains(w) {
                let f = ggx.eval_cos(wo, w);
                if f > 0.0 {
                    y += f / (p_cap + ggx.pdf_vndf(wo, w));
                }
            }
            sum += y;
            sum2 += y * y;
        }
    }
    let nn = (n * n) as f64;
    let mean = sum / nn;
    let var = (sum2 / nn - mean * mean).max(0.0);
    Truth {
        value: mean,
        std_err: (var / nn).sqrt(),
    }
}

/// `ωo` in the local frame for a view angle θo.
pub fn wo_local(theta_o: f64) -> DVec3 {
    DVec3::new(theta_o.sin(), 0.0, theta_o.cos())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vndf_pdf_integrates_to_one_and_matches_sampling() {
        // ∫ pdf over the sphere = 1 (uniform-sphere Monte Carlo), and the albedo from VNDF
        // sampling equals the albedo from uniform-hemisphere sampling.
        for &(alpha, theta) in &[(0.3, 0.4), (0.8, 1.2), (0.1, 0.0)] {
            let g = Ggx::new(alpha);
            let wo = wo_local(theta);
            let n = 600;
            let (mut int_pdf, mut alb) = (0.0, 0.0);
            for i in 0..n {
                for j in 0..n {
                    let (u1, u2) = jitter(7, i, j, n);
                    let z = 1.0 - 2.0 * u1;
                    let phi = 2.0 * PI * u2;
                    let s = (1.0 - z * z).max(0.0).sqrt();
                    let w = DVec3::new(s * phi.cos(), s * phi.sin(), z);
                    int_pdf += g.pdf_vndf(wo, w) * 4.0 * PI;
                    alb += g.eval_cos(wo, w) * 4.0 * PI;
                }
            }
            let nn = (n * n) as f64;
            let (int_pdf, alb) = (int_pdf / nn, alb / nn);
            let (rho, _) = g.albedo(wo, 256);
            let tol = if alpha < 0.2 { 0.05 } else { 0.01 };
            assert!((int_pdf - 1.0).abs() < tol, "∫pdf = {int_pdf} (α {alpha})");
            assert!(
                (alb / rho - 1.0).abs() < tol,
                "albedo {alb} vs VNDF {rho} (α {alpha})"
            );
        }
    }

    #[test]
    fn whole_hemisphere_truth_is_the_albedo() {
        for &(alpha, theta) in &[(0.05, 0.3), (0.5, 1.0), (1.0, 1.4)] {
            let g = Ggx::new(alpha);
            let wo = wo_local(theta);
            let t = cap_integral(&g, wo, &Cap64::new(DVec3::Z, PI / 2.0), 128, 3);
            let (rho, _) = g.albedo(wo, 256);
            assert!((t.value / rho - 1.0).abs() < 0.01, "{} vs {rho}", t.value);
            assert!(t.std_err < 0.03 * rho);
        }
    }
}
