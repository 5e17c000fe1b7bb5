//! The harness: the live handles of one input, the checks every call gets ([`Harness::status`])
//! and those of the values the ABI writes, and [`check`], which replays the operations. Each
//! operation is dispatched to the module of its family of the ABI: [`tree`] (`ml_tree_*`),
//! [`light`] (`ml_light_*`), [`cut`] (`ml_cut_*`), [`brdf`] (`ml_brdf_*`), [`estimator`]
//! (`ml_direct_estimate`, `ml_estimator_*`), [`acceptor`] (`ml_acceptor_*`),
//! [`visibility_cache`] (`ml_visibility_cache_*` and the estimator's cache calls) and
//! [`defaults`] (the `*_default` functions, `ml_version`, `ml_status_name`).

mod acceptor;
mod brdf;
mod cut;
mod defaults;
mod estimator;
mod light;
mod tree;
mod visibility_cache;

use super::buffers::{Buf, HandleArg, Out};
use super::grammar::{Handle, Input, Op, Ptr, MAX_OPS};
use super::host::{EnvSpec, EnvState};
use manylights_ffi::*;
use std::ffi::CStr;
use std::fmt;
use std::ptr;

/// A live tree: its handle, light count and, when it holds them, the light descriptors it
/// was built from and its environment.
struct Tree {
    p: *mut ml_tree,
    lights: usize,
    descs: Option<Vec<ml_light>>,
    env: Option<Env>,
}

/// The environment a tree holds: its light index (one past the descriptors) and the state
/// its callbacks get (owned by [`Harness::envs`]).
#[derive(Clone, Copy)]
struct Env {
    light: u32,
    state: *const EnvState,
}

impl Env {
    fn state(&self) -> &EnvState {
        // SAFETY: the states live in `Harness::envs` until the harness is dropped, after
        // every handle is freed.
        unsafe { &*self.state }
    }
}

/// A live cut: its handle and, once built, the light count of its tree and its size, and
/// whether it is BRDF-oriented (`ml_cut_build_bl`) rather than a split cut.
struct Cut {
    p: *mut ml_cut,
    built: Option<(usize, usize)>,
    bl: bool,
}

/// A live estimator: its handle, its tree's light count and environment, and the shading
/// point it was set up at.
struct Est {
    p: *mut ml_estimator,
    lights: usize,
    env: Option<Env>,
    sp: Option<ml_shading_point>,
}

/// The live handles of one input's run, the environments' states (kept until the end: a
/// tree's environment is called by its estimators after the tree is freed), and the bytes of
/// its last serialized tree (with that tree's light descriptors and environment when it
/// holds them, and its handle while it is live).
struct Harness<'a> {
    input: &'a Input,
    at: usize,
    trees: Vec<Tree>,
    cuts: Vec<Cut>,
    ests: Vec<Est>,
    accs: Vec<*mut ml_acceptor>,
    caches: Vec<visibility_cache::Cache>,
    serialized: Option<Vec<u8>>,
    serialized_lights: Option<(Vec<ml_light>, Option<EnvSpec>)>,
    serialized_tree: Option<*mut ml_tree>,
    // Boxed: their addresses are the callbacks' user data, and must not move as it grows.
    #[allow(clippy::vec_box)]
    envs: Vec<Box<EnvState>>,
}

fn message() -> String {
    // SAFETY: never NULL, NUL-terminated, valid until the thread's next failing call.
    unsafe { CStr::from_ptr(ml_last_error_message()) }
        .to_string_lossy()
        .into_owned()
}

/// Picks the live handle `h` refers to: (index in `live`, the pointer to pass, misaligned).
fn pick<T>(h: Handle, live: &[*mut T]) -> (Option<usize>, *mut T, bool) {
    match h {
        Handle::Null => (None, ptr::null_mut(), false),
        _ if live.is_empty() => (None, ptr::null_mut(), false),
        Handle::Live(i) => {
            let i = usize::from(i) % live.len();
            (Some(i), live[i], false)
        }
        Handle::Misaligned(i) => {
            let i = usize::from(i) % live.len();
            (None, live[i].cast::<u8>().wrapping_add(1).cast(), true)
        }
    }
}

fn nan32(v: f32) -> bool {
    v.is_nan()
}

/// Every channel finite and ≥ 0.
fn colour_ok(c: ml_rgb) -> bool {
    [c.r, c.g, c.b].iter().all(|v| v.is_finite() && *v >= 0.0)
}

/// The same bytes (values of types without padding: bit for bit, NaN included).
fn same_bits<T: Copy>(a: &T, b: &T) -> bool {
    let n = core::mem::size_of::<T>();
    // SAFETY: both are `n` initialised bytes (the types compared have no padding).
    let (x, y) = unsafe {
        (
            core::slice::from_raw_parts((a as *const T).cast::<u8>(), n),
            core::slice::from_raw_parts((b as *const T).cast::<u8>(), n),
        )
    };
    x == y
}

/// Every channel of an estimate finite and ≥ 0.
fn estimate_ok(e: ml_rgb64) -> bool {
    [e.r, e.g, e.b].iter().all(|v| v.is_finite() && *v >= 0.0)
}

impl Harness<'_> {
    fn fail(&self, what: impl fmt::Display) -> ! {
        panic!(
            "op {} ({:?}): {what}\ninput: {:?}",
            self.at, self.input.ops[self.at], self.input
        )
    }

    fn ensure(&self, cond: bool, what: impl FnOnce() -> String) {
        if !cond {
            self.fail(what())
        }
    }

    /// The checks every call gets; `true` on success.
    fn status(&self, name: &str, s: ml_status, bufs: &[&dyn Buf]) -> bool {
        if s == ML_ERR_INTERNAL {
            self.fail(format_args!("{name}: ML_ERR_INTERNAL: {}", message()));
        }
        self.ensure((ML_OK..=ML_ERR_STATE).contains(&s), || {
            format!("{name}: status {s} is no ml_status")
        });
        if s == ML_OK {
            self.ensure(!bufs.iter().any(|b| b.misaligned()), || {
                format!("{name}: succeeded with a misaligned pointer")
            });
            return true;
        }
        let m = message();
        self.ensure(
            m.starts_with(&format!("{name}: ")) && m.len() > name.len() + 2,
            || format!("{name}: status {s} with the message {m:?}"),
        );
        self.ensure(bufs.iter().all(|b| b.untouched()), || {
            format!("{name}: status {s} ({m}) and an output written")
        });
        false
    }

    /// The live tree `h` refers to (none for NULL and misaligned handles).
    fn tree_at(&self, h: Handle) -> Option<&Tree> {
        let ptrs: Vec<_> = self.trees.iter().map(|t| t.p).collect();
        pick(h, &ptrs).0.map(|i| &self.trees[i])
    }

    fn tree(&self, h: Handle) -> (*mut ml_tree, usize, HandleArg) {
        let ptrs: Vec<_> = self.trees.iter().map(|t| t.p).collect();
        let (i, p, mis) = pick(h, &ptrs);
        (p, i.map_or(0, |i| self.trees[i].lights), HandleArg(mis))
    }

    fn cut(&self, h: Handle) -> (Option<usize>, *mut ml_cut, HandleArg) {
        let ptrs: Vec<_> = self.cuts.iter().map(|c| c.p).collect();
        let (i, p, mis) = pick(h, &ptrs);
        (i, p, HandleArg(mis))
    }

    fn est(&self, h: Handle) -> (Option<usize>, *mut ml_estimator, HandleArg) {
        let ptrs: Vec<_> = self.ests.iter().map(|e| e.p).collect();
        let (i, p, mis) = pick(h, &ptrs);
        (i, p, HandleArg(mis))
    }

    fn acc(&self, h: Handle) -> (Option<usize>, *mut ml_acceptor, HandleArg) {
        let (i, p, mis) = pick(h, &self.accs);
        (i, p, HandleArg(mis))
    }

    fn cache(&self, h: Handle) -> (Option<usize>, *mut ml_visibility_cache, HandleArg) {
        let ptrs: Vec<_> = self.caches.iter().map(|c| c.p).collect();
        let (i, p, mis) = pick(h, &ptrs);
        (i, p, HandleArg(mis))
    }

    fn sample(&self, name: &str, s: ml_sampled_light, n: usize) {
        if s.light == ML_NO_LIGHT {
            self.ensure(s.pmf == 0.0, || {
                format!("{name}: no light with pmf {}", s.pmf)
            });
        } else {
            self.ensure((s.light as usize) < n, || {
                format!("{name}: light {} of {n}", s.light)
            });
            self.ensure(s.pmf > 0.0 && s.pmf <= 1.0, || {
                format!("{name}: light {} with pmf {}", s.light, s.pmf)
            });
        }
    }

    /// The pmf `query` gives a sampled light: what the sample reported (1e-5 relative).
    fn queried(&self, name: &str, r: ml_sampled_light, query: impl Fn(u32, *mut f32) -> ml_status) {
        if r.light == ML_NO_LIGHT {
            return;
        }
        let mut q = Out::<f32>::one(Ptr::Valid);
        let s = query(r.light, q.p());
        self.ensure(s == ML_OK, || {
            format!("{name} of a sampled light: {s} ({})", message())
        });
        let q = q.get(0);
        self.ensure((q - r.pmf).abs() <= 1e-5 * q.max(r.pmf), || {
            format!("{name}: {q} of a light sampled with pmf {}", r.pmf)
        });
    }

    fn pmf(&self, name: &str, p: f32) {
        self.ensure((0.0..=1.0).contains(&p), || format!("{name}: pmf {p}"));
    }

    fn light_point(&self, name: &str, p: &ml_light_point) {
        let fields = [
            p.position.x,
            p.position.y,
            p.position.z,
            p.normal.x,
            p.normal.y,
            p.normal.z,
            p.direction.x,
            p.direction.y,
            p.direction.z,
            p.distance,
            p.pdf,
            p.radiance.r,
            p.radiance.g,
            p.radiance.b,
        ];
        self.ensure(!fields.iter().any(|&v| nan32(v)), || {
            format!("{name}: NaN in {p:?}")
        });
        self.ensure(p.pdf >= 0.0 && p.pdf.is_finite(), || {
            format!("{name}: pdf of {p:?}")
        });
        self.ensure(p.delta <= 1, || format!("{name}: delta of {p:?}"));
        if p.pdf > 0.0 {
            self.ensure(p.distance > 0.0 && colour_ok(p.radiance), || {
                format!("{name}: {p:?}")
            });
        }
    }

    fn weighted(&self, name: &str, w: &ml_weighted) {
        self.ensure(
            (0.0..=1.0).contains(&w.weight)
                && !nan32(w.pdf)
                && w.scale >= 0.0
                && w.scale.is_finite(),
            || format!("{name}: {w:?}"),
        );
    }

    /// A new environment state of `spec`, kept until the end of the run.
    fn new_env(&mut self, spec: EnvSpec) -> *const EnvState {
        let b = EnvState::new(spec);
        let p: *const EnvState = &*b;
        self.envs.push(b);
        p
    }

    /// Forgets what the environment's callbacks did (before a call that may call them).
    fn env_reset(env: Option<Env>) {
        if let Some(e) = env {
            e.state().take();
        }
    }

    /// After a call on a tree with the environment `env` (status `s`): a bad value from its
    /// callbacks made the call `ML_ERR_INVALID_ARGUMENT`, and only one makes its message name
    /// the environment's values. Whether one was returned.
    fn env_check(&self, name: &str, env: Option<Env>, s: ml_status) -> bool {
        let Some(e) = env else { return false };
        let log = e.state().take();
        if log.bad {
            self.ensure(s == ML_ERR_INVALID_ARGUMENT, || {
                format!(
                    "{name}: {s} after the environment's callbacks returned a bad value ({:?})",
                    e.state().spec
                )
            });
        } else if s == ML_ERR_INVALID_ARGUMENT {
            let m = message();
            self.ensure(!m.contains("environment->"), || {
                format!(
                    "{name}: {m:?} from valid callbacks ({:?}, {} calls)",
                    e.state().spec,
                    log.calls
                )
            });
        }
        log.bad
    }

    /// A light point of the environment `env` (sampled, or reached by an escaping ray)
    /// carries its radiance and pdf, at distance +∞.
    fn env_point(&self, name: &str, env: Env, p: &ml_light_point) {
        let spec = env.state().spec;
        if !spec.good() || p.pdf == 0.0 {
            return;
        }
        let r = p.radiance;
        let l = spec.radiance.to_bits();
        self.ensure(
            p.distance == f32::INFINITY
                && p.pdf.to_bits() == spec.pdf.to_bits()
                && r.r.to_bits() == l
                && r.g.to_bits() == l
                && r.b.to_bits() == l,
            || format!("{name}: the environment's point {p:?} of {spec:?}"),
        );
    }

    fn run(&mut self) {
        for at in 0..self.input.ops.len().min(MAX_OPS) {
            self.at = at;
            self.op(&self.input.ops[at]);
        }
    }

    /// One operation, by the family of the ABI it calls (each in its own module).
    fn op(&mut self, op: &Op) {
        match op {
            Op::Build { .. }
            | Op::Load { .. }
            | Op::Serialize { .. }
            | Op::Stats { .. }
            | Op::FreeTree(_)
            | Op::SampleTl { .. }
            | Op::PmfTl { .. }
            | Op::SampleBl { .. }
            | Op::PmfBl { .. }
            | Op::SampleTlBatch { .. }
            | Op::PmfTlBatch { .. }
            | Op::SampleBlBatch { .. }
            | Op::PmfBlBatch { .. }
            | Op::BuildParallel { .. }
            | Op::LoadWithLights { .. } => self.tree_op(op),
            Op::LightSamplePoint { .. }
            | Op::LightPdfPoint { .. }
            | Op::LightSamplePointBatch { .. } => self.light_op(op),
            Op::CutCreate { .. }
            | Op::CutFree(_)
            | Op::CutBuild { .. }
            | Op::CutBuildSplit { .. }
            | Op::CutSize { .. }
            | Op::CutSample { .. }
            | Op::CutPmf { .. }
            | Op::CutSampleClusters { .. }
            | Op::CutPmfIn { .. } => self.cut_op(op),
            Op::BrdfSample { .. } | Op::BrdfPdf { .. } => self.brdf_op(op),
            Op::DirectEstimate { .. }
            | Op::EstimatorCreate { .. }
            | Op::EstimatorFree(_)
            | Op::SetPoint { .. }
            | Op::Estimate { .. }
            | Op::Start(_)
            | Op::Next { .. }
            | Op::Weigh { .. }
            | Op::BsdfHits { .. }
            | Op::Run { .. }
            | Op::DirectEstimateBatch { .. }
            | Op::EnvBuild { .. }
            | Op::EstimateEnv { .. }
            | Op::BsdfHitsEnv { .. }
            | Op::RunEnv { .. } => self.estimator_op(op),
            Op::AcceptorCreate { .. }
            | Op::AcceptorFree(_)
            | Op::SetImportons { .. }
            | Op::Luminance { .. }
            | Op::Accept { .. }
            | Op::AcceptorStats { .. } => self.acceptor_op(op),
            Op::CacheCreate { .. }
            | Op::CacheFree(_)
            | Op::Cache { .. }
            | Op::SetCache { .. }
            | Op::Record { .. } => self.cache_op(op),
            Op::Defaults { out, status } => self.defaults(*out, *status),
        }
    }

    fn release(&mut self) {
        for t in self.trees.drain(..) {
            ml_tree_free(t.p);
        }
        for c in self.cuts.drain(..) {
            ml_cut_free(c.p);
        }
        for e in self.ests.drain(..) {
            ml_estimator_free(e.p);
        }
        for a in self.accs.drain(..) {
            ml_acceptor_free(a);
        }
        for c in self.caches.drain(..) {
            ml_visibility_cache_free(c.p);
        }
    }
}

impl Drop for Harness<'_> {
    fn drop(&mut self) {
        self.release();
    }
}

/// Runs the operations with the checks of [the `ffi` module's documentation](crate::ffi).
pub fn check(input: &Input) {
    let mut h = Harness {
        input,
        at: 0,
        trees: Vec::new(),
        cuts: Vec::new(),
        ests: Vec::new(),
        accs: Vec::new(),
        caches: Vec::new(),
        serialized: None,
        serialized_lights: None,
        serialized_tree: None,
        envs: Vec::new(),
    };
    h.run();
}
