//! Direct illumination: every `direct` technique as one call with host callbacks (shadow ray
//! or first-surface distance, uniform numbers), and the lower level (light samples with their
//! weights; BSDF samples whose hits the host reports with its pdf).

use crate::arg;
use crate::cut::{cut_options, ml_bl_cut_options, ml_split_cut_options, split_options};
use crate::error::{ml_status, Error, Result};
use crate::ffi_fn;
use crate::tree::{ml_tree, tree_arg, TreeData};
use crate::types::{
    finite3, ml_light_point, ml_rgb, ml_rgb64, ml_shading_point, ml_vec3, shading_error,
    shading_point,
};
use crate::visibility_cache::{cache_arg, ml_visibility_cache, CacheData};
use core::ffi::c_void;
use glam::Vec3;
use manylights::direct::MAX_LIGHT_SAMPLES;
use manylights::direct::{
    BsdfDraw, DirectError, LambertMode, LightDraw, Occluder, Params, Step, Technique, Uniforms,
};
use manylights::light::{Environment, EnvironmentSample};
use manylights::MAX_BUDGET;
use manylights::{Estimator, Heuristic, LightSet};
use std::cell::Cell;
use std::sync::Arc;

/// A direct-lighting technique (`technique` arguments take these values).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ml_technique {
    /// One light uniformly, a point on it.
    Uniform = 0,
    /// One light in proportion to its energy (an alias table).
    Energy = 1,
    /// One light by tree descent with the Conty–Kulla importance.
    Tl = 2,
    /// Conty & Kulla's split sampling: one light in each cluster of the split cut.
    TlSplit = 3,
    /// One light from the BRDF-oriented cut of Liu et al. 2019.
    Bl = 4,
    /// `tl-split` plus BRDF-aware samples in equal numbers (BL and BSDF).
    MisEqual = 5,
    /// The method of Liu et al. 2019: `tl-split` plus BRDF-aware samples allocated adaptively
    /// (their Algorithm 1), sequential MIS weights.
    Full = 6,
    /// One `tl` light sample plus one BSDF sample, power heuristic (pbrt-v4's and Cycles').
    TlMis = 7,
    /// `bl_light_samples` (2 by default) `bl` light samples from one cut plus one BSDF
    /// sample, power heuristic with the counts: the default.
    BlMis = 8,
    /// `tl-mis` with pbrt-v4's handling of distant and environment lights: each picked with
    /// the fixed probability 1 / (n + 1) whatever the point (n of them), the node tree
    /// otherwise; 1 / n each when the tree holds no local light.
    TlMisPinf = 9,
}

/// The technique a renderer should use without a reason to choose another (`bl-mis`).
pub const ML_TECHNIQUE_DEFAULT: u32 = 8;
const _: () = assert!(ML_TECHNIQUE_DEFAULT == ml_technique::BlMis as u32);

/// What `full` does at a Lambert-only shading point.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ml_lambert_mode {
    /// TL split alone (the default).
    TlOnly = 0,
    /// TL split plus the budget's BSDF samples.
    TbBudget = 1,
    /// TL split plus one BSDF sample.
    TbOne = 2,
    /// As at glossy points: BL and BSDF samples allocated adaptively.
    BlTb = 3,
}

/// The MIS heuristic of the combined techniques (Veach 1997, section 9.2).
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ml_heuristic {
    /// The power heuristic, β = 2 (the default).
    Power = 0,
    /// The balance heuristic.
    Balance = 1,
}

/// The estimators' parameters (`ml_direct_params_default` fills the defaults).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ml_direct_params {
    /// The split-sampling cut (`tl-split`, `mis-equal`, `full`).
    pub split_cut: ml_split_cut_options,
    /// The BRDF-oriented cut of `bl` and `bl-mis` (default δ = 0.3, 64 clusters, `split_sin`
    /// 0.9).
    pub bl_cut: ml_bl_cut_options,
    /// The BRDF-oriented cut of `mis-equal` and `full`, whose IB(x) also sets their budget
    /// (default Liu et al. 2019's: δ = 0.5, 32 clusters, `split_sin` 1).
    pub mixture_cut: ml_bl_cut_options,
    /// Light samples per estimate of `bl-mis`, all from its one cut, in [1,
    /// `ML_MAX_LIGHT_SAMPLES`] = [1, 64] (default 2).
    pub bl_light_samples: u32,
    /// Nmax of the BRDF-aware budget N = ceil(Nmax · IB(x)), in [1, `ML_MAX_BUDGET`] = [1, 64]
    /// (default 50).
    pub n_max: u32,
    /// An `ml_lambert_mode` (default `ML_LAMBERT_MODE_TL_ONLY`).
    pub lambert: u32,
    /// An `ml_heuristic`: the MIS heuristic between the techniques (default
    /// `ML_HEURISTIC_POWER`).
    pub heuristic: u32,
}

/// The host's uniform numbers: `next_f32(user_data)` and `next_f64(user_data)` return the
/// next number in [0, 1) (`next_f64` with more bits, for choosing among many lights; NULL:
/// `next_f32` is used). A number outside [0, 1) fails the call with
/// `ML_ERR_INVALID_ARGUMENT`. Callbacks must return normally (no longjmp, no C++ exception).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ml_uniforms {
    /// The next uniform number in [0, 1) (required).
    pub next_f32: Option<unsafe extern "C" fn(user_data: *mut c_void) -> f32>,
    /// The next uniform number in [0, 1) with 53 bits (optional).
    pub next_f64: Option<unsafe extern "C" fn(user_data: *mut c_void) -> f64>,
    /// Passed to both.
    pub user_data: *mut c_void,
}

/// The host's visibility, one of two callbacks (both NULL: nothing is occluded):
/// `occluded(user_data, x, d, t)` returns non-zero if a surface lies on the ray from `x` along
/// the unit `d` before distance `t` (a shadow ray); `first_hit(user_data, x, d)` returns the
/// distance to the first surface along the ray (+infinity for none; not NaN). `occluded` is
/// used when both are set. Callbacks must return normally.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ml_visibility {
    /// Shadow ray.
    pub occluded:
        Option<unsafe extern "C" fn(user_data: *mut c_void, x: ml_vec3, d: ml_vec3, t: f32) -> i32>,
    /// First-surface distance.
    pub first_hit:
        Option<unsafe extern "C" fn(user_data: *mut c_void, x: ml_vec3, d: ml_vec3) -> f32>,
    /// Passed to both.
    pub user_data: *mut c_void,
}

/// The kind of an `ml_step`.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ml_step_kind {
    /// A light point to shade: evaluate `value = f · radiance · cos θi` towards
    /// `point.direction`, test visibility up to `point.distance`, and if it contributes, weigh
    /// it with `ml_estimator_weigh` (passing the BSDF's pdf of the direction if
    /// `needs_bsdf_pdf`) and add `value · scale`.
    Light = 0,
    /// A BSDF sample to take with `u0`, `u1`: sample the BSDF, cast the ray and report the
    /// direction, its pdf and the first surface's distance to `ml_estimator_bsdf_hits`. When
    /// the host's BSDF gives no direction for them, skip the report (as the one call does):
    /// the sample contributes nothing, and `full` counts it as a ray that reached no light.
    Bsdf = 1,
    /// The estimate is complete.
    Done = 2,
}

/// One step of an estimate (see `ml_step_kind`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_step {
    /// An `ml_step_kind`.
    pub kind: u32,
    /// Light step: the light's index.
    pub light: u32,
    /// Light step: the probability of having chosen it.
    pub pmf: f32,
    /// Light step: 1 if `ml_estimator_weigh` uses the host's BSDF pdf of the direction.
    pub needs_bsdf_pdf: u32,
    /// Light step: the point on the light.
    pub point: ml_light_point,
    /// BSDF step: the first uniform number for sampling the BSDF.
    pub u0: f32,
    /// BSDF step: the second uniform number.
    pub u1: f32,
}

/// A sample's MIS weight and density: its contribution is `value · scale`, with `value = f ·
/// L · cos θi` (or each channel of it, of any sign) evaluated by the host.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_weighted {
    /// The MIS weight, in [0, 1].
    pub weight: f32,
    /// The density the weight is relative to (solid angle; 1 for point, spot and VPL lights):
    /// the light sample's density for light steps; for BSDF hits the BSDF's pdf with
    /// `tl-mis` and `bl-mis`, and the combined density of the mixed BL and BSDF samples with
    /// `mis-equal` and `full`.
    pub pdf: f32,
    /// `weight / pdf` (finite, ≥ 0), the factor of every channel of the value.
    pub scale: f32,
}

/// A light a BSDF ray reached, for `ml_estimator_bsdf_hits`'s callback: the host shades it
/// (`value = f · point.radiance · cos θi` with its own f) and adds `value · weighted.scale`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_light_hit {
    /// The light's index.
    pub light: u32,
    /// The point the ray reached on it.
    pub point: ml_light_point,
    /// Its weight and the density the weight is relative to (see `ml_weighted.pdf`).
    pub weighted: ml_weighted,
}

/// The host's environment (a sky or an environment map), given once to the tree
/// (`ml_tree_build`, `ml_tree_build_parallel`, `ml_tree_load_with_lights`), which copies this
/// struct and calls the callbacks for every estimate and point on the environment:
/// `sample(user_data, u0, u1, direction, radiance, pdf)` writes a direction towards the
/// environment (any positive length), the radiance along it and its solid-angle pdf (> 0)
/// and returns non-zero, or returns 0 for no sample; `eval(user_data, direction, radiance,
/// pdf)` writes the radiance along the unit `direction` and the pdf with which `sample`
/// returns it (≥ 0, 0 where it never does). Their values are checked at every call: a NaN,
/// negative or infinite radiance channel or pdf (or a pdf of 0 from `sample`) is
/// `ML_ERR_INVALID_ARGUMENT` of the estimate. The callbacks must return normally, may be
/// called from every thread that uses the tree at once, and `user_data` must stay valid
/// until the tree and every cut and estimator made from it are freed.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ml_environment {
    /// Samples a direction.
    pub sample: Option<
        unsafe extern "C" fn(
            user_data: *mut c_void,
            u0: f32,
            u1: f32,
            direction: *mut ml_vec3,
            radiance: *mut ml_rgb,
            pdf: *mut f32,
        ) -> i32,
    >,
    /// Radiance and pdf of a direction.
    pub eval: Option<
        unsafe extern "C" fn(
            user_data: *mut c_void,
            direction: ml_vec3,
            radiance: *mut ml_rgb,
            pdf: *mut f32,
        ),
    >,
    /// Passed to both.
    pub user_data: *mut c_void,
    /// Upper bounds of the irradiance the environment delivers (luminance, W/m²) to a
    /// receiver facing +x, −x, +y, −y, +z and −z: `∫ Y(L(ω)) max(0, a·ω) dω` for each axis
    /// direction a (πY(L) in all six for a uniform radiance L); finite and ≥ 0, each at most
    /// `ML_MAX_LIGHT_ENERGY`. They decide how often the environment is chosen, never its
    /// weight: bounds too large cost variance only; a bound of 0 at a receiver the
    /// environment lights makes the techniques without a BSDF sample there (`power`, `tl`,
    /// `bl`, `tl-split`, and `mis-equal`, `full` where their budget is 0) miss it, biased low.
    pub irradiance_bounds: [f32; 6],
}

/// The host's environment as the core's.
pub(crate) struct HostEnvironment {
    sample: unsafe extern "C" fn(*mut c_void, f32, f32, *mut ml_vec3, *mut ml_rgb, *mut f32) -> i32,
    eval: unsafe extern "C" fn(*mut c_void, ml_vec3, *mut ml_rgb, *mut f32),
    user: *mut c_void,
    bounds: [f32; 6],
}

// SAFETY: the host's contract (`ml_environment`): its callbacks may be called from any
// thread at once, and `user_data` stays valid while the tree lives.
unsafe impl Send for HostEnvironment {}
// SAFETY: as above.
unsafe impl Sync for HostEnvironment {}

impl HostEnvironment {
    pub(crate) fn new(e: &ml_environment) -> Result<HostEnvironment> {
        Ok(HostEnvironment {
            sample: e.sample.ok_or_else(|| Error::null("environment->sample"))?,
            eval: e.eval.ok_or_else(|| Error::null("environment->eval"))?,
            user: e.user_data,
            bounds: e.irradiance_bounds,
        })
    }
}

impl Environment for HostEnvironment {
    fn sample(&self, u: [f32; 2]) -> Option<EnvironmentSample> {
        let (mut d, mut r, mut pdf) = (ml_vec3::default(), ml_rgb::default(), 0.0f32);
        // SAFETY: a host callback with its own user data; the out-pointers are to locals.
        let ok = unsafe { (self.sample)(self.user, u[0], u[1], &mut d, &mut r, &mut pdf) };
        (ok != 0).then(|| EnvironmentSample {
            direction: d.into(),
            radiance: r.into(),
            pdf,
        })
    }

    fn eval(&self, direction: Vec3) -> (manylights::Rgb, f32) {
        let (mut r, mut pdf) = (ml_rgb::default(), 0.0f32);
        // SAFETY: as above.
        unsafe { (self.eval)(self.user, direction.into(), &mut r, &mut pdf) };
        (r.into(), pdf)
    }

    fn irradiance_bounds(&self) -> [f32; 6] {
        self.bounds
    }
}

/// Called by `ml_estimator_bsdf_hits` for each light reached.
pub type ml_hit_fn = Option<unsafe extern "C" fn(user_data: *mut c_void, hit: *const ml_light_hit)>;

/// A per-point estimator (opaque): per-thread state, set up for one shading point and
/// technique by `ml_estimator_set_point`, then any number of estimates. It keeps its tree
/// alive, and the visibility cache it was given. Not to be used by two threads at once.
pub struct ml_estimator {
    // Declared before `set_up_cache` and `tree`, so dropped first: it borrows the light set
    // `tree` owns and the cache `set_up_cache` holds.
    est: Option<Estimator<'static>>,
    last_light: Option<LightDraw>,
    last_bsdf: Option<BsdfDraw>,
    /// The cache `est` was set up with (and borrows).
    set_up_cache: Option<Arc<CacheData>>,
    /// The cache the next `ml_estimator_set_point` sets up with.
    cache: Option<Arc<CacheData>>,
    tree: Arc<TreeData>,
}

impl From<manylights::direct::Weighted> for ml_weighted {
    fn from(w: manylights::direct::Weighted) -> ml_weighted {
        ml_weighted {
            weight: w.weight(),
            pdf: w.pdf(),
            scale: w.factor(),
        }
    }
}

/// The technique of a C value.
fn technique_of(t: u32) -> Result<Technique> {
    Technique::ALL.get(t as usize).copied().ok_or_else(|| {
        Error::invalid(format_args!(
            "technique: {t} is not an ml_technique (0 to 9)"
        ))
    })
}

/// Fills `*out` with the default parameters.
///
/// Errors: `ML_ERR_NULL` if `out` is NULL.
#[no_mangle]
pub extern "C" fn ml_direct_params_default(out: *mut ml_direct_params) -> ml_status {
    ffi_fn!("ml_direct_params_default", {
        let p = Params::default();
        arg::out(out, "out")?.write(ml_direct_params {
            split_cut: ml_split_cut_options {
                threshold: p.split_cut.threshold,
                max_size: p.split_cut.max_size,
            },
            bl_cut: ml_bl_cut_options {
                delta: p.bl_cut.delta,
                max_size: p.bl_cut.max_size,
                split_sin: p.bl_cut.split_sin,
            },
            mixture_cut: ml_bl_cut_options {
                delta: p.mixture_cut.delta,
                max_size: p.mixture_cut.max_size,
                split_sin: p.mixture_cut.split_sin,
            },
            bl_light_samples: p.bl_light_samples,
            n_max: p.n_max,
            lambert: ml_lambert_mode::TlOnly as u32,
            heuristic: ml_heuristic::Power as u32,
        });
        Ok(())
    })
}

/// The core's parameters of checked C ones (NULL: defaults).
fn params_of(p: Option<&ml_direct_params>) -> Result<Params> {
    let Some(p) = p else {
        return Ok(Params::default());
    };
    if !(1..=MAX_BUDGET).contains(&p.n_max) {
        return Err(Error::invalid(format_args!(
            "params.n_max must be in [1, {MAX_BUDGET}], 1 to ML_MAX_BUDGET (got {})",
            p.n_max
        )));
    }
    let lambert = *LambertMode::ALL.get(p.lambert as usize).ok_or_else(|| {
        Error::invalid(format_args!(
            "params.lambert: {} is not an ml_lambert_mode (0 to 3)",
            p.lambert
        ))
    })?;
    let heuristic = match p.heuristic {
        0 => Heuristic::Power,
        1 => Heuristic::Balance,
        v => {
            return Err(Error::invalid(format_args!(
                "params.heuristic: {v} is not an ml_heuristic (0 or 1)"
            )))
        }
    };
    if !(1..=MAX_LIGHT_SAMPLES).contains(&p.bl_light_samples) {
        return Err(Error::invalid(format_args!(
            "params.bl_light_samples must be in [1, {MAX_LIGHT_SAMPLES}], 1 to \
             ML_MAX_LIGHT_SAMPLES (got {})",
            p.bl_light_samples
        )));
    }
    Ok(Params {
        split_cut: split_options(Some(&p.split_cut), "params.split_cut")?,
        bl_cut: cut_options(Some(&p.bl_cut), "params.bl_cut")?,
        mixture_cut: cut_options(Some(&p.mixture_cut), "params.mixture_cut")?,
        bl_light_samples: p.bl_light_samples,
        n_max: p.n_max,
        lambert,
        heuristic,
    })
}

/// The host's uniform numbers as the core asks for them.
struct HostUniforms {
    f32: unsafe extern "C" fn(*mut c_void) -> f32,
    f64: Option<unsafe extern "C" fn(*mut c_void) -> f64>,
    user: *mut c_void,
}

impl HostUniforms {
    fn new(u: &ml_uniforms) -> Result<HostUniforms> {
        Ok(HostUniforms {
            f32: u
                .next_f32
                .ok_or_else(|| Error::null("uniforms->next_f32"))?,
            f64: u.next_f64,
            user: u.user_data,
        })
    }
}

impl Uniforms for HostUniforms {
    #[inline]
    fn next_f32(&mut self) -> f32 {
        // SAFETY: a host callback with its own user data (the caller's contract).
        unsafe { (self.f32)(self.user) }
    }

    #[inline]
    fn next_f64(&mut self) -> f64 {
        match self.f64 {
            // SAFETY: as above.
            Some(f) => unsafe { f(self.user) },
            None => f64::from(self.next_f32()),
        }
    }
}

/// The host's visibility as the core's occluder; remembers a NaN distance from `first_hit`.
struct HostVisibility {
    vis: Option<ml_visibility>,
    bad: Cell<Option<f32>>,
}

impl Occluder for HostVisibility {
    #[inline]
    fn occluded(&self, x: Vec3, d: Vec3, t: f32) -> bool {
        let Some(v) = self.vis else {
            return false;
        };
        if let Some(f) = v.occluded {
            // SAFETY: a host callback with its own user data (the caller's contract).
            return unsafe { f(v.user_data, x.into(), d.into(), t) } != 0;
        }
        if let Some(f) = v.first_hit {
            // SAFETY: as above.
            let h = unsafe { f(v.user_data, x.into(), d.into()) };
            if h.is_nan() || h < 0.0 {
                self.bad.set(Some(h));
                return true;
            }
            return h < t;
        }
        false
    }
}

/// A core estimator error in the C arguments' terms.
pub(crate) fn direct_error(e: DirectError) -> Error {
    match e {
        DirectError::Shading(s) => shading_error(s, &|| "sp".into()),
        DirectError::Uniform { value } => Error::invalid(format_args!(
            "uniforms: a number from next_f32 or next_f64 is outside [0, 1) (got {value})"
        )),
        DirectError::BsdfPdf { value } => Error::invalid(format_args!(
            "bsdf_pdf must be finite and non-negative (got {value})"
        )),
        DirectError::Direction { length_squared } => Error::invalid(format_args!(
            "direction must be finite and non-zero (squared length {length_squared})"
        )),
        DirectError::HitDistance { value } => Error::invalid(format_args!(
            "hit_distance must be non-negative or +infinity (got {value})"
        )),
        DirectError::EnvironmentPdf { value } => Error::invalid(format_args!(
            "environment: the pdf from environment->sample or environment->eval must be \
             finite and non-negative, and positive for a sample (got {value})"
        )),
        DirectError::EnvironmentRadiance { value } => Error::invalid(format_args!(
            "environment: every channel of the radiance from environment->sample or \
             environment->eval must be finite and non-negative (got {value})"
        )),
        _ => Error::invalid(e),
    }
}

/// One estimate with the core's material and the host's callbacks.
fn estimate_with(
    est: &mut Estimator<'_>,
    vis: Option<&ml_visibility>,
    u: &ml_uniforms,
) -> Result<ml_rgb64> {
    let mut u = HostUniforms::new(u)?;
    let occ = HostVisibility {
        vis: vis.copied(),
        bad: Cell::new(None),
    };
    let r = est.estimate(&occ, &mut u).map_err(direct_error)?;
    if let Some(h) = occ.bad.get() {
        return Err(Error::invalid(format_args!(
            "visibility->first_hit returned {h} (must be non-negative or +infinity)"
        )));
    }
    Ok(r.into())
}

/// The shading point of a checked C one.
fn sp_arg(sp: *const ml_shading_point) -> Result<manylights::ShadingPoint> {
    shading_point(arg::get(sp, "sp")?, &|| "sp".into())
}

/// One estimate of the radiance reflected at `sp` towards `sp->wo` from the tree's lights
/// (and its environment, if it was given one), with `technique` (an `ml_technique`), `params`
/// (NULL: defaults), the host's `visibility` (NULL: nothing occluded) and `uniforms`, with the
/// core's material (`sp->material`), in linear RGB. Every channel of the estimate is finite
/// and ≥ 0; its expectation is the reflected radiance (every technique is unbiased). For many
/// estimates at one point, `ml_estimator_*` sets up once.
///
/// Errors: `ML_ERR_NULL` (`tree`, `sp`, `uniforms`, `uniforms->next_f32`, `out`);
/// `ML_ERR_INVALID_ARGUMENT` (a bad shading point, technique or parameter; a uniform number
/// outside [0, 1); a NaN or negative `first_hit`; a bad value from the environment's
/// callbacks, see `ml_environment`); `ML_ERR_STATE` (a tree loaded by `ml_tree_load`, without
/// its lights).
#[no_mangle]
pub extern "C" fn ml_direct_estimate(
    tree: *const ml_tree,
    sp: *const ml_shading_point,
    technique: u32,
    params: *const ml_direct_params,
    visibility: *const ml_visibility,
    uniforms: *const ml_uniforms,
    out: *mut ml_rgb64,
) -> ml_status {
    ffi_fn!("ml_direct_estimate", {
        let data = tree_arg(tree)?;
        let sp = sp_arg(sp)?;
        let t = technique_of(technique)?;
        let p = params_of(arg::opt(params, "params")?)?;
        let vis = arg::opt(visibility, "visibility")?;
        let u = arg::get(uniforms, "uniforms")?;
        let out = arg::out(out, "out")?;
        let set = data.set()?;
        let mut est = Estimator::new(set, &sp, t, &p).map_err(direct_error)?;
        out.write(estimate_with(&mut est, vis, u)?);
        Ok(())
    })
}

/// Estimates at `count` shading points at once, for wavefront hosts: for each `points[j]` in
/// order, the per-point set-up (as `ml_estimator_set_point` with `technique` and `params`) and
/// `per_point` (≥ 1) estimates (as `ml_estimator_estimate` with `visibility` and `uniforms`),
/// written to `out[j · per_point + i]` — bit for bit, and drawing exactly the uniform numbers,
/// of those calls made one after the other (with `per_point` = 1, of `count` calls of
/// `ml_direct_estimate`). Every shading point is checked before the first estimate; `out`
/// (`count · per_point` RGB estimates) is written only on success.
///
/// Errors: `ML_ERR_NULL` (`tree`, `uniforms`, `uniforms->next_f32`; `points`, `out` when
/// `count` > 0); `ML_ERR_INVALID_ARGUMENT` (`per_point` 0, a count that overflows, a bad
/// technique or parameter, a bad shading point named `points[j]`, a uniform number outside
/// [0, 1), a bad `first_hit` or a bad value from the environment's callbacks, named with the
/// point it was drawn for); `ML_ERR_STATE` (a tree loaded without its lights).
#[no_mangle]
pub extern "C" fn ml_direct_estimate_batch(
    tree: *const ml_tree,
    points: *const ml_shading_point,
    count: usize,
    per_point: u32,
    technique: u32,
    params: *const ml_direct_params,
    visibility: *const ml_visibility,
    uniforms: *const ml_uniforms,
    out: *mut ml_rgb64,
) -> ml_status {
    ffi_fn!("ml_direct_estimate_batch", {
        let data = tree_arg(tree)?;
        if per_point == 0 {
            return Err(Error::invalid("per_point must be at least 1 (got 0)"));
        }
        let total = count.checked_mul(per_point as usize).ok_or_else(|| {
            Error::invalid(format_args!(
                "count: {count} points of {per_point} estimates overflow the address space"
            ))
        })?;
        let pts = arg::slice(points, count, "points")?;
        let t = technique_of(technique)?;
        let p = params_of(arg::opt(params, "params")?)?;
        let vis = arg::opt(visibility, "visibility")?;
        let u = arg::get(uniforms, "uniforms")?;
        let mut out = arg::out_slice(out, total, "out")?;
        let set = data.set()?;
        HostUniforms::new(u)?;
        let mut sps = Vec::with_capacity(count);
        for (j, sp) in pts.iter().enumerate() {
            sps.push(shading_point(sp, &|| format!("points[{j}]"))?);
        }
        let mut res = vec![ml_rgb64::default(); total];
        let per = per_point as usize;
        // One estimator, moved from point to point (the same set-up as a new one).
        let mut slot: Option<Estimator<'_>> = None;
        for (j, (sp, r)) in sps.iter().zip(res.chunks_exact_mut(per)).enumerate() {
            let name = || format!("points[{j}]");
            let est = Estimator::reuse(&mut slot, set, sp, t, &p)
                .map_err(|e| direct_error_at(e, &name()))?;
            for v in r {
                *v = estimate_with(est, vis, u).map_err(|e| e.within(&name()))?;
            }
        }
        for (i, v) in res.into_iter().enumerate() {
            out.set(i, v);
        }
        Ok(())
    })
}

/// A core estimator error in the C arguments' terms, the shading point named `path`.
fn direct_error_at(e: DirectError, path: &str) -> Error {
    match e {
        DirectError::Shading(s) => shading_error(s, &|| path.into()),
        e => direct_error(e),
    }
}

/// Creates an estimator for the lights of `tree` (built by `ml_tree_build` or loaded by
/// `ml_tree_load_with_lights`). Set it up for a shading point with `ml_estimator_set_point`.
/// Free it with `ml_estimator_free`.
///
/// Errors: `ML_ERR_NULL` (`tree`, `out`); `ML_ERR_STATE` (a tree loaded by `ml_tree_load`,
/// without its lights).
#[no_mangle]
pub extern "C" fn ml_estimator_create(
    tree: *const ml_tree,
    out: *mut *mut ml_estimator,
) -> ml_status {
    ffi_fn!("ml_estimator_create", {
        let data = tree_arg(tree)?;
        let out = arg::out(out, "out")?;
        data.set()?;
        out.write(arg::into_handle(ml_estimator {
            est: None,
            last_light: None,
            last_bsdf: None,
            set_up_cache: None,
            cache: None,
            tree: Arc::clone(data),
        }));
        Ok(())
    })
}

/// Frees an estimator (NULL: nothing).
#[no_mangle]
pub extern "C" fn ml_estimator_free(est: *mut ml_estimator) -> ml_status {
    ffi_fn!("ml_estimator_free", { arg::free_handle(est, "est") })
}

/// Sets the estimator up for the shading point `sp` with `technique` and `params` (NULL:
/// defaults): builds what the technique needs there (its cuts, its budget). With the
/// technique and parameters of its previous set-up the estimator is rebuilt in place (the
/// same set-up, and bit for bit the same estimates, without a new estimator's copy): a host
/// keeps one estimator per thread and sets it up at every shading point. With a visibility
/// cache (`ml_estimator_set_visibility_cache`), the BRDF-oriented cut's cluster weights are
/// scaled by the cache's committed state at `sp` (`bl`, `bl-mis`, `mis-equal`, `full`; the
/// techniques without that cut neither use nor feed the cache). On error the estimator keeps
/// its previous set-up.
///
/// Errors: `ML_ERR_NULL` (`est`, `sp`); `ML_ERR_INVALID_ARGUMENT` (a bad shading point,
/// technique or parameter).
#[no_mangle]
pub extern "C" fn ml_estimator_set_point(
    est: *mut ml_estimator,
    sp: *const ml_shading_point,
    technique: u32,
    params: *const ml_direct_params,
) -> ml_status {
    ffi_fn!("ml_estimator_set_point", {
        let h = arg::get_mut(est, "est")?;
        let sp = sp_arg(sp)?;
        let t = technique_of(technique)?;
        let p = params_of(arg::opt(params, "params")?)?;
        let set: &LightSet = h.tree.set()?;
        // SAFETY: the light set lives in `h.tree`'s allocation, which `h` keeps alive and never
        // replaces; `h.est` is declared before `h.tree` (dropped first) and the reference never
        // leaves the handle.
        let set: &'static LightSet = unsafe { &*(set as *const LightSet) };
        // The same technique, parameters and cache: the estimator is moved to the point in
        // place (`reset`, the same set-up as a new one without its copy).
        match &h.cache {
            Some(c) => {
                // SAFETY: the cache lives in the `Arc` that `h.set_up_cache` holds from here
                // on (it is stored below, once the set-up succeeded, and replaced only by the
                // cache of a later set-up, which also replaces or resets `h.est`); `h.est` is
                // declared before `h.set_up_cache` (dropped first) and the reference never
                // leaves the handle.
                let cache: &'static manylights::direct::VisibilityCache =
                    unsafe { &*(&c.cache as *const manylights::direct::VisibilityCache) };
                Estimator::reuse_with_visibility(&mut h.est, set, cache, &sp, t, &p)
                    .map_err(direct_error)?;
            }
            None => {
                Estimator::reuse(&mut h.est, set, &sp, t, &p).map_err(direct_error)?;
            }
        }
        h.set_up_cache = h.cache.clone();
        h.last_light = None;
        h.last_bsdf = None;
        Ok(())
    })
}

/// Gives the estimator a visibility cache made for its tree (`ml_visibility_cache_create`),
/// or none (`cache` NULL): from the next `ml_estimator_set_point` on, the BRDF-oriented cut's
/// cluster weights are scaled by the cache's committed state, and `ml_estimator_estimate`
/// records its shadow rays in it (the step loop records with `ml_estimator_record`). Until
/// then the current set-up is kept, with the cache it was made with. The estimator keeps the
/// cache alive: the cache's handle may be freed first. Pmfs stay exact (sampled = queried)
/// and every technique unbiased whatever the cache learned. One cache serves every thread's
/// estimators at once.
///
/// Errors: `ML_ERR_NULL` (`est`); `ML_ERR_INVALID_ARGUMENT` (`cache` made for another tree).
#[no_mangle]
pub extern "C" fn ml_estimator_set_visibility_cache(
    est: *mut ml_estimator,
    cache: *const ml_visibility_cache,
) -> ml_status {
    ffi_fn!("ml_estimator_set_visibility_cache", {
        let h = arg::get_mut(est, "est")?;
        let c = match arg::opt(cache, "cache")? {
            Some(c) => Some(cache_arg(c, "cache")?),
            None => None,
        };
        if let Some(c) = c {
            if !Arc::ptr_eq(&c.tree, &h.tree) || !c.cache.fits(h.tree.tree()) {
                return Err(Error::invalid(
                    "cache: made for another tree (a visibility cache serves the estimators \
                     of the tree it was created with)",
                ));
            }
        }
        h.cache = c.cloned();
        Ok(())
    })
}

/// Records the host's shadow ray for the last light step (`ML_STEP_KIND_LIGHT`) in the
/// estimator's visibility cache: `visible` 1 if the light point was unoccluded, 0 if not.
/// Call it once per light step whose value (f · radiance · cos θi) is positive, before or
/// after `ml_estimator_weigh`, as `ml_estimator_estimate` does for its own; nothing happens
/// without a cache or with its recording off, and what is recorded changes sampling only
/// after `ml_visibility_cache_commit`. Thread-safe with respect to the cache (every thread's
/// estimators record into it at once).
///
/// Errors: `ML_ERR_NULL` (`est`); `ML_ERR_INVALID_ARGUMENT` (`visible` other than 0 or 1);
/// `ML_ERR_STATE` (not set up, or no light step yielded since the last start).
#[no_mangle]
pub extern "C" fn ml_estimator_record(est: *mut ml_estimator, visible: u32) -> ml_status {
    ffi_fn!("ml_estimator_record", {
        let h = arg::get_mut(est, "est")?;
        if visible > 1 {
            return Err(Error::invalid(format_args!(
                "visible must be 0 or 1 (got {visible})"
            )));
        }
        let draw = h.last_light;
        let e = set_up(h)?;
        let draw = draw.ok_or_else(|| Error::state("est: no light step to record"))?;
        e.record(&draw, visible == 1);
        Ok(())
    })
}

fn set_up(h: &mut ml_estimator) -> Result<&mut Estimator<'static>> {
    h.est
        .as_mut()
        .ok_or_else(|| Error::state("est: not set up (call ml_estimator_set_point first)"))
}

/// One estimate at the estimator's shading point with the core's material: as
/// `ml_direct_estimate`, without the set-up. With a visibility cache, every shadow ray of a
/// light sample whose unshadowed value is positive is recorded in it (as
/// `ml_estimator_record`).
///
/// Errors: `ML_ERR_NULL` (`est`, `uniforms`, `uniforms->next_f32`, `out`);
/// `ML_ERR_INVALID_ARGUMENT` (a uniform number outside [0, 1), a bad `first_hit`, a bad value
/// from the environment's callbacks); `ML_ERR_STATE` (not set up).
#[no_mangle]
pub extern "C" fn ml_estimator_estimate(
    est: *mut ml_estimator,
    visibility: *const ml_visibility,
    uniforms: *const ml_uniforms,
    out: *mut ml_rgb64,
) -> ml_status {
    ffi_fn!("ml_estimator_estimate", {
        let h = arg::get_mut(est, "est")?;
        let vis = arg::opt(visibility, "visibility")?;
        let u = arg::get(uniforms, "uniforms")?;
        let out = arg::out(out, "out")?;
        let e = set_up(h)?;
        out.write(estimate_with(e, vis, u)?);
        h.last_light = None;
        h.last_bsdf = None;
        Ok(())
    })
}

/// Starts a new estimate of the lower level (forgetting the current one); then call
/// `ml_estimator_next` until it gives `ML_STEP_KIND_DONE`, adding up the contributions.
///
/// Errors: `ML_ERR_NULL` (`est`); `ML_ERR_STATE` (not set up).
#[no_mangle]
pub extern "C" fn ml_estimator_start(est: *mut ml_estimator) -> ml_status {
    ffi_fn!("ml_estimator_start", {
        let h = arg::get_mut(est, "est")?;
        set_up(h)?.start();
        h.last_light = None;
        h.last_bsdf = None;
        Ok(())
    })
}

/// The next step of the estimate begun by `ml_estimator_start`, drawing uniform numbers from
/// `uniforms` as needed (see `ml_step_kind`). After `ML_STEP_KIND_DONE` it keeps giving it.
///
/// Errors: `ML_ERR_NULL` (`est`, `uniforms`, `uniforms->next_f32`, `out`);
/// `ML_ERR_INVALID_ARGUMENT` (a uniform number outside [0, 1)); `ML_ERR_STATE` (not set up).
#[no_mangle]
pub extern "C" fn ml_estimator_next(
    est: *mut ml_estimator,
    uniforms: *const ml_uniforms,
    out: *mut ml_step,
) -> ml_status {
    ffi_fn!("ml_estimator_next", {
        let h = arg::get_mut(est, "est")?;
        let u = arg::get(uniforms, "uniforms")?;
        let out = arg::out(out, "out")?;
        let mut u = HostUniforms::new(u)?;
        let step = set_up(h)?.next(&mut u).map_err(direct_error)?;
        let s = match step {
            Step::Light(d) => {
                h.last_light = Some(d);
                ml_step {
                    kind: ml_step_kind::Light as u32,
                    light: d.light,
                    pmf: d.pmf,
                    needs_bsdf_pdf: u32::from(d.needs_bsdf_pdf),
                    point: Some(d.point).into(),
                    ..ml_step::default()
                }
            }
            Step::Bsdf(b) => {
                h.last_bsdf = Some(b);
                ml_step {
                    kind: ml_step_kind::Bsdf as u32,
                    u0: b.u[0],
                    u1: b.u[1],
                    ..ml_step::default()
                }
            }
            Step::Done => ml_step {
                kind: ml_step_kind::Done as u32,
                ..ml_step::default()
            },
        };
        out.write(s);
        Ok(())
    })
}

/// The weight and density of the last light step, given the host's BSDF pdf of its direction
/// (used only where the step's `needs_bsdf_pdf` is 1; pass 0 otherwise). Weigh a light step
/// only if it contributes (its value is positive and it is visible).
///
/// Errors: `ML_ERR_NULL` (`est`, `out`); `ML_ERR_INVALID_ARGUMENT` (`bsdf_pdf` NaN, negative
/// or infinite); `ML_ERR_STATE` (not set up, or no light step yielded since the last start).
#[no_mangle]
pub extern "C" fn ml_estimator_weigh(
    est: *mut ml_estimator,
    bsdf_pdf: f32,
    out: *mut ml_weighted,
) -> ml_status {
    ffi_fn!("ml_estimator_weigh", {
        let h = arg::get_mut(est, "est")?;
        let out = arg::out(out, "out")?;
        let draw = h.last_light;
        let e = set_up(h)?;
        let draw = draw.ok_or_else(|| Error::state("est: no light step to weigh"))?;
        out.write(e.weigh(&draw, bsdf_pdf).map_err(direct_error)?.into());
        Ok(())
    })
}

/// Reports the last BSDF step's sample: the host sampled `direction` (world space, any
/// positive length) with density `bsdf_pdf` (solid angle), and its ray's first surface is at
/// `hit_distance` (+infinity for none). Calls `each(user_data, hit)` for every light reached in
/// front of it with non-zero radiance, with its weight (the host adds `value ·
/// hit->weighted.scale`) — a ray that escapes also reaches the distant lights whose cones
/// hold its direction, and the tree's environment, whose hit carries the environment's
/// radiance and pdf along `direction` (from `environment->eval`); `*any_hit` gets 1 if any
/// was reached (what the adaptive allocation learns; the environment counts whatever its
/// radiance), else 0.
///
/// Errors: `ML_ERR_NULL` (`est`, `each`, `any_hit`); `ML_ERR_INVALID_ARGUMENT` (a zero or
/// non-finite `direction`, a bad `bsdf_pdf`, a NaN or negative `hit_distance`, a bad value
/// from `environment->eval`); `ML_ERR_STATE` (not set up, or no BSDF step yielded since the
/// last start).
#[no_mangle]
pub extern "C" fn ml_estimator_bsdf_hits(
    est: *mut ml_estimator,
    direction: ml_vec3,
    bsdf_pdf: f32,
    hit_distance: f32,
    each: ml_hit_fn,
    user_data: *mut c_void,
    any_hit: *mut u32,
) -> ml_status {
    ffi_fn!("ml_estimator_bsdf_hits", {
        let h = arg::get_mut(est, "est")?;
        let each = each.ok_or_else(|| Error::null("each"))?;
        let any_hit = arg::out(any_hit, "any_hit")?;
        let draw = h.last_bsdf;
        let e = set_up(h)?;
        let draw = draw.ok_or_else(|| Error::state("est: no BSDF step to report"))?;
        let d = finite3(direction, &|| "direction".into())?;
        if hit_distance.is_nan() || hit_distance < 0.0 {
            return Err(direct_error(DirectError::HitDistance {
                value: hit_distance,
            }));
        }
        let call = |lh: manylights::direct::LightHit| {
            let c = ml_light_hit {
                light: lh.light,
                point: Some(lh.point).into(),
                weighted: lh.weighted.into(),
            };
            // SAFETY: a host callback with its own user data; `c` outlives the call.
            unsafe { each(user_data, &c) };
        };
        let hit = e
            .bsdf_hits(&draw, d, bsdf_pdf, |p| p.reached_before(hit_distance), call)
            .map_err(direct_error)?;
        h.last_bsdf = None;
        any_hit.write(u32::from(hit));
        Ok(())
    })
}
