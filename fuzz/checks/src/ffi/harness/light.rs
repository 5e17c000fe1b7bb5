//! The light family (`ml_light_*`): a point sampled on one light of a tree and its pdf, and
//! batches of them against the single calls.

use super::{message, nan32, same_bits, Harness};
use crate::ffi::buffers::{In, Out};
use crate::ffi::grammar::{indices, numbers, v3, Op, Ptr, MAX_LEN};
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
                let env = self.tree_at(*tree).and_then(|t| t.env);
                let l = light.value(n);
                let x = v3(x);
                let mut o = Out::<ml_light_point>::one(*out);
                Self::env_reset(env);
                let s = ml_light_sample_point(t, l, x, u0.value(), u1.value(), o.p());
                self.env_check("ml_light_sample_point", env, s);
                if self.status("ml_light_sample_point", s, &[&th, &o]) {
                    let lp = o.get(0);
                    self.light_point("ml_light_sample_point", &lp);
                    let on_env = env.filter(|e| e.light == l);
                    if let Some(e) = on_env {
                        self.env_point("ml_light_sample_point", e, &lp);
                    }
                    let mut q = Out::<f32>::one(Ptr::Valid);
                    let s = ml_light_pdf_point(t, l, x, lp.position, q.p());
                    self.env_check("ml_light_pdf_point", env, s);
                    if self.status("ml_light_pdf_point", s, &[&q]) {
                        let q = q.get(0);
                        self.ensure(q >= 0.0 && !nan32(q), || {
                            format!("ml_light_pdf_point: {q} of the sampled point")
                        });
                        // The environment's pdf of its own sample is eval's.
                        if let Some(e) = on_env.filter(|e| e.state().spec.good() && lp.pdf > 0.0) {
                            let want = e.state().spec.pdf;
                            self.ensure(q.to_bits() == want.to_bits(), || {
                                format!("ml_light_pdf_point: {q} of the environment's sample, eval gives {want}")
                            });
                        }
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
                let env = self.tree_at(*tree).and_then(|t| t.env);
                let mut o = Out::<f32>::one(*out);
                Self::env_reset(env);
                let s = ml_light_pdf_point(t, light.value(n), v3(x), v3(point), o.p());
                self.env_check("ml_light_pdf_point", env, s);
                if self.status("ml_light_pdf_point", s, &[&th, &o]) {
                    let q = o.get(0);
                    self.ensure(q >= 0.0 && !nan32(q), || format!("ml_light_pdf_point: {q}"));
                }
            }
            Op::LightSamplePointBatch {
                tree,
                xs,
                lights,
                u0s,
                u1s,
                count,
                ptrs,
            } => {
                let name = "ml_light_sample_point_batch";
                let (t, n, th) = self.tree(*tree);
                let env = self.tree_at(*tree).and_then(|t| t.env);
                let x: Vec<ml_vec3> = xs.iter().take(MAX_LEN).map(v3).collect();
                let len = x.len();
                let ls = indices(lights, len, n);
                let (u0, u1) = (numbers(u0s, len), numbers(u1s, len));
                let all_null = ptrs.iter().all(|&p| p == Ptr::Null);
                let c = count.value(len, all_null);
                let la = In::new(&ls, ptrs[0], c);
                let xa = In::new(&x, ptrs[1], c);
                let u0a = In::new(&u0, ptrs[2], c);
                let u1a = In::new(&u1, ptrs[3], c);
                let mut o = Out::<ml_light_point>::new(len, ptrs[4], c);
                Self::env_reset(env);
                let s = ml_light_sample_point_batch(t, la.p(), xa.p(), u0a.p(), u1a.p(), c, o.p());
                // A bad sample of the environment is found on the way: the points before it
                // are written.
                let partial = self.env_check(name, env, s);
                let single = |j: usize, out: *mut ml_light_point| {
                    Self::env_reset(env);
                    let s = ml_light_sample_point(t, ls[j], x[j], u0[j], u1[j], out);
                    self.env_check("ml_light_sample_point", env, s);
                    s
                };
                let single = &single;
                let ok = if partial {
                    self.status(name, s, &[&th, &la, &xa, &u0a, &u1a])
                } else {
                    self.status(name, s, &[&th, &la, &xa, &u0a, &u1a, &o])
                };
                if !ok {
                    // Every input checked first: with valid arrays, some single call fails.
                    if c > 0 && ptrs.iter().all(|&p| p == Ptr::Valid) {
                        let fails = (0..c).any(|j| {
                            let mut one = Out::<ml_light_point>::one(Ptr::Valid);
                            single(j, one.p()) != ML_OK
                        });
                        self.ensure(fails, || {
                            format!(
                                "{name}: {s} ({}), yet every single call succeeds",
                                message()
                            )
                        });
                    }
                    return;
                }
                self.ensure(o.untouched_from(c), || {
                    format!("{name}: wrote past the count")
                });
                for (j, &l) in ls.iter().enumerate().take(c) {
                    let r = o.get(j);
                    self.light_point(name, &r);
                    if let Some(e) = env.filter(|e| e.light == l) {
                        self.env_point(name, e, &r);
                    }
                    let mut one = Out::<ml_light_point>::one(Ptr::Valid);
                    let s = single(j, one.p());
                    self.ensure(s == ML_OK, || {
                        format!(
                            "{name}: element {j} succeeded, its single call gave {s} ({})",
                            message()
                        )
                    });
                    let q = one.get(0);
                    self.ensure(same_bits(&r, &q), || {
                        format!("{name}: element {j} is {r:?}, its single call {q:?}")
                    });
                }
            }
            _ => unreachable!("{op:?} is no light operation"),
        }
    }
}
