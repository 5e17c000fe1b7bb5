//! The tree family (`ml_tree_*`): built from light descriptors, with or without an
//! environment (serially, or in parallel and checked against the serial build byte for byte)
//! or loaded from (edited) serialized bytes, with or without (edited) lights and an
//! environment, serialized, its statistics, freed; TL and BL samples
//! checked against the queried pmfs, the batches against the single calls, and a tree
//! loaded with its lights against the one it was saved from.

use super::{message, pick, Env, Harness, Tree};
use crate::ffi::buffers::{HandleArg, In, Out};
use crate::ffi::grammar::{
    indices, numbers, Arg, Bytes, Capacity, Count, Drawn, Handle, Light, LightsArg, Op, Ptr, Sp,
    TlPoint, MAX_COMPARE, MAX_LEN,
};
use crate::ffi::host::{EnvSpec, EnvState};
use manylights_ffi::*;
use std::fmt;
use std::ptr;

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
                let (ls, spec) = split_env(lights);
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
                let env = spec.map(|s| self.new_env(s));
                let ea = env_arg(env, Ptr::Valid);
                let mut o = Out::<*mut ml_tree>::one(*out);
                let s = ml_tree_build(arr.p(), c, ea.p(), opts.p(), o.p());
                let ok = self.status("ml_tree_build", s, &[&arr, &ea, &opts, &o]);
                self.bounds_check("ml_tree_build", spec, ok);
                if ok {
                    self.add_tree(o.get(0), Some(ls[..c].to_vec()), env);
                }
            }
            Op::Load {
                bytes,
                count,
                ptr: bp,
                out,
            } => {
                let Some((data, pristine)) = self.load_bytes(bytes) else {
                    return;
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
                    self.add_tree(o.get(0), None, None);
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
                    let src = self.tree_at(*tree).map(|t| {
                        let spec = t.env.map(|e| e.state().spec);
                        (t.descs.clone().map(|d| (d, spec)), t.p)
                    });
                    self.serialized_lights = src.as_ref().and_then(|t| t.0.clone());
                    self.serialized_tree = src.map(|t| t.1);
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
                        if self.serialized_tree == Some(self.trees[i].p) {
                            self.serialized_tree = None;
                        }
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
                let mut o = Out::<ml_sampled_light>::one(*out);
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
                let mut o = Out::<ml_sampled_light>::one(*out);
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
            Op::BuildParallel {
                lights,
                count,
                ptr,
                options,
                threads,
                out,
            } => self.build_parallel(
                lights,
                *count,
                *ptr,
                options.as_ref(),
                threads.value(),
                *out,
            ),
            Op::LoadWithLights {
                bytes,
                lights,
                count,
                ptrs,
                out,
                points,
                sps,
            } => self.load_with_lights(bytes, lights, *count, *ptrs, *out, points, sps),
            _ => unreachable!("{op:?} is no tree operation"),
        }
    }

    /// A build or load that succeeded had valid bounds (each finite, ≥ 0 and at most
    /// `ML_MAX_LIGHT_ENERGY`).
    fn bounds_check(&self, name: &str, spec: Option<EnvSpec>, ok: bool) {
        if let Some(spec) = spec {
            let valid = spec
                .bounds
                .iter()
                .all(|b| b.is_finite() && *b >= 0.0 && *b <= ML_MAX_LIGHT_ENERGY);
            self.ensure(valid || !ok, || {
                format!(
                    "{name}: succeeded with the environment's bounds {:?}",
                    spec.bounds
                )
            });
        }
    }

    /// `ml_tree_build` of `descs` (valid pointers) with the environment `spec` passed as
    /// `ptr` (`None`: NULL), the tree kept: its index among the live trees.
    pub(super) fn build_env(
        &mut self,
        descs: &[ml_light],
        spec: Option<EnvSpec>,
        ptr: Ptr,
    ) -> Option<usize> {
        let env = spec.map(|s| self.new_env(s));
        let ea = env_arg(env, ptr);
        let mut o = Out::<*mut ml_tree>::one(Ptr::Valid);
        let s = ml_tree_build(descs.as_ptr(), descs.len(), ea.p(), ptr::null(), o.p());
        let ok = self.status("ml_tree_build", s, &[&ea, &o]);
        self.bounds_check("ml_tree_build", spec, ok);
        if !ok {
            return None;
        }
        let env = if ptr == Ptr::Null { None } else { env };
        self.add_tree(o.get(0), Some(descs.to_vec()), env);
        Some(self.trees.len() - 1)
    }

    /// A new tree, with the descriptors it holds (`None`: loaded without them) and its
    /// environment.
    fn add_tree(
        &mut self,
        p: *mut ml_tree,
        descs: Option<Vec<ml_light>>,
        env: Option<*const EnvState>,
    ) {
        self.ensure(!p.is_null(), || "a NULL tree".into());
        let mut st = Out::<ml_tree_statistics>::one(Ptr::Valid);
        let s = ml_tree_stats(p, st.p());
        self.ensure(s == ML_OK, || format!("ml_tree_stats of a new tree: {s}"));
        let st = st.get(0);
        let lights = st.lights;
        if let Some(d) = &descs {
            let c = d.len() + usize::from(env.is_some());
            self.ensure(lights == c && st.has_lights == 1, || {
                format!("a tree of {c} lights with them has {st:?}")
            });
        } else {
            self.ensure(st.has_lights == 0, || {
                format!("a tree loaded without lights has {st:?}")
            });
        }
        let env = match (&descs, env) {
            (Some(d), Some(state)) => Some(Env {
                light: d.len() as u32,
                state,
            }),
            _ => None,
        };
        self.trees.push(Tree {
            p,
            lights,
            descs,
            env,
        });
    }

    /// The serialized bytes of a tree (valid pointers; `None` when that fails).
    fn bytes_of(&self, t: *const ml_tree) -> Option<Vec<u8>> {
        let mut size = Out::<usize>::one(Ptr::Valid);
        if !self.status(
            "ml_tree_serialized_size",
            ml_tree_serialized_size(t, size.p()),
            &[],
        ) {
            return None;
        }
        let n = size.get(0);
        let mut buf = Out::<u8>::new(n, Ptr::Valid, n);
        let mut w = Out::<usize>::one(Ptr::Valid);
        let s = ml_tree_serialize(t, buf.p(), n, w.p());
        if !self.status("ml_tree_serialize", s, &[]) {
            return None;
        }
        self.ensure(w.get(0) == n, || {
            format!("ml_tree_serialize: wrote {} of {n}", w.get(0))
        });
        Some((0..n).map(|i| buf.get(i)).collect())
    }

    /// `ml_tree_build_parallel`, then `ml_tree_build` of the same arguments.
    fn build_parallel(
        &mut self,
        lights: &[Light],
        count: Count,
        lp: Ptr,
        options: Option<&Arg<u8>>,
        threads: u32,
        out: Ptr,
    ) {
        let (ls, spec) = split_env(lights);
        let c = count.value(ls.len(), lp == Ptr::Null);
        let arr = In::new(&ls, lp, c);
        let env = spec.map(|s| self.new_env(s));
        let ea = env_arg(env, Ptr::Valid);
        let opts = In::opt(options.map(|o| {
            (
                ml_build_options {
                    buckets: u32::from(o.value),
                },
                o.ptr,
            )
        }));
        let mut o = Out::<*mut ml_tree>::one(out);
        let s = ml_tree_build_parallel(arr.p(), c, ea.p(), opts.p(), threads, o.p());
        let ok = self.status("ml_tree_build_parallel", s, &[&arr, &ea, &opts, &o]);
        if threads <= 1024 {
            self.bounds_check("ml_tree_build_parallel", spec, ok);
        }
        if threads > 1024 {
            self.ensure(s == ML_ERR_INVALID_ARGUMENT || s == ML_ERR_NULL, || {
                format!("ml_tree_build_parallel: {s} with {threads} threads")
            });
            return;
        }
        let mut o1 = Out::<*mut ml_tree>::one(out);
        let s1 = ml_tree_build(arr.p(), c, ea.p(), opts.p(), o1.p());
        self.ensure(s1 == s, || {
            format!("ml_tree_build_parallel: {s}, ml_tree_build of the same arguments: {s1}")
        });
        if !ok {
            return;
        }
        let (tp, ts) = (o.get(0), o1.get(0));
        self.add_tree(tp, Some(ls[..c].to_vec()), env);
        let (a, b) = (self.bytes_of(tp), self.bytes_of(ts));
        ml_tree_free(ts);
        self.ensure(a.is_some() && a == b, || {
            "ml_tree_build_parallel: serialized bytes other than ml_tree_build's".into()
        });
    }

    /// `ml_tree_load_with_lights` (see [`Op::LoadWithLights`]).
    #[allow(clippy::too_many_arguments)]
    fn load_with_lights(
        &mut self,
        bytes: &Bytes,
        lights: &LightsArg,
        count: Count,
        ptrs: [Ptr; 2],
        out: Ptr,
        points: &[TlPoint],
        sps: &[Sp],
    ) {
        let Some((data, pristine)) = self.load_bytes(bytes) else {
            return;
        };
        let (ls, spec, own): (Vec<ml_light>, Option<EnvSpec>, bool) = match lights {
            LightsArg::Own => match &self.serialized_lights {
                Some((l, e)) => (l.clone(), *e, true),
                None => return,
            },
            LightsArg::Edited(edits) => {
                let Some((mut l, e)) = self.serialized_lights.clone() else {
                    return;
                };
                let mut changed = false;
                for (i, e) in edits.iter().take(MAX_LEN) {
                    if !l.is_empty() {
                        let n = l.len();
                        l[usize::from(*i) % n] = e.drawn().ml();
                        changed = true;
                    }
                }
                (l, e, !changed)
            }
            LightsArg::Drawn(d) => {
                let (l, e) = split_env(d);
                (l, e, false)
            }
        };
        let env = spec.map(|s| self.new_env(s));
        let ea = env_arg(env, Ptr::Valid);
        let bp = if ptrs[0] == Ptr::Null {
            Ptr::Null
        } else {
            Ptr::Valid
        };
        let bc = data.len();
        let b = In::new(&data, bp, bc);
        let c = count.value(ls.len(), ptrs[1] == Ptr::Null);
        let arr = In::new(&ls, ptrs[1], c);
        let mut o = Out::<*mut ml_tree>::one(out);
        let s = ml_tree_load_with_lights(b.p(), bc, arr.p(), c, ea.p(), o.p());
        let ok = self.status("ml_tree_load_with_lights", s, &[&b, &arr, &ea, &o]);
        self.bounds_check("ml_tree_load_with_lights", spec, ok);
        let exact = pristine
            && own
            && bp == Ptr::Valid
            && ptrs[1] == Ptr::Valid
            && out == Ptr::Valid
            && c == ls.len();
        if exact {
            self.ensure(ok, || {
                format!(
                    "ml_tree_load_with_lights of serialized bytes and their lights: {s} ({})",
                    message()
                )
            });
        }
        if !ok {
            return;
        }
        let t = o.get(0);
        self.add_tree(t, Some(ls[..c].to_vec()), env);
        if !exact {
            return;
        }
        let again = self.bytes_of(t);
        self.ensure(again.as_deref() == Some(&data[..]), || {
            "ml_tree_load_with_lights: the tree serializes to other bytes".into()
        });
        // The tree the bytes were saved from, or (freed) the bytes loaded without lights.
        let (reference, temporary) = match self.serialized_tree {
            Some(p) => (p, false),
            None => {
                let mut o = Out::<*mut ml_tree>::one(Ptr::Valid);
                let s = ml_tree_load(data.as_ptr(), data.len(), o.p());
                self.ensure(self.status("ml_tree_load", s, &[]), || {
                    "ml_tree_load of serialized bytes failed".into()
                });
                (o.get(0), true)
            }
        };
        self.compare_trees(
            t,
            reference,
            !temporary,
            c + usize::from(env.is_some()),
            points,
            sps,
        );
        if temporary {
            ml_tree_free(reference);
        }
    }

    /// A tree loaded with its lights against the tree `r` (holding its lights when
    /// `points_on_lights`): TL and BL pmfs of every light, samples and points on lights,
    /// bit for bit.
    fn compare_trees(
        &self,
        t: *const ml_tree,
        r: *const ml_tree,
        points_on_lights: bool,
        n: usize,
        points: &[TlPoint],
        sps: &[Sp],
    ) {
        let name = "ml_tree_load_with_lights";
        let pair = |what: &str, f: &dyn Fn(*const ml_tree, *mut u8) -> ml_status, size: usize| {
            let mut a = Out::<[u8; 64]>::one(Ptr::Valid);
            let mut b = Out::<[u8; 64]>::one(Ptr::Valid);
            let (sa, sb) = (f(t, a.p().cast()), f(r, b.p().cast()));
            let (a, b) = (a.get(0), b.get(0));
            self.ensure(sa == sb && a[..size] == b[..size], || {
                format!(
                    "{name}: {what}: {sa} {:?}, the saved tree's {sb} {:?}",
                    &a[..size],
                    &b[..size]
                )
            });
        };
        let us = [0.0f32, 0.3, 0.7, 1.0 - f32::EPSILON / 2.0];
        for p in points.iter().take(MAX_COMPARE) {
            let p = p.ml();
            for l in 0..n as u32 {
                pair(
                    &format!("ml_tree_pmf_tl of light {l}"),
                    &|t, o| ml_tree_pmf_tl(t, &p, l, o.cast()),
                    4,
                );
                if points_on_lights {
                    pair(
                        &format!("ml_light_sample_point of light {l}"),
                        &|t, o| ml_light_sample_point(t, l, p.position, 0.5, 0.25, o.cast()),
                        core::mem::size_of::<ml_light_point>(),
                    );
                }
            }
            for u in us {
                pair(
                    &format!("ml_tree_sample_tl with u {u}"),
                    &|t, o| ml_tree_sample_tl(t, &p, u, o.cast()),
                    8,
                );
            }
        }
        for sp in sps.iter().take(MAX_COMPARE) {
            let sp = sp.ml();
            for l in 0..n as u32 {
                pair(
                    &format!("ml_tree_pmf_bl of light {l}"),
                    &|t, o| ml_tree_pmf_bl(t, &sp, l, o.cast()),
                    4,
                );
            }
            for u in us {
                pair(
                    &format!("ml_tree_sample_bl with u {u}"),
                    &|t, o| ml_tree_sample_bl(t, &sp, u, o.cast()),
                    8,
                );
            }
        }
    }

    /// The bytes `bytes` stands for and whether they are the serialized ones unedited
    /// (`None`: none serialized yet).
    fn load_bytes(&self, bytes: &Bytes) -> Option<(Vec<u8>, bool)> {
        Some(match bytes {
            Bytes::Serialized { edits, keep } => {
                let mut b = self.serialized.clone()?;
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
        })
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
            // Every input checked first: with valid arrays, some element's single call fails.
            if c > 0 && ptrs.iter().all(|&p| p == Ptr::Valid) {
                let fails = (0..c).any(|j| {
                    let mut one = Out::<R>::one(Ptr::Valid);
                    single(t, &points[j], args[j], one.p()) != ML_OK
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

impl BatchOut for ml_sampled_light {
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

/// A build's lights as the harness passes them: the drawn ones (the first [`MAX_LEN`]), the
/// first of kind 7 taken out as the build's environment ([`EnvSpec::from_light`]).
fn split_env(lights: &[Light]) -> (Vec<ml_light>, Option<EnvSpec>) {
    let mut ls: Vec<Drawn> = lights.iter().take(MAX_LEN).map(Light::drawn).collect();
    let env = ls
        .iter()
        .position(|l| l.kind == 7)
        .map(|i| EnvSpec::from_light(&ls.remove(i)));
    (ls.iter().map(Drawn::ml).collect(), env)
}

/// The environment argument of a build or load: `env`'s callbacks passed as `ptr`, NULL
/// without one.
fn env_arg(env: Option<*const EnvState>, ptr: Ptr) -> In<ml_environment> {
    // SAFETY: the states live in `Harness::envs` until the end of the run.
    In::opt(env.map(|e| (unsafe { &*e }.ml(), ptr)))
}
