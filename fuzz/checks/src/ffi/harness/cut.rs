//! The cut family (`ml_cut_*`): cuts created, built (BRDF-oriented or split) on a tree,
//! their size and IB, samples checked against the queried pmfs, freed.

use super::{nan32, Cut, Harness};
use crate::ffi::buffers::{In, Out};
use crate::ffi::grammar::{numbers, Count, Op, Ptr, MAX_LEN};
use manylights_ffi::*;

impl Harness<'_> {
    /// A cut operation: `CutCreate` to `CutPmfIn`.
    pub(super) fn cut_op(&mut self, op: &Op) {
        match op {
            Op::CutCreate { out } => {
                let mut o = Out::<*mut ml_cut>::one(*out);
                let s = ml_cut_create(o.p());
                if self.status("ml_cut_create", s, &[&o]) {
                    let p = o.get(0);
                    self.ensure(!p.is_null(), || "ml_cut_create: NULL".into());
                    self.cuts.push(Cut {
                        p,
                        built: None,
                        bl: false,
                    });
                }
            }
            Op::CutFree(h) => {
                let (i, p, ch) = self.cut(*h);
                let s = ml_cut_free(p);
                if self.status("ml_cut_free", s, &[&ch]) {
                    if let Some(i) = i {
                        self.cuts.swap_remove(i);
                    }
                }
            }
            Op::CutBuild {
                cut,
                tree,
                sp,
                options,
            } => {
                let (ci, c, ch) = self.cut(*cut);
                let (t, n, th) = self.tree(*tree);
                let p = In::one(sp.value.ml(), sp.ptr);
                let opts = In::opt(options.as_ref().map(|o| (o.value.ml(), o.ptr)));
                let s = ml_cut_build_bl(c, t, p.p(), opts.p());
                if self.status("ml_cut_build_bl", s, &[&ch, &th, &p, &opts]) {
                    self.built(ci, n, true);
                }
            }
            Op::CutBuildSplit {
                cut,
                tree,
                point,
                options,
            } => {
                let (ci, c, ch) = self.cut(*cut);
                let (t, n, th) = self.tree(*tree);
                let p = In::one(point.value.ml(), point.ptr);
                let opts = In::opt(options.as_ref().map(|o| (o.value.ml(), o.ptr)));
                let s = ml_cut_build_split(c, t, p.p(), opts.p());
                if self.status("ml_cut_build_split", s, &[&ch, &th, &p, &opts]) {
                    self.built(ci, n, false);
                }
            }
            Op::CutSize { cut, out } => {
                let (ci, c, ch) = self.cut(*cut);
                let built = ci.and_then(|i| self.cuts[i].built);
                let mut o = Out::<usize>::one(*out);
                let s = ml_cut_size(c, o.p());
                if s == ML_ERR_STATE {
                    self.ensure(built.is_none(), || {
                        "ml_cut_size: a built cut unbuilt".into()
                    });
                }
                if self.status("ml_cut_size", s, &[&ch, &o]) {
                    let k = o.get(0);
                    self.ensure(built.is_none_or(|(_, size)| size == k), || {
                        format!("ml_cut_size: {k}, then {built:?}")
                    });
                }
                // IB(x) answers for a BRDF-oriented cut, the largest normalised variance for a
                // split cut; each is ML_ERR_STATE on the other kind.
                let bl = ci.map(|i| self.cuts[i].bl);
                let mut o = Out::<f32>::one(*out);
                let s = ml_cut_ib(c, o.p());
                if self.status("ml_cut_ib", s, &[&ch, &o]) {
                    let ib = o.get(0);
                    self.ensure(ib >= 0.0 && !nan32(ib), || format!("ml_cut_ib: {ib}"));
                    self.ensure(bl != Some(false), || "ml_cut_ib of a split cut".into());
                } else if built.is_some() && bl == Some(true) && *out == Ptr::Valid {
                    self.fail(format_args!("ml_cut_ib of a BRDF-oriented cut: {s}"));
                }
                let mut o = Out::<f32>::one(*out);
                let s = ml_cut_max_variance(c, o.p());
                if self.status("ml_cut_max_variance", s, &[&ch, &o]) {
                    let v = o.get(0);
                    self.ensure(v >= 0.0 && !nan32(v), || {
                        format!("ml_cut_max_variance: {v}")
                    });
                    self.ensure(bl != Some(true), || {
                        "ml_cut_max_variance of a BRDF-oriented cut".into()
                    });
                } else if built.is_some() && bl == Some(false) && *out == Ptr::Valid {
                    self.fail(format_args!("ml_cut_max_variance of a split cut: {s}"));
                }
            }
            Op::CutSample { cut, u, out } => {
                let (ci, c, ch) = self.cut(*cut);
                let n = ci.and_then(|i| self.cuts[i].built).map_or(0, |b| b.0);
                let mut o = Out::<ml_sampled_light>::one(*out);
                let s = ml_cut_sample(c, u.value(), o.p());
                if self.status("ml_cut_sample", s, &[&ch, &o]) {
                    let r = o.get(0);
                    self.sample("ml_cut_sample", r, n);
                    self.queried("ml_cut_pmf", r, |l, q| ml_cut_pmf(c, l, q));
                }
            }
            Op::CutPmf { cut, light, out } => {
                let (ci, c, ch) = self.cut(*cut);
                let n = ci.and_then(|i| self.cuts[i].built).map_or(0, |b| b.0);
                let mut o = Out::<f32>::one(*out);
                let s = ml_cut_pmf(c, light.value(n), o.p());
                if self.status("ml_cut_pmf", s, &[&ch, &o]) {
                    self.pmf("ml_cut_pmf", o.get(0));
                }
            }
            Op::CutSampleClusters {
                cut,
                us,
                count,
                ptrs,
            } => {
                let (ci, c, ch) = self.cut(*cut);
                let built = ci.and_then(|i| self.cuts[i].built);
                let n = built.map_or(0, |b| b.0);
                // Buffers of at least the cut's size, so that `All` passes exactly it.
                let len = us.len().min(MAX_LEN + 1).max(built.map_or(0, |b| b.1));
                let us = numbers(us, len);
                let all_null = ptrs.iter().all(|&p| p == Ptr::Null);
                let k = match (count, built) {
                    (Count::All, Some((_, size))) => size,
                    _ => count.value(len, all_null),
                };
                let u = In::new(&us, ptrs[0], k);
                let mut o = Out::<ml_sampled_light>::new(len, ptrs[1], k);
                let s = ml_cut_sample_clusters(c, u.p(), k, o.p());
                if self.status("ml_cut_sample_clusters", s, &[&ch, &u, &o]) {
                    for i in 0..k {
                        let r = o.get(i);
                        self.sample("ml_cut_sample_clusters", r, n);
                        if r.light == ML_NO_LIGHT {
                            continue;
                        }
                        // The light's cluster is the one that gave it, with the same pmf (a
                        // light at infinity: its own cluster, pmf 1).
                        let (mut kc, mut p) = (ML_NO_CLUSTER, f32::NAN);
                        let s = ml_cut_pmf_in(c, r.light, &mut kc, &mut p);
                        self.ensure(
                            s == ML_OK && kc as usize == i && p.to_bits() == r.pmf.to_bits(),
                            || {
                                format!(
                                    "ml_cut_sample_clusters: cluster {i} gave {r:?}, \
                                     ml_cut_pmf_in: {s}, cluster {kc}, pmf {p}"
                                )
                            },
                        );
                    }
                    self.ensure(o.untouched_from(k), || {
                        "ml_cut_sample_clusters: wrote past the count".into()
                    });
                }
            }
            Op::CutPmfIn { cut, light, ptrs } => {
                let (ci, c, ch) = self.cut(*cut);
                let built = ci.and_then(|i| self.cuts[i].built);
                let n = built.map_or(0, |b| b.0);
                let mut k = Out::<u32>::one(ptrs[0]);
                let mut p = Out::<f32>::one(ptrs[1]);
                let s = ml_cut_pmf_in(c, light.value(n), k.p(), p.p());
                if self.status("ml_cut_pmf_in", s, &[&ch, &k, &p]) {
                    let (k, p) = (k.get(0), p.get(0));
                    self.pmf("ml_cut_pmf_in", p);
                    let size = built.map_or(usize::MAX, |b| b.1);
                    self.ensure(
                        (k == ML_NO_CLUSTER && p == 0.0) || (k as usize) < size,
                        || format!("ml_cut_pmf_in: cluster {k} of {size}, pmf {p}"),
                    );
                }
            }
            _ => unreachable!("{op:?} is no cut operation"),
        }
    }

    fn built(&mut self, ci: Option<usize>, n: usize, bl: bool) {
        let Some(i) = ci else { return };
        let mut o = Out::<usize>::one(Ptr::Valid);
        let s = ml_cut_size(self.cuts[i].p, o.p());
        self.ensure(s == ML_OK, || format!("ml_cut_size of a built cut: {s}"));
        let size = o.get(0);
        self.ensure(size <= ML_CUT_CAPACITY, || {
            format!("a cut of {size} clusters")
        });
        self.cuts[i].built = Some((n, size));
        self.cuts[i].bl = bl;
    }
}
