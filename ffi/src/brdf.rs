//! The core's BRDFs (Lambert, GGX, plastic) in world space: sampling, pdf and value, for hosts
//! that take BSDF samples with the same lobes and pdfs as the estimators.

use crate::arg;
use crate::error::{ml_status, Error, Result};
use crate::ffi_fn;
use crate::types::{direction3, ml_rgb, ml_shading_point, ml_vec3, shading_point, unit};
use glam::Vec3;
use manylights::{Brdf, Frame, Material};

/// A direction sampled from a BRDF: `pdf = 0` (and `wi`, `value` zero) when the draw gives no
/// direction (the view or the sampled direction is below the surface). The direction and its
/// pdf follow the material's luminance (as the estimators' BSDF samples do); `value` is f in
/// colour.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_brdf_draw {
    /// Unit direction away from the surface, world space.
    pub wi: ml_vec3,
    /// Its solid-angle pdf (> 0 and finite; 0: no direction).
    pub pdf: f32,
    /// The BRDF value f(ωo, ωi) per channel of linear RGB (not multiplied by cos θi): for an
    /// RGB albedo, each channel's own f.
    pub value: ml_rgb,
}

/// `wi` in the local frame: a direction already of unit length (to f32 rounding, as the
/// estimators' light points are) is taken as it is, so that its value and pdf are the ones
/// the one-call estimator computes for it; any other is normalised first.
fn to_local(frame: &Frame, wi: Vec3) -> Vec3 {
    let l2 = wi.length_squared();
    let w = if (l2 - 1.0).abs() <= 4.0 * f32::EPSILON {
        wi
    } else {
        wi.normalize()
    };
    frame.to_local(w)
}

/// The local frame (normal = +z), ωo in it and the material of a checked shading point.
fn local(sp: *const ml_shading_point) -> Result<(Frame, Vec3, Material)> {
    let s = shading_point(arg::get(sp, "sp")?, &|| "sp".into())?;
    let frame =
        Frame::from_normal(s.normal).ok_or_else(|| Error::invalid("sp.normal has zero length"))?;
    let wo = frame.to_local(s.wo.normalize());
    Ok((frame, wo, s.material))
}

/// Samples the material of `sp` (GGX through its visible normals, Heitz 2018; Lambert by
/// cosine; plastic by choosing a lobe in proportion to its weight) with `u0`, `u1` in [0, 1).
/// The local frame has `sp->normal` as +z (as the estimators use it). With a BSDF step's `u0`,
/// `u1` the draw is the one-call estimator's BSDF sample: the same direction (here in world
/// space), its pdf and value (in every channel) bit for bit.
///
/// Errors: `ML_ERR_NULL` (`sp`, `out`); `ML_ERR_INVALID_ARGUMENT` (a bad shading point, `u0`
/// or `u1` outside [0, 1)).
#[no_mangle]
pub extern "C" fn ml_brdf_sample(
    sp: *const ml_shading_point,
    u0: f32,
    u1: f32,
    out: *mut ml_brdf_draw,
) -> ml_status {
    ffi_fn!("ml_brdf_sample", {
        let out = arg::out(out, "out")?;
        let (frame, wo, m) = local(sp)?;
        let u = [unit(u0, &|| "u0".into())?, unit(u1, &|| "u1".into())?];
        let d = match m.sample(wo, u) {
            Some((wi, pdf)) => ml_brdf_draw {
                wi: frame.to_world(wi).normalize().into(),
                pdf,
                value: m.eval_rgb(wo, wi).into(),
            },
            None => ml_brdf_draw::default(),
        };
        out.write(d);
        Ok(())
    })
}

/// The solid-angle pdf with which `ml_brdf_sample` returns the direction `wi` (world space,
/// any non-zero length; 0 below the surface). For a light step's `point.direction` it is, bit
/// for bit, the BSDF pdf the one-call estimator uses. For the `wi` of an `ml_brdf_sample` draw
/// it is recomputed after the draw's round trip through the shading frame, so it differs from
/// the draw's `pdf` by f32 rounding (about 1e-6 relative for α ≥ 0.4, up to about 1e-4 for
/// the sharpest lobes, α near `ML_MIN_ALPHA`): pass the draw's own `pdf` to
/// `ml_estimator_bsdf_hits`, as the one call does.
///
/// Errors: `ML_ERR_NULL` (`sp`, `out`); `ML_ERR_INVALID_ARGUMENT` (a bad shading point, a zero
/// or non-finite `wi`).
#[no_mangle]
pub extern "C" fn ml_brdf_pdf(
    sp: *const ml_shading_point,
    wi: ml_vec3,
    out: *mut f32,
) -> ml_status {
    ffi_fn!("ml_brdf_pdf", {
        let out = arg::out(out, "out")?;
        let (frame, wo, m) = local(sp)?;
        let wi = direction3(wi, &|| "wi".into())?;
        out.write(m.pdf(wo, to_local(&frame, wi)));
        Ok(())
    })
}

/// The BRDF value f(ωo, ωi) of `sp`'s material for the direction `wi` (world space, any
/// non-zero length; 0 below the surface), per channel of linear RGB: channel c is f with the
/// albedo's channel c (the specular lobe is the same in every channel). For a light step's
/// `point.direction`, bit for bit the f of the one-call estimator in each channel.
///
/// Errors: `ML_ERR_NULL` (`sp`, `out`); `ML_ERR_INVALID_ARGUMENT` (a bad shading point, a zero
/// or non-finite `wi`).
#[no_mangle]
pub extern "C" fn ml_brdf_eval(
    sp: *const ml_shading_point,
    wi: ml_vec3,
    out: *mut ml_rgb,
) -> ml_status {
    ffi_fn!("ml_brdf_eval", {
        let out = arg::out(out, "out")?;
        let (frame, wo, m) = local(sp)?;
        let wi = direction3(wi, &|| "wi".into())?;
        out.write(m.eval_rgb(wo, to_local(&frame, wi)).into());
        Ok(())
    })
}
