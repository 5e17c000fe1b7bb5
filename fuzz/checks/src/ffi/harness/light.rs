//! The light family (`ml_light_*`): a point sampled on one light of a tree and its pdf.

use super::{nan32, Harness};
use crate::ffi::buffers::Out;
use crate::ffi::grammar::{v3, Op, Ptr};
use manylights_ffi::*;

impl Harness<'_> {
    /// A light operation: `LightSamplePoint` or `LightPdfPoint`.
    pub(super) fn light_op(&mut self, op: &Op) {
        match op {
            Op::LightSamplePoint {
                tree,
                light,
                x,
                u0,
                u1,
                out,
            } => {
                let (t, n, th) = self.tree(*tree);
                let l = light.value(n);
                let x = v3(x);
                let mut o = Out::<ml_light_point>::one(*out);
                let s = ml_light_sample_point(t, l, x, u0.value(), u1.value(), o.p());
                if self.status("ml_light_sample_point", s, &[&th, &o]) {
                    let lp = o.get(0);
                    self.light_point("ml_light_sample_point", &lp);
                    let mut q = Out::<f32>::one(Ptr::Valid);
                    let s = ml_light_pdf_point(t, l, x, lp.position, q.p());
                    if self.status("ml_light_pdf_point", s, &[&q]) {
                        let q = q.get(0);
                        self.ensure(q >= 0.0 && !nan32(q), || {
                            format!("ml_light_pdf_point: {q} of the sampled point")
                        });
                    }
                }
            }
            Op::LightPdfPoint {
                tree,
                light,
                x,
                point,
                out,
            } => {
                let (t, n, th) = self.tree(*tree);
                let mut o = Out::<f32>::one(*out);
                let s = ml_light_pdf_point(t, light.value(n), v3(x), v3(point), o.p());
                if self.status("ml_light_pdf_point", s, &[&th, &o]) {
                    let q = o.get(0);
                    self.ensure(q >= 0.0 && !nan32(q), || format!("ml_light_pdf_point: {q}"));
                }
            }
            _ => unreachable!("{op:?} is no light operation"),
        }
    }
}
