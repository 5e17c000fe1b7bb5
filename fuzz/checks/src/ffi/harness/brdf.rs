//! The BRDF family (`ml_brdf_*`): directions sampled from a shading point's material, their
//! pdf and value.

use super::{nan32, Harness};
use crate::ffi::buffers::{In, Out};
use crate::ffi::grammar::{v3, Op, Ptr};
use manylights_ffi::*;

impl Harness<'_> {
    /// A BRDF operation: `BrdfSample` or `BrdfPdf`.
    pub(super) fn brdf_op(&mut self, op: &Op) {
        match op {
            Op::BrdfSample { sp, u0, u1, out } => {
                let p = In::one(sp.value.ml(), sp.ptr);
                let mut o = Out::<ml_brdf_draw>::one(*out);
                let s = ml_brdf_sample(p.p(), u0.value(), u1.value(), o.p());
                if self.status("ml_brdf_sample", s, &[&p, &o]) {
                    let d = o.get(0);
                    self.ensure(
                        d.pdf >= 0.0
                            && d.pdf.is_finite()
                            && colour_ok(d.value)
                            && ![d.wi.x, d.wi.y, d.wi.z].iter().any(|v| v.is_nan()),
                        || format!("ml_brdf_sample: {d:?}"),
                    );
                    if d.pdf > 0.0 {
                        self.brdf(&p, d.wi);
                    }
                }
            }
            Op::BrdfPdf { sp, wi, out } => {
                let p = In::one(sp.value.ml(), sp.ptr);
                let mut o = Out::<f32>::one(*out);
                let s = ml_brdf_pdf(p.p(), v3(wi), o.p());
                if self.status("ml_brdf_pdf", s, &[&p, &o]) {
                    let q = o.get(0);
                    self.ensure(q >= 0.0 && !nan32(q), || format!("ml_brdf_pdf: {q}"));
                }
                let mut o = Out::<ml_rgb>::one(*out);
                let s = ml_brdf_eval(p.p(), v3(wi), o.p());
                if self.status("ml_brdf_eval", s, &[&p, &o]) {
                    let f = o.get(0);
                    self.ensure(colour_ok(f), || format!("ml_brdf_eval: {f:?}"));
                }
            }
            _ => unreachable!("{op:?} is no brdf operation"),
        }
    }

    fn brdf(&self, p: &In<ml_shading_point>, wi: ml_vec3) {
        let mut o = Out::<f32>::one(Ptr::Valid);
        let s = ml_brdf_pdf(p.p(), wi, o.p());
        if self.status("ml_brdf_pdf", s, &[&o]) {
            let q = o.get(0);
            self.ensure(q >= 0.0 && !nan32(q), || {
                format!("ml_brdf_pdf: {q} of a sampled direction")
            });
        }
        let mut o = Out::<ml_rgb>::one(Ptr::Valid);
        let s = ml_brdf_eval(p.p(), wi, o.p());
        if self.status("ml_brdf_eval", s, &[&o]) {
            let f = o.get(0);
            self.ensure(colour_ok(f), || {
                format!("ml_brdf_eval: {f:?} of a sampled direction")
            });
        }
    }
}

/// A BRDF value: every channel finite and ≥ 0.
fn colour_ok(c: ml_rgb) -> bool {
    [c.r, c.g, c.b].iter().all(|&v| v >= 0.0 && v.is_finite())
}
