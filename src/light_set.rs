//! A renderer's lights as the direct-lighting estimators use them: the lights themselves (for
//! points on them and ray hits), their [`LightTree`] (the node tree and, beside it, the distant
//! and environment lights it weighs against the nodes at the root: [`crate::light_set`]), and
//! an alias table for sampling ∝ power.
//!
//! The power of a light at infinity, for the alias table (pbrt-v4's `Phi` of its infinite
//! lights, with the scene's bounding sphere taken as that of the local lights' boxes, radius
//! R, or R = 1 without local lights): `π R² Y(E)` for a distant light of irradiance E, and for
//! the environment `(2/3) π R² Σ` of its six irradiance bounds (`4π · πR² · Y(L)` for a
//! uniform environment of radiance L, whose six bounds are `π Y(L)`).
//!
//! One [`LightSet`] is built per scene (it allocates); it is immutable afterwards,
//! `Send + Sync`, and shared by every thread and every shading point.

use alloc::vec::Vec;

pub use crate::infinite::RootChoice;
pub use crate::infinite_light::{InfiniteKind, InfiniteLight};

use crate::build::BuildOptions;
use crate::error::{BuildError, FormatError};
use crate::light::point::LightPoint;
use crate::light::Light;
use crate::tree::LightTree;
use glam::Vec3;

/// Lights, their tree and their power distribution.
#[derive(Clone, Debug)]
pub struct LightSet {
    lights: Vec<Light>,
    tree: LightTree,
    power: AliasTable,
}

impl LightSet {
    /// Validates `lights` (errors name the light and field, as [`LightTree::build`]) and builds
    /// their tree and alias table.
    pub fn build(lights: Vec<Light>) -> Result<LightSet, BuildError> {
        LightSet::build_with(lights, &BuildOptions::default())
    }

    /// [`LightSet::build`] with the tree built with `opts`.
    pub fn build_with(lights: Vec<Light>, opts: &BuildOptions) -> Result<LightSet, BuildError> {
        LightSet::build_parallel(lights, opts, &crate::Serial)
    }

    /// [`LightSet::build_with`], the tree built by [`LightTree::build_parallel`] over `join`
    /// (the same tree as the serial build).
    pub fn build_parallel<J: crate::Join>(
        lights: Vec<Light>,
        opts: &BuildOptions,
        join: &J,
    ) -> Result<LightSet, BuildError> {
        let tree = LightTree::build_parallel(&lights, opts, join)?;
        let power = power_table(&lights);
        Ok(LightSet {
            lights,
            tree,
            power,
        })
    }

    /// The lights and the tree of `bytes` ([`LightTree::as_bytes`] of the tree of a set built
    /// from these very lights), checked as [`LightTree::from_bytes_with_lights`] checks them
    /// (corrupt bytes, or lights other than the ones the tree was built from, are an error
    /// naming the first mismatch), and their alias table: a set that samples, answers pmfs,
    /// gives points on lights and estimates bit for bit as the set the tree was saved from.
    pub fn from_bytes(bytes: &[u8], lights: Vec<Light>) -> Result<LightSet, FormatError> {
        let tree = LightTree::from_bytes_with_lights(bytes, &lights)?;
        let power = power_table(&lights);
        Ok(LightSet {
            lights,
            tree,
            power,
        })
    }

    /// The lights, in the order given to [`LightSet::build`] (light indices index this).
    #[inline]
    #[must_use]
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// Their tree.
    #[inline]
    #[must_use]
    pub fn tree(&self) -> &LightTree {
        &self.tree
    }

    /// The alias table of their energies.
    #[inline]
    #[must_use]
    pub fn power(&self) -> &AliasTable {
        &self.power
    }

    /// The environment light's index, if the set has one.
    #[inline]
    #[must_use]
    pub fn environment(&self) -> Option<u32> {
        self.tree.environment()
    }

    /// Number of lights.
    #[inline]
    #[must_use]
    pub fn len(&self) -> usize {
        self.lights.len()
    }

    /// No lights.
    #[inline]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Calls `hit(light, point)` for every light the ray from `x` along the unit `d` reaches
    /// ([`LightTree::trace`]).
    #[inline]
    pub fn trace(&self, x: Vec3, d: Vec3, hit: impl FnMut(u32, &LightPoint)) {
        self.tree.trace(&self.lights, x, d, hit);
    }
}

/// The squared radius of the bounding sphere of the boxes of the lights of positive energy
/// (1 without any).
fn scene_radius2(lights: &[Light]) -> f64 {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for l in lights.iter().filter(|l| l.energy() > 0.0) {
        let b = l.bounds().aabb;
        for k in 0..3 {
            lo[k] = lo[k].min(f64::from(b.min[k]));
            hi[k] = hi[k].max(f64::from(b.max[k]));
        }
    }
    let d2: f64 = (0..3).map(|k| (hi[k] - lo[k]) * (hi[k] - lo[k])).sum();
    if d2 > 0.0 && d2.is_finite() {
        d2 / 4.0
    } else {
        1.0
    }
}

/// The alias table of the power-proportional technique over `lights` ([`power`]).
fn power_table(lights: &[Light]) -> AliasTable {
    let r2 = scene_radius2(lights);
    AliasTable::new(lights.iter().map(|l| power(l, r2)))
}

/// A light's weight in the alias table: its energy, or for a light at infinity the power of
/// the module documentation.
fn power(l: &Light, r2: f64) -> f64 {
    let disk = core::f64::consts::PI * r2;
    match *l {
        Light::Distant { irradiance, .. } => disk * f64::from(irradiance.luminance()),
        Light::Environment { irradiance } => {
            disk * (2.0 / 3.0) * irradiance.iter().map(|&e| f64::from(e)).sum::<f64>()
        }
        _ => f64::from(l.energy()),
    }
}

/// Walker's alias table over non-negative weights: O(1) sampling with one uniform number.
///
/// Entry `i` keeps itself with probability `threshold[i]` and otherwise gives `alias[i]`; the
/// table is built (Vose's method, in f64) so that entry `i` comes out with probability
/// `weight[i] / Σ weight`, which [`AliasTable::pmf`] reports. Entries of weight 0 are never
/// sampled (their threshold is 0 and no alias points to them).
#[derive(Clone, Debug, Default)]
pub struct AliasTable {
    threshold: Vec<f32>,
    alias: Vec<u32>,
    pmf: Vec<f32>,
}

impl AliasTable {
    /// A table over `weights`; negative, NaN and infinite weights count as 0. With no positive
    /// weight the table samples nothing.
    pub fn new(weights: impl IntoIterator<Item = f64>) -> AliasTable {
        let w: Vec<f64> = weights
            .into_iter()
            .map(|x| if x > 0.0 && x.is_finite() { x } else { 0.0 })
            .collect();
        let n = w.len();
        let total: f64 = w.iter().sum();
        if n == 0 || !(total > 0.0 && total.is_finite()) || n > u32::MAX as usize {
            return AliasTable {
                threshold: Vec::new(),
                alias: Vec::new(),
                pmf: alloc::vec![0.0; n],
            };
        }
        let pmf: Vec<f32> = w.iter().map(|&x| (x / total) as f32).collect();
        // Scaled weights (mean 1), split into those below and above the mean.
        let mut scaled: Vec<f64> = w.iter().map(|&x| x / total * n as f64).collect();
        let mut threshold = alloc::vec![0f32; n];
        let mut alias: Vec<u32> = (0..n as u32).collect();
        let mut small: Vec<u32> = Vec::new();
        let mut large: Vec<u32> = Vec::new();
        for (i, &s) in scaled.iter().enumerate() {
            if s < 1.0 {
                small.push(i as u32);
            } else {
                large.push(i as u32);
            }
        }
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            threshold[s as usize] = scaled[s as usize] as f32;
            alias[s as usize] = l;
            scaled[l as usize] -= 1.0 - scaled[s as usize];
            if scaled[l as usize] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What is left is 1 up to rounding.
        for i in large.into_iter().chain(small) {
            threshold[i as usize] = 1.0;
            alias[i as usize] = i;
        }
        // Rounding may leave a weightless entry with a threshold or as an alias: send it to
        // the heaviest entry instead, so that a sampled entry always has pmf > 0.
        let heaviest = (0..n).fold(0, |b, i| if w[i] > w[b] { i } else { b }) as u32;
        for i in 0..n {
            if pmf[i] == 0.0 {
                threshold[i] = 0.0;
            }
            if pmf[alias[i] as usize] == 0.0 {
                alias[i] = heaviest;
            }
        }
        AliasTable {
            threshold,
            alias,
            pmf,
        }
    }

    /// Number of entries.
    #[inline]
    #[must_use]
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// No entries.
    #[inline]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// An entry for `u` in [0, 1) (clamped into it; NaN counts as 0) and its probability
    /// (> 0); `None` when no weight is positive.
    #[inline]
    #[must_use]
    pub fn sample(&self, u: f64) -> Option<(u32, f32)> {
        let n = self.threshold.len();
        if n == 0 {
            return None;
        }
        let u = if u > 0.0 { u.min(1.0) } else { 0.0 };
        let scaled = u * n as f64;
        let i = (scaled as usize).min(n - 1);
        let rest = scaled - i as f64;
        let pick = if rest < f64::from(self.threshold[i]) {
            i as u32
        } else {
            self.alias[i]
        };
        Some((pick, self.pmf[pick as usize]))
    }

    /// The probability of entry `i` (0 outside the table).
    #[inline]
    #[must_use]
    pub fn pmf(&self, i: u32) -> f32 {
        self.pmf.get(i as usize).copied().unwrap_or(0.0)
    }
}
