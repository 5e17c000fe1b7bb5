//! The light tree: build from light descriptors, free, stats, serialize / load, TL and BL
//! sampling and pmfs (single and batch), points on lights.

use crate::arg;
use crate::direct::{direct_error, ml_environment, HostEnvironment};
use crate::error::{ml_status, Error, Result};
use crate::ffi_fn;
use crate::limits::{ML_MAX_BUCKETS, ML_MIN_BUCKETS};
use crate::types::{
    build_error, finite3, light, ml_light, ml_light_point, ml_sampled_light, ml_shading_point,
    ml_tl_point, ml_vec3, receiver, shading_point, tl_point, unit,
};
use manylights::error::LightMismatch;
use manylights::{
    BlImportance, BuildError, BuildOptions, FormatError, Importance, Light, LightSet, LightTree,
    SampledLight, Serial, TlImportance,
};
use std::sync::Arc;

/// The most lights a tree may hold (`ml_tree_build`'s `count`).
pub const ML_MAX_LIGHTS: u32 = 2_147_483_646;
const _: () = assert!(ML_MAX_LIGHTS == manylights::tree::MAX_LIGHTS);

/// What a tree handle holds: the lights with their tree (built from descriptors, or loaded
/// with them), or a tree alone (loaded from bytes without them).
#[derive(Debug)]
pub(crate) enum TreeData {
    /// Built by `ml_tree_build` or loaded by `ml_tree_load_with_lights`.
    Set(LightSet),
    /// Loaded by `ml_tree_load`: sampling and pmfs only.
    Tree(LightTree),
}

impl TreeData {
    #[inline]
    pub(crate) fn tree(&self) -> &LightTree {
        match self {
            TreeData::Set(s) => s.tree(),
            TreeData::Tree(t) => t,
        }
    }

    /// The lights and their tree, for calls that need the lights.
    pub(crate) fn set(&self) -> Result<&LightSet> {
        match self {
            TreeData::Set(s) => Ok(s),
            TreeData::Tree(_) => Err(Error::state(
                "tree: loaded from bytes, it holds no light descriptors (load it with \
                 ml_tree_load_with_lights, or build it with ml_tree_build, for points on \
                 lights and the direct estimators)",
            )),
        }
    }

    /// The light of index `light` (checked).
    pub(crate) fn light(&self, light: u32, name: &str) -> Result<&Light> {
        let set = self.set()?;
        check_light(light, set.len(), name)?;
        Ok(&set.lights()[light as usize])
    }
}

/// A light tree (opaque). Immutable once built: one tree may be shared by any number of
/// threads, each calling the `const ml_tree *` functions at once. Cuts and estimators made
/// from it keep it alive: it may be freed before them.
pub struct ml_tree {
    pub(crate) data: Arc<TreeData>,
}

/// Options of `ml_tree_build` (`ml_build_options_default` fills the defaults).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ml_build_options {
    /// SAOH buckets per axis, in [`ML_MIN_BUCKETS`, `ML_MAX_BUCKETS`] = [12, 64]; 0 for the
    /// default (12).
    pub buckets: u32,
}

/// Size and shape of a tree.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ml_tree_statistics {
    /// Lights the tree was built from.
    pub lights: usize,
    /// Lights that can be sampled: those in the node tree (of positive energy), and the
    /// distant and environment lights of positive irradiance (for the environment, a positive
    /// bound), which `ml_tree_sample_tl` chooses at the root.
    pub sampled_lights: usize,
    /// Tree nodes.
    pub nodes: usize,
    /// Bytes of the tree's arrays (nodes, node statistics, light paths, the lights' checksums).
    pub bytes: usize,
    /// Levels of nodes (0 for a tree that samples nothing).
    pub depth: u32,
    /// 1 if the tree holds its light descriptors (built by `ml_tree_build` or loaded by
    /// `ml_tree_load_with_lights`), 0 if loaded by `ml_tree_load`.
    pub has_lights: u32,
    /// Total energy of the sampled lights: the sum of their fluxes in W (see `ml_light_kind`),
    /// as the root's slots store it (each rounded up by at most 2⁻¹¹ relative).
    pub total_energy: f32,
}

/// Checks a light index against a count.
#[inline]
pub(crate) fn check_light(light: u32, count: usize, name: &str) -> Result<()> {
    if (light as usize) < count {
        Ok(())
    } else {
        Err(Error::invalid(format_args!(
            "{name}: light index {light} is out of range (the tree has {count} lights)"
        )))
    }
}

/// The tree behind a handle.
#[inline]
pub(crate) fn tree_arg<'a>(tree: *const ml_tree) -> Result<&'a Arc<TreeData>> {
    Ok(&arg::get(tree, "tree")?.data)
}

/// Fills `*out` with the default build options.
///
/// Errors: `ML_ERR_NULL` if `out` is NULL.
#[no_mangle]
pub extern "C" fn ml_build_options_default(out: *mut ml_build_options) -> ml_status {
    ffi_fn!("ml_build_options_default", {
        arg::out(out, "out")?.write(ml_build_options { buckets: 0 });
        Ok(())
    })
}

/// Builds a tree from `count` light descriptors (`lights` may be NULL when `count` is 0: a
/// tree that samples nothing) and the host's `environment` (NULL: none; see
/// `ml_environment`: the tree copies the struct and keeps calling its callbacks) with
/// `options` (NULL: the defaults). Light indices everywhere else are positions in this
/// array; the environment, when given, is light `count`, one past the array. Every light is
/// validated: the error names its index and field, e.g. `lights[17].sphere.radius must be
/// positive (got -1)`. Lights of zero intensity, radiance or area are accepted and never sampled. Free the tree with
/// `ml_tree_free`.
///
/// Errors: `ML_ERR_NULL` (`lights` with `count` > 0, `out`, `environment->sample`,
/// `environment->eval`); `ML_ERR_INVALID_ARGUMENT` (a bad light, a bad option, more than
/// `ML_MAX_LIGHTS` lights, a light's energy above `ML_MAX_LIGHT_ENERGY`, coordinates beyond
/// `ML_MAX_COORDINATE`, a total energy above `ML_MAX_TOTAL_ENERGY`, a tree deeper than
/// `ML_MAX_DEPTH`, bad `environment->irradiance_bounds`: the message names the macro, the
/// light, the field and its value).
#[no_mangle]
pub extern "C" fn ml_tree_build(
    lights: *const ml_light,
    count: usize,
    environment: *const ml_environment,
    options: *const ml_build_options,
    out: *mut *mut ml_tree,
) -> ml_status {
    ffi_fn!("ml_tree_build", {
        build_tree(
            lights,
            count,
            environment,
            options,
            out,
            |core, env, opts| Ok(build_serial(core, env, opts)),
        )
    })
}

/// `ml_tree_build` with the build's work spread over `threads` threads (0: one per core),
/// made for the call: the same tree, byte for byte (`ml_tree_serialize`), as
/// `ml_tree_build` gives, sooner on a machine with idle cores. With `threads` = 1 the build
/// runs on the calling thread and starts no other.
///
/// Errors: those of `ml_tree_build`; `ML_ERR_INVALID_ARGUMENT` if `threads` is above 1024;
/// `ML_ERR_INTERNAL` if the threads cannot be started.
#[no_mangle]
pub extern "C" fn ml_tree_build_parallel(
    lights: *const ml_light,
    count: usize,
    environment: *const ml_environment,
    options: *const ml_build_options,
    threads: u32,
    out: *mut *mut ml_tree,
) -> ml_status {
    ffi_fn!("ml_tree_build_parallel", {
        if threads > 1024 {
            return Err(Error::invalid(format_args!(
                "threads must be at most 1024 (got {threads})"
            )));
        }
        build_tree(
            lights,
            count,
            environment,
            options,
            out,
            |core, env, opts| {
                if threads == 1 {
                    // On the caller's thread: no pool, no hand-off (the same tree).
                    return Ok(build_serial(core, env, opts));
                }
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads as usize)
                    .build()
                    .map_err(|e| {
                        Error::internal(format_args!("threads: cannot start them ({e})"))
                    })?;
                Ok(pool.install(|| match env {
                    Some(env) => LightSet::build_with_environment(core, env, opts, &RayonJoin),
                    None => LightSet::build_parallel(core, opts, &RayonJoin),
                }))
            },
        )
    })
}

/// The build's fork-join on the rayon pool the call runs in.
// The C library depends on no crate of the workspace but the core: the tools' `RayonJoin`
// (in the test kit) is not a dependency a product library takes.
struct RayonJoin;

impl manylights::Join for RayonJoin {
    fn join<A, B, RA, RB>(&self, a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA + Send,
        B: FnOnce() -> RB + Send,
        RA: Send,
        RB: Send,
    {
        rayon::join(a, b)
    }
}

/// The light set of `ml_tree_build`, on the calling thread.
fn build_serial(
    core: Vec<Light>,
    env: Option<HostEnvironment>,
    opts: &BuildOptions,
) -> std::result::Result<LightSet, BuildError> {
    match env {
        Some(env) => LightSet::build_with_environment(core, env, opts, &Serial),
        None => LightSet::build_with(core, opts),
    }
}

/// The checks of `ml_tree_build`, then `build` of the lights, the environment and the
/// options.
fn build_tree(
    lights: *const ml_light,
    count: usize,
    environment: *const ml_environment,
    options: *const ml_build_options,
    out: *mut *mut ml_tree,
    build: impl FnOnce(
        Vec<Light>,
        Option<HostEnvironment>,
        &BuildOptions,
    ) -> Result<std::result::Result<LightSet, BuildError>>,
) -> Result<()> {
    let descs = arg::slice(lights, count, "lights")?;
    let env = environment_arg(environment)?;
    let options = arg::opt(options, "options")?;
    let out = arg::out(out, "out")?;
    let mut opts = BuildOptions::default();
    if let Some(o) = options {
        match o.buckets {
            0 => {}
            b @ ML_MIN_BUCKETS..=ML_MAX_BUCKETS => opts.buckets = b as usize,
            b => {
                return Err(Error::invalid(format_args!(
                    "options.buckets must be 0 or in [12, 64], ML_MIN_BUCKETS to \
                     ML_MAX_BUCKETS (got {b})"
                )))
            }
        }
    }
    if count > ML_MAX_LIGHTS as usize {
        return Err(Error::invalid(format_args!(
            "count: {count} lights, at most ML_MAX_LIGHTS ({ML_MAX_LIGHTS}) are supported"
        )));
    }
    let mut core = Vec::with_capacity(count);
    for (i, l) in descs.iter().enumerate() {
        core.push(light(l, i, "lights")?);
    }
    let set = build(core, env, &opts)?.map_err(|e| build_error(e, descs, "lights"))?;
    out.write(arg::into_handle(ml_tree {
        data: Arc::new(TreeData::Set(set)),
    }));
    Ok(())
}

/// The host's environment of a build or load (NULL: none), checked.
fn environment_arg(environment: *const ml_environment) -> Result<Option<HostEnvironment>> {
    match arg::opt(environment, "environment")? {
        Some(e) => Ok(Some(HostEnvironment::new(e)?)),
        None => Ok(None),
    }
}

/// Frees a tree (NULL: nothing). Cuts and estimators made from it stay valid.
#[no_mangle]
pub extern "C" fn ml_tree_free(tree: *mut ml_tree) -> ml_status {
    ffi_fn!("ml_tree_free", { arg::free_handle(tree, "tree") })
}

/// The tree's size and shape.
///
/// Errors: `ML_ERR_NULL` (`tree`, `out`).
#[no_mangle]
pub extern "C" fn ml_tree_stats(tree: *const ml_tree, out: *mut ml_tree_statistics) -> ml_status {
    ffi_fn!("ml_tree_stats", {
        let data = tree_arg(tree)?;
        let out = arg::out(out, "out")?;
        let t = data.tree();
        let s = t.stats();
        out.write(ml_tree_statistics {
            lights: s.lights as usize,
            sampled_lights: s.sampled_lights as usize,
            nodes: s.nodes as usize,
            bytes: s.bytes,
            depth: s.depth,
            has_lights: u32::from(matches!(**data, TreeData::Set(_))),
            total_energy: t.total_energy(),
        });
        Ok(())
    })
}

/// The number of bytes `ml_tree_serialize` writes for this tree.
///
/// Errors: `ML_ERR_NULL` (`tree`, `out`).
#[no_mangle]
pub extern "C" fn ml_tree_serialized_size(tree: *const ml_tree, out: *mut usize) -> ml_status {
    ffi_fn!("ml_tree_serialized_size", {
        let data = tree_arg(tree)?;
        let out = arg::out(out, "out")?;
        out.write(data.tree().as_bytes().len());
        Ok(())
    })
}

/// Writes the tree as bytes (a versioned format for the same library version and byte order,
/// with a CRC-64 of everything after its header and a checksum of the lights per block of 64;
/// the light descriptors themselves are not included) to `buffer` of `capacity` bytes, and
/// their number to `*written`. Read back with `ml_tree_load`, or with
/// `ml_tree_load_with_lights` and the descriptors it was built from.
///
/// Errors: `ML_ERR_NULL` (`tree`, `buffer` with `capacity` > 0, `written`);
/// `ML_ERR_BUFFER_TOO_SMALL` when `capacity` is below `ml_tree_serialized_size`.
#[no_mangle]
pub extern "C" fn ml_tree_serialize(
    tree: *const ml_tree,
    buffer: *mut u8,
    capacity: usize,
    written: *mut usize,
) -> ml_status {
    ffi_fn!("ml_tree_serialize", {
        let data = tree_arg(tree)?;
        let mut buf = arg::out_slice(buffer, capacity, "buffer")?;
        let written = arg::out(written, "written")?;
        let bytes = data.tree().as_bytes();
        if bytes.len() > buf.len() {
            return Err(Error::too_small(format_args!(
                "capacity: {capacity} bytes, the tree needs {}",
                bytes.len()
            )));
        }
        for (i, &b) in bytes.iter().enumerate() {
            buf.set(i, b);
        }
        written.write(bytes.len());
        Ok(())
    })
}

/// Loads a tree written by `ml_tree_serialize`. The header is checked first (magic, version,
/// length and the CRC-64 of the rest) and nothing else is read unless it matches; then the tree
/// is validated fully: corrupt, truncated or foreign bytes give `ML_ERR_FORMAT`, never a crash
/// or a bad tree (a change confined to 64 consecutive bits is always caught, any other
/// change escapes with probability 2⁻⁶⁴). The loaded tree samples and answers pmfs (TL, BL,
/// cuts); it has no light descriptors, so points on lights and the direct estimators need
/// `ml_tree_load_with_lights` or `ml_tree_build` (they return `ML_ERR_STATE`).
///
/// Errors: `ML_ERR_NULL` (`bytes` with `len` > 0, `out`); `ML_ERR_FORMAT`.
#[no_mangle]
pub extern "C" fn ml_tree_load(bytes: *const u8, len: usize, out: *mut *mut ml_tree) -> ml_status {
    ffi_fn!("ml_tree_load", {
        let bytes = arg::slice(bytes, len, "bytes")?;
        let out = arg::out(out, "out")?;
        let tree =
            LightTree::from_bytes(bytes).map_err(|e| Error::format(format_args!("bytes: {e}")))?;
        out.write(arg::into_handle(ml_tree {
            data: Arc::new(TreeData::Tree(tree)),
        }));
        Ok(())
    })
}

/// Loads a tree written by `ml_tree_serialize` together with the `count` light descriptors it
/// was built from (`lights` may be NULL when `count` is 0) and its environment (NULL: it had
/// none; else one with the same `irradiance_bounds`, as `ml_tree_build` takes it): the bytes are checked as
/// `ml_tree_load` checks them, then the lights against the tree, in index order by blocks of
/// 64: their count, each light valid, in the tree exactly when its energy is positive, its
/// bounds inside its slot, and each block's checksum the one the bytes store. The tree is then
/// the one it was saved from with its lights: sampling, pmfs, points on lights and every
/// estimator give bit for bit what the saved tree gives. Free it with `ml_tree_free`.
///
/// Errors: `ML_ERR_NULL` (`bytes` with `len` > 0, `lights` with `count` > 0, `out`,
/// `environment->sample`, `environment->eval`); `ML_ERR_FORMAT` (corrupt bytes, or lights other than the ones the tree was built from: the
/// message names the first mismatch, `lights[123]` or the block `lights[64..128]`);
/// `ML_ERR_INVALID_ARGUMENT` (a light descriptor no tree could be built from, named as
/// `ml_tree_build` names it).
#[no_mangle]
pub extern "C" fn ml_tree_load_with_lights(
    bytes: *const u8,
    len: usize,
    lights: *const ml_light,
    count: usize,
    environment: *const ml_environment,
    out: *mut *mut ml_tree,
) -> ml_status {
    ffi_fn!("ml_tree_load_with_lights", {
        let bytes = arg::slice(bytes, len, "bytes")?;
        let descs = arg::slice(lights, count, "lights")?;
        let env = environment_arg(environment)?;
        let out = arg::out(out, "out")?;
        let mut core = Vec::with_capacity(count);
        for (i, l) in descs.iter().enumerate() {
            core.push(light(l, i, "lights")?);
        }
        let set = match env {
            Some(env) => LightSet::from_bytes_with_environment(bytes, core, env),
            None => LightSet::from_bytes(bytes, core),
        };
        let set = set.map_err(|e| match e {
            FormatError::Lights(LightMismatch::Invalid(b)) => build_error(b, descs, "lights"),
            FormatError::Lights(m) => Error::format(format_args!("lights: {}", mismatch(m))),
            e => Error::format(format_args!("bytes: {e}")),
        })?;
        out.write(arg::into_handle(ml_tree {
            data: Arc::new(TreeData::Set(set)),
        }));
        Ok(())
    })
}

/// A light mismatch in the C array's terms.
fn mismatch(m: LightMismatch) -> String {
    match m {
        LightMismatch::Count { tree, given } => {
            format!("count is {given}, the tree was built from {tree} lights")
        }
        LightMismatch::Sampled {
            light,
            in_tree: true,
        } => format!(
            "lights[{light}] has no energy but the tree holds it: not the light the tree was \
             built from"
        ),
        LightMismatch::Sampled { light, .. } => format!(
            "lights[{light}] has energy but the tree does not hold it: not the light the tree \
             was built from"
        ),
        LightMismatch::Escapes { light } => format!(
            "lights[{light}] lies outside its slot's bounds: not the light the tree was built \
             from (moved, turned, grown or brighter)"
        ),
        LightMismatch::Changed { first, end } => format!(
            "lights[{first}..{end}] differ from the lights the tree was built from (their \
             checksum), though each lies inside its slot"
        ),
        LightMismatch::Invalid(e) => e.to_string(),
        _ => m.to_string(),
    }
}

/// Samples a light with TL importance (Conty & Kulla) at `point` with the uniform number `u`
/// in [0, 1): `*out` gets the light and its pmf, or `ML_NO_LIGHT` when none can contribute.
/// The point's `receiver` decides which lights can (`ml_receiver`).
///
/// Errors: `ML_ERR_NULL` (`tree`, `point`, `out`); `ML_ERR_INVALID_ARGUMENT` (a non-finite
/// position or normal, a `receiver` that is no `ml_receiver`, `u` outside [0, 1)).
#[no_mangle]
pub extern "C" fn ml_tree_sample_tl(
    tree: *const ml_tree,
    point: *const ml_tl_point,
    u: f32,
    out: *mut ml_sampled_light,
) -> ml_status {
    ffi_fn!("ml_tree_sample_tl", {
        let data = tree_arg(tree)?;
        let point = arg::get(point, "point")?;
        let out = arg::out(out, "out")?;
        let imp = tl_point(point, &|| "point".into())?;
        let u = unit(u, &|| "u".into())?;
        out.write(data.tree().sample(&imp, u).into());
        Ok(())
    })
}

/// The probability that `ml_tree_sample_tl` returns `light` at `point`: exactly the pmf it
/// reports (0 for lights that cannot contribute or have no energy, and for the lights whose
/// probability would be below `ML_MIN_PMF`: the one way a light that can contribute has pmf 0).
///
/// Errors: `ML_ERR_NULL` (`tree`, `point`, `out`); `ML_ERR_INVALID_ARGUMENT` (a non-finite
/// point, a bad `point.receiver`, `light` out of range).
#[no_mangle]
pub extern "C" fn ml_tree_pmf_tl(
    tree: *const ml_tree,
    point: *const ml_tl_point,
    light: u32,
    out: *mut f32,
) -> ml_status {
    ffi_fn!("ml_tree_pmf_tl", {
        let data = tree_arg(tree)?;
        let point = arg::get(point, "point")?;
        let out = arg::out(out, "out")?;
        let imp = tl_point(point, &|| "point".into())?;
        let t = data.tree();
        check_light(light, t.light_count() as usize, "light")?;
        out.write(t.pmf(&imp, light));
        Ok(())
    })
}

/// Samples a light with the BRDF-oriented importance (Liu et al. 2019) at the shading point
/// `sp` with `u` in [0, 1), by tree descent.
///
/// Errors: `ML_ERR_NULL` (`tree`, `sp`, `out`); `ML_ERR_INVALID_ARGUMENT` (a bad shading
/// point: the message names its field; `u` outside [0, 1)).
#[no_mangle]
pub extern "C" fn ml_tree_sample_bl(
    tree: *const ml_tree,
    sp: *const ml_shading_point,
    u: f32,
    out: *mut ml_sampled_light,
) -> ml_status {
    ffi_fn!("ml_tree_sample_bl", {
        let data = tree_arg(tree)?;
        let sp = arg::get(sp, "sp")?;
        let out = arg::out(out, "out")?;
        let imp = bl_importance(sp, &|| "sp".into())?;
        let u = unit(u, &|| "u".into())?;
        out.write(data.tree().sample(&imp, u).into());
        Ok(())
    })
}

/// The probability that `ml_tree_sample_bl` returns `light` at `sp`.
///
/// Errors: `ML_ERR_NULL` (`tree`, `sp`, `out`); `ML_ERR_INVALID_ARGUMENT` (a bad shading
/// point, `light` out of range).
#[no_mangle]
pub extern "C" fn ml_tree_pmf_bl(
    tree: *const ml_tree,
    sp: *const ml_shading_point,
    light: u32,
    out: *mut f32,
) -> ml_status {
    ffi_fn!("ml_tree_pmf_bl", {
        let data = tree_arg(tree)?;
        let sp = arg::get(sp, "sp")?;
        let out = arg::out(out, "out")?;
        let imp = bl_importance(sp, &|| "sp".into())?;
        let t = data.tree();
        check_light(light, t.light_count() as usize, "light")?;
        out.write(t.pmf(&imp, light));
        Ok(())
    })
}

/// The BL importance of a checked shading point.
#[inline]
pub(crate) fn bl_importance(
    sp: &ml_shading_point,
    path: &dyn Fn() -> String,
) -> Result<BlImportance> {
    let s = shading_point(sp, path)?;
    BlImportance::new(&s).map_err(|e| crate::types::shading_error(e, path))
}

/// TL points per chunk of a batch export: the chunk's importances and results live in two
/// arrays on the stack (about 9 KiB), so that a batch allocates nothing.
const TL_CHUNK: usize = 256;
/// Shading points per chunk of a BL batch export: the BL importance is larger (about 27 KiB
/// of stack for the chunk); as many as the core's batch descent keeps in flight.
const BL_CHUNK: usize = 32;
const _: () = assert!(TL_CHUNK * core::mem::size_of::<TlImportance>() <= 16 * 1024);
const _: () = assert!(BL_CHUNK * core::mem::size_of::<BlImportance>() <= 32 * 1024);

/// Whether a TL point is finite with a valid receiver (the fast path of the check;
/// [`tl_point`] words an error).
#[inline(always)]
fn tl_point_ok(p: &ml_tl_point) -> bool {
    let (a, b) = (p.position, p.normal);
    (a.x + a.y + a.z + b.x + b.y + b.z).is_finite() && receiver(p.receiver).is_some()
}

/// The shading points of a batch export: TL points (position and normal) or full shading
/// points (BL).
trait BatchPoint {
    /// The importance a point gives.
    type Imp: Importance + Copy;
    /// Whether the point surely passes [`BatchPoint::check`] (a fast test; `false` sends
    /// every point through the full check).
    fn surely_ok(&self) -> bool;
    /// Checks the point `points[j]`, the error naming it.
    fn check(&self, j: usize) -> Result<()>;
    /// The importance of the checked point `points[j]`.
    fn importance(&self, j: usize) -> Result<Self::Imp>;
}

impl BatchPoint for ml_tl_point {
    type Imp = TlImportance;

    #[inline(always)]
    fn surely_ok(&self) -> bool {
        tl_point_ok(self)
    }

    fn check(&self, j: usize) -> Result<()> {
        tl_point(self, &|| format!("points[{j}]")).map(drop)
    }

    #[inline]
    fn importance(&self, j: usize) -> Result<TlImportance> {
        match receiver(self.receiver) {
            Some(r) => Ok(TlImportance::with_receiver(
                self.position.into(),
                self.normal.into(),
                r,
            )),
            None => tl_point(self, &|| format!("points[{j}]")),
        }
    }
}

impl BatchPoint for ml_shading_point {
    type Imp = BlImportance;

    #[inline(always)]
    fn surely_ok(&self) -> bool {
        false
    }

    fn check(&self, j: usize) -> Result<()> {
        self.importance(j).map(drop)
    }

    #[inline]
    fn importance(&self, j: usize) -> Result<BlImportance> {
        bl_importance(self, &|| format!("points[{j}]"))
    }
}

/// What a batch export asks of the tree at each point: a sample with a uniform number
/// ([`Sample`]) or a light's pmf ([`Pmf`]).
trait BatchQuery {
    /// The per-point argument (`us[j]`, `lights[j]`).
    type Arg: Copy;
    /// The core's result per point.
    type Res: Copy;
    /// What `out[j]` holds.
    type Out: Copy;
    /// The name of the arguments' array.
    const ARGS: &'static str;
    /// The value the results' buffer starts with.
    const EMPTY: Self::Res;
    /// Whether `a` surely passes [`BatchQuery::check`] in a tree of `lights` lights.
    fn surely_ok(a: Self::Arg, lights: usize) -> bool;
    /// Checks the argument `args[j]`, the error naming it.
    fn check(a: Self::Arg, lights: usize, j: usize) -> Result<()>;
    /// The core's batch call.
    fn call<I: Importance>(
        t: &LightTree,
        imps: &[I],
        args: &[Self::Arg],
        res: &mut [Self::Res],
    ) -> core::result::Result<(), manylights::LengthMismatch>;
    /// `out[j]` from its result.
    fn put(r: Self::Res) -> Self::Out;
}

/// A light sampled with a uniform number in [0, 1) (`us`).
struct Sample;

impl BatchQuery for Sample {
    type Arg = f32;
    type Res = Option<SampledLight>;
    type Out = ml_sampled_light;
    const ARGS: &'static str = "us";
    const EMPTY: Option<SampledLight> = None;

    #[inline(always)]
    fn surely_ok(u: f32, _lights: usize) -> bool {
        (0.0..1.0).contains(&u)
    }

    fn check(u: f32, _lights: usize, j: usize) -> Result<()> {
        unit(u, &|| format!("us[{j}]")).map(drop)
    }

    #[inline]
    fn call<I: Importance>(
        t: &LightTree,
        imps: &[I],
        us: &[f32],
        res: &mut [Option<SampledLight>],
    ) -> core::result::Result<(), manylights::LengthMismatch> {
        t.sample_batch(imps, us, res)
    }

    #[inline]
    fn put(r: Option<SampledLight>) -> ml_sampled_light {
        r.into()
    }
}

/// A light's pmf (`lights`).
struct Pmf;

impl BatchQuery for Pmf {
    type Arg = u32;
    type Res = f32;
    type Out = f32;
    const ARGS: &'static str = "lights";
    const EMPTY: f32 = 0.0;

    #[inline(always)]
    fn surely_ok(l: u32, lights: usize) -> bool {
        (l as usize) < lights
    }

    fn check(l: u32, lights: usize, j: usize) -> Result<()> {
        // The element's name is written only for the error.
        if Self::surely_ok(l, lights) {
            return Ok(());
        }
        check_light(l, lights, &format!("lights[{j}]"))
    }

    #[inline]
    fn call<I: Importance>(
        t: &LightTree,
        imps: &[I],
        lights: &[u32],
        res: &mut [f32],
    ) -> core::result::Result<(), manylights::LengthMismatch> {
        t.pmf_batch(imps, lights, res)
    }

    #[inline]
    fn put(p: f32) -> f32 {
        p
    }
}

/// A batch export: `out[j]` is the query `Q` at `points[j]` with `args[j]`. Checks the
/// handle, the arrays, then every element (the first bad one is the error, before anything
/// is written); then queries in chunks of up to `K` points, each chunk's importances built
/// into an array on the stack for the core's batch call (nothing is allocated).
fn tree_batch<P: BatchPoint, Q: BatchQuery, const K: usize>(
    tree: *const ml_tree,
    points: *const P,
    args: *const Q::Arg,
    count: usize,
    out: *mut Q::Out,
) -> Result<()> {
    let data = tree_arg(tree)?;
    // `count` against the larger element, a shading point, for both kinds of point.
    arg::check_count::<ml_shading_point>(count, "count")?;
    let n = count;
    let points = arg::slice(points, n, "points")?;
    let args = arg::slice(args, n, Q::ARGS)?;
    let mut out = arg::out_slice(out, n, "out")?;
    let t = data.tree();
    let nl = t.light_count() as usize;
    for (j, (p, &a)) in points.iter().zip(args).enumerate() {
        if !(p.surely_ok() && Q::surely_ok(a, nl)) {
            p.check(j)?;
            Q::check(a, nl, j)?;
        }
    }
    let Some(first) = points.first() else {
        return Ok(());
    };
    // Filled with the first point's importance, then overwritten chunk by chunk.
    let mut imps = [first.importance(0)?; K];
    let mut res = [Q::EMPTY; K];
    for start in (0..n).step_by(K) {
        let m = K.min(n - start);
        for (j, p) in points[start..start + m].iter().enumerate() {
            imps[j] = p.importance(start + j)?;
        }
        // The slices are sized alike here: a length mismatch would be a bug, reported as an
        // internal error.
        Q::call(t, &imps[..m], &args[start..start + m], &mut res[..m])
            .map_err(|e| Error::internal(format_args!("batch lengths: {e}")))?;
        for (i, &r) in res[..m].iter().enumerate() {
            out.set(start + i, Q::put(r));
        }
    }
    Ok(())
}

/// `count` TL samples at once, bit for bit what `count` calls of `ml_tree_sample_tl` give:
/// `out[j]` for `points[j]` and `us[j]` (the throughput path). Every input is checked before
/// anything is written.
///
/// Errors: `ML_ERR_NULL` (`tree`; `points`, `us`, `out` when `count` > 0);
/// `ML_ERR_INVALID_ARGUMENT` naming the element (`points[j].normal`, `points[j].receiver`,
/// `us[j]`).
#[no_mangle]
pub extern "C" fn ml_tree_sample_tl_batch(
    tree: *const ml_tree,
    points: *const ml_tl_point,
    us: *const f32,
    count: usize,
    out: *mut ml_sampled_light,
) -> ml_status {
    ffi_fn!("ml_tree_sample_tl_batch", {
        tree_batch::<_, Sample, TL_CHUNK>(tree, points, us, count, out)
    })
}

/// `count` TL pmfs at once: `out[j]` = `ml_tree_pmf_tl(points[j], lights[j])`, bit for bit.
///
/// Errors: `ML_ERR_NULL` (`tree`; `points`, `lights`, `out` when `count` > 0);
/// `ML_ERR_INVALID_ARGUMENT` naming the element (`points[j].position`, `points[j].receiver`,
/// `lights[j]`).
#[no_mangle]
pub extern "C" fn ml_tree_pmf_tl_batch(
    tree: *const ml_tree,
    points: *const ml_tl_point,
    lights: *const u32,
    count: usize,
    out: *mut f32,
) -> ml_status {
    ffi_fn!("ml_tree_pmf_tl_batch", {
        tree_batch::<_, Pmf, TL_CHUNK>(tree, points, lights, count, out)
    })
}

/// `count` BL samples at once: `out[j]` = `ml_tree_sample_bl(points[j], us[j])`, bit for bit.
///
/// Errors: `ML_ERR_NULL` (`tree`; `points`, `us`, `out` when `count` > 0);
/// `ML_ERR_INVALID_ARGUMENT` naming the element (`points[j].material.alpha`, `us[j]`).
#[no_mangle]
pub extern "C" fn ml_tree_sample_bl_batch(
    tree: *const ml_tree,
    points: *const ml_shading_point,
    us: *const f32,
    count: usize,
    out: *mut ml_sampled_light,
) -> ml_status {
    ffi_fn!("ml_tree_sample_bl_batch", {
        tree_batch::<_, Sample, BL_CHUNK>(tree, points, us, count, out)
    })
}

/// `count` BL pmfs at once: `out[j]` = `ml_tree_pmf_bl(points[j], lights[j])`, bit for bit.
///
/// Errors: `ML_ERR_NULL` (`tree`; `points`, `lights`, `out` when `count` > 0);
/// `ML_ERR_INVALID_ARGUMENT` naming the element.
#[no_mangle]
pub extern "C" fn ml_tree_pmf_bl_batch(
    tree: *const ml_tree,
    points: *const ml_shading_point,
    lights: *const u32,
    count: usize,
    out: *mut f32,
) -> ml_status {
    ffi_fn!("ml_tree_pmf_bl_batch", {
        tree_batch::<_, Pmf, BL_CHUNK>(tree, points, lights, count, out)
    })
}

/// Samples a point on light `light` as seen from `x`, with `u0`, `u1` in [0, 1): its position,
/// direction, distance, solid-angle pdf and arriving radiance (`pdf = 0` when the light cannot
/// reach x). The sample's contribution to an estimate is `f · radiance · cos θ / (pmf · pdf)`
/// (`radiance` is already divided by d² for point, spot and VPL lights, whose `pdf` is 1: see
/// `ml_light_point`). For the environment (light `count` of `ml_tree_build`) the point is the
/// tree's environment's sample: `environment->sample(u0, u1)` as a point at infinity
/// (`position` = `direction`, `distance` = +infinity), `pdf = 0` when it returns none.
///
/// Errors: `ML_ERR_NULL` (`tree`, `out`); `ML_ERR_INVALID_ARGUMENT` (`light` out of range, a
/// non-finite `x`, `u0` or `u1` outside [0, 1), a bad value from `environment->sample`);
/// `ML_ERR_STATE` (a tree loaded without its lights).
#[no_mangle]
pub extern "C" fn ml_light_sample_point(
    tree: *const ml_tree,
    light: u32,
    x: ml_vec3,
    u0: f32,
    u1: f32,
    out: *mut ml_light_point,
) -> ml_status {
    ffi_fn!("ml_light_sample_point", {
        let data = tree_arg(tree)?;
        let out = arg::out(out, "out")?;
        data.light(light, "light")?;
        let x = finite3(x, &|| "x".into())?;
        let u0 = unit(u0, &|| "u0".into())?;
        let u1 = unit(u1, &|| "u1".into())?;
        let p = data.set()?.sample_point(light, x, [u0, u1]);
        out.write(p.map_err(direct_error)?.into());
        Ok(())
    })
}

/// The solid-angle pdf at `x` with which `ml_light_sample_point` returns the point `point` of
/// light `light` (0 where it returns none). Point, spot and VPL lights have the convention of
/// `ml_light_point.pdf`: the delta's weight reported as 1 at the light's position (0 at any
/// other point). For a distant light and the environment `point` is the direction (as their
/// points' `position` is); the environment's pdf is `environment->eval`'s.
///
/// Errors: `ML_ERR_NULL` (`tree`, `out`); `ML_ERR_INVALID_ARGUMENT` (`light` out of range,
/// non-finite `x` or `point`, a bad value from `environment->eval`); `ML_ERR_STATE` (a tree
/// loaded without its lights).
#[no_mangle]
pub extern "C" fn ml_light_pdf_point(
    tree: *const ml_tree,
    light: u32,
    x: ml_vec3,
    point: ml_vec3,
    out: *mut f32,
) -> ml_status {
    ffi_fn!("ml_light_pdf_point", {
        let data = tree_arg(tree)?;
        let out = arg::out(out, "out")?;
        data.light(light, "light")?;
        let x = finite3(x, &|| "x".into())?;
        let p = finite3(point, &|| "point".into())?;
        let pdf = data.set()?.pdf_point(light, x, p).map_err(direct_error)?;
        out.write(pdf);
        Ok(())
    })
}

/// `count` points on lights at once, for wavefront hosts: `out[j]` is what
/// `ml_light_sample_point(tree, lights[j], xs[j], u0s[j], u1s[j])` gives, bit for bit. Every
/// input is checked before anything is written (a bad value from `environment->sample`, the
/// host's, is found on the way: `out` then holds the points before it).
///
/// Errors: `ML_ERR_NULL` (`tree`; `lights`, `xs`, `u0s`, `u1s`, `out` when `count` > 0);
/// `ML_ERR_INVALID_ARGUMENT` naming the element (`lights[j]` out of range, `xs[j]` not finite,
/// `u0s[j]` or `u1s[j]` outside [0, 1), a bad environment sample for `lights[j]`);
/// `ML_ERR_STATE` (a tree loaded without its lights).
#[no_mangle]
pub extern "C" fn ml_light_sample_point_batch(
    tree: *const ml_tree,
    lights: *const u32,
    xs: *const ml_vec3,
    u0s: *const f32,
    u1s: *const f32,
    count: usize,
    out: *mut ml_light_point,
) -> ml_status {
    ffi_fn!("ml_light_sample_point_batch", {
        let data = tree_arg(tree)?;
        arg::check_count::<ml_light_point>(count, "count")?;
        let which = arg::slice(lights, count, "lights")?;
        let xs = arg::slice(xs, count, "xs")?;
        let u0s = arg::slice(u0s, count, "u0s")?;
        let u1s = arg::slice(u1s, count, "u1s")?;
        let mut out = arg::out_slice(out, count, "out")?;
        let set = data.set()?;
        let n = set.len();
        for j in 0..count {
            let x = xs[j];
            let fine = (which[j] as usize) < n
                && (x.x + x.y + x.z).is_finite()
                && (0.0..1.0).contains(&u0s[j])
                && (0.0..1.0).contains(&u1s[j]);
            if !fine {
                check_light(which[j], n, &format!("lights[{j}]"))?;
                finite3(x, &|| format!("xs[{j}]"))?;
                unit(u0s[j], &|| format!("u0s[{j}]"))?;
                unit(u1s[j], &|| format!("u1s[{j}]"))?;
            }
        }
        // What `ml_light_sample_point` computes, element by element.
        for j in 0..count {
            let p = set.sample_point(which[j], xs[j].into(), [u0s[j], u1s[j]]);
            out.set(
                j,
                p.map_err(|e| direct_error(e).within(&format!("lights[{j}]")))?
                    .into(),
            );
        }
        Ok(())
    })
}
