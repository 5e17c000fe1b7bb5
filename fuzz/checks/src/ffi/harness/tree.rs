//! The tree family (`ml_tree_*`): built from light descriptors or loaded from (edited)
//! serialized bytes, serialized, its statistics, freed; TL and BL samples checked against the
//! queried pmfs, and the batches against the single calls.

use super::{message, pick, Harness, Tree};
use crate::ffi::buffers::{HandleArg, In, Out};
use crate::ffi::grammar::{
    indices, numbers, Bytes, Capacity, Count, Handle, Light, Op, Ptr, Sp, TlPoint, MAX_LEN,
};
use manylights_ffi::*;
use std::fmt;

impl Harness<'_> {
    /// A tree operation: `Build` to `PmfBlBatch`.
    pub(super) fn tree_op(&mut self, op: &Op) {
        match op {
            Op::Build {
                lights,
                count,
                ptr: lp,
                options,
                out,
            } => {
                let ls: Vec<ml_light> = lights.iter().take(MAX_LEN).map(Light::ml).collect();
                let c = count.value(ls.len(), *lp == Ptr::Null);
                let arr = In::new(&ls, *lp, c);
                let opts = In::opt(options.as_ref().map(|o| {
                    (
                        ml_build_options {
                            buckets: u32::from(o.value),
                        },
                        o.ptr,
                    )
                }));
                let mut o = Out::<*mut ml_tree>::one(*out);
                let s = ml_tree_build(arr.p(), c, opts.p(), o.p());
                if self.status("ml_tree_build", s, &[&arr, &opts, &o]) {
                    self.add_tree(o.get(0), Some(c));
                }
            }
            Op::Load {
                bytes,
                count,
                ptr: bp,
                out,
            } => {
                let (data, pristine) = match bytes {
                    Bytes::Serialized { edits, keep } => {
                        let Some(mut b) = self.serialized.clone() else {
                            return;
                        };
                        let mut changed = false;
                        for &(i, x) in edits.iter().take(MAX_LEN) {
                            if !b.is_empty() && x != 0 {
                                let n = b.len();
                                b[usize::from(i) % n] ^= x;
                                changed = true;
                            }
                        }
                        if let Some(k) = keep {
                            if usize::from(*k) < b.len() {
                                b.truncate(usize::from(*k));
                                changed = true;
                            }
                        }
                        (b, !changed)
                    }
                    Bytes::Raw(b) => (b.clone(), false),
                };
                // Bytes have no alignment: a misaligned pointer is a valid one.
                let bp = if *bp == Ptr::Null {
                    Ptr::Null
                } else {
                    Ptr::Valid
                };
                let c = count.value(data.len(), bp == Ptr::Null);
                let arr = In::new(&data, bp, c);
                let mut o = Out::<*mut ml_tree>::one(*out);
                let s = ml_tree_load(arr.p(), c, o.p());
                let ok = self.status("ml_tree_load", s, &[&arr, &o]);
                if pristine && bp == Ptr::Valid && *out == Ptr::Valid && c == data.len() {
                    self.ensure(ok, || {
                        format!("ml_tree_load of serialized bytes: {s} ({})", message())
                    });
                }
                if ok {
                    self.add_tree(o.get(0), None);
                }
            }
            Op::Serialize {
                tree,
                capacity,
                buffer,
                written,
            } => {
                let (t, _, th) = self.tree(*tree);
                let mut size = Out::<usize>::one(Ptr::Valid);
                let s = ml_tree_serialized_size(t, size.p());
                if !self.status("ml_tree_serialized_size", s, &[&th, &size]) {
                    return;
                }
                let need = size.get(0);
                let cap = match capacity {
                    Capacity::Exact => need,
                    Capacity::Less(k) => need.saturating_sub(usize::from(*k).max(1)),
                    Capacity::More(k) => need + usize::from(*k),
                    Capacity::Zero => 0,
                };
                let mut buf = Out::<u8>::new(cap, *buffer, cap);
                let mut w = Out::<usize>::one(*written);
                let s = ml_tree_serialize(t, buf.p(), cap, w.p());
                if s == ML_ERR_BUFFER_TOO_SMALL {
                    self.ensure(cap < need, || {
                        format!("ml_tree_serialize: too small with {cap} ≥ {need}")
                    });
                }
                if self.status("ml_tree_serialize", s, &[&th, &buf, &w]) {
                    let n = w.get(0);
                    self.ensure(n == need && n <= cap, || {
                        format!("ml_tree_serialize: wrote {n} of {need} into {cap}")
                    });
                    self.ensure(buf.untouched_from(n), || {
                        "ml_tree_serialize: wrote past its bytes".into()
                    });
                    self.serialized = Some((0..n).map(|i| buf.get(i)).collect());
                }
            }
            Op::Stats { tree, out } => {
                let (t, n, th) = self.tree(*tree);
                let mut o = Out::<ml_tree_statistics>::one(*out);
                let s = ml_tree_stats(t, o.p());
                if self.status("ml_tree_stats", s, &[&th, &o]) {
                    let st = o.get(0);
                    self.ensure(
                        st.lights == n
                            && st.sampled_lights <= st.lights
                            && st.has_lights <= 1
                            && st.total_energy >= 0.0
                            && st.total_energy.is_finite(),
                        || format!("ml_tree_stats: {st:?} of a tree of {n} lights"),
                    );
                }
            }
            Op::FreeTree(h) => {
                let ptrs: Vec<_> = self.trees.iter().map(|t| t.p).collect();
                let (i, p, mis) = pick(*h, &ptrs);
                let s = ml_tree_free(p);
                if self.status("ml_tree_free", s, &[&HandleArg(mis)]) {
                    if let Some(i) = i {
                        self.trees.swap_remove(i);
                    }
                }
            }
            Op::SampleTl {
                tree,
                point,
                u,
                out,
            } => {
                let (t, n, th) = self.tree(*tree);
                let pt = In::one(point.value.ml(), point.ptr);
                let mut o = Out::<ml_light_sample>::one(*out);
                let s = ml_tree_sample_tl(t, pt.p(), u.value(), o.p());
                if self.status("ml_tree_sample_tl", s, &[&th, &pt, &o]) {
                    let r = o.get(0);
                    self.sample("ml_tree_sample_tl", r, n);
                    self.queried("ml_tree_pmf_tl", r, |l, q| ml_tree_pmf_tl(t, pt.p(), l, q));
                }
            }
            Op::PmfTl {
                tree,
                point,
                light,
                out,
            } => {
                let (t, n, th) = self.tree(*tree);
                let pt = In::one(point.value.ml(), point.ptr);
                let mut o = Out::<f32>::one(*out);
                let s = ml_tree_pmf_tl(t, pt.p(), light.value(n), o.p());
                if self.status("ml_tree_pmf_tl", s, &[&th, &pt, &o]) {
                    self.pmf("ml_tree_pmf_tl", o.get(0));
                }
            }
            Op::SampleBl { tree, sp, u, out } => {
                let (t, n, th) = self.tree(*tree);
                let p = In::one(sp.value.ml(), sp.ptr);
                let mut o = Out::<ml_light_sample>::one(*out);
                let s = ml_tree_sample_bl(t, p.p(), u.value(), o.p());
                if self.status("ml_tree_sample_bl", s, &[&th, &p, &o]) {
                    let r = o.get(0);
                    self.sample("ml_tree_sample_bl", r, n);
                    self.queried("ml_tree_pmf_bl", r, |l, q| ml_tree_pmf_bl(t, p.p(), l, q));
                }
            }
            Op::PmfBl {
                tree,
                sp,
                light,
                out,
            } => {
                let (t, n, th) = self.tree(*tree);
                let p = In::one(sp.value.ml(), sp.ptr);
                let mut o = Out::<f32>::one(*out);
                let s = ml_tree_pmf_bl(t, p.p(), light.value(n), o.p());
                if self.status("ml_tree_pmf_bl", s, &[&th, &p, &o]) {
                    self.pmf("ml_tree_pmf_bl", o.get(0));
                }
            }
            Op::SampleTlBatch {
                tree,
                points,
                us,
                count,
                ptrs,
            } => {
                let pts: Vec<ml_tl_point> = points.iter().take(MAX_LEN).map(TlPoint::ml).collect();
                let us = numbers(us, pts.len());
                self.batch(
                    "ml_tree_sample_tl_batch",
                    *tree,
                    &pts,
                    &us,
                    *count,
                    *ptrs,
                    ml_tree_sample_tl_batch,
                    |t, p, u, o| ml_tree_sample_tl(t, p, u, o),
                );
            }
            Op::SampleBlBatch {
                tree,
                points,
                us,
                count,
                ptrs,
            } => {
                let pts: Vec<ml_shading_point> = points.iter().take(MAX_LEN).map(Sp::ml).collect();
                let us = numbers(us, pts.len());
                self.batch(
                    "ml_tree_sample_bl_batch",
                    *tree,
                    &pts,
                    &us,
                    *count,
                    *ptrs,
                    ml_tree_sample_bl_batch,
                    |t, p, u, o| ml_tree_sample_bl(t, p, u, o),
                );
            }
            Op::PmfTlBatch {
                tree,
                points,
                lights,
                count,
                ptrs,
            } => {
                let (_, n, _) = self.tree(*tree);
                let pts: Vec<ml_tl_point> = points.iter().take(MAX_LEN).map(TlPoint::ml).collect();
                let ls = indices(lights, pts.len(), n);
                self.batch(
                    "ml_tree_pmf_tl_batch",
                    *tree,
                    &pts,
                    &ls,
                    *count,
                    *ptrs,
                    ml_tree_pmf_tl_batch,
                    |t, p, l, o| ml_tree_pmf_tl(t, p, l, o),
                );
            }
            Op::PmfBlBatch {
                tree,
                points,
                lights,
                count,
                ptrs,
            } => {
                let (_, n, _) = self.tree(*tree);
                let pts: Vec<ml_shading_point> = points.iter().take(MAX_LEN).map(Sp::ml).collect();
                let ls = indices(lights, pts.len(), n);
                self.batch(
                    "ml_tree_pmf_bl_batch",
                    *tree,
                    &pts,
                    &ls,
                    *count,
                    *ptrs,
                    ml_tree_pmf_bl_batch,
                    |t, p, l, o| ml_tree_pmf_bl(t, p, l, o),
                );
            }
            _ => unreachable!("{op:?} is no tree operation"),
        }
    }

    fn add_tree(&mut self, p: *mut ml_tree, count: Option<usize>) {
        self.ensure(!p.is_null(), || "a NULL tree".into());
        let mut st = Out::<ml_tree_statistics>::one(Ptr::Valid);
        let s = ml_tree_stats(p, st.p());
        self.ensure(s == ML_OK, || format!("ml_tree_stats of a new tree: {s}"));
        let lights = st.get(0).lights;
        if let Some(c) = count {
            self.ensure(lights == c, || format!("a tree of {c} lights has {lights}"));
        }
        self.trees.push(Tree { p, lights });
    }

    /// A batch call, then the single calls it equals bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn batch<P: Copy, A: Copy, R: Copy + PartialEq + fmt::Debug + BatchOut>(
        &self,
        name: &str,
        tree: Handle,
        points: &[P],
        args: &[A],
        count: Count,
        ptrs: [Ptr; 3],
        call: extern "C" fn(*const ml_tree, *const P, *const A, usize, *mut R) -> ml_status,
        single: impl Fn(*const ml_tree, *const P, A, *mut R) -> ml_status,
    ) {
        let (t, n, th) = self.tree(tree);
        let len = points.len();
        let all_null = ptrs.iter().all(|&p| p == Ptr::Null);
        let c = count.value(len, all_null);
        let p = In::new(points, ptrs[0], c);
        let a = In::new(args, ptrs[1], c);
        let mut o = Out::<R>::new(len, ptrs[2], c);
        let s = call(t, p.p(), a.p(), c, o.p());
        if !self.status(name, s, &[&th, &p, &a, &o]) {
            return;
        }
        self.ensure(o.untouched_from(c), || {
            format!("{name}: wrote past the count")
        });
        for j in 0..c {
            let r = o.get(j);
            r.check(self, name, n);
            let mut one = Out::<R>::one(Ptr::Valid);
            let s = single(t, &points[j], args[j], one.p());
            self.ensure(s == ML_OK, || {
                format!(
                    "{name}: element {j} succeeded, its single call gave {s} ({})",
                    message()
                )
            });
            let q = one.get(0);
            self.ensure(r.same(&q), || {
                format!("{name}: element {j} is {r:?}, its single call {q:?}")
            });
        }
    }
}

/// What a batch writes: a sample or a pmf.
trait BatchOut: Sized {
    fn check(&self, h: &Harness<'_>, name: &str, n: usize);
    fn same(&self, other: &Self) -> bool;
}

impl BatchOut for ml_light_sample {
    fn check(&self, h: &Harness<'_>, name: &str, n: usize) {
        h.sample(name, *self, n);
    }
    fn same(&self, o: &Self) -> bool {
        self.light == o.light && self.pmf.to_bits() == o.pmf.to_bits()
    }
}

impl BatchOut for f32 {
    fn check(&self, h: &Harness<'_>, name: &str, _n: usize) {
        h.pmf(name, *self);
    }
    fn same(&self, o: &Self) -> bool {
        self.to_bits() == o.to_bits()
    }
}
