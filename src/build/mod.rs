//! Building a [`LightTree`]: validate the lights, bound them, build a binary tree with the
//! binned SAOH (module `saoh`), collapse it to 4-wide nodes (module `collapse`).

pub(crate) mod collapse;
pub(crate) mod saoh;

use crate::error::BuildError;
use crate::light::{Light, MAX_TOTAL_ENERGY};
use crate::tree::{LightTree, MAX_LIGHTS};
use alloc::vec::Vec;
use saoh::{BinTree, Prim};

/// Options of the build.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildOptions {
    /// SAOH buckets per axis, clamped to 12..=64.
    pub buckets: usize,
    /// Pack subtrees of at most 16 lights free-form so that their nodes are full: about 8 %
    /// less memory (30.9 instead of 33.6 bytes per light on the `mlrender bench` scene of
    /// 10⁵ lights) for about 10 % more variance (it mixes lights across the SAOH's clusters;
    /// docs/measurements.md). Off by default.
    pub compact: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            buckets: 12,
            compact: false,
        }
    }
}

/// Validates every light and returns the ones with positive energy, bounded.
pub(crate) fn prepare(lights: &[Light]) -> Result<Vec<Prim>, BuildError> {
    if lights.len() > MAX_LIGHTS as usize {
        return Err(BuildError::TooManyLights {
            count: lights.len(),
        });
    }
    let mut prims = Vec::with_capacity(lights.len());
    let mut total = 0.0f64;
    for (i, l) in lights.iter().enumerate() {
        l.validate(i)?;
        let bounds = l.bounds();
        if bounds.energy > 0.0 {
            total += f64::from(bounds.energy);
            prims.push(Prim {
                centroid: bounds.aabb.center(),
                bounds,
                light: i as u32,
            });
        }
    }
    if total > f64::from(MAX_TOTAL_ENERGY) {
        return Err(BuildError::TotalEnergyTooLarge);
    }
    Ok(prims)
}

/// The binary SAOH tree of `lights` (empty when no light has energy).
pub(crate) fn binary(lights: &[Light], opts: &BuildOptions) -> Result<BinTree, BuildError> {
    let mut prims = prepare(lights)?;
    if prims.is_empty() {
        return Ok(BinTree { nodes: Vec::new() });
    }
    Ok(saoh::build(
        &mut prims,
        opts.buckets.clamp(12, saoh::MAX_BUCKETS),
    ))
}

impl LightTree {
    /// Builds the tree with default options. Lights of zero energy (zero power or area) are
    /// accepted and never sampled; an empty slice gives a tree that samples nothing.
    pub fn build(lights: &[Light]) -> Result<LightTree, BuildError> {
        LightTree::build_with(lights, &BuildOptions::default())
    }

    /// Builds the tree with `opts`.
    pub fn build_with(lights: &[Light], opts: &BuildOptions) -> Result<LightTree, BuildError> {
        let bin = binary(lights, opts)?;
        let tree = collapse::collapse(&bin, lights.len(), opts.compact)?;
        #[cfg(debug_assertions)]
        if let Err(e) = tree.validate() {
            panic!("manylights: internal error, built tree fails validation: {e}");
        }
        Ok(tree)
    }
}
