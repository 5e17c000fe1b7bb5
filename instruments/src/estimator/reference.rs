//! The exact value of a configuration: every light integrated on its own, independently of the
//! library's light sampling (own samplers in f64), until its relative standard error is below
//! a target.
//!
//! The integrand is the reflected radiance without visibility,
//! `Σ_lights ∫_{light} f(ωo, ωi) · L · cos θi dωi`, with f from [`Material`]'s
//! [`Brdf::eval`] and L the light's radiance towards x (0 behind a one-sided disk, whose
//! whole contribution is then skipped).
//!
//! - **Sphere** (x is always outside): directions uniform in the cone the sphere subtends,
//!   value `f · L · max(0, cos θi) · 2π(1 − cos σ)`.
//! - **Disk**: points uniform by area through the polar map (not the concentric map of the
//!   library), value `f · L · max(0, cos θi) · |cos θy| · A / d²`.
//!
//! A light whose solid angle lies entirely below the horizon of the normal contributes exactly
//! 0 and is skipped (spheres: `n·a ≤ −sin σ`; disks: the highest point of the disk above the
//! tangent plane, `n·(c − x) + R·sqrt(1 − (n·n_d)²)`, is ≤ 0).
//!
//! **Estimator**: jittered stratified sampling of the unit square on an `m × m` grid with two
//! independent points per cell. The cell means give the estimate and the two points per cell an
//! unbiased estimate of its variance, `Var = (1/m⁴) Σ_cells (g₁ − g₂)² / 4`, with `m²` degrees
//! of freedom. `m` starts at 16 and doubles (each level a fresh estimate) until the relative
//! standard error is below the target or `m` reaches [`MAX_GRID`]; a light whose samples are all
//! 0 at `m = 64` is taken as 0 (it can only be a sliver at the horizon). Then, while the
//! configuration's total has a relative standard error above its own target, the light with
//! the largest standard error is estimated afresh on a grid twice as fine.

use super::scene::Scene;
use glam::{DVec3, Vec3};
use manylights::{Brdf, Frame, Light, Material, ShadingPoint};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f64::consts::PI;

/// Largest stratification grid side.
pub const MAX_GRID: usize = 2048;

/// One light's integral.
#[derive(Clone, Copy, Debug, Default)]
pub struct LightIntegral {
    /// The value.
    pub value: f64,
    /// Its standard error.
    pub std_err: f64,
    /// Integrand evaluations spent.
    pub evals: u64,
    /// Side of the stratification grid.
    pub grid: usize,
}

/// One configuration's exact value.
#[derive(Clone, Copy, Debug, Default)]
pub struct Reference {
    /// Sum over the lights.
    pub value: f64,
    /// Its standard error (the lights' errors in quadrature).
    pub std_err: f64,
    /// Largest relative standard error of a light with a positive value.
    pub worst_light_rel_se: f64,
    /// Lights integrated (not skipped as exactly 0).
    pub integrated: usize,
    /// Lights that did not reach the target within [`MAX_GRID`].
    pub unconverged: usize,
    /// Integrand evaluations.
    pub evals: u64,
}

/// The BRDF side of the integrand.
struct Receiver {
    x: DVec3,
    n: DVec3,
    frame: Frame,
    wo: Vec3,
    material: Material,
}

impl Receiver {
    fn new(sp: &ShadingPoint) -> Receiver {
        let frame = Frame::from_normal(sp.normal).expect("non-zero normal");
        Receiver {
            x: sp.position.as_dvec3(),
            n: frame.normal.as_dvec3(),
            frame,
            wo: frame.to_local(sp.wo.normalize()),
            material: sp.material,
        }
    }

    /// `f(ωo, ω) · max(0, cos θi)` for a unit world direction ω.
    #[inline]
    fn f_cos(&self, w: DVec3) -> f64 {
        let cos = self.n.dot(w);
        if cos <= 0.0 {
            return 0.0;
        }
        let wi = self.frame.to_local(w.as_vec3());
        f64::from(self.material.eval(self.wo, wi)) * cos
    }
}

/// An orthonormal basis (t, b) of the plane orthogonal to the unit `a`.
fn basis(a: DVec3) -> (DVec3, DVec3) {
    let t = a.any_orthonormal_vector();
    (t, a.cross(t))
}

/// One light's integrand over [0, 1)² (see the module documentation).
enum Integrand {
    Sphere {
        /// Unit direction x → centre and its basis.
        a: DVec3,
        t: DVec3,
        b: DVec3,
        /// 1 − cos σ.
        omc_max: f64,
        /// L · 2π(1 − cos σ).
        scale: f64,
    },
    Disk {
        c: DVec3,
        /// Unit normal and its basis.
        nd: DVec3,
        t: DVec3,
        b: DVec3,
        r: f64,
        /// L · A.
        scale: f64,
    },
}

impl Integrand {
    /// The integrand of `light` at `rx`; `None` when the contribution is exactly 0.
    fn new(light: &Light, rx: &Receiver) -> Option<Integrand> {
        match *light {
            Light::Sphere {
                center,
                radius,
                radiance,
            } => {
                let v = center.as_dvec3() - rx.x;
                let d2 = v.length_squared();
                let r = f64::from(radius);
                assert!(
                    d2 > r * r,
                    "the estimator scene keeps x outside every sphere"
                );
                let a = v / d2.sqrt();
                let sin2 = r * r / d2;
                if rx.n.dot(a) <= -sin2.sqrt() {
                    return None;
                }
                let omc_max = sin2 / (1.0 + (1.0 - sin2).sqrt());
                let (t, b) = basis(a);
                Some(Integrand::Sphere {
                    a,
                    t,
                    b,
                    omc_max,
                    scale: f64::from(radiance.luminance()) * 2.0 * PI * omc_max,
                })
            }
            Light::Disk {
                center,
                normal,
                radius,
                radiance,
                two_sided,
            } => {
                let c = center.as_dvec3();
                let nd = normal.as_dvec3().normalize();
                let side = nd.dot(rx.x - c);
                if side == 0.0 || (!two_sided && side < 0.0) {
                    return None;
                }
                let r = f64::from(radius);
                let cos_nn = rx.n.dot(nd);
                if rx.n.dot(c - rx.x) + r * (1.0 - cos_nn * cos_nn).max(0.0).sqrt() <= 0.0 {
                    return None;
                }
                let (t, b) = basis(nd);
                Some(Integrand::Disk {
                    c,
                    nd,
                    t,
                    b,
                    r,
                    scale: f64::from(radiance.luminance()) * PI * r * r,
                })
            }
            _ => panic!("the estimator scene holds only spheres and disks"),
        }
    }

    #[inline]
    fn eval(&self, rx: &Receiver, u0: f64, u1: f64) -> f64 {
        let (sp, cp) = (2.0 * PI * u1).sin_cos();
        match *self {
            Integrand::Sphere {
                a,
                t,
                b,
                omc_max,
                scale,
            } => {
                let omc = u0 * omc_max;
                let cos = 1.0 - omc;
                let sin = (omc * (2.0 - omc)).max(0.0).sqrt();
                let w = (a * cos + (t * cp + b * sp) * sin).normalize();
                rx.f_cos(w) * scale
            }
            Integrand::Disk {
                c,
                nd,
                t,
                b,
                r,
                scale,
            } => {
                let p = c + (t * cp + b * sp) * (r * u0.sqrt());
                let v = p - rx.x;
                let dist2 = v.length_squared();
                let w = v / dist2.sqrt();
                rx.f_cos(w) * nd.dot(w).abs() / dist2 * scale
            }
        }
    }

    /// Jittered stratified estimate on an `m × m` grid, two points per cell.
    fn integrate(&self, rx: &Receiver, m: usize, rng: &mut Pcg64Mcg) -> LightIntegral {
        let inv = 1.0 / m as f64;
        let (mut sum, mut var) = (0.0f64, 0.0f64);
        for i in 0..m {
            for j in 0..m {
                let mut s = [0.0f64; 2];
                for v in &mut s {
                    let u0 = (i as f64 + rng.random::<f64>()) * inv;
                    let u1 = (j as f64 + rng.random::<f64>()) * inv;
                    *v = self.eval(rx, u0, u1);
                }
                sum += s[0] + s[1];
                var += (s[0] - s[1]) * (s[0] - s[1]);
            }
        }
        let cells = (m * m) as f64;
        LightIntegral {
            value: sum / (2.0 * cells),
            std_err: (var / 4.0).sqrt() / cells,
            evals: 2 * (m * m) as u64,
            grid: m,
        }
    }
}

/// The exact value of configuration `sp` of `scene`: each light to relative standard error
/// `light_target`; then the lights with the largest variance are refined (grid side doubled,
/// fresh estimate) until the total's relative standard error is below `total_target` or they
/// reach [`MAX_GRID`].
pub fn reference(
    scene: &Scene,
    sp: &ShadingPoint,
    light_target: f64,
    total_target: f64,
    seed: u64,
) -> Reference {
    let rx = Receiver::new(sp);
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut out = Reference::default();
    let mut parts: Vec<(Integrand, LightIntegral)> = Vec::new();
    for light in scene.set.lights() {
        let Some(g) = Integrand::new(light, &rx) else {
            continue;
        };
        let mut m = 16;
        let li = loop {
            let li = g.integrate(&rx, m, &mut rng);
            out.evals += li.evals;
            let done = if li.value > 0.0 {
                li.std_err <= light_target * li.value
            } else {
                m >= 64
            };
            if done || m >= MAX_GRID {
                break li;
            }
            m *= 2;
        };
        parts.push((g, li));
    }
    loop {
        let value: f64 = parts.iter().map(|p| p.1.value).sum();
        let var: f64 = parts.iter().map(|p| p.1.std_err * p.1.std_err).sum();
        if var.sqrt() <= total_target * value {
            break;
        }
        let worst = parts
            .iter_mut()
            .filter(|p| p.1.grid < MAX_GRID)
            .max_by(|a, b| a.1.std_err.total_cmp(&b.1.std_err));
        let Some((g, li)) = worst else {
            break;
        };
        let next = g.integrate(&rx, li.grid * 2, &mut rng);
        out.evals += next.evals;
        *li = next;
    }
    out.integrated = parts.len();
    let mut var = 0.0;
    for (_, li) in &parts {
        out.value += li.value;
        var += li.std_err * li.std_err;
        if li.value > 0.0 {
            let rel = li.std_err / li.value;
            out.worst_light_rel_se = out.worst_light_rel_se.max(rel);
            if rel > light_target {
                out.unconverged += 1;
            }
        }
    }
    out.std_err = var.sqrt();
    out
}
