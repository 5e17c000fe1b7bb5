//! The environment: the host's sky or environment map ([`Environment`]: its radiance, its
//! sampling and that sampling's pdf, and bounds of the irradiance it delivers), and two
//! built-in ones for renderers and tests: a uniform environment ([`UniformSky`]) and an
//! analytic sky ([`GradientSky`]).
//!
//! An environment is infinitely far: its radiance and pdf depend on the direction alone. It
//! is given once, to the light set ([`crate::LightSet::build_with_environment`]), which holds it
//! for every estimate: there it is the light [`Light::Environment`](crate::Light::Environment) carrying
//! [`Environment::irradiance_bounds`], the last of the set's lights, which the importances
//! weigh against the other lights.

use crate::colour::Rgb;
use crate::math;
use core::f32::consts::PI;
use glam::Vec3;

/// A direction sampled from an environment, with its radiance and solid-angle pdf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvironmentSample {
    /// Unit direction from the shading point towards the environment.
    pub direction: Vec3,
    /// The radiance arriving along `-direction`.
    pub radiance: Rgb,
    /// The solid-angle pdf of having sampled `direction` (> 0, finite).
    pub pdf: f32,
}

/// The host's environment: its radiance, its importance sampling and that sampling's pdf, and
/// bounds of the irradiance it delivers.
///
/// Its values are checked where they are used: a sample's direction must be finite and
/// non-zero, its pdf positive and finite, every radiance channel (of a sample and of
/// [`Environment::eval`]) finite and non-negative, `eval`'s pdf finite and non-negative;
/// anything else is an error of the estimate ([`crate::error::DirectError`]), never a NaN.
pub trait Environment {
    /// A direction for the uniform numbers `u` in [0, 1)², or `None` (the sample is skipped).
    fn sample(&self, u: [f32; 2]) -> Option<EnvironmentSample>;
    /// The radiance arriving along `-direction` from the unit `direction`, and the solid-angle
    /// pdf with which [`Environment::sample`] returns it (0 where it never does).
    fn eval(&self, direction: Vec3) -> (Rgb, f32);
    /// Upper bounds of the irradiance (luminance, W/m²) the environment delivers to a receiver
    /// facing +x, −x, +y, −y, +z and −z: `∫ Y(L(ω)) max(0, a·ω) dω` for each axis direction
    /// a (the field of [`Light::Environment`](crate::Light::Environment), with the same validation when the set is
    /// built). A uniform environment of radiance L has πY(L) in all six.
    ///
    /// The bounds decide how often the environment is chosen, never how it is weighed, so
    /// bounds that are too large cost variance only. Bounds must not be too small: where the
    /// bound at a receiver's normal is 0 while the environment lights it, the importances
    /// never choose the environment there, and the techniques that take no BSDF sample at
    /// the point (`power`, `tl`, `bl`, `tl-split`, and `mis-equal` and `full` where their
    /// budget is 0) lose its light — biased low. Positive bounds that are too small keep
    /// every technique unbiased, at the cost of variance.
    fn irradiance_bounds(&self) -> [f32; 6];
}

/// An environment behind a reference or a pointer is the environment: `&E`, `Box<E>`, and
/// (where the target has atomics) `Arc<E>` — a host that keeps its map elsewhere as well gives
/// the light set an `Arc` of it.
macro_rules! forward_environment {
    ($($(#[$attr:meta])* $ty:ty;)*) => {$(
        $(#[$attr])*
        impl<E: Environment + ?Sized> Environment for $ty {
            #[inline]
            fn sample(&self, u: [f32; 2]) -> Option<EnvironmentSample> {
                (**self).sample(u)
            }

            #[inline]
            fn eval(&self, direction: Vec3) -> (Rgb, f32) {
                (**self).eval(direction)
            }

            #[inline]
            fn irradiance_bounds(&self) -> [f32; 6] {
                (**self).irradiance_bounds()
            }
        }
    )*};
}

forward_environment! {
    &E;
    alloc::boxed::Box<E>;
    #[cfg(target_has_atomic = "ptr")]
    alloc::sync::Arc<E>;
}

/// A uniform environment of radiance `radiance`, sampled uniformly over the sphere (pdf
/// `1 / 4π`). A Lambert surface of albedo ρ under it reflects `ρ · radiance` (its irradiance
/// is π · radiance).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UniformSky {
    /// The radiance from every direction.
    pub radiance: Rgb,
}

/// The unit direction of `u` on the sphere (uniform), `z = 1 − 2 u₀`.
#[inline]
fn uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = math::sqrt((1.0 - z * z).max(0.0));
    let (s, c) = math::sin_cos(2.0 * PI * u[1]);
    Vec3::new(r * c, r * s, z)
}

impl Environment for UniformSky {
    fn sample(&self, u: [f32; 2]) -> Option<EnvironmentSample> {
        Some(EnvironmentSample {
            direction: math::normalize(uniform_sphere(u)),
            radiance: self.radiance,
            pdf: 1.0 / (4.0 * PI),
        })
    }

    fn eval(&self, _direction: Vec3) -> (Rgb, f32) {
        (self.radiance, 1.0 / (4.0 * PI))
    }

    /// `π Y(radiance)` on every axis.
    fn irradiance_bounds(&self) -> [f32; 6] {
        [PI * self.radiance.luminance(); 6]
    }
}

/// An analytic sky about the unit `up`: above the horizon (`c = up·ω > 0`) the radiance
/// `horizon (1 − c) + zenith c`, below it `ground`. The upper hemisphere is sampled with
/// probability q, the lower one uniformly otherwise, q the upper hemisphere's share of
/// `Y(zenith) + Y(horizon)` against `2 Y(ground)` (1 for a black ground); within the upper
/// one, the cosine lobe about `up` with probability `1 − ε` and uniformly with probability
/// ε = [`GradientSky::UNIFORM_SHARE`]: pdf `q ((1 − ε) c / π + ε / 2π)` above, `(1 − q) / 2π`
/// below. The uniform share keeps the pdf away from 0 at the horizon, where the radiance is
/// not, so that a sample's radiance over its pdf stays bounded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GradientSky {
    /// The up direction (unit).
    pub up: Vec3,
    /// Radiance at the zenith.
    pub zenith: Rgb,
    /// Radiance at the horizon.
    pub horizon: Rgb,
    /// Radiance below the horizon.
    pub ground: Rgb,
}

impl GradientSky {
    /// ε: the share of the upper hemisphere's samples taken uniformly instead of by the
    /// cosine about `up`.
    pub const UNIFORM_SHARE: f32 = 0.2;

    /// The probability of sampling the upper hemisphere.
    fn q(&self) -> f32 {
        let up = self.zenith.luminance() + self.horizon.luminance();
        let low = 2.0 * self.ground.luminance();
        if up + low > 0.0 {
            up / (up + low)
        } else {
            1.0
        }
    }

    /// On a receiver facing the axis direction a, with `c = a·up`, the irradiance is at most
    /// `Y_up π (1 + c)/2 + Y(ground) π (1 − c)/2`, `Y_up` the larger of the zenith's and the
    /// horizon's luminance (the clamped cosine integrates to `π (1 + c)/2` over the upper
    /// hemisphere), rounded up.
    fn bounds(&self) -> [f32; 6] {
        let y_up = self.zenith.luminance().max(self.horizon.luminance());
        let y_low = self.ground.luminance();
        let axes = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        let up = math::normalize(self.up);
        axes.map(|a| {
            let c = a.dot(up).clamp(-1.0, 1.0);
            let e = y_up * PI * (1.0 + c) * 0.5 + y_low * PI * (1.0 - c) * 0.5;
            e * (1.0 + 1e-5)
        })
    }

    /// The radiance along `-d` for a unit `d`.
    fn radiance(&self, d: Vec3) -> Rgb {
        let c = d.dot(self.up);
        if c > 0.0 {
            self.horizon * (1.0 - c) + self.zenith * c
        } else {
            self.ground
        }
    }
}

impl Environment for GradientSky {
    fn sample(&self, u: [f32; 2]) -> Option<EnvironmentSample> {
        let q = self.q();
        let up = math::normalize(self.up);
        let (t, b) = crate::brdf::Frame::from_normal(up).map(|f| (f.tangent, f.bitangent))?;
        let eps = GradientSky::UNIFORM_SHARE;
        let local = if u[0] < q * (1.0 - eps) {
            // Cosine-weighted about up (Malley), the first number rescaled.
            let v = (u[0] / (q * (1.0 - eps))).min(1.0);
            let r = math::sqrt(v);
            let (s, c) = math::sin_cos(2.0 * PI * u[1]);
            Vec3::new(r * c, r * s, math::sqrt((1.0 - v).max(0.0)))
        } else if u[0] < q {
            // Uniform over the upper hemisphere: cos θ uniform in (0, 1].
            let z = 1.0 - ((u[0] - q * (1.0 - eps)) / (q * eps)).min(1.0);
            let r = math::sqrt((1.0 - z * z).max(0.0));
            let (s, c) = math::sin_cos(2.0 * PI * u[1]);
            Vec3::new(r * c, r * s, z)
        } else {
            let v = ((u[0] - q) / (1.0 - q)).min(1.0);
            let z = -v;
            let r = math::sqrt((1.0 - z * z).max(0.0));
            let (s, c) = math::sin_cos(2.0 * PI * u[1]);
            Vec3::new(r * c, r * s, z)
        };
        let d = math::normalize(t * local.x + b * local.y + up * local.z);
        let (radiance, pdf) = self.eval(d);
        (pdf > 0.0 && pdf < f32::INFINITY).then_some(EnvironmentSample {
            direction: d,
            radiance,
            pdf,
        })
    }

    fn eval(&self, d: Vec3) -> (Rgb, f32) {
        let q = self.q();
        let c = d.dot(math::normalize(self.up));
        let eps = GradientSky::UNIFORM_SHARE;
        let pdf = if c > 0.0 {
            q * ((1.0 - eps) * c / PI + eps / (2.0 * PI))
        } else {
            (1.0 - q) / (2.0 * PI)
        };
        (self.radiance(d), pdf)
    }

    fn irradiance_bounds(&self) -> [f32; 6] {
        self.bounds()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::brdf::Frame;

    fn sky(ground: Rgb) -> GradientSky {
        GradientSky {
            up: Vec3::new(0.2, 1.0, 0.1).normalize(),
            zenith: Rgb::new(0.1, 0.2, 0.5),
            horizon: Rgb::new(0.6, 0.5, 0.4),
            ground,
        }
    }

    /// The pdf a sample reports is `eval`'s, it integrates to 1 over the sphere, it is at least
    /// `q ε / 2π` above the horizon, and the sampled directions follow it: the counts in ten
    /// bands of `c = up·ω` (five above the horizon, five below) are within 5 standard
    /// deviations of `N ∫_band pdf`.
    #[test]
    fn gradient_sky_samples_its_pdf() {
        for ground in [Rgb::ZERO, Rgb::new(0.1, 0.08, 0.05)] {
            let s = sky(ground);
            let up = s.up;
            // ∫ pdf over the sphere, by c (the pdf depends on c alone): 2π ∫ pdf(c) dc.
            let m = 200_000;
            let mut integral = 0.0f64;
            for i in 0..m {
                let c = -1.0 + 2.0 * (i as f64 + 0.5) / m as f64;
                let d = up * c as f32
                    + Frame::from_normal(up).unwrap().tangent * (1.0 - c * c).sqrt() as f32;
                integral += f64::from(s.eval(d.normalize()).1) * 2.0 / m as f64;
            }
            integral *= 2.0 * core::f64::consts::PI;
            assert!((integral - 1.0).abs() < 1e-3, "∫ pdf = {integral}");
            let floor = s.q() * GradientSky::UNIFORM_SHARE / (2.0 * PI);
            let grazing = Frame::from_normal(up).unwrap().tangent * 0.999_999 + up * 1e-3;
            assert!(s.eval(grazing.normalize()).1 >= floor * 0.999);
            // Stratified samples, binned by c.
            let n = 400usize;
            let mut bins = [0usize; 10];
            for i in 0..n {
                for j in 0..n {
                    let u = [(i as f32 + 0.37) / n as f32, (j as f32 + 0.61) / n as f32];
                    let e = s.sample(u).expect("a sample");
                    let (r, pdf) = s.eval(e.direction);
                    assert_eq!((e.radiance, e.pdf), (r, pdf), "sample vs eval at {u:?}");
                    let c = f64::from(e.direction.dot(up)).clamp(-1.0, 1.0);
                    bins[(((c + 1.0) * 5.0) as usize).min(9)] += 1;
                }
            }
            let total = (n * n) as f64;
            for (b, &count) in bins.iter().enumerate() {
                let (lo, hi) = (-1.0 + 0.2 * b as f64, -0.8 + 0.2 * b as f64);
                let k = 2000;
                let mut p = 0.0f64;
                for i in 0..k {
                    let c = lo + (hi - lo) * (i as f64 + 0.5) / k as f64;
                    let d = up * c as f32
                        + Frame::from_normal(up).unwrap().tangent * (1.0 - c * c).sqrt() as f32;
                    p += f64::from(s.eval(d.normalize()).1) * (hi - lo) / k as f64;
                }
                let want = total * 2.0 * core::f64::consts::PI * p;
                let sd = (want * (1.0 - want / total)).sqrt().max(1.0);
                assert!(
                    (count as f64 - want).abs() <= 5.0 * sd,
                    "band {b}: {count} samples, expected {want:.0} ± {sd:.0}"
                );
            }
        }
    }
}
