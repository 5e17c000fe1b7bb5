//! The estimator family: the whole method in one call (`ml_direct_estimate`) and estimators
//! (`ml_estimator_*`): created on a tree, set up at a shading point, one-call estimates, the
//! lower-level steps, weights and BSDF hits, freed.

use super::{estimate_ok, Est, Harness};
use crate::ffi::buffers::{HandleArg, In, Out};
use crate::ffi::grammar::{grey, v3, Op, Ptr, Uniforms, Visibility, F, MAX_STEPS};
use crate::ffi::host::{each_hit, host, uniforms, visibility, Host};
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
                let (t, _, th) = self.tree(*tree);
                let p = In::one(sp.value.ml(), sp.ptr);
                let prm = In::opt(params.as_ref().map(|o| (o.value.ml(), o.ptr)));
                let mut h = Host::with_uniforms(&uni.value);
                let hp: *mut Host = &mut h;
                let v = In::opt(
                    vis.as_ref()
                        .map(|v| (visibility(&v.value, host(hp.cast())), v.ptr)),
                );
                let u = In::one(uniforms(&uni.value, hp), uni.ptr);
                let mut o = Out::<ml_rgb64>::one(*out);
                let s =
                    ml_direct_estimate(t, p.p(), technique.value(10), prm.p(), v.p(), u.p(), o.p());
                if self.status("ml_direct_estimate", s, &[&th, &p, &prm, &v, &u, &o]) {
                    let e = o.get(0);
                    self.ensure(estimate_ok(e), || format!("ml_direct_estimate: {e:?}"));
                }
            }
            Op::EstimatorCreate { tree, out } => {
                let (t, n, th) = self.tree(*tree);
                let mut o = Out::<*mut ml_estimator>::one(*out);
                let s = ml_estimator_create(t, o.p());
                if self.status("ml_estimator_create", s, &[&th, &o]) {
                    let p = o.get(0);
                    self.ensure(!p.is_null(), || "ml_estimator_create: NULL".into());
                    self.ests.push(Est {
                        p,
                        lights: n,
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
            } => {
                let (_, e, eh) = self.est(*est);
                let mut h = Host::with_uniforms(&uni.value);
                let hp: *mut Host = &mut h;
                let v = In::opt(
                    vis.as_ref()
                        .map(|v| (visibility(&v.value, host(hp.cast())), v.ptr)),
                );
                let u = In::one(uniforms(&uni.value, hp), uni.ptr);
                let mut o = Out::<ml_rgb64>::one(*out);
                let s = ml_estimator_estimate(e, v.p(), u.p(), o.p());
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
                let mut h = Host::with_uniforms(&uni.value);
                let hp: *mut Host = &mut h;
                let u = In::one(uniforms(&uni.value, hp), uni.ptr);
                let mut o = Out::<ml_step>::one(*out);
                let s = ml_estimator_next(e, u.p(), o.p());
                if self.status("ml_estimator_next", s, &[&eh, &u, &o]) {
                    self.step(&o.get(0), n);
                }
            }
            Op::Weigh { est, bsdf_pdf, out } => {
                let (_, e, eh) = self.est(*est);
                let mut o = Out::<ml_weighted>::one(*out);
                let s = ml_estimator_weigh(e, bsdf_pdf.value(), o.p());
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
                self.bsdf_hits(
                    e,
                    &eh,
                    n,
                    v3(direction),
                    bsdf_pdf.value(),
                    hit_distance.value(),
                    !no_each.set(),
                    *any_hit,
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
            } => {
                let (t, n, th) = self.tree(*tree);
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
                    sp: ok.then_some(sp),
                });
                if ok {
                    self.run_estimator(e, n, sp, uni, vis.as_ref(), distances);
                }
                if !keep {
                    let e = self.ests.pop().map(|e| e.p);
                    let s = ml_estimator_free(e.unwrap_or(ptr::null_mut()));
                    self.status("ml_estimator_free", s, &[]);
                }
            }
            _ => unreachable!("{op:?} is no estimator operation"),
        }
    }

    /// One estimate, then a lower-level one, of an estimator set up at `sp`.
    fn run_estimator(
        &self,
        e: *mut ml_estimator,
        n: usize,
        sp: ml_shading_point,
        uni: &Uniforms,
        vis: Option<&Visibility>,
        distances: &[F],
    ) {
        {
            let mut h = Host::with_uniforms(uni);
            let hp: *mut Host = &mut h;
            let v = vis.map(|v| visibility(v, host(hp.cast())));
            let u = uniforms(uni, hp);
            let mut o = Out::<ml_rgb64>::one(Ptr::Valid);
            let s = ml_estimator_estimate(
                e,
                v.as_ref().map_or(ptr::null(), |v| v as *const _),
                &u,
                o.p(),
            );
            if self.status("ml_estimator_estimate", s, &[&o]) {
                let r = o.get(0);
                self.ensure(estimate_ok(r), || format!("ml_estimator_estimate: {r:?}"));
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
            let s = ml_estimator_next(e, &u, o.p());
            if !self.status("ml_estimator_next", s, &[&o]) {
                return;
            }
            let step = o.get(0);
            self.step(&step, n);
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
                let s = ml_estimator_weigh(e, q, o.p());
                if self.status("ml_estimator_weigh", s, &[&o]) {
                    self.weighted("ml_estimator_weigh", &o.get(0));
                }
            } else if step.kind == 3 {
                // The host's environment: a direction about the normal, radiance 1, pdf 1/4π.
                let mut o = Out::<ml_step>::one(Ptr::Valid);
                let s = ml_estimator_environment_point(
                    e,
                    sp.normal,
                    grey(1.0),
                    0.25 * core::f32::consts::FRAC_1_PI,
                    o.p(),
                );
                if !self.status("ml_estimator_environment_point", s, &[&o]) {
                    return;
                }
                let step = o.get(0);
                self.ensure(step.kind == 0, || {
                    format!("ml_estimator_environment_point: {step:?}")
                });
                self.step(&step, n);
                let mut o = Out::<ml_weighted>::one(Ptr::Valid);
                let s = ml_estimator_weigh(e, 0.0, o.p());
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
                    self.bsdf_hits(e, &HandleArg(false), n, d.wi, d.pdf, t, true, Ptr::Valid);
                }
            } else {
                return;
            }
        }
    }

    fn step(&self, s: &ml_step, n: usize) {
        match s.kind {
            0 => {
                self.ensure((s.light as usize) < n, || {
                    format!("ml_estimator_next: light {} of {n}", s.light)
                });
                self.ensure(s.pmf > 0.0 && s.pmf <= 1.0 && s.needs_bsdf_pdf <= 1, || {
                    format!("ml_estimator_next: {s:?}")
                });
                self.light_point("ml_estimator_next", &s.point);
            }
            1 => self.ensure(
                (0.0..1.0).contains(&s.u0) && (0.0..1.0).contains(&s.u1),
                || format!("ml_estimator_next: {s:?}"),
            ),
            2 => {}
            3 => self.ensure(
                (s.light as usize) < n
                    && s.pmf > 0.0
                    && s.pmf <= 1.0
                    && (0.0..1.0).contains(&s.u0)
                    && (0.0..1.0).contains(&s.u1),
                || format!("ml_estimator_next: {s:?}"),
            ),
            k => self.fail(format_args!("ml_estimator_next: step kind {k}")),
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn bsdf_hits(
        &self,
        e: *mut ml_estimator,
        eh: &HandleArg,
        n: usize,
        d: ml_vec3,
        pdf: f32,
        t: f32,
        each: bool,
        any_hit: Ptr,
    ) {
        let mut h = Host::default();
        let hp: *mut Host = &mut h;
        let mut o = Out::<u32>::one(any_hit);
        let f: ml_hit_fn = if each { Some(each_hit) } else { None };
        let s = ml_estimator_bsdf_hits(e, d, pdf, t, f, hp.cast(), o.p());
        if self.status("ml_estimator_bsdf_hits", s, &[eh, &o]) {
            let any = o.get(0);
            self.ensure(any == u32::from(!h.hits.is_empty()), || {
                format!(
                    "ml_estimator_bsdf_hits: any_hit {any} with {} hits",
                    h.hits.len()
                )
            });
            for hit in &h.hits {
                self.ensure((hit.light as usize) < n, || {
                    format!("ml_estimator_bsdf_hits: light {} of {n}", hit.light)
                });
                self.light_point("ml_estimator_bsdf_hits", &hit.point);
                self.weighted("ml_estimator_bsdf_hits", &hit.weighted);
            }
        }
    }
}
