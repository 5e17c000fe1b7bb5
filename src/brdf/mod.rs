//! BRDF helpers, so that a host's BRDF sampling (TB) and the library's estimators use the same
//! lobes and pdfs (Liu et al. 2019, "Adaptive BRDF-Oriented Multiple Importance Sampling of Many
//! Lights", section 4.2: the BRDF-sampling technique):
//!
//! - [`Ggx`]: the GGX / Trowbridge–Reitz microfacet reflection lobe (Walter et al. 2007,
//!   "Microfacet Models for Refraction through Rough Surfaces") with the height-correlated Smith
//!   masking-shadowing term (Heitz 2014, "Understanding the Masking-Shadowing Function in
//!   Microfacet-Based BRDFs"), sampled through its distribution of visible normals (Heitz 2018,
//!   "Sampling the GGX Distribution of Visible Normals");
//! - [`Lambert`]: the diffuse lobe, cosine-sampled through the concentric map (Shirley & Chiu
//!   1997);
//! - [`Frame`]: the local shading frame in which both are written (normal = +z);
//! - [`Material`](crate::Material) implements [`Brdf`] too: its lobes weighted as the material
//!   says, sampled by choosing a lobe in proportion to its weight (one-sample MIS of the lobes,
//!   Veach 1997, section 9.2.4), with the mixture's pdf. Its [`Brdf::eval`] is one scalar, f
//!   with the albedo's luminance (what the importances and the lobe choice use; for a grey
//!   albedo it is f in every channel); f in colour, what the estimators multiply by, is
//!   [`Material::eval_rgb`](crate::Material::eval_rgb).
//!
//! Conventions: directions point away from the surface and are unit vectors of the local frame;
//! `eval` returns the BRDF value f (not f·cos θ); pdfs are solid-angle densities of `wi`. A view
//! direction at or below the horizon (`wo.z ≤ 0`), a `wi` below it, and any non-finite input give
//! `None` or 0. `sample` returns the pdf computed by `pdf` for the direction it returns, so the
//! two agree to the bit.

mod frame;
mod ggx;
mod lambert;
mod material;

pub use frame::Frame;
pub use ggx::Ggx;
pub use lambert::Lambert;

use crate::math::ONE_MINUS_EPSILON;
use glam::Vec3;

/// A reflection lobe in the local shading frame (normal = +z).
pub trait Brdf {
    /// The BRDF value f(wo, wi) (not multiplied by cos θi); 0 if either direction is at or below
    /// the horizon.
    fn eval(&self, wo: Vec3, wi: Vec3) -> f32;
    /// A direction `wi` above the horizon and its solid-angle pdf, for `u` uniform in [0, 1)².
    /// `None` when wo is at or below the horizon or the sampled direction is (the draw then
    /// contributes 0; it is part of the distribution that [`Brdf::pdf`] describes).
    fn sample(&self, wo: Vec3, u: [f32; 2]) -> Option<(Vec3, f32)>;
    /// The solid-angle pdf with which [`Brdf::sample`] returns `wi` (0 below the horizon).
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
}

/// Schlick's approximation of the Fresnel reflectance, `F0 + (1 − F0)(1 − cos θ)⁵` (Schlick
/// 1994, "An Inexpensive BRDF Model for Physically-based Rendering"), for hosts that want to
/// weight a [`Ggx`] lobe; `cos_theta` is clamped into [0, 1].
#[inline]
#[must_use]
#[cfg(any(test, feature = "internals"))]
pub fn schlick(f0: f32, cos_theta: f32) -> f32 {
    let m = 1.0 - cos_theta.clamp(0.0, 1.0);
    let m2 = m * m;
    f0 + (1.0 - f0) * m2 * m2 * m
}

/// `u` clamped into [0, 1)², or `None` if it holds a NaN.
#[inline]
fn unit_square(u: [f32; 2]) -> Option<[f32; 2]> {
    if u[0].is_nan() || u[1].is_nan() {
        return None;
    }
    Some(u.map(|v| v.clamp(0.0, ONE_MINUS_EPSILON)))
}

#[inline]
fn finite(v: Vec3) -> bool {
    v.is_finite()
}
