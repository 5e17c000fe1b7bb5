//! What the lower level hands the host and takes back: the steps of an estimate (light
//! points, BSDF samples), the lights a BSDF ray reached, and a sample's
//! weight.

use crate::colour::Rgb;
use crate::light::point::LightPoint;
use crate::mis::Factors;

/// A sample's weight and density: it contributes `value · weight / pdf`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weighted {
    f: Factors,
}

impl Weighted {
    /// Contributes nothing.
    pub(super) const ZERO: Weighted = Weighted {
        f: Factors {
            num: 0.0,
            den: 1.0,
            pdf: 1.0,
        },
    };

    /// Weight 1, density `pdf`.
    #[inline]
    pub(super) fn plain(pdf: f32) -> Weighted {
        Weighted::checked(Factors {
            num: 1.0,
            den: pdf,
            pdf,
        })
    }

    /// `num / den` with density `pdf`; nothing unless `den` and `pdf` are positive and finite.
    #[inline]
    pub(super) fn checked(f: Factors) -> Weighted {
        let ok = f.den > 0.0 && f.den < f32::INFINITY && f.pdf > 0.0 && f.pdf < f32::INFINITY;
        if ok && f.num >= 0.0 && f.num < f32::INFINITY {
            Weighted { f }
        } else {
            Weighted::ZERO
        }
    }

    /// The MIS weight, in [0, 1].
    #[inline]
    #[must_use]
    pub fn weight(&self) -> f32 {
        (self.f.num * self.f.pdf / self.f.den).clamp(0.0, 1.0)
    }

    /// The density the weight is relative to (in the measure of its value: solid angle, or 1
    /// for point, spot and VPL lights): for a light sample, its technique's density (pmf ·
    /// point pdf, times k for the k light samples of `bl-mis`; for a BRDF-aware sample of
    /// `mis-equal` or `full`, the mixture's density);
    /// for a BSDF hit ([`LightHit`]), the BSDF's pdf for `tl-mis` and `bl-mis`, and the
    /// combined density of the BRDF-aware mixture (BL and BSDF, as the technique mixes them)
    /// for `mis-equal` and `full`. The contribution is `value · weight / pdf` in every case.
    #[inline]
    #[must_use]
    pub fn pdf(&self) -> f32 {
        self.f.pdf
    }

    /// The factor a sample's value is multiplied by, `weight / pdf` (finite, ≥ 0): what a host
    /// applies to each channel of a spectral or RGB value (negative values included, which
    /// [`Weighted::contribution`] clamps to 0). `value · factor()` equals
    /// `contribution(value)` for positive values up to one rounding (the one call computes
    /// `value · num / den`, with weight = num·pdf/den); the C ABI's `ml_weighted.scale` is
    /// this factor, bit for bit.
    #[inline]
    #[must_use]
    pub fn factor(&self) -> f32 {
        let v = self.f.num / self.f.den;
        if v < f32::INFINITY {
            v
        } else {
            0.0
        }
    }

    /// [`Weighted::contribution`] of each channel of `value`.
    #[inline]
    #[must_use]
    pub fn contribution_rgb(&self, value: Rgb) -> Rgb {
        value.map(|c| self.contribution(c))
    }

    /// What a sample of `value` (`f · L · cos θi`, or one channel of it) contributes:
    /// `value · weight / pdf`, evaluated as the one-call estimator does; 0 for a value that is
    /// not positive, and never NaN or infinite. For values of any sign use
    /// [`Weighted::factor`].
    #[inline]
    #[must_use]
    pub fn contribution(&self, value: f32) -> f32 {
        if value.is_nan() || value <= 0.0 {
            return 0.0;
        }
        let v = value * self.f.num / self.f.den;
        if v < f32::INFINITY {
            v
        } else {
            0.0
        }
    }
}

/// What a light sample is, for its weight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Role {
    /// A technique without MIS: weight 1.
    Plain,
    /// A sample of split sampling.
    Split,
    /// A BL sample of the BRDF-aware mixture, drawn with BL probability `p`; `pmf_bl` is BL's
    /// probability of the light (its density is `pmf_bl` times the point's).
    MixtureBl { p: f32, pmf_bl: f32 },
    /// A light sample of `tl-mis` or `bl-mis`, weighted against one BSDF sample.
    OneMis,
}

/// A light point for the host to shade: evaluate `f · L · cos θi` towards
/// `point.direction` (with `point.radiance` as L), test visibility up to `point.distance`, and
/// weigh it with [`Estimator::weigh`](super::Estimator::weigh).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightDraw {
    /// The light's index in the light set.
    pub light: u32,
    /// The probability of having chosen the light.
    pub pmf: f32,
    /// The point on it, its direction, distance, radiance and solid-angle density.
    pub point: LightPoint,
    /// Whether [`Estimator::weigh`](super::Estimator::weigh) uses the host's BSDF pdf of the direction (otherwise any
    /// value may be passed, 0 say).
    pub needs_bsdf_pdf: bool,
    pub(super) role: Role,
}

/// A BSDF sample for the host to take: sample its BSDF with `u`, cast the ray, and report the
/// direction, its pdf and what the ray reaches to [`Estimator::bsdf_hits`](super::Estimator::bsdf_hits). A host
/// whose BSDF gives no direction for `u` (below the surface, a zero pdf) skips the report, as
/// the one call does: the sample contributes nothing, and for `full` it counts as a ray that
/// reached no light (the next [`Estimator::next`](super::Estimator::next) records it so).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfDraw {
    /// The two uniform numbers (in [0, 1)) for sampling the BSDF.
    pub u: [f32; 2],
    /// For a mixture sample, its BL probability; `None` for `tl-mis` and `bl-mis`.
    pub(super) p: Option<f32>,
}

/// A light a BSDF ray reached: the host shades it (`f · L · cos θi` with its own `f`, L =
/// `point.radiance`) and adds `weighted.contribution(value)` (or `value ·
/// weighted.factor()` per channel). `weighted.pdf()` is the BSDF's pdf only for `tl-mis` and
/// `bl-mis`; for `mis-equal` and `full` it is the combined density of the mixed samples (see
/// [`Weighted::pdf`]). A ray that escapes (no surface) reaches the distant lights whose cones
/// hold its direction (`point.distance` = +∞) and the set's environment, whose
/// `point.radiance` and `point.pdf` are the environment's along the direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightHit {
    /// The light's index in the light set.
    pub light: u32,
    /// The point the ray reached on it.
    pub point: LightPoint,
    /// Its weight and the density the weight is relative to.
    pub weighted: Weighted,
}

/// One step of an estimate (see the [module documentation](crate::direct)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// A light point to shade.
    Light(LightDraw),
    /// A BSDF sample to take.
    Bsdf(BsdfDraw),
    /// The estimate is complete.
    Done,
}
