//! The host's callbacks: uniform numbers (`ml_uniforms`), visibility and first-surface
//! distances (`ml_visibility`), VPL visibility (`ml_vpl_visibility`), the BSDF hits
//! reported (`ml_hit_fn`) and an environment (`ml_environment`), all through one [`Host`] as
//! user data.

use super::grammar::{grey, EnvDesc, Uniforms, Visibility, VplVisibility, MAX_LEN};
use core::ffi::c_void;
use manylights_ffi::*;

/// The user data of every callback: the numbers, answers and distances it hands out (each
/// cycled from its position), and the hits reported to it.
#[derive(Default)]
pub(super) struct Host {
    values: Vec<f32>,
    raw: bool,
    u_at: usize,
    occluded: Vec<bool>,
    occ_at: usize,
    first_hit: Vec<f32>,
    hit_at: usize,
    visible: Vec<bool>,
    vis_at: usize,
    pub(super) hits: Vec<ml_light_hit>,
    env: Env,
    /// Calls of the environment's callbacks.
    pub(super) env_calls: usize,
}

/// The environment's values (see [`EnvDesc`]).
#[derive(Default)]
struct Env {
    radiance: f32,
    pdf: f32,
    zero: bool,
    misses: Vec<bool>,
    at: usize,
}

impl Host {
    pub(super) fn with_uniforms(u: &Uniforms) -> Host {
        Host {
            values: u.values.iter().take(MAX_LEN).map(|f| f.value()).collect(),
            raw: u.raw.set(),
            ..Host::default()
        }
    }

    fn next(&mut self) -> f32 {
        let i = self.u_at;
        self.u_at += 1;
        let v = if self.values.is_empty() {
            0.5
        } else {
            self.values[i % self.values.len()]
        };
        if self.raw {
            v
        } else {
            crate::bounded::unit(crate::bounded::unit(v) + 0.618_034 * i as f32)
        }
    }
}

impl Host {
    /// The environment's sample for `u0`, `u1`: a direction, its radiance and pdf, or none.
    pub(super) fn env_sample(&mut self, u0: f32, u1: f32) -> Option<(ml_vec3, ml_rgb, f32)> {
        self.env_calls += 1;
        let e = &mut self.env;
        let i = e.at;
        e.at += 1;
        if !e.misses.is_empty() && e.misses[i % e.misses.len()] {
            return None;
        }
        let d = if e.zero {
            ml_vec3::default()
        } else {
            let z = 1.0 - 2.0 * u0;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * core::f32::consts::PI * u1;
            ml_vec3 {
                x: r * phi.cos(),
                y: r * phi.sin(),
                z,
            }
        };
        Some((d, grey(e.radiance), e.pdf))
    }

    /// The environment's radiance and pdf of a direction.
    pub(super) fn env_eval(&mut self) -> (ml_rgb, f32) {
        self.env_calls += 1;
        (grey(self.env.radiance), self.env.pdf)
    }
}

pub(super) fn host<'a>(user: *mut c_void) -> &'a mut Host {
    // SAFETY: every callback is registered with a `Host` that outlives the call, and no other
    // reference to it is live while the library runs.
    unsafe { &mut *user.cast::<Host>() }
}

extern "C" fn next_f32(user: *mut c_void) -> f32 {
    host(user).next()
}

extern "C" fn next_f64(user: *mut c_void) -> f64 {
    f64::from(host(user).next())
}

extern "C" fn occluded(user: *mut c_void, _x: ml_vec3, _d: ml_vec3, _t: f32) -> i32 {
    let h = host(user);
    let i = h.occ_at;
    h.occ_at += 1;
    if h.occluded.is_empty() {
        0
    } else {
        i32::from(h.occluded[i % h.occluded.len()])
    }
}

extern "C" fn first_hit(user: *mut c_void, _x: ml_vec3, _d: ml_vec3) -> f32 {
    let h = host(user);
    let i = h.hit_at;
    h.hit_at += 1;
    if h.first_hit.is_empty() {
        f32::INFINITY
    } else {
        h.first_hit[i % h.first_hit.len()]
    }
}

extern "C" fn visible(user: *mut c_void, _i: ml_vec3, _v: ml_vec3) -> i32 {
    let h = host(user);
    let i = h.vis_at;
    h.vis_at += 1;
    if h.visible.is_empty() {
        1
    } else {
        i32::from(h.visible[i % h.visible.len()])
    }
}

pub(super) extern "C" fn each_hit(user: *mut c_void, hit: *const ml_light_hit) {
    // SAFETY: the library passes a valid hit for the call.
    let hit = unsafe { *hit };
    let h = host(user);
    if h.hits.len() < 4096 {
        h.hits.push(hit);
    }
}

pub(super) fn uniforms(u: &Uniforms, user: *mut Host) -> ml_uniforms {
    ml_uniforms {
        next_f32: if u.no_f32.set() { None } else { Some(next_f32) },
        next_f64: if u.f64 { Some(next_f64) } else { None },
        user_data: user.cast(),
    }
}

pub(super) fn visibility(v: &Visibility, h: &mut Host) -> ml_visibility {
    if let Some(o) = &v.occluded {
        h.occluded = o.iter().take(MAX_LEN).copied().collect();
    }
    if let Some(d) = &v.first_hit {
        h.first_hit = d.iter().take(MAX_LEN).map(|f| f.value()).collect();
    }
    ml_visibility {
        occluded: v.occluded.as_ref().map(|_| occluded as _),
        first_hit: v.first_hit.as_ref().map(|_| first_hit as _),
        user_data: (h as *mut Host).cast(),
    }
}

/// The VPL visibility `v` describes, its answers in `h`.
pub(super) fn vpl_visibility(v: &VplVisibility, h: &mut Host) -> ml_vpl_visibility {
    if let Some(answers) = &v.visible {
        h.visible = answers.iter().take(MAX_LEN).copied().collect();
    }
    let f: Option<unsafe extern "C" fn(*mut c_void, ml_vec3, ml_vec3) -> i32> =
        v.visible.as_ref().map(|_| visible as _);
    ml_vpl_visibility {
        visible: f,
        user_data: (h as *mut Host).cast(),
    }
}

extern "C" fn env_sample(
    user: *mut c_void,
    u0: f32,
    u1: f32,
    d: *mut ml_vec3,
    r: *mut ml_rgb,
    pdf: *mut f32,
) -> i32 {
    match host(user).env_sample(u0, u1) {
        Some((dv, rv, pv)) => {
            // SAFETY: the library passes valid out-pointers for the call.
            unsafe {
                *d = dv;
                *r = rv;
                *pdf = pv;
            }
            1
        }
        None => 0,
    }
}

extern "C" fn env_eval(user: *mut c_void, _d: ml_vec3, r: *mut ml_rgb, pdf: *mut f32) {
    let (rv, pv) = host(user).env_eval();
    // SAFETY: the library passes valid out-pointers for the call.
    unsafe {
        *r = rv;
        *pdf = pv;
    }
}

/// The environment `e` describes, its values in `h`.
pub(super) fn environment(e: &EnvDesc, h: &mut Host) -> ml_environment {
    let v = e.radiance.value();
    h.env = Env {
        radiance: if e.raw.set() {
            v
        } else if v.is_finite() {
            v.abs().min(1e4)
        } else {
            1.0
        },
        pdf: if e.raw.set() {
            e.pdf.value()
        } else {
            0.25 * core::f32::consts::FRAC_1_PI
        },
        zero: e.zero.set(),
        misses: e.misses.iter().take(MAX_LEN).copied().collect(),
        at: 0,
    };
    ml_environment {
        sample: if e.no_sample.set() {
            None
        } else {
            Some(env_sample)
        },
        eval: if e.no_eval.set() {
            None
        } else {
            Some(env_eval)
        },
        user_data: (h as *mut Host).cast(),
    }
}
