//! The acceptance decision of Georgiev & Slusallek 2010 (section 3.2, Eqn. 3) and the
//! progressive estimate of the image's total VPL luminance (section 3.3).

use super::{err, Importons, Unoccluded, Visibility, Vpl};
use crate::error::{Problem, VplError, VplField};
use crate::light::MAX_LIGHT_ENERGY;

/// The paper's ε = 0.05: the lowest acceptance probability of a candidate.
pub const DEFAULT_EPSILON: f32 = 0.05;

/// A candidate that was kept: the VPL with its intensity divided by `probability`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Accepted {
    /// The VPL to render with (intensity already scaled by 1/p).
    pub vpl: Vpl,
    /// Its acceptance probability p, in (0, 1].
    pub probability: f32,
}

/// Counts of the decisions since the last [`VplAcceptor::reset_stats`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AcceptStats {
    /// Candidates decided.
    pub candidates: u64,
    /// Candidates accepted.
    pub accepted: u64,
    /// Σ p over the candidates.
    pub sum_probability: f64,
    /// Σ πI over the candidates (their energy before acceptance).
    pub candidate_energy: f64,
    /// Σ πI/p over the accepted VPLs (their energy as rendered).
    pub accepted_energy: f64,
    /// Σ (πI)² (1/p − 1) over the candidates: the variance of `accepted_energy` given the
    /// probabilities (its expectation is `candidate_energy`).
    pub energy_variance: f64,
}

impl AcceptStats {
    /// Accepted / candidates (0 with no candidate).
    #[must_use]
    pub fn acceptance_rate(&self) -> f64 {
        if self.candidates == 0 {
            0.0
        } else {
            self.accepted as f64 / self.candidates as f64
        }
    }

    /// `accepted_energy / candidate_energy` (1 in expectation) and its standard deviation
    /// from [`AcceptStats::energy_variance`]; (1, 0) with no candidate energy.
    #[must_use]
    pub fn energy_ratio(&self) -> (f64, f64) {
        if self.candidate_energy > 0.0 {
            (
                self.accepted_energy / self.candidate_energy,
                crate::math::sqrt64(self.energy_variance) / self.candidate_energy,
            )
        } else {
            (1.0, 0.0)
        }
    }

    /// Adds the counts of `other` (e.g. of another thread's acceptor).
    pub fn merge(&mut self, other: &AcceptStats) {
        self.candidates += other.candidates;
        self.accepted += other.accepted;
        self.sum_probability += other.sum_probability;
        self.candidate_energy += other.candidate_energy;
        self.accepted_energy += other.accepted_energy;
        self.energy_variance += other.energy_variance;
    }

    /// The mean acceptance probability (0 with no candidate).
    #[must_use]
    pub fn mean_probability(&self) -> f64 {
        if self.candidates == 0 {
            0.0
        } else {
            self.sum_probability / self.candidates as f64
        }
    }
}

/// Probabilistic VPL acceptance for one image: ε, P pixels, N wanted VPLs, the estimate
/// Φ̃_total, the frame's [`Importons`] and the decision counts. Caller-owned, one per thread
/// (or one shared read-only for [`VplAcceptor::probability`]).
///
/// ```
/// use manylights::vpl::{Vpl, VplAcceptor};
/// use manylights::Rgb;
/// use glam::Vec3;
///
/// let mut acc = VplAcceptor::new(64 * 64, 1000)?;
/// acc.importons_mut().push_diffuse(Vec3::ZERO, Vec3::Z, 0.5)?;
/// let candidate = Vpl {
///     position: Vec3::new(0.0, 0.0, 1.0),
///     normal: -Vec3::Z,
///     intensity: Rgb::grey(2.0),
/// };
/// // First frame: Φ̃_total = 0, everything is kept unchanged.
/// let a = acc.accept(&candidate, 0.99)?.expect("p = 1");
/// assert_eq!((a.probability, a.vpl.intensity), (1.0, Rgb::grey(2.0)));
/// // Later frames: Φ̃_total from the rendered frames.
/// acc.update(1e6)?;
/// let p = acc.probability(&candidate)?;
/// assert!(p > 0.0 && p <= 1.0);
/// # Ok::<(), manylights::VplError>(())
/// ```
#[derive(Clone, Debug)]
pub struct VplAcceptor {
    epsilon: f32,
    pixels: usize,
    wanted: usize,
    total: f64,
    frames: u64,
    g_max: f32,
    importons: Importons,
    stats: AcceptStats,
}

/// The least acceptance probability of a (validated) candidate of energy `E = πI`:
/// `E/MAX_LIGHT_ENERGY`, raised by 1e-6 for rounding (and to `f32::MIN_POSITIVE` below it), so
/// that a kept VPL's energy `E/p` stays within [`MAX_LIGHT_ENERGY`] whatever ε: the accepted
/// VPL is a valid [`crate::Light`], and its intensity `I/p` is finite. For any ordinary
/// intensity it is far below ε (3e-24 for I = 1), so p is the paper's.
fn probability_floor(c: &Vpl) -> f32 {
    let e = core::f64::consts::PI * f64::from(c.intensity.luminance());
    let f = e / f64::from(MAX_LIGHT_ENERGY) * (1.0 + 1e-6);
    if f <= 0.0 {
        0.0
    } else if f < f64::from(f32::MIN_POSITIVE) {
        f32::MIN_POSITIVE
    } else {
        f as f32
    }
}

fn check_count(field: VplField, n: usize) -> Result<(), VplError> {
    if n == 0 {
        return Err(err(field, Problem::OutOfRange, 0.0));
    }
    Ok(())
}

fn check_luminance(v: f64) -> Result<(), VplError> {
    if !v.is_finite() {
        return Err(err(VplField::Luminance, Problem::NotFinite, v as f32));
    }
    if v < 0.0 {
        return Err(err(VplField::Luminance, Problem::Negative, v as f32));
    }
    Ok(())
}

impl VplAcceptor {
    /// An acceptor for an image of `pixels` pixels (P) and `wanted` VPLs (N), with the paper's
    /// ε ([`DEFAULT_EPSILON`]), no geometry clamp, Φ̃_total = 0 and no importons.
    pub fn new(pixels: usize, wanted: usize) -> Result<VplAcceptor, VplError> {
        check_count(VplField::Pixels, pixels)?;
        check_count(VplField::Wanted, wanted)?;
        Ok(VplAcceptor {
            epsilon: DEFAULT_EPSILON,
            pixels,
            wanted,
            total: 0.0,
            frames: 0,
            g_max: f32::INFINITY,
            importons: Importons::with_capacity(super::DEFAULT_IMPORTONS),
            stats: AcceptStats::default(),
        })
    }

    /// Sets ε (> 0 and finite; ε ≥ 1 accepts every candidate, as plain instant radiosity).
    pub fn with_epsilon(mut self, epsilon: f32) -> Result<VplAcceptor, VplError> {
        if !epsilon.is_finite() {
            return Err(err(VplField::Epsilon, Problem::NotFinite, epsilon));
        }
        if epsilon <= 0.0 {
            return Err(err(VplField::Epsilon, Problem::NotPositive, epsilon));
        }
        self.epsilon = epsilon;
        Ok(self)
    }

    /// Clamps the geometry term of Φ̃_i at `g_max` (> 0; infinity for none), the same clamp the
    /// host's gather applies (the usual bound of instant radiosity against the 1/d² spikes
    /// near a VPL), so that Φ̃_i estimates what the VPL will actually add.
    pub fn with_geometry_clamp(mut self, g_max: f32) -> Result<VplAcceptor, VplError> {
        if g_max.is_nan() {
            return Err(err(VplField::GeometryClamp, Problem::NotFinite, g_max));
        }
        if g_max <= 0.0 {
            return Err(err(VplField::GeometryClamp, Problem::NotPositive, g_max));
        }
        self.g_max = g_max;
        Ok(self)
    }

    /// ε.
    #[must_use]
    pub fn epsilon(&self) -> f32 {
        self.epsilon
    }

    /// P.
    #[must_use]
    pub fn pixels(&self) -> usize {
        self.pixels
    }

    /// N.
    #[must_use]
    pub fn wanted(&self) -> usize {
        self.wanted
    }

    /// The importons the decisions use.
    #[must_use]
    pub fn importons(&self) -> &Importons {
        &self.importons
    }

    /// The importons, to refill for a new frame.
    pub fn importons_mut(&mut self) -> &mut Importons {
        &mut self.importons
    }

    /// Φ̃_total.
    #[must_use]
    pub fn total_luminance(&self) -> f64 {
        self.total
    }

    /// Sets Φ̃_total (finite, ≥ 0) directly, e.g. from a separate estimate, and restarts the
    /// running mean of [`VplAcceptor::update`] from it (as one frame).
    pub fn set_total_luminance(&mut self, total: f64) -> Result<(), VplError> {
        check_luminance(total)?;
        self.total = total;
        self.frames = 1;
        Ok(())
    }

    /// Refines Φ̃_total with the total VPL illumination luminance of the frame just rendered
    /// (the sum over its pixels of the VPLs' contribution): Φ̃_total becomes the mean over
    /// the frames reported so far, each an estimate of the same image.
    pub fn update(&mut self, frame_luminance: f64) -> Result<(), VplError> {
        check_luminance(frame_luminance)?;
        self.frames += 1;
        self.total += (frame_luminance - self.total) / self.frames as f64;
        Ok(())
    }

    /// Φ̃_v = Φ̃_total / (P·N).
    #[must_use]
    pub fn target(&self) -> f64 {
        self.total / (self.pixels as f64 * self.wanted as f64)
    }

    /// The decisions counted since the last reset.
    #[must_use]
    pub fn stats(&self) -> AcceptStats {
        self.stats
    }

    /// Zeroes the counts.
    pub fn reset_stats(&mut self) {
        self.stats = AcceptStats::default();
    }

    /// Φ̃_i, the candidate's average contribution over the importons (0 with none), without
    /// occlusion: never negative or NaN (+∞ where f·G·I overflows f32, which gives p = 1).
    pub fn estimate(&self, candidate: &Vpl) -> Result<f32, VplError> {
        let m = candidate.validate()?;
        Ok(self.estimate_unit(candidate, m, None::<&mut Unoccluded>))
    }

    /// Φ̃_i with the host's visibility test.
    pub fn estimate_with<V: Visibility + ?Sized>(
        &self,
        candidate: &Vpl,
        visibility: &mut V,
    ) -> Result<f32, VplError> {
        let m = candidate.validate()?;
        Ok(self.estimate_unit(candidate, m, Some(visibility)))
    }

    fn estimate_unit<V: Visibility + ?Sized>(
        &self,
        c: &Vpl,
        m: glam::Vec3,
        vis: Option<&mut V>,
    ) -> f32 {
        self.estimate_until(c, m, vis, false)
    }

    /// Φ̃_i; with `early`, possibly a lower bound that already gives p = 1 (the visibility
    /// tests stop once the importons seen so far make p = 1: further ones only add).
    fn estimate_until<V: Visibility + ?Sized>(
        &self,
        c: &Vpl,
        m: glam::Vec3,
        vis: Option<&mut V>,
        early: bool,
    ) -> f32 {
        let n = self.importons.len();
        if n == 0 {
            return 0.0;
        }
        let n = n as f32;
        let floor = probability_floor(c);
        // Monotone in the partial sum: f32 division and addition round monotonically.
        let enough = |s: f32| early && self.probability_of(s / n, floor) >= 1.0;
        self.importons.total(
            c.position,
            m,
            c.intensity.luminance(),
            self.g_max,
            vis,
            enough,
        ) / n
    }

    /// p from Φ̃_i and the candidate's [`probability_floor`].
    fn probability_of(&self, phi_i: f32, floor: f32) -> f32 {
        let phi_v = self.target() as f32;
        if phi_v <= 0.0 || phi_v.is_nan() {
            return 1.0; // first frame (or a target below f32): no importance sampling
        }
        let p = phi_i / phi_v + self.epsilon;
        let p = if p < floor { floor } else { p };
        if p < 1.0 {
            p
        } else {
            1.0 // also an infinite ratio
        }
    }

    /// The acceptance probability p of `candidate`, in (0, 1], without occlusion: the paper's
    /// `min(Φ̃_i/Φ̃_v + ε, 1)`, raised where needed so that the kept VPL's energy `πI/p`
    /// stays within [`MAX_LIGHT_ENERGY`] (only for intensities within a factor 1/ε of it).
    pub fn probability(&self, candidate: &Vpl) -> Result<f32, VplError> {
        let phi = self.estimate(candidate)?;
        Ok(self.probability_of(phi, probability_floor(candidate)))
    }

    /// The acceptance probability p of `candidate` with the host's visibility test.
    pub fn probability_with<V: Visibility + ?Sized>(
        &self,
        candidate: &Vpl,
        visibility: &mut V,
    ) -> Result<f32, VplError> {
        let m = candidate.validate()?;
        let phi = self.estimate_until(candidate, m, Some(visibility), true);
        Ok(self.probability_of(phi, probability_floor(candidate)))
    }

    /// Decides `candidate` with the uniform number `xi` in [0, 1), ignoring occlusion: the
    /// accepted VPL with its intensity scaled by 1/p, or `None`.
    pub fn accept(&mut self, candidate: &Vpl, xi: f32) -> Result<Option<Accepted>, VplError> {
        self.decide(candidate, xi, None::<&mut Unoccluded>)
    }

    /// As [`VplAcceptor::accept`], with the host's visibility test between importons and the
    /// candidate (called only for importons it would otherwise reach, and no more once those
    /// found visible make p = 1: the decision and p are those of the full sum).
    pub fn accept_with<V: Visibility + ?Sized>(
        &mut self,
        candidate: &Vpl,
        xi: f32,
        visibility: &mut V,
    ) -> Result<Option<Accepted>, VplError> {
        self.decide(candidate, xi, Some(visibility))
    }

    fn decide<V: Visibility + ?Sized>(
        &mut self,
        candidate: &Vpl,
        xi: f32,
        vis: Option<&mut V>,
    ) -> Result<Option<Accepted>, VplError> {
        if xi.is_nan() {
            return Err(err(VplField::Xi, Problem::NotFinite, xi));
        }
        if !(0.0..1.0).contains(&xi) {
            return Err(err(VplField::Xi, Problem::OutOfRange, xi));
        }
        let m = candidate.validate()?;
        // No need to look at the importons while Φ̃_total = 0: p = 1.
        let p = if self.target() > 0.0 {
            let phi = self.estimate_until(candidate, m, vis, true);
            self.probability_of(phi, probability_floor(candidate))
        } else {
            1.0
        };
        let energy = f64::from(candidate.energy());
        self.stats.candidates += 1;
        self.stats.sum_probability += f64::from(p);
        self.stats.candidate_energy += energy;
        self.stats.energy_variance += energy * energy * (1.0 / f64::from(p) - 1.0);
        if xi > p {
            return Ok(None);
        }
        self.stats.accepted += 1;
        self.stats.accepted_energy += energy / f64::from(p);
        Ok(Some(Accepted {
            vpl: Vpl {
                intensity: candidate.intensity / p,
                ..*candidate
            },
            probability: p,
        }))
    }
}
