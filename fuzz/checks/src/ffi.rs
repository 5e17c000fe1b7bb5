//! The C ABI (`manylights-ffi`) called from Rust as a host would call it, with arbitrary
//! arguments: a sequence of operations on handles the harness keeps (trees built from light
//! descriptors of every kind or loaded from serialized bytes, edited or not; cuts; estimators;
//! VPL acceptors), each pointer argument NULL, valid or misaligned, each value raw or in range,
//! each count at most the length of the buffer behind it (the ABI trusts a pointer and count
//! the host passes: only NULL pointers go with larger counts), light indices in or out of
//! range. Freed handles are never used again. After every call:
//!
//! - the status is one of `ML_OK` … `ML_ERR_STATE`: `ML_ERR_INTERNAL` (a caught panic or a
//!   broken invariant) and any other value are findings;
//! - on failure no output was written (every output is pre-filled with a sentinel) and
//!   `ml_last_error_message()` starts with the function's name and says something;
//! - on success no misaligned pointer was accepted, no output is NaN, a sampled light is in
//!   range with pmf in (0, 1] (`ML_NO_LIGHT` with pmf 0), pmfs are in [0, 1], estimates and
//!   MIS scales are finite and non-negative, weights in [0, 1], a batch leaves the elements
//!   past its count alone and equals the single calls bit for bit, and the unedited bytes of a
//!   serialized tree load back.

use arbitrary::{Arbitrary, Unstructured};
use core::ffi::{c_char, c_void};
use core::mem::size_of;
use manylights_ffi::*;
use std::ffi::CStr;
use std::fmt;
use std::ptr;

/// A grey colour.
fn grey(v: f32) -> ml_rgb {
    ml_rgb { r: v, g: v, b: v }
}

/// Every channel finite and ≥ 0.
fn colour_ok(c: ml_rgb) -> bool {
    [c.r, c.g, c.b].iter().all(|v| v.is_finite() && *v >= 0.0)
}

/// Every channel of an estimate finite and ≥ 0.
fn estimate_ok(e: ml_rgb64) -> bool {
    [e.r, e.g, e.b].iter().all(|v| v.is_finite() && *v >= 0.0)
}

/// The target's input: the operations, in order (the first [`MAX_OPS`]).
#[derive(Arbitrary, Debug)]
pub struct Input {
    /// The operations.
    pub ops: Vec<Op>,
}

/// Operations replayed per input.
pub const MAX_OPS: usize = 64;
/// Lights, batch elements, importons and callback values taken per operation.
pub const MAX_LEN: usize = 64;
/// Steps of a lower-level estimate before the harness gives up on it.
pub const MAX_STEPS: usize = 512;

/// How a pointer argument is passed: valid (most of the time), NULL or misaligned (one byte
/// past a valid, aligned buffer).
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Ptr {
    /// A valid pointer.
    Valid,
    /// NULL.
    Null,
    /// Misaligned by one byte (the buffer behind it is large enough).
    Misaligned,
}

impl<'a> Arbitrary<'a> for Ptr {
    fn arbitrary(u: &mut Unstructured<'a>) -> arbitrary::Result<Self> {
        Ok(match u8::arbitrary(u)? {
            0..=231 => Ptr::Valid,
            232..=247 => Ptr::Null,
            _ => Ptr::Misaligned,
        })
    }
    fn size_hint(_: usize) -> (usize, Option<usize>) {
        (1, Some(1))
    }
}

impl fmt::Debug for Ptr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Ptr::Valid => "Valid",
            Ptr::Null => "Null",
            Ptr::Misaligned => "Misaligned",
        })
    }
}

/// A handle argument: one of the live handles of its type (index modulo their number; NULL
/// when there is none), NULL, or a live handle's address plus one byte.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Handle {
    /// A live handle.
    Live(u8),
    /// NULL.
    Null,
    /// A live handle, misaligned.
    Misaligned(u8),
}

impl<'a> Arbitrary<'a> for Handle {
    fn arbitrary(u: &mut Unstructured<'a>) -> arbitrary::Result<Self> {
        let b = u8::arbitrary(u)?;
        Ok(match b {
            0..=239 => Handle::Live(b % 8),
            240..=247 => Handle::Null,
            _ => Handle::Misaligned(b % 8),
        })
    }
    fn size_hint(_: usize) -> (usize, Option<usize>) {
        (1, Some(1))
    }
}

impl fmt::Debug for Handle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Handle::Live(i) => write!(f, "Live({i})"),
            Handle::Null => f.write_str("Null"),
            Handle::Misaligned(i) => write!(f, "Misaligned({i})"),
        }
    }
}

/// An f32: in [0, 1) (`k/65536`), small (`k/256`), special (NaN, ±∞, ±0, 1, 1⁻, huge,
/// subnormal, −1) or any bit pattern.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum F {
    /// `k/65536`, in [0, 1).
    Unit(u16),
    /// `k/256`, in [−128, 128).
    Small(i16),
    /// One of [`SPECIAL`].
    Special(u8),
    /// Any bits.
    Raw(f32),
}

/// The special values of [`F::Special`].
pub const SPECIAL: [f32; 12] = [
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    0.0,
    -0.0,
    1.0,
    1.0 - f32::EPSILON / 2.0,
    1e30,
    -1e30,
    1e-40,
    -1.0,
    1e16,
];

impl F {
    /// The value.
    pub fn value(self) -> f32 {
        match self {
            F::Unit(k) => f32::from(k) / 65536.0,
            F::Small(k) => f32::from(k) / 256.0,
            F::Special(k) => SPECIAL[k as usize % SPECIAL.len()],
            F::Raw(x) => x,
        }
    }
}

/// A 3-vector of [`F`].
pub type V3 = [F; 3];

fn v3(v: &V3) -> ml_vec3 {
    ml_vec3 {
        x: v[0].value(),
        y: v[1].value(),
        z: v[2].value(),
    }
}

/// An enum-typed `uint32_t`: `b mod n` for `b` < 240, else `b` itself (out of range).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Enum(pub u8);

impl Enum {
    /// The value for an enum of `n` values.
    pub fn value(self, n: u32) -> u32 {
        if self.0 < 240 {
            u32::from(self.0) % n
        } else {
            u32::from(self.0)
        }
    }
}

/// A flag that is rarely set (`b` ≥ 240).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Rare(pub u8);

impl Rare {
    /// Whether it is set.
    pub fn set(self) -> bool {
        self.0 >= 240
    }
}

/// A cut size option: in [4, 64] for `b` < 224, else `b − 224` (0 to 31).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Size(pub u8);

impl Size {
    /// The value.
    pub fn value(self) -> usize {
        if self.0 < 224 {
            4 + usize::from(self.0) % 61
        } else {
            usize::from(self.0 - 224)
        }
    }
}

/// A count passed with buffers of `n` elements: all of them, fewer, or (only with every
/// array pointer NULL) anything.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Count {
    /// All `n`.
    All,
    /// `k mod (n + 1)`.
    Fewer(u8),
    /// `k` when every array pointer is NULL, else `n`.
    Any(u64),
}

impl Count {
    /// The count for buffers of `n` elements (`all_null`: every array pointer is NULL).
    pub fn value(self, n: usize, all_null: bool) -> usize {
        match self {
            Count::All => n,
            Count::Fewer(k) => usize::from(k) % (n + 1),
            Count::Any(k) if all_null => k as usize,
            Count::Any(_) => n,
        }
    }
}

/// A light index: in range (modulo the light count), the light count itself, `ML_NO_LIGHT`
/// or anything.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Index {
    /// `k mod n` (0 with no lights).
    In(u16),
    /// `n`.
    Count,
    /// `ML_NO_LIGHT`.
    NoLight,
    /// As given.
    Raw(u32),
}

impl Index {
    /// The index for `n` lights.
    pub fn value(self, n: usize) -> u32 {
        match self {
            Index::In(k) => (usize::from(k) % n.max(1)) as u32,
            Index::Count => n as u32,
            Index::NoLight => ML_NO_LIGHT,
            Index::Raw(k) => k,
        }
    }
}

/// A light descriptor (`ml_light`), every field drawn.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Light {
    /// An `ml_light_kind` (six values).
    pub kind: Enum,
    /// 0 or 1, or out of range.
    pub two_sided: Enum,
    /// Position, centre or vertex 0.
    pub position: V3,
    /// Axis, normal or vertex 1.
    pub direction: V3,
    /// Vertex 2.
    pub vertex2: V3,
    /// Power.
    pub power: F,
    /// Radius.
    pub radius: F,
    /// Spot half-angle.
    pub half_angle: F,
    /// Spot falloff start, as a fraction of the half-angle (or raw).
    pub falloff_start: F,
}

impl Light {
    fn ml(&self) -> ml_light {
        ml_light {
            kind: self.kind.value(8),
            two_sided: self.two_sided.value(2),
            position: v3(&self.position),
            direction: v3(&self.direction),
            vertex2: v3(&self.vertex2),
            power: grey(self.power.value()),
            radius: self.radius.value(),
            half_angle: self.half_angle.value(),
            irradiance_bounds: [self.power.value(); 6],
            falloff_start: match self.falloff_start {
                F::Unit(_) => self.falloff_start.value() * self.half_angle.value(),
                f => f.value(),
            },
        }
    }
}

/// A material (`ml_material`).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct MaterialDesc {
    /// An `ml_material_kind` (three values).
    pub kind: Enum,
    /// Albedo.
    pub albedo: F,
    /// Specular weight.
    pub specular: F,
    /// GGX α.
    pub alpha: F,
}

impl MaterialDesc {
    fn ml(&self) -> ml_material {
        ml_material {
            kind: self.kind.value(3),
            albedo: grey(self.albedo.value()),
            specular: self.specular.value(),
            alpha: self.alpha.value(),
        }
    }
}

/// A shading point (`ml_shading_point`).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Sp {
    /// Position.
    pub position: V3,
    /// Normal.
    pub normal: V3,
    /// ωo.
    pub wo: V3,
    /// Material.
    pub material: MaterialDesc,
}

impl Sp {
    fn ml(&self) -> ml_shading_point {
        ml_shading_point {
            position: v3(&self.position),
            normal: v3(&self.normal),
            wo: v3(&self.wo),
            material: self.material.ml(),
        }
    }
}

/// A TL point (`ml_tl_point`).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct TlPoint {
    /// Position.
    pub position: V3,
    /// Normal.
    pub normal: V3,
}

impl TlPoint {
    fn ml(&self) -> ml_tl_point {
        ml_tl_point {
            position: v3(&self.position),
            normal: v3(&self.normal),
        }
    }
}

/// A read-only argument: how it is passed and its value.
#[derive(Arbitrary, Debug, Clone)]
pub struct Arg<T> {
    /// Valid, NULL or misaligned.
    pub ptr: Ptr,
    /// The value behind it.
    pub value: T,
}

/// `ml_bl_cut_options`.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct CutOpts {
    /// δ.
    pub delta: F,
    /// Most clusters.
    pub max_size: Size,
}

impl CutOpts {
    fn ml(&self) -> ml_bl_cut_options {
        ml_bl_cut_options {
            delta: self.delta.value(),
            max_size: self.max_size.value(),
        }
    }
}

/// `ml_split_cut_options`.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct SplitOpts {
    /// The variance threshold.
    pub threshold: F,
    /// Most clusters.
    pub max_size: Size,
}

impl SplitOpts {
    fn ml(&self) -> ml_split_cut_options {
        ml_split_cut_options {
            threshold: self.threshold.value(),
            max_size: self.max_size.value(),
        }
    }
}

/// `ml_direct_params`.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Params {
    /// The split cut's options.
    pub split: SplitOpts,
    /// The BRDF-oriented cut's options.
    pub cut: CutOpts,
    /// Nmax: `1 + b mod 64` for `b` < 240, else `b − 240` (0 to 15: 0 is out of range).
    pub n_max: u8,
    /// An `ml_lambert_mode` (four values).
    pub lambert: Enum,
    /// 0 or 1, or out of range.
    pub balance_heuristic: Enum,
}

impl Params {
    fn ml(&self) -> ml_direct_params {
        ml_direct_params {
            split_cut: self.split.ml(),
            bl_cut: self.cut.ml(),
            n_max: if self.n_max < 240 {
                1 + u32::from(self.n_max) % 64
            } else {
                u32::from(self.n_max - 240)
            },
            lambert: self.lambert.value(4),
            heuristic: self.balance_heuristic.value(2),
        }
    }
}

/// The host's uniform numbers (`ml_uniforms`): `values` cycled (varied by the golden ratio
/// each turn), mapped into [0, 1) unless `raw`.
#[derive(Arbitrary, Debug, Clone)]
pub struct Uniforms {
    /// `next_f32` NULL (rarely).
    pub no_f32: Rare,
    /// `next_f64` given.
    pub f64: bool,
    /// The values as drawn, out of range included (rarely).
    pub raw: Rare,
    /// The values (the first [`MAX_LEN`]; none: the golden-ratio sequence).
    pub values: Vec<F>,
}

/// The host's visibility (`ml_visibility`): `occluded` cycles `occluded`, `first_hit` cycles
/// the distances (empty: +∞).
#[derive(Arbitrary, Debug, Clone)]
pub struct Visibility {
    /// The shadow-ray callback's answers, when it is given.
    pub occluded: Option<Vec<bool>>,
    /// The first-surface callback's distances, when it is given.
    pub first_hit: Option<Vec<F>>,
}

/// `ml_acceptor_options`.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct AcceptorOpts {
    /// P (0 is an error).
    pub pixels: u16,
    /// N (0 is an error).
    pub wanted: u16,
    /// ε.
    pub epsilon: F,
    /// The geometry clamp (`None`: +∞).
    pub geometry_clamp: Option<F>,
}

/// An importon (`ml_importon`).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Importon {
    /// 0, 1 or out of range.
    pub hit: Enum,
    /// Position.
    pub position: V3,
    /// Normal.
    pub normal: V3,
    /// ωo.
    pub wo: V3,
    /// Material.
    pub material: MaterialDesc,
}

/// A VPL candidate (`ml_vpl`).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct VplDesc {
    /// Position.
    pub position: V3,
    /// Normal.
    pub normal: V3,
    /// Intensity.
    pub intensity: F,
}

impl VplDesc {
    fn ml(&self) -> ml_vpl {
        ml_vpl {
            position: v3(&self.position),
            normal: v3(&self.normal),
            intensity: grey(self.intensity.value()),
        }
    }
}

/// The host's VPL visibility (`ml_vpl_visibility`): `visible` cycles the answers (empty:
/// visible), or NULL.
#[derive(Arbitrary, Debug, Clone)]
pub struct VplVisibility {
    /// The callback's answers; `None`: the callback is NULL.
    pub visible: Option<Vec<bool>>,
}

/// The bytes `ml_tree_load` reads.
#[derive(Arbitrary, Debug, Clone)]
pub enum Bytes {
    /// The bytes of the last successful `ml_tree_serialize`, each edit XOR-ing a byte (index
    /// modulo the length), then truncated to `keep` bytes (when given).
    Serialized {
        /// (index, XOR mask).
        edits: Vec<(u16, u8)>,
        /// Bytes kept.
        keep: Option<u16>,
    },
    /// Arbitrary bytes.
    Raw(Vec<u8>),
}

/// The capacity passed to `ml_tree_serialize`, relative to the tree's size.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Capacity {
    /// Exactly the size.
    Exact,
    /// The size minus `k` (at least 0).
    Less(u8),
    /// The size plus `k`.
    More(u8),
    /// 0.
    Zero,
}

/// One call (or, for `Run` and `Defaults`, a few) of the ABI.
#[derive(Arbitrary, Debug, Clone)]
pub enum Op {
    /// `ml_tree_build`.
    Build {
        /// The lights (the first [`MAX_LEN`]).
        lights: Vec<Light>,
        /// How many are passed.
        count: Count,
        /// The array pointer.
        ptr: Ptr,
        /// `options` (NULL: defaults); `buckets` as given.
        options: Option<Arg<u8>>,
        /// `out`.
        out: Ptr,
    },
    /// `ml_tree_load`.
    Load {
        /// The bytes.
        bytes: Bytes,
        /// How many are passed.
        count: Count,
        /// The byte pointer (valid or NULL).
        ptr: Ptr,
        /// `out`.
        out: Ptr,
    },
    /// `ml_tree_serialized_size`, then `ml_tree_serialize`.
    Serialize {
        /// The tree.
        tree: Handle,
        /// The capacity.
        capacity: Capacity,
        /// `buffer`.
        buffer: Ptr,
        /// `written`.
        written: Ptr,
    },
    /// `ml_tree_stats`.
    Stats {
        /// The tree.
        tree: Handle,
        /// `out`.
        out: Ptr,
    },
    /// `ml_tree_free`.
    FreeTree(Handle),
    /// `ml_tree_sample_tl`.
    SampleTl {
        /// The tree.
        tree: Handle,
        /// The point.
        point: Arg<TlPoint>,
        /// u.
        u: F,
        /// `out`.
        out: Ptr,
    },
    /// `ml_tree_pmf_tl`.
    PmfTl {
        /// The tree.
        tree: Handle,
        /// The point.
        point: Arg<TlPoint>,
        /// The light.
        light: Index,
        /// `out`.
        out: Ptr,
    },
    /// `ml_tree_sample_bl`.
    SampleBl {
        /// The tree.
        tree: Handle,
        /// The shading point.
        sp: Arg<Sp>,
        /// u.
        u: F,
        /// `out`.
        out: Ptr,
    },
    /// `ml_tree_pmf_bl`.
    PmfBl {
        /// The tree.
        tree: Handle,
        /// The shading point.
        sp: Arg<Sp>,
        /// The light.
        light: Index,
        /// `out`.
        out: Ptr,
    },
    /// `ml_tree_sample_tl_batch` (then the single calls).
    SampleTlBatch {
        /// The tree.
        tree: Handle,
        /// The points (the first [`MAX_LEN`]).
        points: Vec<TlPoint>,
        /// The numbers (as many as the points are used; missing ones 0.5).
        us: Vec<F>,
        /// How many are passed.
        count: Count,
        /// `points`, `us`, `out`.
        ptrs: [Ptr; 3],
    },
    /// `ml_tree_pmf_tl_batch` (then the single calls).
    PmfTlBatch {
        /// The tree.
        tree: Handle,
        /// The points (the first [`MAX_LEN`]).
        points: Vec<TlPoint>,
        /// The lights (missing ones 0).
        lights: Vec<Index>,
        /// How many are passed.
        count: Count,
        /// `points`, `lights`, `out`.
        ptrs: [Ptr; 3],
    },
    /// `ml_tree_sample_bl_batch` (then the single calls).
    SampleBlBatch {
        /// The tree.
        tree: Handle,
        /// The shading points (the first [`MAX_LEN`]).
        points: Vec<Sp>,
        /// The numbers.
        us: Vec<F>,
        /// How many are passed.
        count: Count,
        /// `points`, `us`, `out`.
        ptrs: [Ptr; 3],
    },
    /// `ml_tree_pmf_bl_batch` (then the single calls).
    PmfBlBatch {
        /// The tree.
        tree: Handle,
        /// The shading points (the first [`MAX_LEN`]).
        points: Vec<Sp>,
        /// The lights.
        lights: Vec<Index>,
        /// How many are passed.
        count: Count,
        /// `points`, `lights`, `out`.
        ptrs: [Ptr; 3],
    },
    /// `ml_light_sample_point`, then `ml_light_pdf_point` of the point it gave.
    LightSamplePoint {
        /// The tree.
        tree: Handle,
        /// The light.
        light: Index,
        /// x.
        x: V3,
        /// u0.
        u0: F,
        /// u1.
        u1: F,
        /// `out`.
        out: Ptr,
    },
    /// `ml_light_pdf_point`.
    LightPdfPoint {
        /// The tree.
        tree: Handle,
        /// The light.
        light: Index,
        /// x.
        x: V3,
        /// The point.
        point: V3,
        /// `out`.
        out: Ptr,
    },
    /// `ml_cut_create`.
    CutCreate {
        /// `out`.
        out: Ptr,
    },
    /// `ml_cut_free`.
    CutFree(Handle),
    /// `ml_cut_build_bl`.
    CutBuild {
        /// The cut.
        cut: Handle,
        /// The tree.
        tree: Handle,
        /// The shading point.
        sp: Arg<Sp>,
        /// `options` (NULL: defaults).
        options: Option<Arg<CutOpts>>,
    },
    /// `ml_cut_build_split`.
    CutBuildSplit {
        /// The cut.
        cut: Handle,
        /// The tree.
        tree: Handle,
        /// The point.
        point: Arg<TlPoint>,
        /// `options` (NULL: defaults).
        options: Option<Arg<SplitOpts>>,
    },
    /// `ml_cut_size` and `ml_cut_ib`.
    CutSize {
        /// The cut.
        cut: Handle,
        /// `out` of both.
        out: Ptr,
    },
    /// `ml_cut_sample`.
    CutSample {
        /// The cut.
        cut: Handle,
        /// u.
        u: F,
        /// `out`.
        out: Ptr,
    },
    /// `ml_cut_pmf`.
    CutPmf {
        /// The cut.
        cut: Handle,
        /// The light.
        light: Index,
        /// `out`.
        out: Ptr,
    },
    /// `ml_cut_sample_clusters`, with the count the cut's size (when `count` is `All`) or
    /// another.
    CutSampleClusters {
        /// The cut.
        cut: Handle,
        /// The numbers (missing ones 0.5; [`crate::ffi::MAX_LEN`] + 1 buffers at most).
        us: Vec<F>,
        /// How many are passed: `All` the cut's size (when known), else of the buffer.
        count: Count,
        /// `us`, `out`.
        ptrs: [Ptr; 2],
    },
    /// `ml_cut_pmf_in`.
    CutPmfIn {
        /// The cut.
        cut: Handle,
        /// The light.
        light: Index,
        /// `cluster`, `pmf`.
        ptrs: [Ptr; 2],
    },
    /// `ml_brdf_sample`, then `ml_brdf_pdf` and `ml_brdf_eval` of the direction it gave.
    BrdfSample {
        /// The shading point.
        sp: Arg<Sp>,
        /// u0.
        u0: F,
        /// u1.
        u1: F,
        /// `out`.
        out: Ptr,
    },
    /// `ml_brdf_pdf` and `ml_brdf_eval`.
    BrdfPdf {
        /// The shading point.
        sp: Arg<Sp>,
        /// ωi.
        wi: V3,
        /// `out`.
        out: Ptr,
    },
    /// `ml_direct_estimate`.
    DirectEstimate {
        /// The tree.
        tree: Handle,
        /// The shading point.
        sp: Arg<Sp>,
        /// An `ml_technique` (nine values).
        technique: Enum,
        /// `params` (NULL: defaults).
        params: Option<Arg<Params>>,
        /// `visibility` (NULL: unoccluded).
        visibility: Option<Arg<Visibility>>,
        /// `uniforms`.
        uniforms: Arg<Uniforms>,
        /// `out`.
        out: Ptr,
    },
    /// `ml_estimator_create`.
    EstimatorCreate {
        /// The tree.
        tree: Handle,
        /// `out`.
        out: Ptr,
    },
    /// `ml_estimator_free`.
    EstimatorFree(Handle),
    /// `ml_estimator_set_point`.
    SetPoint {
        /// The estimator.
        est: Handle,
        /// The shading point.
        sp: Arg<Sp>,
        /// An `ml_technique`.
        technique: Enum,
        /// `params` (NULL: defaults).
        params: Option<Arg<Params>>,
    },
    /// `ml_estimator_estimate`.
    Estimate {
        /// The estimator.
        est: Handle,
        /// `visibility` (NULL: unoccluded).
        visibility: Option<Arg<Visibility>>,
        /// `uniforms`.
        uniforms: Arg<Uniforms>,
        /// `out`.
        out: Ptr,
    },
    /// `ml_estimator_start`.
    Start(Handle),
    /// `ml_estimator_next`.
    Next {
        /// The estimator.
        est: Handle,
        /// `uniforms`.
        uniforms: Arg<Uniforms>,
        /// `out`.
        out: Ptr,
    },
    /// `ml_estimator_weigh`.
    Weigh {
        /// The estimator.
        est: Handle,
        /// The BSDF pdf.
        bsdf_pdf: F,
        /// `out`.
        out: Ptr,
    },
    /// `ml_estimator_bsdf_hits`.
    BsdfHits {
        /// The estimator.
        est: Handle,
        /// The direction.
        direction: V3,
        /// The BSDF pdf.
        bsdf_pdf: F,
        /// The first surface's distance.
        hit_distance: F,
        /// `each` NULL (rarely).
        no_each: Rare,
        /// `any_hit`.
        any_hit: Ptr,
    },
    /// An estimator of `tree` set up at `sp` with valid pointers, one estimate, then a whole
    /// lower-level estimate: start, then next until done, weighing light steps with the core's
    /// BSDF pdf and reporting BSDF steps sampled with the core's BRDF (the hit distance cycled
    /// from `distances`, +∞ when empty); then freed, or kept for the operations that follow.
    Run {
        /// The tree.
        tree: Handle,
        /// The shading point.
        sp: Sp,
        /// An `ml_technique`.
        technique: Enum,
        /// `params` (NULL: defaults).
        params: Option<Params>,
        /// `uniforms`.
        uniforms: Uniforms,
        /// `visibility` of the one-call estimate (NULL: unoccluded).
        visibility: Option<Visibility>,
        /// First-surface distances of the BSDF rays.
        distances: Vec<F>,
        /// Kept as a live estimator.
        keep: bool,
    },
    /// `ml_acceptor_create` (NULL `options`, or the defaults with these fields).
    AcceptorCreate {
        /// `options`.
        options: Arg<AcceptorOpts>,
        /// `out`.
        out: Ptr,
    },
    /// `ml_acceptor_free`.
    AcceptorFree(Handle),
    /// `ml_acceptor_set_importons`.
    SetImportons {
        /// The acceptor.
        acc: Handle,
        /// The importons (the first [`MAX_LEN`]).
        importons: Vec<Importon>,
        /// How many are passed.
        count: Count,
        /// The array pointer.
        ptr: Ptr,
    },
    /// `ml_acceptor_update` (or `ml_acceptor_set_total_luminance` when `set`).
    Luminance {
        /// The acceptor.
        acc: Handle,
        /// `ml_acceptor_set_total_luminance` instead.
        set: bool,
        /// The value (an f32 widened, or `10^(k/10)`).
        value: Result<F, i8>,
    },
    /// `ml_acceptor_accept` (or `ml_acceptor_probability` when `probability`).
    Accept {
        /// The acceptor.
        acc: Handle,
        /// `ml_acceptor_probability` instead.
        probability: bool,
        /// The candidate.
        candidate: Arg<VplDesc>,
        /// ξ.
        xi: F,
        /// `visibility` (NULL: unoccluded).
        visibility: Option<Arg<VplVisibility>>,
        /// `out`.
        out: Ptr,
    },
    /// `ml_acceptor_stats` (after `ml_acceptor_reset_stats` when `reset`).
    AcceptorStats {
        /// The acceptor.
        acc: Handle,
        /// `ml_acceptor_reset_stats` first.
        reset: bool,
        /// `out`.
        out: Ptr,
    },
    /// The `*_default` functions, `ml_version` and `ml_status_name` (with `status`).
    Defaults {
        /// Their `out`.
        out: Ptr,
        /// The status named.
        status: i32,
    },
}

// ---------------------------------------------------------------------------------------------
// Buffers: every output pre-filled with a sentinel; inputs copied behind aligned or misaligned
// pointers.

const SENTINEL: u8 = 0xA5;

/// A misaligned pointer to bytes is a valid one.
fn aligned_if_bytes<T>(ptr: Ptr) -> Ptr {
    if ptr == Ptr::Misaligned && core::mem::align_of::<T>() == 1 {
        Ptr::Valid
    } else {
        ptr
    }
}

/// What the harness checks of a buffer after a call.
trait Buf {
    /// No byte was written.
    fn untouched(&self) -> bool {
        true
    }
    /// A misaligned pointer with a non-zero count was passed (a success is then a finding).
    fn misaligned(&self) -> bool;
}

/// An output buffer of `len` elements of `T` (plus a byte), pre-filled with [`SENTINEL`].
struct Out<T> {
    mem: Vec<u64>,
    len: usize,
    ptr: Ptr,
    count: usize,
    _t: core::marker::PhantomData<T>,
}

impl<T: Copy> Out<T> {
    /// An output of `len` elements passed as `ptr` with `count` (≤ `len` unless NULL).
    fn new(len: usize, ptr: Ptr, count: usize) -> Out<T> {
        let ptr = aligned_if_bytes::<T>(ptr);
        let bytes = len * size_of::<T>() + 1;
        Out {
            mem: vec![u64::from_ne_bytes([SENTINEL; 8]); bytes.div_ceil(8) + 1],
            len,
            ptr,
            count,
            _t: core::marker::PhantomData,
        }
    }

    /// One output.
    fn one(ptr: Ptr) -> Out<T> {
        Out::new(1, ptr, 1)
    }

    fn base(&mut self) -> *mut u8 {
        self.mem.as_mut_ptr().cast()
    }

    /// The pointer to pass.
    fn p(&mut self) -> *mut T {
        match self.ptr {
            Ptr::Valid => self.base().cast(),
            Ptr::Null => ptr::null_mut(),
            Ptr::Misaligned => self.base().wrapping_add(1).cast(),
        }
    }

    fn bytes(&self) -> &[u8] {
        // SAFETY: the u64 buffer viewed as its bytes.
        unsafe { core::slice::from_raw_parts(self.mem.as_ptr().cast(), self.mem.len() * 8) }
    }

    /// Element `i` (written by a successful call through a valid pointer).
    fn get(&self, i: usize) -> T {
        assert!(i < self.len);
        // SAFETY: in the buffer; every `T` here is plain integers, floats and pointers.
        unsafe { self.mem.as_ptr().cast::<T>().add(i).read() }
    }

    /// The bytes from element `i` on are untouched.
    fn untouched_from(&self, i: usize) -> bool {
        let start = i.min(self.len) * size_of::<T>() + usize::from(self.ptr == Ptr::Misaligned);
        self.bytes()[start..].iter().all(|&b| b == SENTINEL)
    }
}

impl<T: Copy> Buf for Out<T> {
    fn untouched(&self) -> bool {
        self.bytes().iter().all(|&b| b == SENTINEL)
    }
    fn misaligned(&self) -> bool {
        self.ptr == Ptr::Misaligned && self.count > 0
    }
}

/// A read-only array copied behind an aligned or misaligned pointer (or NULL).
struct In<T> {
    mem: Vec<u64>,
    ptr: Ptr,
    count: usize,
    _t: core::marker::PhantomData<T>,
}

impl<T: Copy> In<T> {
    /// `values` passed as `ptr` with `count` (≤ `values.len()` unless NULL).
    fn new(values: &[T], ptr: Ptr, count: usize) -> In<T> {
        let ptr = aligned_if_bytes::<T>(ptr);
        let bytes = core::mem::size_of_val(values) + 1;
        let mut mem = vec![0u64; bytes.div_ceil(8) + 1];
        let off = usize::from(ptr == Ptr::Misaligned);
        // SAFETY: the buffer holds the values' bytes after `off`.
        unsafe {
            ptr::copy_nonoverlapping(
                values.as_ptr().cast::<u8>(),
                mem.as_mut_ptr().cast::<u8>().add(off),
                core::mem::size_of_val(values),
            );
        }
        In {
            mem,
            ptr,
            count,
            _t: core::marker::PhantomData,
        }
    }

    /// One value.
    fn one(v: T, ptr: Ptr) -> In<T> {
        In::new(&[v], ptr, 1)
    }

    /// An optional argument (NULL when absent).
    fn opt(v: Option<(T, Ptr)>) -> In<T> {
        match v {
            Some((v, p)) => In::one(v, p),
            None => In::new(&[], Ptr::Null, 0),
        }
    }

    /// The pointer to pass.
    fn p(&self) -> *const T {
        match self.ptr {
            Ptr::Valid => self.mem.as_ptr().cast(),
            Ptr::Null => ptr::null(),
            Ptr::Misaligned => self.mem.as_ptr().cast::<u8>().wrapping_add(1).cast(),
        }
    }
}

impl<T> Buf for In<T> {
    fn misaligned(&self) -> bool {
        self.ptr == Ptr::Misaligned && self.count > 0
    }
}

/// A handle passed misaligned (or not).
struct HandleArg(bool);

impl Buf for HandleArg {
    fn misaligned(&self) -> bool {
        self.0
    }
}

// ---------------------------------------------------------------------------------------------
// Callbacks: the host's uniform numbers, visibility and hits, through one `Host` as user data.

#[derive(Default)]
struct Host {
    values: Vec<f32>,
    raw: bool,
    u_at: usize,
    occluded: Vec<bool>,
    occ_at: usize,
    first_hit: Vec<f32>,
    hit_at: usize,
    visible: Vec<bool>,
    vis_at: usize,
    hits: Vec<ml_light_hit>,
}

impl Host {
    fn with_uniforms(u: &Uniforms) -> Host {
        Host {
            values: u.values.iter().take(MAX_LEN).map(|f| f.value()).collect(),
            raw: u.raw.set(),
            ..Host::default()
        }
    }

    fn next(&mut self) -> f32 {
        let i = self.u_at;
        self.u_at += 1;
        let v = if self.values.is_empty() {
            0.5
        } else {
            self.values[i % self.values.len()]
        };
        if self.raw {
            v
        } else {
            crate::bounded::unit(crate::bounded::unit(v) + 0.618_034 * i as f32)
        }
    }
}

fn host<'a>(user: *mut c_void) -> &'a mut Host {
    // SAFETY: every callback is registered with a `Host` that outlives the call, and no other
    // reference to it is live while the library runs.
    unsafe { &mut *user.cast::<Host>() }
}

extern "C" fn next_f32(user: *mut c_void) -> f32 {
    host(user).next()
}

extern "C" fn next_f64(user: *mut c_void) -> f64 {
    f64::from(host(user).next())
}

extern "C" fn occluded(user: *mut c_void, _x: ml_vec3, _d: ml_vec3, _t: f32) -> i32 {
    let h = host(user);
    let i = h.occ_at;
    h.occ_at += 1;
    if h.occluded.is_empty() {
        0
    } else {
        i32::from(h.occluded[i % h.occluded.len()])
    }
}

extern "C" fn first_hit(user: *mut c_void, _x: ml_vec3, _d: ml_vec3) -> f32 {
    let h = host(user);
    let i = h.hit_at;
    h.hit_at += 1;
    if h.first_hit.is_empty() {
        f32::INFINITY
    } else {
        h.first_hit[i % h.first_hit.len()]
    }
}

extern "C" fn visible(user: *mut c_void, _i: ml_vec3, _v: ml_vec3) -> i32 {
    let h = host(user);
    let i = h.vis_at;
    h.vis_at += 1;
    if h.visible.is_empty() {
        1
    } else {
        i32::from(h.visible[i % h.visible.len()])
    }
}

extern "C" fn each_hit(user: *mut c_void, hit: *const ml_light_hit) {
    // SAFETY: the library passes a valid hit for the call.
    let hit = unsafe { *hit };
    let h = host(user);
    if h.hits.len() < 4096 {
        h.hits.push(hit);
    }
}

fn uniforms(u: &Uniforms, user: *mut Host) -> ml_uniforms {
    ml_uniforms {
        next_f32: if u.no_f32.set() { None } else { Some(next_f32) },
        next_f64: if u.f64 { Some(next_f64) } else { None },
        user_data: user.cast(),
    }
}

fn visibility(v: &Visibility, h: &mut Host) -> ml_visibility {
    if let Some(o) = &v.occluded {
        h.occluded = o.iter().take(MAX_LEN).copied().collect();
    }
    if let Some(d) = &v.first_hit {
        h.first_hit = d.iter().take(MAX_LEN).map(|f| f.value()).collect();
    }
    ml_visibility {
        occluded: v.occluded.as_ref().map(|_| occluded as _),
        first_hit: v.first_hit.as_ref().map(|_| first_hit as _),
        user_data: (h as *mut Host).cast(),
    }
}

// ---------------------------------------------------------------------------------------------
// The harness.

/// A live tree: its handle and light count.
struct Tree {
    p: *mut ml_tree,
    lights: usize,
}

/// A live cut: its handle and, once built, the light count of its tree and its size.
struct Cut {
    p: *mut ml_cut,
    built: Option<(usize, usize)>,
}

/// A live estimator: its handle, its tree's light count, and the shading point it was set
/// up at.
struct Est {
    p: *mut ml_estimator,
    lights: usize,
    sp: Option<ml_shading_point>,
}

struct Harness<'a> {
    input: &'a Input,
    at: usize,
    trees: Vec<Tree>,
    cuts: Vec<Cut>,
    ests: Vec<Est>,
    accs: Vec<*mut ml_acceptor>,
    serialized: Option<Vec<u8>>,
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

    fn sample(&self, name: &str, s: ml_light_sample, n: usize) {
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
    fn queried(&self, name: &str, r: ml_light_sample, query: impl Fn(u32, *mut f32) -> ml_status) {
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

    fn run(&mut self) {
        for at in 0..self.input.ops.len().min(MAX_OPS) {
            self.at = at;
            self.op(&self.input.ops[at]);
        }
    }

    fn op(&mut self, op: &Op) {
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
            Op::CutCreate { out } => {
                let mut o = Out::<*mut ml_cut>::one(*out);
                let s = ml_cut_create(o.p());
                if self.status("ml_cut_create", s, &[&o]) {
                    let p = o.get(0);
                    self.ensure(!p.is_null(), || "ml_cut_create: NULL".into());
                    self.cuts.push(Cut { p, built: None });
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
                    self.built(ci, n);
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
                    self.built(ci, n);
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
                let mut o = Out::<f32>::one(*out);
                let s = ml_cut_ib(c, o.p());
                if self.status("ml_cut_ib", s, &[&ch, &o]) {
                    let ib = o.get(0);
                    self.ensure(ib >= 0.0 && !nan32(ib), || format!("ml_cut_ib: {ib}"));
                }
            }
            Op::CutSample { cut, u, out } => {
                let (ci, c, ch) = self.cut(*cut);
                let n = ci.and_then(|i| self.cuts[i].built).map_or(0, |b| b.0);
                let mut o = Out::<ml_light_sample>::one(*out);
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
                let mut o = Out::<ml_light_sample>::new(len, ptrs[1], k);
                let s = ml_cut_sample_clusters(c, u.p(), k, o.p());
                if self.status("ml_cut_sample_clusters", s, &[&ch, &u, &o]) {
                    for i in 0..k {
                        self.sample("ml_cut_sample_clusters", o.get(i), n);
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
            Op::BrdfSample { sp, u0, u1, out } => {
                let p = In::one(sp.value.ml(), sp.ptr);
                let mut o = Out::<ml_brdf_draw>::one(*out);
                let s = ml_brdf_sample(p.p(), u0.value(), u1.value(), o.p());
                if self.status("ml_brdf_sample", s, &[&p, &o]) {
                    let d = o.get(0);
                    self.ensure(
                        d.pdf >= 0.0
                            && d.pdf.is_finite()
                            && d.value >= 0.0
                            && d.value.is_finite()
                            && ![d.wi.x, d.wi.y, d.wi.z].iter().any(|v| v.is_nan()),
                        || format!("ml_brdf_sample: {d:?}"),
                    );
                    if d.pdf > 0.0 {
                        self.brdf(&p, d.wi);
                    }
                }
            }
            Op::BrdfPdf { sp, wi, out } => {
                let p = In::one(sp.value.ml(), sp.ptr);
                let mut o = Out::<f32>::one(*out);
                let s = ml_brdf_pdf(p.p(), v3(wi), o.p());
                if self.status("ml_brdf_pdf", s, &[&p, &o]) {
                    let q = o.get(0);
                    self.ensure(q >= 0.0 && !nan32(q), || format!("ml_brdf_pdf: {q}"));
                }
                let mut o = Out::<f32>::one(*out);
                let s = ml_brdf_eval(p.p(), v3(wi), o.p());
                if self.status("ml_brdf_eval", s, &[&p, &o]) {
                    let f = o.get(0);
                    self.ensure(f >= 0.0 && !nan32(f), || format!("ml_brdf_eval: {f}"));
                }
            }
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
                let list: Vec<ml_importon> = importons
                    .iter()
                    .take(MAX_LEN)
                    .map(|i| ml_importon {
                        hit: if i.hit.0 < 32 {
                            0
                        } else if i.hit.0 < 240 {
                            1
                        } else {
                            u32::from(i.hit.0)
                        },
                        position: v3(&i.position),
                        normal: v3(&i.normal),
                        wo: v3(&i.wo),
                        material: i.material.ml(),
                    })
                    .collect();
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
                let v = In::opt(vis.as_ref().map(|v| {
                    if let Some(answers) = &v.value.visible {
                        h.visible = answers.iter().take(MAX_LEN).copied().collect();
                    }
                    let f: Option<unsafe extern "C" fn(*mut c_void, ml_vec3, ml_vec3) -> i32> =
                        v.value.visible.as_ref().map(|_| visible as _);
                    (
                        ml_vpl_visibility {
                            visible: f,
                            user_data: (&mut h as *mut Host).cast(),
                        },
                        v.ptr,
                    )
                }));
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
                                    && colour_ok(d.vpl.intensity)
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
            Op::Defaults { out, status } => self.defaults(*out, *status),
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

    fn built(&mut self, ci: Option<usize>, n: usize) {
        let Some(i) = ci else { return };
        let mut o = Out::<usize>::one(Ptr::Valid);
        let s = ml_cut_size(self.cuts[i].p, o.p());
        self.ensure(s == ML_OK, || format!("ml_cut_size of a built cut: {s}"));
        let size = o.get(0);
        self.ensure(size <= ML_CUT_CAPACITY, || {
            format!("a cut of {size} clusters")
        });
        self.cuts[i].built = Some((n, size));
    }

    fn brdf(&self, p: &In<ml_shading_point>, wi: ml_vec3) {
        let mut o = Out::<f32>::one(Ptr::Valid);
        let s = ml_brdf_pdf(p.p(), wi, o.p());
        if self.status("ml_brdf_pdf", s, &[&o]) {
            let q = o.get(0);
            self.ensure(q >= 0.0 && !nan32(q), || {
                format!("ml_brdf_pdf: {q} of a sampled direction")
            });
        }
        let mut o = Out::<f32>::one(Ptr::Valid);
        let s = ml_brdf_eval(p.p(), wi, o.p());
        if self.status("ml_brdf_eval", s, &[&o]) {
            let f = o.get(0);
            self.ensure(f >= 0.0 && !nan32(f), || {
                format!("ml_brdf_eval: {f} of a sampled direction")
            });
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

    fn defaults(&self, out: Ptr, status: i32) {
        let mut o = Out::<ml_build_options>::one(out);
        let s = ml_build_options_default(o.p());
        if self.status("ml_build_options_default", s, &[&o]) {
            let b = o.get(0).buckets;
            self.ensure(b == 0 || (12..=64).contains(&b), || format!("buckets {b}"));
        }
        let mut o = Out::<ml_bl_cut_options>::one(out);
        let s = ml_bl_cut_options_default(o.p());
        if self.status("ml_bl_cut_options_default", s, &[&o]) {
            let c = o.get(0);
            self.ensure(c.delta >= 0.0 && (4..=64).contains(&c.max_size), || {
                format!("{c:?}")
            });
        }
        let mut o = Out::<ml_split_cut_options>::one(out);
        let s = ml_split_cut_options_default(o.p());
        if self.status("ml_split_cut_options_default", s, &[&o]) {
            let c = o.get(0);
            self.ensure(c.threshold >= 0.0 && (4..=64).contains(&c.max_size), || {
                format!("{c:?}")
            });
        }
        let mut o = Out::<ml_direct_params>::one(out);
        let s = ml_direct_params_default(o.p());
        if self.status("ml_direct_params_default", s, &[&o]) {
            let p = o.get(0);
            self.ensure((1..=64).contains(&p.n_max), || format!("{p:?}"));
        }
        let mut o = Out::<ml_acceptor_options>::one(out);
        let s = ml_acceptor_options_default(o.p());
        if self.status("ml_acceptor_options_default", s, &[&o]) {
            let a = o.get(0);
            self.ensure(a.epsilon > 0.0 && a.geometry_clamp > 0.0, || {
                format!("{a:?}")
            });
        }
        let mut v = [
            Out::<u32>::one(out),
            Out::<u32>::one(Ptr::Valid),
            Out::<u32>::one(Ptr::Valid),
        ];
        let [a, b, c] = &mut v;
        let s = ml_version(a.p(), b.p(), c.p());
        if self.status("ml_version", s, &[a, b, c]) {
            let got = (a.get(0), b.get(0), c.get(0));
            let want = (ML_VERSION_MAJOR, ML_VERSION_MINOR, ML_VERSION_PATCH);
            self.ensure(got == want, || format!("ml_version: {got:?}"));
        }
        let mut o = Out::<*const c_char>::one(out);
        let s = ml_status_name(status, o.p());
        if self.status("ml_status_name", s, &[&o]) {
            // SAFETY: a static NUL-terminated string.
            let name = unsafe { CStr::from_ptr(o.get(0)) }.to_string_lossy();
            let known = (ML_OK..=ML_ERR_INTERNAL).contains(&status);
            self.ensure(
                if known {
                    name.starts_with("ML_")
                } else {
                    name == "unknown"
                },
                || format!("ml_status_name({status}): {name}"),
            );
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
    }
}

impl Drop for Harness<'_> {
    fn drop(&mut self) {
        self.release();
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

/// `len` numbers: the drawn ones, then 0.5.
fn numbers(us: &[F], len: usize) -> Vec<f32> {
    (0..len)
        .map(|i| us.get(i).map_or(0.5, |f| f.value()))
        .collect()
}

/// `len` light indices for `n` lights: the drawn ones, then 0.
fn indices(ls: &[Index], len: usize, n: usize) -> Vec<u32> {
    (0..len)
        .map(|i| ls.get(i).map_or(0, |l| l.value(n)))
        .collect()
}

/// Runs the operations with the checks of the module's documentation.
pub fn check(input: &Input) {
    let mut h = Harness {
        input,
        at: 0,
        trees: Vec::new(),
        cuts: Vec::new(),
        ests: Vec::new(),
        accs: Vec::new(),
        serialized: None,
    };
    h.run();
}

impl crate::Checked for Input {
    fn check(&self) {
        check(self)
    }
}

#[cfg(test)]
mod tests {
    /// splitmix64 bytes.
    fn bytes(seed: u64, len: usize) -> Vec<u8> {
        let mut s = seed;
        (0..len)
            .map(|_| {
                s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = s;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                (z ^ (z >> 31)) as u8
            })
            .collect()
    }

    /// Seeded inputs of every length up to 4 KiB pass the checks (the harness itself works:
    /// the committed crash inputs are replayed by `tests/fuzz_regressions.rs`).
    #[test]
    fn seeded_inputs_pass() {
        for seed in 0..300u64 {
            let b = bytes(seed, (seed as usize * 37) % 4096);
            assert!(crate::run::<super::Input>(&b), "seed {seed}: not decoded");
        }
    }
}
