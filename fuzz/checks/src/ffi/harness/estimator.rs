//! The estimator family: the whole method in one call (`ml_direct_estimate`, at many points
//! `ml_direct_estimate_batch`, checked against the single calls) and estimators
//! (`ml_estimator_*`): created on a tree, set up at a shading point, one-call estimates, the
//! lower-level steps, weights and BSDF hits, freed; on trees with and without an
//! environment (whose bad values from the callbacks make the calls that reach them
//! `ML_ERR_INVALID_ARGUMENT`, and whose points carry its radiance and pdf).

use super::{estimate_ok, message, same_bits, Env, Est, Harness};
use crate::ffi::buffers::{HandleArg, In, Out};
use crate::ffi::grammar::{
    v3, Arg, Count, Enum, Handle, Op, Params, Ptr, Sp, Uniforms, Visibility, F, MAX_ESTIMATE_BATCH,
    MAX_STEPS,
};
use crate::ffi::host::{each_hit, host, uniforms, visibility, EnvSpec, Host};
use manylights_ffi::*;
use std::ptr;

impl Harness<'_> {
    /// An estimator operation: `DirectEstimate` to `Run`.
    pub(super) fn estimator_op(&mut self, op: &Op) {
        match op {
            Op::DirectEstimate {
                tree,
                sp,
                technique,
                params,
                visibility: vis,
                uniforms: uni,
                out,
            } => {
                self.direct_estimate(
                    *tree,
                    sp,
                    *technique,
                    params.as_ref(),
                    vis.as_ref(),
                    uni,
                    *out,
                );
            }
            Op::EstimatorCreate { tree, out } => {
                let (t, n, th) = self.tree(*tree);
                let env = self.tree_at(*tree).and_then(|t| t.env);
                let mut o = Out::<*mut ml_estimator>::one(*out);
                let s = ml_estimator_create(t, o.p());
                if self.status("ml_estimator_create", s, &[&th, &o]) {
                    let p = o.get(0);
                    self.ensure(!p.is_null(), || "ml_estimator_create: NULL".into());
                    self.ests.push(Est {
                        p,
                        lights: n,
                        env,
                        sp: None,
                    });
                }
            }
            Op::EstimatorFree(h) => {
                let (i, p, eh) = self.est(*h);
                let s = ml_estimator_free(p);
                if self.status("ml_estimator_free", s, &[&eh]) {
                    if let Some(i) = i {
                        self.ests.swap_remove(i);
                    }
                }
            }
            Op::SetPoint {
                est,
                sp,
                technique,
                params,
            } => {
                let (ei, e, eh) = self.est(*est);
                let spv = sp.value.ml();
                let p = In::one(spv, sp.ptr);
                let prm = In::opt(params.as_ref().map(|o| (o.value.ml(), o.ptr)));
                let s = ml_estimator_set_point(e, p.p(), technique.value(10), prm.p());
                if self.status("ml_estimator_set_point", s, &[&eh, &p, &prm]) {
                    if let Some(i) = ei {
                        self.ests[i].sp = Some(spv);
                    }
                }
            }
            Op::Estimate {
                est,
                visibility: vis,
                uniforms: uni,
                out,
            }
            | Op::EstimateEnv {
                est,
                visibility: vis,
                uniforms: uni,
                out,
                ..
            } => {
                let (ei, e, eh) = self.est(*est);
                let env = ei.and_then(|i| self.ests[i].env);
                let mut h = Host::with_uniforms(&uni.value);
                let hp: *mut Host = &mut h;
                let v = visibility_arg(hp, vis.as_ref());
                let u = In::one(uniforms(&uni.value, hp), uni.ptr);
                let mut o = Out::<ml_rgb64>::one(*out);
                Harness::env_reset(env);
                let s = ml_estimator_estimate(e, v.p(), u.p(), o.p());
                self.env_check("ml_estimator_estimate", env, s);
                if self.status("ml_estimator_estimate", s, &[&eh, &v, &u, &o]) {
                    let r = o.get(0);
                    self.ensure(estimate_ok(r), || format!("ml_estimator_estimate: {r:?}"));
                }
            }
            Op::Start(est) => {
                let (ei, e, eh) = self.est(*est);
                let s = ml_estimator_start(e);
                if s == ML_ERR_STATE {
                    self.ensure(ei.is_none_or(|i| self.ests[i].sp.is_none()), || {
                        "ml_estimator_start: an estimator set up is not".into()
                    });
                }
                self.status("ml_estimator_start", s, &[&eh]);
            }
            Op::Next {
                est,
                uniforms: uni,
                out,
            } => {
                let (ei, e, eh) = self.est(*est);
                let n = ei.map_or(0, |i| self.ests[i].lights);
                let env = ei.and_then(|i| self.ests[i].env);
                let mut h = Host::with_uniforms(&uni.value);
                let hp: *mut Host = &mut h;
                let u = In::one(uniforms(&uni.value, hp), uni.ptr);
                let mut o = Out::<ml_step>::one(*out);
                Harness::env_reset(env);
                let s = ml_estimator_next(e, u.p(), o.p());
                self.env_check("ml_estimator_next", env, s);
                if self.status("ml_estimator_next", s, &[&eh, &u, &o]) {
                    self.step(&o.get(0), n, env);
                }
            }
            Op::Weigh { est, bsdf_pdf, out } => {
                let (ei, e, eh) = self.est(*est);
                let env = ei.and_then(|i| self.ests[i].env);
                let mut o = Out::<ml_weighted>::one(*out);
                Harness::env_reset(env);
                let s = ml_estimator_weigh(e, bsdf_pdf.value(), o.p());
                self.env_check("ml_estimator_weigh", env, s);
                if self.status("ml_estimator_weigh", s, &[&eh, &o]) {
                    self.weighted("ml_estimator_weigh", &o.get(0));
                }
            }
            Op::BsdfHits {
                est,
                direction,
                bsdf_pdf,
                hit_distance,
                no_each,
                any_hit,
            } => {
                let (ei, e, eh) = self.est(*est);
                let n = ei.map_or(0, |i| self.ests[i].lights);
                let env = ei.and_then(|i| self.ests[i].env);
                self.bsdf_hits(
                    e,
                    &eh,
                    n,
                    v3(direction),
                    bsdf_pdf.value(),
                    hit_distance.value(),
                    env,
                    !no_each.set(),
                    *any_hit,
                );
            }
            Op::BsdfHitsEnv {
                est,
                direction,
                bsdf_pdf,
                hit_distance,
                environment_pdf,
                no_each,
                any_hit,
            } => {
                let (ei, e, eh) = self.est(*est);
                let n = ei.map_or(0, |i| self.ests[i].lights);
                let env = ei.and_then(|i| self.ests[i].env);
                let escapes = (0.0..1.0).contains(&environment_pdf.value());
                self.bsdf_hits(
                    e,
                    &eh,
                    n,
                    v3(direction),
                    bsdf_pdf.value(),
                    if escapes {
                        f32::INFINITY
                    } else {
                        hit_distance.value()
                    },
                    env,
                    !no_each.set(),
                    *any_hit,
                );
            }
            Op::DirectEstimateBatch {
                tree,
                points,
                count,
                per_point,
                technique,
                params,
                visibility: vis,
                uniforms: uni,
                ptrs,
            } => {
                let pp = if *per_point < 240 {
                    1 + u32::from(*per_point) % 3
                } else {
                    u32::from(*per_point - 240)
                };
                self.estimate_batch(
                    *tree,
                    points,
                    *count,
                    pp,
                    technique.value(10),
                    params.as_ref(),
                    vis.as_ref(),
                    uni,
                    *ptrs,
                );
            }
            Op::EnvBuild {
                tree,
                sp,
                technique,
                params,
                visibility: vis,
                environment: env,
                uniforms: uni,
                out,
            } => {
                let Some(descs) = self.tree_at(*tree).and_then(|t| t.descs.clone()) else {
                    return;
                };
                let spec = env.as_ref().map(|e| EnvSpec::from_desc(&e.value));
                let ptr = env.as_ref().map_or(Ptr::Null, |e| e.ptr);
                let Some(i) = self.build_env(&descs, spec, ptr) else {
                    return;
                };
                self.direct_estimate(
                    Handle::Live(i as u8),
                    sp,
                    *technique,
                    params.as_ref(),
                    vis.as_ref(),
                    uni,
                    *out,
                );
            }
            Op::Run {
                tree,
                sp,
                technique,
                params,
                uniforms: uni,
                visibility: vis,
                distances,
                keep,
            } => self.run_op(
                *tree,
                sp,
                *technique,
                params.as_ref(),
                uni,
                vis.as_ref(),
                distances,
                *keep,
            ),
            Op::RunEnv {
                tree,
                sp,
                technique,
                params,
                uniforms: uni,
                visibility: vis,
                environment: env,
                distances,
                keep,
            } => {
                let Some(descs) = self.tree_at(*tree).and_then(|t| t.descs.clone()) else {
                    return;
                };
                let spec = EnvSpec::from_desc(env);
                let Some(i) = self.build_env(&descs, Some(spec), Ptr::Valid) else {
                    return;
                };
                self.run_op(
                    Handle::Live(i as u8),
                    sp,
                    *technique,
                    params.as_ref(),
                    uni,
                    vis.as_ref(),
                    distances,
                    *keep,
                );
            }
            _ => unreachable!("{op:?} is no estimator operation"),
        }
    }

    /// `ml_direct_estimate` ([`Op::DirectEstimate`]).
    #[allow(clippy::too_many_arguments)]
    fn direct_estimate(
        &self,
        tree: Handle,
        sp: &Arg<Sp>,
        technique: Enum,
        params: Option<&Arg<Params>>,
        vis: Option<&Arg<Visibility>>,
        uni: &Arg<Uniforms>,
        out: Ptr,
    ) {
        let (t, _, th) = self.tree(tree);
        let env = self.tree_at(tree).and_then(|t| t.env);
        let p = In::one(sp.value.ml(), sp.ptr);
        let prm = In::opt(params.map(|o| (o.value.ml(), o.ptr)));
        let mut h = Host::with_uniforms(&uni.value);
        let hp: *mut Host = &mut h;
        let v = visibility_arg(hp, vis);
        let u = In::one(uniforms(&uni.value, hp), uni.ptr);
        let mut o = Out::<ml_rgb64>::one(out);
        Harness::env_reset(env);
        let s = ml_direct_estimate(t, p.p(), technique.value(10), prm.p(), v.p(), u.p(), o.p());
        self.env_check("ml_direct_estimate", env, s);
        if self.status("ml_direct_estimate", s, &[&th, &p, &prm, &v, &u, &o]) {
            let e = o.get(0);
            self.ensure(estimate_ok(e), || format!("ml_direct_estimate: {e:?}"));
        }
    }

    /// [`Op::Run`].
    #[allow(clippy::too_many_arguments)]
    fn run_op(
        &mut self,
        tree: Handle,
        sp: &Sp,
        technique: Enum,
        params: Option<&Params>,
        uni: &Uniforms,
        vis: Option<&Visibility>,
        distances: &[F],
        keep: bool,
    ) {
        let (t, n, th) = self.tree(tree);
        let env = self.tree_at(tree).and_then(|t| t.env);
        let mut o = Out::<*mut ml_estimator>::one(Ptr::Valid);
        let s = ml_estimator_create(t, o.p());
        if !self.status("ml_estimator_create", s, &[&th, &o]) {
            return;
        }
        let e = o.get(0);
        self.ensure(!e.is_null(), || "ml_estimator_create: NULL".into());
        let sp = sp.ml();
        let prm = params.map(|p| p.ml());
        let s = ml_estimator_set_point(
            e,
            &sp,
            technique.value(10),
            prm.as_ref().map_or(ptr::null(), |p| p as *const _),
        );
        let ok = self.status("ml_estimator_set_point", s, &[]);
        self.ests.push(Est {
            p: e,
            lights: n,
            env,
            sp: ok.then_some(sp),
        });
        if ok {
            self.run_estimator(e, n, sp, uni, vis, env, distances);
        }
        if !keep {
            let e = self.ests.pop().map(|e| e.p);
            let s = ml_estimator_free(e.unwrap_or(ptr::null_mut()));
            self.status("ml_estimator_free", s, &[]);
        }
    }

    /// One estimate, then a lower-level one, of an estimator set up at `sp` (of a tree with
    /// the environment `env`).
    #[allow(clippy::too_many_arguments)]
    fn run_estimator(
        &self,
        e: *mut ml_estimator,
        n: usize,
        sp: ml_shading_point,
        uni: &Uniforms,
        vis: Option<&Visibility>,
        env: Option<Env>,
        distances: &[F],
    ) {
        {
            let mut h = Host::with_uniforms(uni);
            let hp: *mut Host = &mut h;
            let v = vis.map(|v| visibility(v, host(hp.cast())));
            let u = uniforms(uni, hp);
            let vp = v.as_ref().map_or(ptr::null(), |v| v as *const _);
            let mut o = Out::<ml_rgb64>::one(Ptr::Valid);
            let name = "ml_estimator_estimate";
            Harness::env_reset(env);
            let s = ml_estimator_estimate(e, vp, &u, o.p());
            self.env_check(name, env, s);
            if self.status(name, s, &[&o]) {
                let r = o.get(0);
                self.ensure(estimate_ok(r), || format!("{name}: {r:?}"));
            }
        }
        let s = ml_estimator_start(e);
        if !self.status("ml_estimator_start", s, &[]) {
            return;
        }
        let mut h = Host::with_uniforms(uni);
        let hp: *mut Host = &mut h;
        let u = uniforms(uni, hp);
        let spp: *const ml_shading_point = &sp;
        let mut bsdf = 0;
        for _ in 0..MAX_STEPS {
            let mut o = Out::<ml_step>::one(Ptr::Valid);
            Harness::env_reset(env);
            let s = ml_estimator_next(e, &u, o.p());
            self.env_check("ml_estimator_next", env, s);
            if !self.status("ml_estimator_next", s, &[&o]) {
                return;
            }
            let step = o.get(0);
            self.step(&step, n, env);
            if step.kind == 0 {
                let mut q = 0.0f32;
                if step.needs_bsdf_pdf == 1 {
                    let mut o = Out::<f32>::one(Ptr::Valid);
                    let s = ml_brdf_pdf(spp, step.point.direction, o.p());
                    if !self.status("ml_brdf_pdf", s, &[&o]) {
                        return;
                    }
                    q = o.get(0);
                }
                let mut o = Out::<ml_weighted>::one(Ptr::Valid);
                Harness::env_reset(env);
                let s = ml_estimator_weigh(e, q, o.p());
                self.env_check("ml_estimator_weigh", env, s);
                if self.status("ml_estimator_weigh", s, &[&o]) {
                    self.weighted("ml_estimator_weigh", &o.get(0));
                }
            } else if step.kind == 1 {
                let mut o = Out::<ml_brdf_draw>::one(Ptr::Valid);
                let s = ml_brdf_sample(spp, step.u0, step.u1, o.p());
                if !self.status("ml_brdf_sample", s, &[&o]) {
                    return;
                }
                let d = o.get(0);
                if d.pdf > 0.0 {
                    let t = if distances.is_empty() {
                        f32::INFINITY
                    } else {
                        distances[bsdf % distances.len()].value()
                    };
                    bsdf += 1;
                    self.bsdf_hits(
                        e,
                        &HandleArg(false),
                        n,
                        d.wi,
                        d.pdf,
                        t,
                        env,
                        true,
                        Ptr::Valid,
                    );
                }
            } else {
                return;
            }
        }
    }

    /// A step of `ml_estimator_next` on a tree of `n` lights (with the environment `env`,
    /// whose samples come as light steps at distance +∞).
    fn step(&self, s: &ml_step, n: usize, env: Option<Env>) {
        match s.kind {
            0 => {
                self.ensure((s.light as usize) < n, || {
                    format!("ml_estimator_next: light {} of {n}", s.light)
                });
                self.ensure(s.pmf > 0.0 && s.pmf <= 1.0 && s.needs_bsdf_pdf <= 1, || {
                    format!("ml_estimator_next: {s:?}")
                });
                self.light_point("ml_estimator_next", &s.point);
                if let Some(e) = env.filter(|e| e.light == s.light) {
                    self.env_point("ml_estimator_next", e, &s.point);
                }
            }
            1 => self.ensure(
                (0.0..1.0).contains(&s.u0) && (0.0..1.0).contains(&s.u1),
                || format!("ml_estimator_next: {s:?}"),
            ),
            2 => {}
            k => self.fail(format_args!("ml_estimator_next: step kind {k}")),
        }
    }

    /// `ml_estimator_bsdf_hits` (of an estimator on a tree with the environment `env`: an
    /// escaping ray's hit of it carries its radiance and pdf; no other ray reaches it).
    #[allow(clippy::too_many_arguments)]
    fn bsdf_hits(
        &self,
        e: *mut ml_estimator,
        eh: &HandleArg,
        n: usize,
        d: ml_vec3,
        pdf: f32,
        t: f32,
        env: Option<Env>,
        each: bool,
        any_hit: Ptr,
    ) {
        let name = "ml_estimator_bsdf_hits";
        let mut h = Host::default();
        let hp: *mut Host = &mut h;
        let mut o = Out::<u32>::one(any_hit);
        let f: ml_hit_fn = if each { Some(each_hit) } else { None };
        Harness::env_reset(env);
        let s = ml_estimator_bsdf_hits(e, d, pdf, t, f, hp.cast(), o.p());
        self.env_check(name, env, s);
        if self.status(name, s, &[eh, &o]) {
            let any = o.get(0);
            self.ensure(any == u32::from(!h.hits.is_empty()), || {
                format!("{name}: any_hit {any} with {} hits", h.hits.len())
            });
            for hit in &h.hits {
                self.ensure((hit.light as usize) < n, || {
                    format!("{name}: light {} of {n}", hit.light)
                });
                self.light_point(name, &hit.point);
                self.weighted(name, &hit.weighted);
                if let Some(env) = env.filter(|e| e.light == hit.light) {
                    self.ensure(t == f32::INFINITY, || {
                        format!("{name}: the environment's hit {hit:?} (hit distance {t})")
                    });
                    self.env_point(name, env, &hit.point);
                }
            }
        }
    }

    /// `ml_direct_estimate_batch`, then the same estimates one call at a time, from a host
    /// with the same numbers and answers: `ml_direct_estimate` per point when `pp` is 1,
    /// else one estimator set up at each point and `pp` estimates.
    #[allow(clippy::too_many_arguments)]
    fn estimate_batch(
        &self,
        tree: Handle,
        points: &[Sp],
        count: Count,
        pp: u32,
        technique: u32,
        params: Option<&Arg<Params>>,
        vis: Option<&Arg<Visibility>>,
        uni: &Arg<Uniforms>,
        ptrs: [Ptr; 2],
    ) {
        let name = "ml_direct_estimate_batch";
        let (t, _, th) = self.tree(tree);
        let env = self.tree_at(tree).and_then(|t| t.env);
        let pts: Vec<ml_shading_point> =
            points.iter().take(MAX_ESTIMATE_BATCH).map(Sp::ml).collect();
        let len = pts.len();
        let all_null = ptrs.iter().all(|&p| p == Ptr::Null);
        let c = count.value(len, all_null);
        let per = pp as usize;
        let arr = In::new(&pts, ptrs[0], c);
        let prm = In::opt(params.map(|o| (o.value.ml(), o.ptr)));
        let mut h = Host::with_uniforms(&uni.value);
        let hp: *mut Host = &mut h;
        let v = visibility_arg(hp, vis);
        let u = In::one(uniforms(&uni.value, hp), uni.ptr);
        let mut o = Out::<ml_rgb64>::new(len * per.max(1), ptrs[1], c.saturating_mul(per));
        Harness::env_reset(env);
        let s =
            ml_direct_estimate_batch(t, arr.p(), c, pp, technique, prm.p(), v.p(), u.p(), o.p());
        self.env_check(name, env, s);
        let ok = self.status(name, s, &[&th, &arr, &prm, &v, &u, &o]);
        if pp == 0 {
            self.ensure(!ok, || format!("{name}: succeeded with per_point 0"));
            return;
        }
        let valid = ptrs.iter().all(|&p| p == Ptr::Valid);
        if !(ok || valid && c > 0) {
            return;
        }
        if ok {
            self.ensure(o.untouched_from(c * per), || {
                format!("{name}: wrote past count · per_point")
            });
            for i in 0..c * per {
                let r = o.get(i);
                self.ensure(estimate_ok(r), || format!("{name}: out[{i}] {r:?}"));
            }
        }
        // The single calls, from a host with the same numbers and answers.
        let mut h = Host::with_uniforms(&uni.value);
        let hp: *mut Host = &mut h;
        let v = visibility_arg(hp, vis);
        let u = In::one(uniforms(&uni.value, hp), uni.ptr);
        let mut est = ptr::null_mut();
        if per > 1 {
            let mut eo = Out::<*mut ml_estimator>::one(Ptr::Valid);
            let s = ml_estimator_create(t, eo.p());
            if s == ML_OK {
                est = eo.get(0);
            } else {
                self.ensure(!ok, || {
                    format!(
                        "{name} succeeded, ml_estimator_create gave {s} ({})",
                        message()
                    )
                });
                return;
            }
        }
        let mut failed = None;
        'points: for (j, sp) in pts.iter().enumerate().take(c) {
            if per > 1 {
                let s = ml_estimator_set_point(est, sp, technique, prm.p());
                if s != ML_OK {
                    failed = Some((j, 0, "ml_estimator_set_point", s));
                    break;
                }
            }
            for i in 0..per {
                let mut one = Out::<ml_rgb64>::one(Ptr::Valid);
                Harness::env_reset(env);
                let (single, s) = if per == 1 {
                    let s = ml_direct_estimate(t, sp, technique, prm.p(), v.p(), u.p(), one.p());
                    ("ml_direct_estimate", s)
                } else {
                    let s = ml_estimator_estimate(est, v.p(), u.p(), one.p());
                    ("ml_estimator_estimate", s)
                };
                self.env_check(single, env, s);
                if s != ML_OK {
                    failed = Some((j, i, single, s));
                    break 'points;
                }
                if ok {
                    let (r, q) = (o.get(j * per + i), one.get(0));
                    self.ensure(same_bits(&r, &q), || {
                        format!("{name}: out[{}] is {r:?}, {single} {q:?}", j * per + i)
                    });
                }
            }
        }
        if !est.is_null() {
            ml_estimator_free(est);
        }
        match failed {
            Some((j, i, single, s)) => self.ensure(!ok, || {
                format!(
                    "{name} succeeded; {single} at points[{j}], estimate {i}: {s} ({})",
                    message()
                )
            }),
            None => self.ensure(ok, || {
                format!(
                    "{name}: {s} ({}), yet every single call succeeds",
                    message()
                )
            }),
        }
    }
}

/// The host's visibility callbacks as the ABI takes them (calling back into `hp`), NULL where
/// the input has none.
fn visibility_arg(hp: *mut Host, vis: Option<&Arg<Visibility>>) -> In<ml_visibility> {
    In::opt(vis.map(|v| (visibility(&v.value, host(hp.cast())), v.ptr)))
}
