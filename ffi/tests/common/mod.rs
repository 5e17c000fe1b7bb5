//! Helpers the C ABI's Rust test binaries share (each binary uses some of them).
#![allow(dead_code)]

pub mod counting;

use manylights_ffi::*;
use manylights_testkit::SplitMix64 as Rng;
use std::ffi::{c_void, CStr};

/// The last error message of this thread.
pub fn message() -> String {
    // SAFETY: the library's message is a valid NUL-terminated string until its next call.
    unsafe { CStr::from_ptr(ml_last_error_message()) }
        .to_string_lossy()
        .into_owned()
}

/// Asserts `ML_OK`, printing the library's message otherwise.
pub fn ok(s: ml_status) {
    assert_eq!(s, ML_OK, "{}", message());
}

/// Light `i` of a mixed test scene at `p` with emission `e`: a point, a sphere, or a disk
/// facing −z, in turn (radii drawn from `r`).
pub fn mixed_light(i: usize, p: ml_vec3, e: ml_rgb, r: &mut Rng) -> ml_light {
    match i % 3 {
        0 => ml_point_light {
            kind: ml_light_kind::Point as u32,
            position: p,
            intensity: e,
        }
        .into(),
        1 => ml_sphere_light {
            kind: ml_light_kind::Sphere as u32,
            center: p,
            radius: r.range(0.05, 0.4),
            radiance: e,
        }
        .into(),
        _ => ml_disk_light {
            kind: ml_light_kind::Disk as u32,
            center: p,
            normal: ml_vec3 {
                x: 0.0,
                y: 0.0,
                z: -1.0,
            },
            radius: r.range(0.1, 0.5),
            radiance: e,
            two_sided: 0,
        }
        .into(),
    }
}

unsafe extern "C" fn next_f32(user: *mut c_void) -> f32 {
    (*(user as *mut Rng)).f32()
}
unsafe extern "C" fn next_f64(user: *mut c_void) -> f64 {
    (*(user as *mut Rng)).f64()
}

/// The host uniform numbers of `r` through the C callbacks (valid while `r` lives).
pub fn uniforms(r: &mut Rng) -> ml_uniforms {
    ml_uniforms {
        next_f32: Some(next_f32),
        next_f64: Some(next_f64),
        user_data: r as *mut Rng as *mut c_void,
    }
}
