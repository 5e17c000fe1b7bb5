//! A renderer's lights as the direct-lighting estimators use them: the lights themselves (for
//! points on them and ray hits), their [`LightTree`] (the node tree and, beside it, the distant
//! and environment lights it weighs against the nodes at the root: [`crate::light_set`]), and
//! an alias table for sampling ∝ energy.
//!
//! The energy of a light at infinity, for the alias table (pbrt-v4's `Phi` of its infinite
//! lights, with the scene's bounding sphere taken as that of the local lights' boxes, radius
//! R, or R = 1 without local lights): `π R² Y(E)` for a distant light of irradiance E, and for
//! the environment `(2/3) π R² Σ` of its six irradiance bounds (`4π · πR² · Y(L)` for a
//! uniform environment of radiance L, whose six bounds are `π Y(L)`).
//!
//! One [`LightSet`] is built per scene (it allocates); it is immutable afterwards,
//! `Send + Sync`, and shared by every thread and every shading point.

use alloc::boxed::Box;
use alloc::vec::Vec;
use core::fmt;

pub use crate::infinite::RootChoice;
pub use crate::infinite_light::{InfiniteKind, InfiniteLight};

use crate::build::BuildOptions;
use crate::colour::Rgb;
use crate::error::{BuildError, DirectError, FormatError, LightMismatch};
use crate::light::point::{pdf_point, sample_point, LightPoint};
use crate::light::{Environment, Light};
use crate::tree::LightTree;
use glam::Vec3;

/// Lights, their tree and their energy distribution, and the host's environment if it has one.
///
/// The environment is given once, here ([`LightSet::build_with_environment`]): a light set
/// with an environment holds it for every estimate, point on a light and BSDF hit, and a
/// plain light list cannot hold an environment light (the build refuses it), so no call
/// downstream takes an environment or can be made without it.
pub struct LightSet {
    lights: Vec<Light>,
    tree: LightTree,
    energies: AliasTable,
    environment: Option<Box<dyn Environment + Send + Sync>>,
}

impl fmt::Debug for LightSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LightSet")
            .field("lights", &self.lights)
            .field("tree", &self.tree)
            .field("energies", &self.energies)
            .field("environment", &self.environment.as_ref().map(|_| "<host>"))
            .finish()
    }
}

impl LightSet {
    /// Validates `lights` (errors name the light and field, as [`LightTree::build`]) and builds
    /// their tree and alias table. An environment light in `lights` is
    /// [`BuildError::EnvironmentLight`]: the environment enters with the host's own
    /// ([`LightSet::build_with_environment`]).
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
        no_environment_light(&lights)?;
        LightSet::assemble(lights, None, opts, join)
    }

    /// `lights` and the host's `environment`: the set of [`LightSet::build_parallel`] over
    /// `lights` followed by the environment's light, [`Light::Environment`] with
    /// [`Environment::irradiance_bounds`] (its index is `lights.len()`), holding
    /// `environment` for every estimate ([`crate::Estimator`] samples it and evaluates it
    /// along BSDF rays that escape) and for [`LightSet::sample_point`]. Errors: those of the
    /// build (the bounds validated as the light's fields, naming index `lights.len()`), and
    /// [`BuildError::EnvironmentLight`] for an environment light in `lights`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use manylights::direct::{Estimator, Params, Technique, Unoccluded};
    /// use manylights::light::UniformSky;
    /// use manylights::{BuildOptions, LightSet, Material, Rgb, Serial, ShadingPoint, Uniforms};
    ///
    /// # struct Lcg(u64);
    /// # impl Uniforms for Lcg {
    /// #     fn next_f64(&mut self) -> f64 {
    /// #         self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    /// #         (self.0 >> 11) as f64 / (1u64 << 53) as f64
    /// #     }
    /// #     fn next_f32(&mut self) -> f32 {
    /// #         (self.next_f64() as f32).min(1.0 - f32::EPSILON / 2.0)
    /// #     }
    /// # }
    /// // A uniform sky of radiance 0.5 and no other light: the sky is light 0.
    /// let sky = UniformSky { radiance: Rgb::grey(0.5) };
    /// let set = LightSet::build_with_environment(Vec::new(), sky, &BuildOptions::default(), &Serial)?;
    /// assert_eq!(set.environment_light(), Some(0));
    /// // A Lambert plane of albedo 0.8 under it reflects 0.8 · 0.5 = 0.4.
    /// let sp = ShadingPoint {
    ///     position: Vec3::ZERO,
    ///     normal: Vec3::Z,
    ///     wo: Vec3::Z,
    ///     material: Material::Lambert { albedo: Rgb::grey(0.8) },
    /// };
    /// let mut est = Estimator::new(&set, &sp, Technique::DEFAULT, &Params::default())?;
    /// let (mut u, n) = (Lcg(1), 20_000);
    /// let (mut sum, mut sum2) = (0.0, 0.0);
    /// for _ in 0..n {
    ///     let v = est.estimate(&Unoccluded, &mut u)?[0];
    ///     sum += v;
    ///     sum2 += v * v;
    /// }
    /// let mean = sum / n as f64;
    /// let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
    /// assert!((mean - 0.4).abs() <= 5.0 * se + 1e-6, "{mean} ± {se}");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn build_with_environment<J: crate::Join>(
        mut lights: Vec<Light>,
        environment: impl Environment + Send + Sync + 'static,
        opts: &BuildOptions,
        join: &J,
    ) -> Result<LightSet, BuildError> {
        no_environment_light(&lights)?;
        lights.push(Light::Environment {
            irradiance: environment.irradiance_bounds(),
        });
        LightSet::assemble(lights, Some(Box::new(environment)), opts, join)
    }

    /// The tree and alias table of lights already checked for environment lights.
    fn assemble<J: crate::Join>(
        lights: Vec<Light>,
        environment: Option<Box<dyn Environment + Send + Sync>>,
        opts: &BuildOptions,
        join: &J,
    ) -> Result<LightSet, BuildError> {
        let tree = LightTree::build_parallel(&lights, opts, join)?;
        let energies = energy_table(&lights);
        Ok(LightSet {
            lights,
            tree,
            energies,
            environment,
        })
    }

    /// The lights and the tree of `bytes` ([`LightTree::as_bytes`] of the tree of a set built
    /// from these very lights), checked as [`LightTree::from_bytes_with_lights`] checks them
    /// (corrupt bytes, or lights other than the ones the tree was built from, are an error
    /// naming the first mismatch), and their alias table: a set that samples, answers pmfs,
    /// gives points on lights and estimates bit for bit as the set the tree was saved from.
    /// The tree of a set with an environment loads with
    /// [`LightSet::from_bytes_with_environment`]; an environment light in `lights` is an error.
    pub fn from_bytes(bytes: &[u8], lights: Vec<Light>) -> Result<LightSet, FormatError> {
        no_environment_light(&lights)
            .map_err(|e| FormatError::Lights(LightMismatch::Invalid(e)))?;
        LightSet::load(bytes, lights, None)
    }

    /// [`LightSet::from_bytes`] of the tree of a set made by
    /// [`LightSet::build_with_environment`] from `lights` and an environment of the same
    /// bounds: `lights` are the lights without the environment's, which `environment`'s
    /// bounds give.
    pub fn from_bytes_with_environment(
        bytes: &[u8],
        mut lights: Vec<Light>,
        environment: impl Environment + Send + Sync + 'static,
    ) -> Result<LightSet, FormatError> {
        no_environment_light(&lights)
            .map_err(|e| FormatError::Lights(LightMismatch::Invalid(e)))?;
        lights.push(Light::Environment {
            irradiance: environment.irradiance_bounds(),
        });
        LightSet::load(bytes, lights, Some(Box::new(environment)))
    }

    /// The set of `bytes` and lights already checked for environment lights.
    fn load(
        bytes: &[u8],
        lights: Vec<Light>,
        environment: Option<Box<dyn Environment + Send + Sync>>,
    ) -> Result<LightSet, FormatError> {
        let tree = LightTree::from_bytes_with_lights(bytes, &lights)?;
        let energies = energy_table(&lights);
        Ok(LightSet {
            lights,
            tree,
            energies,
            environment,
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

    /// The alias table of their energies (what [`crate::direct::Technique::Energy`] samples).
    #[inline]
    #[must_use]
    pub fn energies(&self) -> &AliasTable {
        &self.energies
    }

    /// The environment light's index (the last light), if the set has an environment.
    #[inline]
    #[must_use]
    pub fn environment_light(&self) -> Option<u32> {
        self.tree.environment()
    }

    /// The host's environment, if the set has one.
    #[inline]
    #[must_use]
    pub fn environment(&self) -> Option<&(dyn Environment + Send + Sync)> {
        self.environment.as_deref()
    }

    /// A point on light `light` seen from `x`, for the uniform numbers `u` in [0, 1)²: the
    /// light's [`sample_point`], or for the environment light the host's sample turned into a
    /// point at infinity (`position` = `direction`, `distance` +∞, `normal` zero). `Ok(None)`
    /// where none is given (a light out of range, a zero-area light, an environment that
    /// returns no sample). Errors: a host sample with a zero or non-finite direction
    /// ([`DirectError::Direction`]), a pdf not positive and finite
    /// ([`DirectError::EnvironmentPdf`]) or a radiance channel negative or not finite
    /// ([`DirectError::EnvironmentRadiance`]).
    pub fn sample_point(
        &self,
        light: u32,
        x: Vec3,
        u: [f32; 2],
    ) -> Result<Option<LightPoint>, DirectError> {
        let Some(l) = self.lights.get(light as usize) else {
            return Ok(None);
        };
        match (l, self.environment()) {
            (Light::Environment { .. }, Some(env)) => match env.sample(u) {
                Some(s) => environment_point(s.direction, s.radiance, s.pdf).map(Some),
                None => Ok(None),
            },
            _ => Ok(sample_point(l, x, u)),
        }
    }

    /// The solid-angle pdf with which [`LightSet::sample_point`] gives the point `point` of
    /// light `light` from `x` ([`pdf_point`]; for the environment, where `point` is the
    /// direction, the host's pdf of it, checked as in [`LightSet::sample_point`]); 0 for a
    /// light out of range.
    pub fn pdf_point(&self, light: u32, x: Vec3, point: Vec3) -> Result<f32, DirectError> {
        let Some(l) = self.lights.get(light as usize) else {
            return Ok(0.0);
        };
        match (l, self.environment()) {
            (Light::Environment { .. }, Some(env)) => {
                let l2 = point.length_squared();
                if !(l2 > 0.0 && l2 < f32::INFINITY && point.is_finite()) {
                    return Ok(0.0);
                }
                // A direction already of unit length (to f32 rounding) is taken as it is.
                let d = if (l2 - 1.0).abs() <= 4.0 * f32::EPSILON {
                    point
                } else {
                    point / crate::math::sqrt(l2)
                };
                let (_, pdf) = environment_eval(env, d)?;
                Ok(pdf)
            }
            _ => Ok(pdf_point(l, x, point)),
        }
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

/// [`BuildError::EnvironmentLight`] for the first environment light of `lights`.
fn no_environment_light(lights: &[Light]) -> Result<(), BuildError> {
    match lights
        .iter()
        .position(|l| matches!(l, Light::Environment { .. }))
    {
        Some(index) => Err(BuildError::EnvironmentLight { index }),
        None => Ok(()),
    }
}

/// The light point of a host environment's sample: `direction` (any positive, finite length),
/// its `radiance` and solid-angle `pdf` (> 0), each checked.
pub(crate) fn environment_point(
    direction: Vec3,
    radiance: Rgb,
    pdf: f32,
) -> Result<LightPoint, DirectError> {
    let l2 = direction.length_squared();
    if !(l2 > 0.0 && l2 < f32::INFINITY && direction.is_finite()) {
        return Err(DirectError::Direction { length_squared: l2 });
    }
    if !(pdf > 0.0 && pdf < f32::INFINITY) {
        return Err(DirectError::EnvironmentPdf { value: pdf });
    }
    check_radiance(radiance)?;
    let d = direction / crate::math::sqrt(l2);
    Ok(LightPoint {
        position: d,
        normal: Vec3::ZERO,
        direction: d,
        distance: f32::INFINITY,
        pdf,
        delta: false,
        radiance,
    })
}

/// The host environment's radiance along the unit `direction` and its pdf (≥ 0), checked.
pub(crate) fn environment_eval(
    env: &(dyn Environment + Send + Sync),
    direction: Vec3,
) -> Result<(Rgb, f32), DirectError> {
    let (radiance, pdf) = env.eval(direction);
    if !(0.0..f32::INFINITY).contains(&pdf) {
        return Err(DirectError::EnvironmentPdf { value: pdf });
    }
    check_radiance(radiance)?;
    Ok((radiance, pdf))
}

/// [`DirectError::EnvironmentRadiance`] for a channel that is negative or not finite.
fn check_radiance(radiance: Rgb) -> Result<(), DirectError> {
    for c in radiance.to_array() {
        if !(0.0..f32::INFINITY).contains(&c) {
            return Err(DirectError::EnvironmentRadiance { value: c });
        }
    }
    Ok(())
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

/// The alias table of the energy-proportional technique over `lights` ([`energy`]).
fn energy_table(lights: &[Light]) -> AliasTable {
    let r2 = scene_radius2(lights);
    AliasTable::new(lights.iter().map(|l| energy(l, r2)))
}

/// A light's weight in the alias table: its energy, or for a light at infinity the power of
/// the module documentation.
fn energy(l: &Light, r2: f64) -> f64 {
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
