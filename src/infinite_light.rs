//! The entries of the lights at infinity — distant lights (a cone of directions: a sun) and
//! the host's environment — as the tree stores them beside its nodes ([`InfiniteLight`], 64
//! bytes each, at most [`MAX_INFINITE_LIGHTS`]); how they are weighed against the nodes at the
//! root is [`crate::infinite`]'s.

use crate::error::BuildError;
use crate::light::Light;
use crate::limits::MAX_INFINITE_LIGHTS;
use crate::math;
use alloc::vec::Vec;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// What an [`InfiniteLight`] entry is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum InfiniteKind {
    /// A [`Light::Distant`].
    Distant,
    /// A [`Light::Environment`].
    Environment,
}

/// A distant or environment light as the tree keeps it (64 bytes, `repr(C)`, Pod).
///
/// | offset | field | distant | environment |
/// |---:|---|---|---|
/// | 0 | `light: u32` | its index in the build's input | the same |
/// | 4 | `kind: u32` | 0 | 1 |
/// | 8 | `direction: [f32; 3]` | unit, towards the light | 0 |
/// | 20 | `cos_radius: f32` | cos γ | −1 |
/// | 24 | `sin_radius: f32` | sin γ | 0 |
/// | 28 | `irradiance: [f32; 6]` | the irradiance's luminance, then 0 | the six bounds (+x, −x, +y, −y, +z, −z) |
/// | 52 | `reserved: [u32; 3]` | 0 | 0 |
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct InfiniteLight {
    /// The light's index in the slice the tree was built from.
    pub light: u32,
    /// 0: distant, 1: environment.
    pub kind: u32,
    /// Distant: the unit direction towards the light; environment: 0.
    pub direction: [f32; 3],
    /// Distant: cos γ of its angular radius; environment: −1.
    pub cos_radius: f32,
    /// Distant: sin γ; environment: 0.
    pub sin_radius: f32,
    /// Distant: the luminance of its irradiance in slot 0 (the rest 0); environment: the six
    /// irradiance bounds of [`Light::Environment`].
    pub irradiance: [f32; 6],
    /// Zero.
    pub reserved: [u32; 3],
}

const _: () = assert!(core::mem::size_of::<InfiniteLight>() == 64);

impl InfiniteLight {
    /// The entry of light `index`, `None` for a light of the node tree. Valid only for a light
    /// that passed [`Light::validate`].
    pub fn of(index: u32, light: &Light) -> Option<InfiniteLight> {
        match *light {
            Light::Distant {
                direction,
                angular_radius,
                irradiance,
            } => {
                let d = math::unit_f64(direction.as_ref().map(f64::from)).unwrap_or(Vec3::Z);
                let (s, c) = math::sin_cos64(f64::from(angular_radius));
                let mut e = [0.0; 6];
                e[0] = irradiance.luminance();
                Some(InfiniteLight {
                    light: index,
                    kind: 0,
                    direction: d.to_array(),
                    cos_radius: c as f32,
                    sin_radius: s as f32,
                    irradiance: e,
                    reserved: [0; 3],
                })
            }
            Light::Environment { irradiance } => Some(InfiniteLight {
                light: index,
                kind: 1,
                direction: [0.0; 3],
                cos_radius: -1.0,
                sin_radius: 0.0,
                irradiance,
                reserved: [0; 3],
            }),
            _ => None,
        }
    }

    /// The entry's kind (`None` for a corrupt kind field).
    #[inline]
    #[must_use]
    pub fn kind(&self) -> Option<InfiniteKind> {
        match self.kind {
            0 => Some(InfiniteKind::Distant),
            1 => Some(InfiniteKind::Environment),
            _ => None,
        }
    }

    /// The direction towards a distant light (0 for an environment).
    #[inline]
    #[must_use]
    pub fn direction(&self) -> Vec3 {
        Vec3::from_array(self.direction)
    }
}

/// The entries of `lights` (validated), in input order; errors for too many lights at
/// infinity or a second environment.
pub(crate) fn collect(lights: &[Light]) -> Result<Vec<InfiniteLight>, BuildError> {
    let mut out = Vec::new();
    let mut environment = false;
    for (i, l) in lights.iter().enumerate() {
        let Some(e) = InfiniteLight::of(i as u32, l) else {
            continue;
        };
        if e.kind() == Some(InfiniteKind::Environment) {
            if environment {
                return Err(BuildError::SecondEnvironment { index: i });
            }
            environment = true;
        }
        out.push(e);
    }
    if out.len() > MAX_INFINITE_LIGHTS {
        return Err(BuildError::TooManyInfiniteLights { count: out.len() });
    }
    Ok(out)
}
