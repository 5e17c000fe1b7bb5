//! The host's callbacks: uniform numbers (`ml_uniforms`), visibility and first-surface
//! distances (`ml_visibility`), VPL visibility (`ml_vpl_visibility`) and the BSDF hits
//! reported (`ml_hit_fn`), all through one [`Host`] as user data; and an environment
//! (`ml_environment`), whose user data is an [`EnvState`] that lives as long as the harness
//! (a tree holds its environment, and its estimators call it after the tree is freed).

use super::grammar::{grey, Drawn, EnvDesc, Uniforms, Visibility, VplVisibility, MAX_LEN};
use core::ffi::c_void;
use manylights_ffi::*;
use std::sync::Mutex;

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

/// The 1/4π pdf of the uniform environment.
pub(super) const UNIFORM_PDF: f32 = 0.25 * core::f32::consts::FRAC_1_PI;

/// An environment as the harness gives it to a build or a load: its irradiance bounds, which
/// callbacks are given, and their values. Uniform over the sphere (the direction from `u0`,
/// `u1`), grey radiance `radiance`, pdf `pdf` from both callbacks; `sample` gives no direction
/// for the numbers whose bit of `misses` is set (a function of the numbers, so that a batch
/// and its single calls get the same samples), and a zero direction when `zero`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct EnvSpec {
    pub(super) bounds: [f32; 6],
    pub(super) sample: bool,
    pub(super) eval: bool,
    pub(super) radiance: f32,
    pub(super) pdf: f32,
    pub(super) zero: bool,
    pub(super) misses: u8,
}

/// A radiance as drawn made sane: its magnitude, at most 1e4 (1 when not finite).
fn sane(v: f32) -> f32 {
    if v.is_finite() {
        v.abs().min(1e4)
    } else {
        1.0
    }
}

impl EnvSpec {
    /// The environment a descriptor of kind 7 (the former environment light) stands for, the
    /// first of a build's lights: bounds its `power` in all six (`two_sided` even) or its
    /// `direction` and `vertex2` (odd); `sample` NULL for a raw `two_sided` 240 to 247, `eval`
    /// NULL for 248 to 255; radiance from `radius`; radiance and pdf (`half_angle`) as drawn
    /// when `falloff_start` is negative or not finite, else sane (pdf 1/4π); a zero direction
    /// when `position.x` is −1; `misses` from the bits of `position.y`.
    pub(super) fn from_light(l: &Drawn) -> EnvSpec {
        let raw = !(l.falloff_start >= 0.0 && l.falloff_start.is_finite());
        let (d, v) = (l.direction, l.vertex2);
        EnvSpec {
            bounds: if l.two_sided % 2 == 0 {
                [l.power; 6]
            } else {
                [d.x, d.y, d.z, v.x, v.y, v.z]
            },
            sample: !(240..248).contains(&l.two_sided),
            eval: l.two_sided < 248,
            radiance: if raw { l.radius } else { sane(l.radius) },
            pdf: if raw { l.half_angle } else { UNIFORM_PDF },
            zero: l.position.x == -1.0,
            misses: (l.position.y.to_bits() >> 15) as u8,
        }
    }

    /// The environment `e` describes (bounds π times the sane radiance, valid even when the
    /// callbacks' values are drawn raw, so that the build succeeds and the bad values reach
    /// the estimates; the kind-7 lights fuzz the bounds).
    pub(super) fn from_desc(e: &EnvDesc) -> EnvSpec {
        let raw = e.raw.set();
        let v = e.radiance.value();
        let radiance = if raw { v } else { sane(v) };
        let mut misses = 0u8;
        for (i, &m) in e.misses.iter().take(8).enumerate() {
            misses |= u8::from(m) << i;
        }
        EnvSpec {
            bounds: [core::f32::consts::PI * sane(v); 6],
            sample: !e.no_sample.set(),
            eval: !e.no_eval.set(),
            radiance,
            pdf: if raw { e.pdf.value() } else { UNIFORM_PDF },
            zero: e.zero.set(),
            misses,
        }
    }

    /// Whether the callbacks' values are valid ones (a finite, non-negative radiance; a
    /// positive, finite pdf; a non-zero direction): no estimate is then an error of theirs.
    pub(super) fn good(&self) -> bool {
        self.radiance.is_finite()
            && self.radiance >= 0.0
            && self.pdf.is_finite()
            && self.pdf > 0.0
            && !self.zero
    }

    /// `sample`'s answer for `u0`, `u1`.
    fn sample_at(&self, u0: f32, u1: f32) -> Option<(ml_vec3, ml_rgb, f32)> {
        let bit = ((u0 * 65536.0) as u32 ^ (u1 * 65536.0) as u32) % 8;
        if self.misses >> bit & 1 == 1 {
            return None;
        }
        let d = if self.zero {
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
        Some((d, grey(self.radiance), self.pdf))
    }
}

/// The user data of an environment's callbacks: its values, and what the callbacks did
/// since the harness last asked ([`EnvState::take`]).
pub(super) struct EnvState {
    pub(super) spec: EnvSpec,
    log: Mutex<EnvLog>,
}

/// What an environment's callbacks did.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct EnvLog {
    /// Calls of either.
    pub(super) calls: usize,
    /// Whether one returned a value the library must reject (see [`EnvSpec::good`]).
    pub(super) bad: bool,
}

impl EnvState {
    pub(super) fn new(spec: EnvSpec) -> Box<EnvState> {
        Box::new(EnvState {
            spec,
            log: Mutex::new(EnvLog::default()),
        })
    }

    /// What the callbacks did since the last call, forgotten.
    pub(super) fn take(&self) -> EnvLog {
        core::mem::take(&mut *self.log.lock().unwrap_or_else(|e| e.into_inner()))
    }

    fn log(&self, bad: bool) {
        let mut l = self.log.lock().unwrap_or_else(|e| e.into_inner());
        l.calls += 1;
        l.bad |= bad;
    }

    /// The environment as the ABI takes it, calling back into `self`.
    pub(super) fn ml(&self) -> ml_environment {
        ml_environment {
            sample: if self.spec.sample {
                Some(env_sample)
            } else {
                None
            },
            eval: if self.spec.eval { Some(env_eval) } else { None },
            user_data: (self as *const EnvState).cast_mut().cast(),
            irradiance_bounds: self.spec.bounds,
        }
    }
}

fn env_state<'a>(user: *mut c_void) -> &'a EnvState {
    // SAFETY: the environments' user data are `EnvState`s the harness keeps until every
    // handle is freed; only shared references are made.
    unsafe { &*user.cast::<EnvState>() }
}

extern "C" fn env_sample(
    user: *mut c_void,
    u0: f32,
    u1: f32,
    d: *mut ml_vec3,
    r: *mut ml_rgb,
    pdf: *mut f32,
) -> i32 {
    let e = env_state(user);
    match e.spec.sample_at(u0, u1) {
        Some((dv, rv, pv)) => {
            e.log(!e.spec.good());
            // SAFETY: the library passes valid out-pointers for the call.
            unsafe {
                *d = dv;
                *r = rv;
                *pdf = pv;
            }
            1
        }
        None => {
            e.log(false);
            0
        }
    }
}

extern "C" fn env_eval(user: *mut c_void, _d: ml_vec3, r: *mut ml_rgb, pdf: *mut f32) {
    let e = env_state(user);
    let s = e.spec;
    // eval's values are checked without the direction: a zero pdf is fine there.
    let bad = !(s.radiance.is_finite() && s.radiance >= 0.0 && s.pdf.is_finite() && s.pdf >= 0.0);
    e.log(bad);
    // SAFETY: the library passes valid out-pointers for the call.
    unsafe {
        *r = grey(s.radiance);
        *pdf = s.pdf;
    }
}
