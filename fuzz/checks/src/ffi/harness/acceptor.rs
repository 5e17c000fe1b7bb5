//! The acceptor family (`ml_acceptor_*`): VPL acceptors created from options, given
//! importons and the total luminance, candidates accepted or their probability, statistics,
//! freed.

use super::Harness;
use crate::ffi::buffers::{In, Out};
use crate::ffi::grammar::{Importon, Op, Ptr, F, MAX_LEN};
use crate::ffi::host::{vpl_visibility, Host};
use manylights_ffi::*;

impl Harness<'_> {
    /// An acceptor operation: `AcceptorCreate` to `AcceptorStats`.
    pub(super) fn acceptor_op(&mut self, op: &Op) {
        match op {
            Op::AcceptorCreate { options, out } => {
                let mut d = Out::<ml_acceptor_options>::one(Ptr::Valid);
                let s = ml_acceptor_options_default(d.p());
                if !self.status("ml_acceptor_options_default", s, &[&d]) {
                    return;
                }
                let mut o = d.get(0);
                let v = &options.value;
                o.pixels = usize::from(v.pixels);
                o.wanted = usize::from(v.wanted);
                o.epsilon = match v.epsilon {
                    F::Unit(0) => o.epsilon,
                    e => e.value(),
                };
                if let Some(c) = v.geometry_clamp {
                    o.geometry_clamp = c.value();
                }
                let opts = In::one(o, options.ptr);
                let mut out = Out::<*mut ml_acceptor>::one(*out);
                let s = ml_acceptor_create(opts.p(), out.p());
                if self.status("ml_acceptor_create", s, &[&opts, &out]) {
                    let p = out.get(0);
                    self.ensure(!p.is_null(), || "ml_acceptor_create: NULL".into());
                    self.accs.push(p);
                }
            }
            Op::AcceptorFree(h) => {
                let (i, p, ah) = self.acc(*h);
                let s = ml_acceptor_free(p);
                if self.status("ml_acceptor_free", s, &[&ah]) {
                    if let Some(i) = i {
                        self.accs.swap_remove(i);
                    }
                }
            }
            Op::SetImportons {
                acc,
                importons,
                count,
                ptr: ip,
            } => {
                let (_, a, ah) = self.acc(*acc);
                let list: Vec<ml_importon> =
                    importons.iter().take(MAX_LEN).map(Importon::ml).collect();
                let c = count.value(list.len(), *ip == Ptr::Null);
                let arr = In::new(&list, *ip, c);
                let s = ml_acceptor_set_importons(a, arr.p(), c);
                self.status("ml_acceptor_set_importons", s, &[&ah, &arr]);
            }
            Op::Luminance { acc, set, value } => {
                let (_, a, ah) = self.acc(*acc);
                let v = match value {
                    Ok(f) => f64::from(f.value()),
                    Err(k) => 10f64.powf(f64::from(*k) / 10.0),
                };
                if *set {
                    let s = ml_acceptor_set_total_luminance(a, v);
                    self.status("ml_acceptor_set_total_luminance", s, &[&ah]);
                } else {
                    let s = ml_acceptor_update(a, v);
                    self.status("ml_acceptor_update", s, &[&ah]);
                }
            }
            Op::Accept {
                acc,
                probability,
                candidate,
                xi,
                visibility: vis,
                out,
            } => {
                let (_, a, ah) = self.acc(*acc);
                let c = In::one(candidate.value.ml(), candidate.ptr);
                let mut h = Host::default();
                let v = In::opt(
                    vis.as_ref()
                        .map(|v| (vpl_visibility(&v.value, &mut h), v.ptr)),
                );
                if *probability {
                    let mut o = Out::<f32>::one(*out);
                    let s = ml_acceptor_probability(a, c.p(), v.p(), o.p());
                    if self.status("ml_acceptor_probability", s, &[&ah, &c, &v, &o]) {
                        let p = o.get(0);
                        self.ensure(p > 0.0 && p <= 1.0, || {
                            format!("ml_acceptor_probability: {p}")
                        });
                    }
                } else {
                    let mut o = Out::<ml_vpl_decision>::one(*out);
                    let s = ml_acceptor_accept(a, c.p(), xi.value(), v.p(), o.p());
                    if self.status("ml_acceptor_accept", s, &[&ah, &c, &v, &o]) {
                        let d = o.get(0);
                        let ok = match d.accepted {
                            0 => d == ml_vpl_decision::default(),
                            1 => {
                                let f = [
                                    d.vpl.position.x,
                                    d.vpl.position.y,
                                    d.vpl.position.z,
                                    d.vpl.normal.x,
                                    d.vpl.normal.y,
                                    d.vpl.normal.z,
                                ];
                                d.probability > 0.0
                                    && d.probability <= 1.0
                                    && f.iter().all(|v| v.is_finite())
                                    && super::colour_ok(d.vpl.intensity)
                            }
                            _ => false,
                        };
                        self.ensure(ok, || format!("ml_acceptor_accept: {d:?}"));
                    }
                }
            }
            Op::AcceptorStats { acc, reset, out } => {
                let (_, a, ah) = self.acc(*acc);
                if *reset {
                    let s = ml_acceptor_reset_stats(a);
                    self.status("ml_acceptor_reset_stats", s, &[&ah]);
                }
                let mut o = Out::<ml_accept_stats>::one(*out);
                let s = ml_acceptor_stats(a, o.p());
                if self.status("ml_acceptor_stats", s, &[&ah, &o]) {
                    let st = o.get(0);
                    let f = [
                        st.sum_probability,
                        st.candidate_energy,
                        st.accepted_energy,
                        st.energy_variance,
                        st.acceptance_rate,
                        st.energy_ratio,
                        st.energy_ratio_sd,
                    ];
                    self.ensure(
                        st.accepted <= st.candidates && f.iter().all(|v| !v.is_nan() && *v >= 0.0),
                        || format!("ml_acceptor_stats: {st:?}"),
                    );
                }
            }
            _ => unreachable!("{op:?} is no acceptor operation"),
        }
    }
}
