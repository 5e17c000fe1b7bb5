//! Probabilistic VPL acceptance (Georgiev & Slusallek 2010, "Simple and Robust Iterative
//! Importance Sampling of Virtual Point Lights", section 3): every virtual point light (VPL)
//! candidate of an instant-radiosity random walk (Keller 1997) is kept by a Russian-roulette
//! decision in proportion to its estimated contribution to the image, and a kept one has its
//! intensity divided by its acceptance probability, so that the expected VPL set is that of
//! plain instant radiosity (their Eqn. 2).
//!
//! With P pixels, N VPLs wanted, Φ̃_total an estimate of the image's total VPL illumination
//! luminance (the sum over its pixels; 0 before the first frame):
//!
//! ```text
//! Φ̃_v = Φ̃_total / (P · N)                 the wanted average pixel contribution of one VPL
//! Φ̃_i = (1/N_C) Σ_j c_ij                   the candidate's average contribution to N_C importons
//! p_i = min(Φ̃_i / Φ̃_v + ε, 1)             (their Eqn. 3; p_i = 1 while Φ̃_total = 0)
//! accept if ξ ≤ p_i; the accepted VPL has intensity I_i / p_i
//! ```
//!
//! One addition: p_i is at least `πI_i / MAX_LIGHT_ENERGY` (with a margin for rounding), so
//! that an accepted VPL is a valid [`Light`] (energy within [`crate::MAX_LIGHT_ENERGY`]) with a
//! finite intensity whatever ε; it only matters for intensities within a factor 1/ε of that
//! limit, and like any positive p independent of ξ it keeps the estimate unbiased.
//!
//! `c_ij = f_j · G_ij · V_ij · I_i` is the radiance VPL i sends through importon j towards the
//! camera: f_j the importon's BRDF, `G = max(0, cos θ_j) · max(0, cos θ_i) / d²` (optionally
//! clamped, [`VplAcceptor::with_geometry_clamp`]), V the host's visibility test
//! ([`Visibility`]; none means unoccluded). Importons ([`Importons`]) are camera-ray hit points;
//! the paper uses ε = 0.05 and N_C = 100 ([`DEFAULT_EPSILON`], [`DEFAULT_IMPORTONS`]).
//! Between frames the host reports each frame's total VPL luminance and [`VplAcceptor::update`]
//! refines Φ̃_total as their running mean (the paper's progressive scheme, section 3.3).
//!
//! Unbiasedness needs only that p_i is positive and independent of ξ: E[accepted intensity] =
//! p_i · I_i / p_i = I_i. An estimate Φ̃_i of any quality keeps it; a poor one costs variance.
//!
//! An accepted VPL is a [`Light::Vpl`] (radiant intensity `I · max(0, cos θ)` about its normal),
//! so the accepted set goes into a [`crate::LightTree`] like any other lights.
//!
//! Nothing here allocates per candidate: the importons are stored once per frame, structure of
//! arrays, four to an f32x4, and a candidate's contribution to four importons is one 4-wide
//! evaluation ([`Importons::contribution4`], with its scalar twin [`Importons::contribution`]).

mod acceptor;
mod importons;

pub use acceptor::{AcceptStats, Accepted, VplAcceptor, DEFAULT_EPSILON};
pub use importons::{Importons, DEFAULT_IMPORTONS};

use crate::colour::Rgb;
use crate::error::{Problem, VplError, VplField};
use crate::light::{Light, MAX_COORDINATE, MAX_LIGHT_ENERGY};
use glam::Vec3;

/// A VPL candidate (or an accepted VPL): a point emitting `intensity · max(0, cos θ)` about its
/// `normal`, as [`Light::Vpl`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vpl {
    /// Position.
    pub position: Vec3,
    /// Normal: the emitting side (need not be unit length).
    pub normal: Vec3,
    /// Radiant intensity along the normal (W/sr, every channel ≥ 0); acceptance weighs its
    /// luminance.
    pub intensity: Rgb,
}

impl Vpl {
    /// The light of this VPL.
    #[must_use]
    pub fn light(&self) -> Light {
        Light::Vpl {
            position: self.position,
            normal: self.normal,
            intensity: self.intensity,
        }
    }

    /// Its emitted power πI, I the intensity's luminance (as [`Light::energy`]).
    #[must_use]
    pub fn energy(&self) -> f32 {
        core::f32::consts::PI * self.intensity.luminance()
    }

    /// Checks every field: finite position within [`MAX_COORDINATE`], finite non-zero normal,
    /// finite non-negative intensity whose energy πI is at most [`MAX_LIGHT_ENERGY`] (as for
    /// [`Light::Vpl`]). Returns the unit normal.
    pub fn validate(&self) -> Result<Vec3, VplError> {
        check_position(VplField::Position, self.position)?;
        let n = unit(VplField::Normal, self.normal)?;
        for v in self.intensity.to_array() {
            if !v.is_finite() {
                return Err(err(VplField::Intensity, Problem::NotFinite, v));
            }
            if v < 0.0 {
                return Err(err(VplField::Intensity, Problem::Negative, v));
            }
        }
        let y = self.intensity.luminance();
        if core::f64::consts::PI * f64::from(y) > f64::from(MAX_LIGHT_ENERGY) {
            return Err(err(VplField::Intensity, Problem::EnergyTooLarge, y));
        }
        Ok(n)
    }
}

impl From<Vpl> for Light {
    fn from(v: Vpl) -> Light {
        v.light()
    }
}

/// The host's visibility test between an importon and a VPL: `visible(importon, vpl)` is
/// whether the segment between the two points is unoccluded (a shadow ray). Any
/// `FnMut(Vec3, Vec3) -> bool` is one; [`Unoccluded`] is the test that always passes.
pub trait Visibility {
    /// Whether `vpl` is visible from `importon`.
    fn visible(&mut self, importon: Vec3, vpl: Vec3) -> bool;
}

impl<F: FnMut(Vec3, Vec3) -> bool> Visibility for F {
    #[inline]
    fn visible(&mut self, importon: Vec3, vpl: Vec3) -> bool {
        self(importon, vpl)
    }
}

/// No visibility test: every importon sees every VPL.
#[derive(Clone, Copy, Debug, Default)]
pub struct Unoccluded;

impl Visibility for Unoccluded {
    #[inline]
    fn visible(&mut self, _: Vec3, _: Vec3) -> bool {
        true
    }
}

fn err(field: VplField, problem: Problem, value: f32) -> VplError {
    VplError {
        field,
        problem,
        value,
    }
}

fn check_position(field: VplField, p: Vec3) -> Result<(), VplError> {
    for v in p.to_array() {
        if !v.is_finite() {
            return Err(err(field, Problem::NotFinite, v));
        }
        if v.abs() > MAX_COORDINATE {
            return Err(err(field, Problem::OutOfRange, v));
        }
    }
    Ok(())
}

/// The unit vector of `v` (normalised in f64, as the lights' normals are).
fn unit(field: VplField, v: Vec3) -> Result<Vec3, VplError> {
    for c in v.to_array() {
        if !c.is_finite() {
            return Err(err(field, Problem::NotFinite, c));
        }
    }
    crate::brdf::Frame::from_normal(v)
        .map(|f| f.normal)
        .ok_or(err(field, Problem::ZeroLength, 0.0))
}
