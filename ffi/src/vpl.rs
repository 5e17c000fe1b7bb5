//! Probabilistic VPL acceptance (Georgiev & Slusallek 2010): importons, the acceptor, its
//! decisions (with an optional host visibility callback) and counts. Accepted VPLs go into a
//! tree as lights of kind `ML_LIGHT_KIND_VPL`.

use crate::arg;
use crate::error::{ml_status, Error};
use crate::ffi_fn;
use crate::types::{describe, material, ml_material, ml_rgb, ml_vec3};
use core::ffi::c_void;
use glam::Vec3;
use manylights::error::{VplError, VplField};
use manylights::vpl::DEFAULT_EPSILON;
use manylights::{Importons, Material, Vpl, VplAcceptor};

/// A VPL candidate or an accepted VPL: a point emitting `intensity · max(0, cos θ)` about its
/// `normal` (any non-zero length), as a light of kind `ML_LIGHT_KIND_VPL`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_vpl {
    /// Position (finite, magnitude at most `ML_MAX_COORDINATE`, 1e15).
    pub position: ml_vec3,
    /// Normal: the emitting side.
    pub normal: ml_vec3,
    /// Radiant intensity along the normal, linear RGB (every channel finite, ≥ 0; acceptance
    /// weighs its luminance).
    pub intensity: ml_rgb,
}

/// An importon: where a camera ray hit (`hit` = 1), with the surface's normal (the side facing
/// the camera), the direction towards the camera `wo` (read for glossy materials) and its
/// material; `hit` = 0 for a camera ray that missed (it contributes 0 but counts).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_importon {
    /// 1: a hit; 0: a miss (the other fields are ignored).
    pub hit: u32,
    /// Hit position.
    pub position: ml_vec3,
    /// Surface normal (any non-zero length).
    pub normal: ml_vec3,
    /// Towards the camera (any non-zero length; unused for Lambert).
    pub wo: ml_vec3,
    /// The surface's material.
    pub material: ml_material,
}

/// Options of `ml_acceptor_create` (`ml_acceptor_options_default` fills them; set `pixels`
/// and `wanted`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ml_acceptor_options {
    /// Pixels P of the image (> 0).
    pub pixels: usize,
    /// VPLs wanted N (> 0).
    pub wanted: usize,
    /// ε, the lowest acceptance probability (> 0, finite; default 0.05, the paper's).
    pub epsilon: f32,
    /// The geometry-term clamp of the host's gather (> 0; +infinity for none, the default).
    pub geometry_clamp: f32,
}

/// The host's visibility between an importon and a VPL: `visible(user_data, importon, vpl)`
/// returns non-zero if the segment between the two points is unoccluded. Must return
/// normally.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct ml_vpl_visibility {
    /// The test (required when the struct is passed).
    pub visible: Option<
        unsafe extern "C" fn(user_data: *mut c_void, importon: ml_vec3, vpl: ml_vec3) -> i32,
    >,
    /// Passed to it.
    pub user_data: *mut c_void,
}

/// One acceptance decision.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_vpl_decision {
    /// 1 if the candidate was accepted.
    pub accepted: u32,
    /// Accepted: its acceptance probability p, in (0, 1] (0 when rejected).
    pub probability: f32,
    /// The VPL to render with, intensity already divided by p (zero when rejected).
    pub vpl: ml_vpl,
}

/// The decisions counted since the acceptor was created or its counts reset.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_accept_stats {
    /// Candidates decided.
    pub candidates: u64,
    /// Candidates accepted.
    pub accepted: u64,
    /// Σ p over the candidates.
    pub sum_probability: f64,
    /// Σ πI over the candidates.
    pub candidate_energy: f64,
    /// Σ πI/p over the accepted VPLs.
    pub accepted_energy: f64,
    /// Σ (πI)² (1/p − 1): the variance of `accepted_energy` given the probabilities.
    pub energy_variance: f64,
    /// accepted / candidates (0 with none).
    pub acceptance_rate: f64,
    /// accepted_energy / candidate_energy (1 in expectation; 1 with no energy).
    pub energy_ratio: f64,
    /// The standard deviation of `energy_ratio`.
    pub energy_ratio_sd: f64,
}

/// A VPL acceptor for one image (opaque): per-thread state (one per thread, their counts
/// added up by the host).
pub struct ml_acceptor {
    acc: VplAcceptor,
}

fn vpl_error(e: VplError, at: &str) -> Error {
    let field = match e.field {
        VplField::Position => format!("{at}.position"),
        VplField::Normal => format!("{at}.normal"),
        VplField::Intensity => format!("{at}.intensity"),
        VplField::Epsilon => "options.epsilon".into(),
        VplField::Pixels => "options.pixels".into(),
        VplField::Wanted => "options.wanted".into(),
        VplField::Xi => "xi".into(),
        VplField::Luminance => at.into(),
        VplField::GeometryClamp => "options.geometry_clamp".into(),
        VplField::ImportonPosition => format!("{at}.position"),
        VplField::ImportonNormal => format!("{at}.normal"),
        VplField::ImportonWo => format!("{at}.wo"),
        VplField::ImportonMaterial => format!("{at}.material"),
        _ => format!("{at} ({})", e.field.name()),
    };
    let what = match (e.field, e.problem) {
        (VplField::Xi, manylights::error::Problem::OutOfRange) => "must be in [0, 1)",
        (VplField::Pixels | VplField::Wanted, _) => "must be positive",
        (VplField::ImportonMaterial, _) => {
            "has a value out of range (albedo, specular in [0, 1], alpha in (0, 1])"
        }
        (_, p) => describe(p),
    };
    Error::invalid(format_args!("{field} {what} (got {})", e.value))
}

fn vpl_of(v: &ml_vpl) -> Vpl {
    Vpl {
        position: v.position.into(),
        normal: v.normal.into(),
        intensity: v.intensity.into(),
    }
}

/// Fills `*out` with the default options (`pixels` = `wanted` = 0: set them).
///
/// Errors: `ML_ERR_NULL` if `out` is NULL.
#[no_mangle]
pub extern "C" fn ml_acceptor_options_default(out: *mut ml_acceptor_options) -> ml_status {
    ffi_fn!("ml_acceptor_options_default", {
        arg::out(out, "out")?.write(ml_acceptor_options {
            pixels: 0,
            wanted: 0,
            epsilon: DEFAULT_EPSILON,
            geometry_clamp: f32::INFINITY,
        });
        Ok(())
    })
}

/// Creates an acceptor for an image of `options->pixels` pixels and `options->wanted` VPLs,
/// with Φ̃_total = 0 (every candidate is accepted until the first `ml_acceptor_update`) and no
/// importons. Free it with `ml_acceptor_free`.
///
/// Errors: `ML_ERR_NULL` (`options`, `out`); `ML_ERR_INVALID_ARGUMENT` (a zero count, a bad ε
/// or clamp).
#[no_mangle]
pub extern "C" fn ml_acceptor_create(
    options: *const ml_acceptor_options,
    out: *mut *mut ml_acceptor,
) -> ml_status {
    ffi_fn!("ml_acceptor_create", {
        let o = arg::get(options, "options")?;
        let out = arg::out(out, "out")?;
        let e = |e| vpl_error(e, "options");
        let acc = VplAcceptor::new(o.pixels, o.wanted)
            .map_err(e)?
            .with_epsilon(o.epsilon)
            .map_err(e)?
            .with_geometry_clamp(o.geometry_clamp)
            .map_err(e)?;
        out.write(arg::into_handle(ml_acceptor { acc }));
        Ok(())
    })
}

/// Frees an acceptor (NULL: nothing).
#[no_mangle]
pub extern "C" fn ml_acceptor_free(acc: *mut ml_acceptor) -> ml_status {
    ffi_fn!("ml_acceptor_free", { arg::free_handle(acc, "acc") })
}

/// Replaces the acceptor's importons by `count` new ones (the paper uses 100 per frame; NULL
/// allowed when `count` is 0). All are checked first: on error the importons are unchanged.
///
/// Errors: `ML_ERR_NULL` (`acc`; `importons` when `count` > 0); `ML_ERR_INVALID_ARGUMENT`
/// naming the importon and field.
#[no_mangle]
pub extern "C" fn ml_acceptor_set_importons(
    acc: *mut ml_acceptor,
    importons: *const ml_importon,
    count: usize,
) -> ml_status {
    ffi_fn!("ml_acceptor_set_importons", {
        let a = arg::get_mut(acc, "acc")?;
        let list = arg::slice(importons, count, "importons")?;
        let mut imps = Importons::with_capacity(count);
        for (j, im) in list.iter().enumerate() {
            let at = || format!("importons[{j}]");
            match im.hit {
                0 => imps.push_miss(),
                1 => {
                    let m = material(&im.material, &|| format!("{}.material", at()))?;
                    let (p, n): (Vec3, Vec3) = (im.position.into(), im.normal.into());
                    let r = match m {
                        Material::Lambert { albedo } => imps.push_diffuse(p, n, albedo.luminance()),
                        m => imps.push(p, n, im.wo.into(), m),
                    };
                    r.map_err(|e| vpl_error(e, &at()))?;
                }
                h => {
                    return Err(Error::invalid(format_args!(
                        "{}.hit must be 0 or 1 (got {h})",
                        at()
                    )))
                }
            }
        }
        *a.acc.importons_mut() = imps;
        Ok(())
    })
}

/// Refines Φ̃_total with the total VPL luminance of the frame just rendered (the sum over its
/// pixels of the VPLs' contribution): Φ̃_total becomes the mean over the frames reported.
///
/// Errors: `ML_ERR_NULL` (`acc`); `ML_ERR_INVALID_ARGUMENT` (NaN, infinite or negative).
#[no_mangle]
pub extern "C" fn ml_acceptor_update(acc: *mut ml_acceptor, frame_luminance: f64) -> ml_status {
    ffi_fn!("ml_acceptor_update", {
        let a = arg::get_mut(acc, "acc")?;
        a.acc
            .update(frame_luminance)
            .map_err(|e| vpl_error(e, "frame_luminance"))
    })
}

/// Sets Φ̃_total directly (e.g. from a separate estimate), restarting the running mean of
/// `ml_acceptor_update` from it.
///
/// Errors: `ML_ERR_NULL` (`acc`); `ML_ERR_INVALID_ARGUMENT` (NaN, infinite or negative).
#[no_mangle]
pub extern "C" fn ml_acceptor_set_total_luminance(acc: *mut ml_acceptor, total: f64) -> ml_status {
    ffi_fn!("ml_acceptor_set_total_luminance", {
        let a = arg::get_mut(acc, "acc")?;
        a.acc
            .set_total_luminance(total)
            .map_err(|e| vpl_error(e, "total"))
    })
}

/// Decides `candidate` with the uniform number `xi` in [0, 1): accepted with probability
/// p = min(Φ̃_i / Φ̃_v + ε, 1) (their Eqn. 3), the accepted VPL's intensity divided by p.
/// `visibility` (NULL: unoccluded) tests importons against the candidate.
///
/// Errors: `ML_ERR_NULL` (`acc`, `candidate`, `visibility->visible` of a non-NULL
/// `visibility`, `out`); `ML_ERR_INVALID_ARGUMENT` (a bad candidate field, `xi` outside
/// [0, 1)).
#[no_mangle]
pub extern "C" fn ml_acceptor_accept(
    acc: *mut ml_acceptor,
    candidate: *const ml_vpl,
    xi: f32,
    visibility: *const ml_vpl_visibility,
    out: *mut ml_vpl_decision,
) -> ml_status {
    ffi_fn!("ml_acceptor_accept", {
        let a = arg::get_mut(acc, "acc")?;
        let c = vpl_of(arg::get(candidate, "candidate")?);
        let vis = arg::opt(visibility, "visibility")?;
        let out = arg::out(out, "out")?;
        let r = match vis {
            None => a.acc.accept(&c, xi),
            Some(v) => {
                let f = v
                    .visible
                    .ok_or_else(|| Error::null("visibility->visible"))?;
                let user = v.user_data;
                // SAFETY: a host callback with its own user data (the caller's contract).
                let mut test = |i: Vec3, p: Vec3| unsafe { f(user, i.into(), p.into()) } != 0;
                a.acc.accept_with(&c, xi, &mut test)
            }
        };
        let d = r.map_err(|e| vpl_error(e, "candidate"))?;
        out.write(match d {
            Some(d) => ml_vpl_decision {
                accepted: 1,
                probability: d.probability,
                vpl: ml_vpl {
                    position: d.vpl.position.into(),
                    normal: d.vpl.normal.into(),
                    intensity: d.vpl.intensity.into(),
                },
            },
            None => ml_vpl_decision::default(),
        });
        Ok(())
    })
}

/// The acceptance probability p of `candidate` in (0, 1], without deciding (`visibility`
/// NULL: unoccluded).
///
/// Errors: `ML_ERR_NULL` (`acc`, `candidate`, `visibility->visible` of a non-NULL
/// `visibility`, `out`); `ML_ERR_INVALID_ARGUMENT` (a bad candidate field).
#[no_mangle]
pub extern "C" fn ml_acceptor_probability(
    acc: *const ml_acceptor,
    candidate: *const ml_vpl,
    visibility: *const ml_vpl_visibility,
    out: *mut f32,
) -> ml_status {
    ffi_fn!("ml_acceptor_probability", {
        let a = arg::get(acc, "acc")?;
        let c = vpl_of(arg::get(candidate, "candidate")?);
        let vis = arg::opt(visibility, "visibility")?;
        let out = arg::out(out, "out")?;
        let p = match vis {
            None => a.acc.probability(&c),
            Some(v) => {
                let f = v
                    .visible
                    .ok_or_else(|| Error::null("visibility->visible"))?;
                let user = v.user_data;
                // SAFETY: a host callback with its own user data (the caller's contract).
                let mut test = |i: Vec3, p: Vec3| unsafe { f(user, i.into(), p.into()) } != 0;
                a.acc.probability_with(&c, &mut test)
            }
        };
        out.write(p.map_err(|e| vpl_error(e, "candidate"))?);
        Ok(())
    })
}

/// The decisions counted since creation or the last `ml_acceptor_reset_stats`.
///
/// Errors: `ML_ERR_NULL` (`acc`, `out`).
#[no_mangle]
pub extern "C" fn ml_acceptor_stats(
    acc: *const ml_acceptor,
    out: *mut ml_accept_stats,
) -> ml_status {
    ffi_fn!("ml_acceptor_stats", {
        let a = arg::get(acc, "acc")?;
        let out = arg::out(out, "out")?;
        let s = a.acc.stats();
        let (ratio, sd) = s.energy_ratio();
        out.write(ml_accept_stats {
            candidates: s.candidates,
            accepted: s.accepted,
            sum_probability: s.sum_probability,
            candidate_energy: s.candidate_energy,
            accepted_energy: s.accepted_energy,
            energy_variance: s.energy_variance,
            acceptance_rate: s.acceptance_rate(),
            energy_ratio: ratio,
            energy_ratio_sd: sd,
        });
        Ok(())
    })
}

/// Zeroes the acceptor's counts.
///
/// Errors: `ML_ERR_NULL` (`acc`).
#[no_mangle]
pub extern "C" fn ml_acceptor_reset_stats(acc: *mut ml_acceptor) -> ml_status {
    ffi_fn!("ml_acceptor_reset_stats", {
        arg::get_mut(acc, "acc")?.acc.reset_stats();
        Ok(())
    })
}
