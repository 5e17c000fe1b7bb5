//! The library-wide functions: the `*_default` functions, `ml_version` and `ml_status_name`.

use super::Harness;
use crate::ffi::buffers::Out;
use crate::ffi::grammar::Ptr;
use core::ffi::c_char;
use manylights_ffi::*;
use std::ffi::CStr;

impl Harness<'_> {
    /// The `*_default` functions, `ml_version` and `ml_status_name(status)`, each `out` passed
    /// as `out`.
    pub(super) fn defaults(&self, out: Ptr, status: i32) {
        let mut o = Out::<ml_build_options>::one(out);
        let s = ml_build_options_default(o.p());
        if self.status("ml_build_options_default", s, &[&o]) {
            let b = o.get(0).buckets;
            self.ensure(b == 0 || (12..=64).contains(&b), || format!("buckets {b}"));
        }
        let mut o = Out::<ml_bl_cut_options>::one(out);
        let s = ml_bl_cut_options_default(o.p());
        if self.status("ml_bl_cut_options_default", s, &[&o]) {
            let c = o.get(0);
            self.ensure(
                c.delta >= 0.0
                    && (4..=64).contains(&c.max_size)
                    && (0.0..=1.0).contains(&c.split_sin),
                || format!("{c:?}"),
            );
        }
        let mut o = Out::<ml_split_cut_options>::one(out);
        let s = ml_split_cut_options_default(o.p());
        if self.status("ml_split_cut_options_default", s, &[&o]) {
            let c = o.get(0);
            self.ensure(c.threshold >= 0.0 && (4..=64).contains(&c.max_size), || {
                format!("{c:?}")
            });
        }
        let mut o = Out::<ml_direct_params>::one(out);
        let s = ml_direct_params_default(o.p());
        if self.status("ml_direct_params_default", s, &[&o]) {
            let p = o.get(0);
            self.ensure(
                (1..=64).contains(&p.n_max) && (1..=64).contains(&p.bl_light_samples),
                || format!("{p:?}"),
            );
        }
        let mut o = Out::<ml_acceptor_options>::one(out);
        let s = ml_acceptor_options_default(o.p());
        if self.status("ml_acceptor_options_default", s, &[&o]) {
            let a = o.get(0);
            self.ensure(a.epsilon > 0.0 && a.geometry_clamp > 0.0, || {
                format!("{a:?}")
            });
        }
        let mut v = [
            Out::<u32>::one(out),
            Out::<u32>::one(Ptr::Valid),
            Out::<u32>::one(Ptr::Valid),
        ];
        let [a, b, c] = &mut v;
        let s = ml_version(a.p(), b.p(), c.p());
        if self.status("ml_version", s, &[a, b, c]) {
            let got = (a.get(0), b.get(0), c.get(0));
            let want = (ML_VERSION_MAJOR, ML_VERSION_MINOR, ML_VERSION_PATCH);
            self.ensure(got == want, || format!("ml_version: {got:?}"));
        }
        let mut o = Out::<*const c_char>::one(out);
        let s = ml_status_name(status, o.p());
        if self.status("ml_status_name", s, &[&o]) {
            // SAFETY: a static NUL-terminated string.
            let name = unsafe { CStr::from_ptr(o.get(0)) }.to_string_lossy();
            let known = (ML_OK..=ML_ERR_INTERNAL).contains(&status);
            self.ensure(
                if known {
                    name.starts_with("ML_")
                } else {
                    name == "unknown"
                },
                || format!("ml_status_name({status}): {name}"),
            );
        }
    }
}
