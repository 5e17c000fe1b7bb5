//! What the BRDF-oriented importance knows of a surface: the material and the view.
//!
//! Materials: Lambert (an RGB albedo), GGX (isotropic roughness α, height-correlated Smith masking, no
//! Fresnel in the importance, scaled by a specular weight) and plastic (a Lambert base plus a
//! GGX layer, each with its weight). The albedo is linear RGB; importances, cuts and BSDF
//! sampling use its luminance ([`Rgb::luminance`]), the estimate every channel. Values a host
//! may pass, decided once: every albedo channel and the weights finite in [0, 1]; α finite in (0, 1] (it is clamped below at [`MIN_ALPHA`] where it is used);
//! position, normal and ωo finite, normal and ωo non-zero (they are normalised).

use crate::colour::Rgb;
use crate::error::Problem;
use glam::Vec3;

/// The GGX roughness floor: every α is clamped below at this value where it is used (the GGX
/// lobe of [`crate::Ggx`], the BRDF-oriented importance and the SPTD table, which is fitted
/// down to it): below it the lobe is a mirror that f32 pdfs and no finite table resolve.
pub const MIN_ALPHA: f32 = 5e-3;

/// A surface's reflectance.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Material {
    /// Diffuse: f = albedo/π.
    Lambert {
        /// Diffuse albedo, every channel in [0, 1].
        albedo: Rgb,
    },
    /// Glossy: f = specular · GGX(α).
    Ggx {
        /// Roughness α in (0, 1].
        alpha: f32,
        /// Weight of the lobe in [0, 1].
        specular: f32,
    },
    /// Plastic: f = albedo/π + specular · GGX(α).
    Plastic {
        /// Diffuse albedo, every channel in [0, 1].
        albedo: Rgb,
        /// Weight of the GGX layer in [0, 1].
        specular: f32,
        /// Roughness α in (0, 1].
        alpha: f32,
    },
}

impl Material {
    /// `(luminance of the diffuse albedo, specular weight, α)`; zero weights for absent
    /// lobes. What the importances, cuts and BSDF sampling use.
    #[must_use]
    pub fn lobes(&self) -> (f32, f32, f32) {
        let (albedo, specular, alpha) = self.colour_lobes();
        (albedo.luminance(), specular, alpha)
    }

    /// `(diffuse albedo, specular weight, α)`, the albedo in colour; zero weights for absent
    /// lobes.
    #[must_use]
    pub fn colour_lobes(&self) -> (Rgb, f32, f32) {
        match *self {
            Material::Lambert { albedo } => (albedo, 0.0, 1.0),
            Material::Ggx { alpha, specular } => (Rgb::ZERO, specular, alpha),
            Material::Plastic {
                albedo,
                specular,
                alpha,
            } => (albedo, specular, alpha),
        }
    }

    /// Whether the material has no glossy lobe (then BRDF-oriented light sampling reduces to
    /// TL, and the combined estimator uses TL and TB only).
    #[must_use]
    pub fn is_diffuse_only(&self) -> bool {
        self.lobes().1 <= 0.0
    }
}

pub use crate::error::{ShadingError, ShadingField};

/// A point being shaded: where, which way the surface faces, where the viewer is, and what it
/// is made of.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingPoint {
    /// Position.
    pub position: Vec3,
    /// Surface normal: any finite, non-zero length.
    pub normal: Vec3,
    /// Direction towards the viewer, ωo: any finite, non-zero length.
    pub wo: Vec3,
    /// Material.
    pub material: Material,
}

fn err(field: ShadingField, problem: Problem, value: f32) -> ShadingError {
    ShadingError {
        field,
        problem,
        value,
    }
}

fn unit_range(field: ShadingField, v: f32) -> Result<(), ShadingError> {
    if !v.is_finite() {
        return Err(err(field, Problem::NotFinite, v));
    }
    if !(0.0..=1.0).contains(&v) {
        return Err(err(field, Problem::OutOfRange, v));
    }
    Ok(())
}

fn direction(field: ShadingField, v: Vec3) -> Result<(), ShadingError> {
    for c in v.to_array() {
        if !c.is_finite() {
            return Err(err(field, Problem::NotFinite, c));
        }
    }
    // Only the zero vector: a tiny or huge finite vector is normalised in f64 where needed.
    if v == Vec3::ZERO {
        return Err(err(field, Problem::ZeroLength, 0.0));
    }
    Ok(())
}

impl ShadingPoint {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ShadingError> {
        for c in self.position.to_array() {
            if !c.is_finite() {
                return Err(err(ShadingField::Position, Problem::NotFinite, c));
            }
        }
        direction(ShadingField::Normal, self.normal)?;
        direction(ShadingField::Wo, self.wo)?;
        let (albedo, specular, alpha) = self.material.colour_lobes();
        for c in albedo.to_array() {
            unit_range(ShadingField::Albedo, c)?;
        }
        unit_range(ShadingField::Specular, specular)?;
        if !alpha.is_finite() {
            return Err(err(ShadingField::Alpha, Problem::NotFinite, alpha));
        }
        if !(alpha > 0.0 && alpha <= 1.0) {
            return Err(err(ShadingField::Alpha, Problem::OutOfRange, alpha));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_names_the_field() {
        let good = ShadingPoint {
            position: Vec3::ZERO,
            normal: Vec3::Z,
            wo: Vec3::new(0.3, 0.0, 1.0),
            material: Material::Plastic {
                albedo: Rgb::new(0.5, 0.2, 0.9),
                specular: 0.5,
                alpha: 0.2,
            },
        };
        assert!(good.validate().is_ok());
        let bad = ShadingPoint {
            material: Material::Lambert {
                albedo: Rgb::new(0.5, 1.5, 0.1),
            },
            ..good
        };
        let e = bad.validate().unwrap_err();
        assert_eq!((e.field, e.value), (ShadingField::Albedo, 1.5));
        let bad = ShadingPoint {
            material: Material::Ggx {
                alpha: 0.0,
                specular: 1.0,
            },
            ..good
        };
        let e = bad.validate().unwrap_err();
        assert_eq!(e.field, ShadingField::Alpha);
        assert!(alloc::format!("{e}").contains("alpha"));
        let bad = ShadingPoint {
            normal: Vec3::ZERO,
            ..good
        };
        assert_eq!(bad.validate().unwrap_err().field, ShadingField::Normal);
        let bad = ShadingPoint {
            position: Vec3::new(f32::NAN, 0.0, 0.0),
            ..good
        };
        assert_eq!(bad.validate().unwrap_err().problem, Problem::NotFinite);
    }
}
