//! The input grammar: how the fuzzer's bytes decode (`Arbitrary`) into the operations the
//! harness replays, and how each drawn value becomes an argument of the C ABI (`ml()`,
//! [`F::value`], [`Count::value`], ...). The decoding of every type here is part of what the
//! committed inputs mean: changing a type, a variant or its order changes them.

use arbitrary::{Arbitrary, Unstructured};
use manylights_ffi::*;
use std::fmt;

/// A grey colour.
pub(crate) fn grey(v: f32) -> ml_rgb {
    ml_rgb { r: v, g: v, b: v }
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

pub(super) fn v3(v: &V3) -> ml_vec3 {
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

/// A light descriptor (`ml_light`), every field drawn; the fields feed the member of the
/// kind (`Drawn::ml`).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Light {
    /// An `ml_light_kind` (seven values), or 7: the first light of kind 7 of a build's
    /// lights is its environment instead (`EnvSpec::from_light`: bounds, callbacks and values
    /// from the other fields), any further one stays in the array (invalid).
    pub kind: Enum,
    /// 0 or 1, or out of range (disk and triangle lights).
    pub two_sided: Enum,
    /// Position, centre or vertex 0.
    pub position: V3,
    /// Axis, normal, vertex 1 or a distant light's direction.
    pub direction: V3,
    /// Vertex 2.
    pub vertex2: V3,
    /// Intensity, radiance or irradiance (grey).
    pub power: F,
    /// Radius.
    pub radius: F,
    /// Spot half-angle, or a distant light's angular radius.
    pub half_angle: F,
    /// Spot falloff start, as a fraction of the half-angle (or raw).
    pub falloff_start: F,
}

/// The values a [`Light`] draws, each kind's fields among them.
#[derive(Debug, Clone, Copy)]
pub(super) struct Drawn {
    pub(super) kind: u32,
    pub(super) two_sided: u32,
    pub(super) position: ml_vec3,
    pub(super) direction: ml_vec3,
    pub(super) vertex2: ml_vec3,
    pub(super) power: f32,
    pub(super) radius: f32,
    pub(super) half_angle: f32,
    pub(super) falloff_start: f32,
}

impl Light {
    /// The drawn values.
    pub(super) fn drawn(&self) -> Drawn {
        Drawn {
            kind: self.kind.value(8),
            two_sided: self.two_sided.value(2),
            position: v3(&self.position),
            direction: v3(&self.direction),
            vertex2: v3(&self.vertex2),
            power: self.power.value(),
            radius: self.radius.value(),
            half_angle: self.half_angle.value(),
            falloff_start: match self.falloff_start {
                F::Unit(_) => self.falloff_start.value() * self.half_angle.value(),
                f => f.value(),
            },
        }
    }
}

impl Drawn {
    /// The descriptor: the drawn values in the member of the kind (a point, spot or VPL
    /// light's position, a sphere or disk's centre, vertex 0; a spot's axis, a disk or VPL's
    /// normal, vertex 1, a distant light's direction; the power its intensity, radiance or
    /// irradiance; a distant light's angular radius the half-angle); any other kind alone.
    pub(super) fn ml(&self) -> ml_light {
        let (kind, p, d, e) = (self.kind, self.position, self.direction, grey(self.power));
        match kind {
            0 => ml_point_light {
                kind,
                position: p,
                intensity: e,
            }
            .into(),
            1 => ml_spot_light {
                kind,
                position: p,
                axis: d,
                intensity: e,
                half_angle: self.half_angle,
                falloff_start: self.falloff_start,
            }
            .into(),
            2 => ml_sphere_light {
                kind,
                center: p,
                radius: self.radius,
                radiance: e,
            }
            .into(),
            3 => ml_disk_light {
                kind,
                center: p,
                normal: d,
                radius: self.radius,
                radiance: e,
                two_sided: self.two_sided,
            }
            .into(),
            4 => ml_triangle_light {
                kind,
                v0: p,
                v1: d,
                v2: self.vertex2,
                radiance: e,
                two_sided: self.two_sided,
            }
            .into(),
            5 => ml_vpl_light {
                kind,
                position: p,
                normal: d,
                intensity: e,
            }
            .into(),
            6 => ml_distant_light {
                kind,
                direction: d,
                angular_radius: self.half_angle,
                irradiance: e,
            }
            .into(),
            _ => {
                let mut l = ml_light::default();
                l.kind = kind;
                l
            }
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
    pub(super) fn ml(&self) -> ml_material {
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
    pub(super) fn ml(&self) -> ml_shading_point {
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
    /// The `ml_receiver` (3 kinds, or out of range).
    pub receiver: Enum,
}

impl TlPoint {
    pub(super) fn ml(&self) -> ml_tl_point {
        ml_tl_point {
            position: v3(&self.position),
            normal: v3(&self.normal),
            receiver: self.receiver.value(3),
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
    /// The wide-cap rule.
    pub split_sin: F,
}

impl CutOpts {
    pub(super) fn ml(&self) -> ml_bl_cut_options {
        ml_bl_cut_options {
            delta: self.delta.value(),
            max_size: self.max_size.value(),
            split_sin: self.split_sin.value(),
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
    pub(super) fn ml(&self) -> ml_split_cut_options {
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
    /// The BRDF-oriented cut's options (`bl`, `bl-mis`).
    pub cut: CutOpts,
    /// The mixture's cut options (`mis-equal`, `full`).
    pub mixture_cut: CutOpts,
    /// `bl-mis`'s light samples: `1 + b mod 4` for `b` < 240, 0 for `b` < 248 (out of range),
    /// else `57 + b − 240` (up to 72: 65 and above are out of range).
    pub bl_light_samples: u8,
    /// Nmax: `1 + b mod 64` for `b` < 240, else `b − 240` (0 to 15: 0 is out of range).
    pub n_max: u8,
    /// An `ml_lambert_mode` (four values).
    pub lambert: Enum,
    /// 0 or 1, or out of range.
    pub heuristic: Enum,
}

impl Params {
    pub(super) fn ml(&self) -> ml_direct_params {
        ml_direct_params {
            split_cut: self.split.ml(),
            bl_cut: self.cut.ml(),
            mixture_cut: self.mixture_cut.ml(),
            bl_light_samples: match self.bl_light_samples {
                b @ 0..240 => 1 + u32::from(b) % 4,
                240..248 => 0,
                b => 57 + u32::from(b - 240),
            },
            n_max: if self.n_max < 240 {
                1 + u32::from(self.n_max) % 64
            } else {
                u32::from(self.n_max - 240)
            },
            lambert: self.lambert.value(4),
            heuristic: self.heuristic.value(2),
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

impl Importon {
    pub(super) fn ml(&self) -> ml_importon {
        ml_importon {
            hit: if self.hit.0 < 32 {
                0
            } else if self.hit.0 < 240 {
                1
            } else {
                u32::from(self.hit.0)
            },
            position: v3(&self.position),
            normal: v3(&self.normal),
            wo: v3(&self.wo),
            material: self.material.ml(),
        }
    }
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
    pub(super) fn ml(&self) -> ml_vpl {
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
    /// `ml_cut_size`, `ml_cut_ib` and `ml_cut_max_variance` (each of the two answers for its own
    /// kind of cut only).
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
    /// `ml_tree_build_parallel`, then `ml_tree_build` of the same arguments: the same status,
    /// and on success the same tree byte for byte (`ml_tree_serialize`).
    BuildParallel {
        /// The lights (the first [`MAX_LEN`]).
        lights: Vec<Light>,
        /// How many are passed.
        count: Count,
        /// The array pointer.
        ptr: Ptr,
        /// `options` (NULL: defaults); `buckets` as given.
        options: Option<Arg<u8>>,
        /// `threads`.
        threads: Threads,
        /// `out`.
        out: Ptr,
    },
    /// `ml_tree_load_with_lights`; serialized bytes unedited with the lights of their tree
    /// load, and the tree serializes to the same bytes and answers the pmfs, samples and
    /// points on lights of the tree they were saved from bit for bit (at `points` and `sps`).
    LoadWithLights {
        /// The bytes.
        bytes: Bytes,
        /// The lights.
        lights: LightsArg,
        /// How many lights are passed.
        count: Count,
        /// The byte pointer (valid or NULL) and the lights' pointer.
        ptrs: [Ptr; 2],
        /// `out`.
        out: Ptr,
        /// TL points where the pmfs are compared (the first [`MAX_COMPARE`]).
        points: Vec<TlPoint>,
        /// Shading points where the BL pmfs are compared (the first [`MAX_COMPARE`]).
        sps: Vec<Sp>,
    },
    /// `ml_light_sample_point_batch` (then the single calls).
    LightSamplePointBatch {
        /// The tree.
        tree: Handle,
        /// The shading positions (the first [`MAX_LEN`]).
        xs: Vec<V3>,
        /// The lights (missing ones 0).
        lights: Vec<Index>,
        /// u0 (missing ones 0.5).
        u0s: Vec<F>,
        /// u1 (missing ones 0.5).
        u1s: Vec<F>,
        /// How many are passed.
        count: Count,
        /// `lights`, `xs`, `u0s`, `u1s`, `out`.
        ptrs: [Ptr; 5],
    },
    /// `ml_direct_estimate_batch`, then the same estimates one call at a time from the same
    /// uniform numbers and visibility: `ml_direct_estimate` per point (one estimate a point),
    /// or one estimator set up at each point in turn and its estimates.
    DirectEstimateBatch {
        /// The tree.
        tree: Handle,
        /// The shading points (the first [`MAX_ESTIMATE_BATCH`]).
        points: Vec<Sp>,
        /// How many are passed.
        count: Count,
        /// `per_point`: `1 + b mod 3` for `b` < 240, else `b − 240` (0 to 15: 0 is out of range).
        per_point: u8,
        /// An `ml_technique`.
        technique: Enum,
        /// `params` (NULL: defaults).
        params: Option<Arg<Params>>,
        /// `visibility` (NULL: unoccluded).
        visibility: Option<Arg<Visibility>>,
        /// `uniforms`.
        uniforms: Arg<Uniforms>,
        /// `points`, `out`.
        ptrs: [Ptr; 2],
    },
    /// `ml_tree_build` of the descriptors of `tree` (a tree that holds them) with the host's
    /// `environment` (any environment `tree` had replaced; NULL when absent), the new tree
    /// kept, then `ml_direct_estimate` on it: an environment whose callbacks return a bad value
    /// makes the estimate `ML_ERR_INVALID_ARGUMENT` when they are called.
    EnvBuild {
        /// The tree whose descriptors are taken.
        tree: Handle,
        /// The shading point.
        sp: Arg<Sp>,
        /// An `ml_technique`.
        technique: Enum,
        /// `params` (NULL: defaults).
        params: Option<Arg<Params>>,
        /// `visibility` (NULL: unoccluded).
        visibility: Option<Arg<Visibility>>,
        /// `environment` of the build (NULL when absent).
        environment: Option<Arg<EnvDesc>>,
        /// `uniforms`.
        uniforms: Arg<Uniforms>,
        /// `out`.
        out: Ptr,
    },
    /// `ml_estimator_estimate` (the slot of the former `ml_estimator_estimate_env`; its
    /// `environment` is unused).
    EstimateEnv {
        /// The estimator.
        est: Handle,
        /// `visibility` (NULL: unoccluded).
        visibility: Option<Arg<Visibility>>,
        /// Unused.
        environment: Option<Arg<EnvDesc>>,
        /// `uniforms`.
        uniforms: Arg<Uniforms>,
        /// `out`.
        out: Ptr,
    },
    /// `ml_estimator_bsdf_hits` of an escaping ray (`hit_distance` +∞ when `environment_pdf`
    /// is in [0, 1), else the drawn one): on a tree with an environment it reaches it.
    BsdfHitsEnv {
        /// The estimator.
        est: Handle,
        /// The direction.
        direction: V3,
        /// The BSDF pdf.
        bsdf_pdf: F,
        /// The first surface's distance (when used).
        hit_distance: F,
        /// Chooses +∞ over `hit_distance`.
        environment_pdf: F,
        /// `each` NULL (rarely).
        no_each: Rare,
        /// `any_hit`.
        any_hit: Ptr,
    },
    /// [`Op::Run`] on a new tree: `ml_tree_build` of the descriptors of `tree` with the host's
    /// `environment` (valid pointer), kept as a live tree.
    RunEnv {
        /// The tree whose descriptors are taken.
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
        /// The environment.
        environment: EnvDesc,
        /// First-surface distances of the BSDF rays.
        distances: Vec<F>,
        /// Kept as a live estimator.
        keep: bool,
    },
    /// `ml_visibility_cache_create` (NULL `options`, or the defaults with these fields).
    CacheCreate {
        /// The tree.
        tree: Handle,
        /// `options`.
        options: Arg<CacheOpts>,
        /// `out`.
        out: Ptr,
    },
    /// `ml_visibility_cache_free`.
    CacheFree(Handle),
    /// One of the cache's calls.
    Cache {
        /// The cache.
        cache: Handle,
        /// Which.
        call: CacheCall,
    },
    /// `ml_estimator_set_visibility_cache` (a NULL `cache` detaches).
    SetCache {
        /// The estimator.
        est: Handle,
        /// The cache.
        cache: Handle,
    },
    /// `ml_estimator_record` (`visible` as drawn: 0, 1 or another value).
    Record {
        /// The estimator.
        est: Handle,
        /// `visible`.
        visible: u8,
    },
}

/// `ml_visibility_cache_options`, from the defaults: `cell_size` as drawn; `cells` and
/// `slots` from [`CacheSize`]; `floor` as drawn, or the default's.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct CacheOpts {
    /// `cell_size`.
    pub cell_size: F,
    /// `cells`.
    pub cells: CacheSize,
    /// `slots`.
    pub slots: CacheSize,
    /// `floor` (`None`: the default).
    pub floor: Option<F>,
}

/// A cache's `cells` or `slots`: `b` for `b` < 200 (a power of two or not, 0 included), else
/// above its limit (`limit << (b − 199)` in u32, 0 once the bit is shifted out): never a
/// table above 199 × 199 counters.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct CacheSize(pub u8);

impl CacheSize {
    /// The value, for a field whose limit is `limit`.
    pub fn value(self, limit: u32) -> u32 {
        if self.0 < 200 {
            u32::from(self.0)
        } else {
            limit.checked_shl(u32::from(self.0 - 199)).unwrap_or(0)
        }
    }
}

/// A call of a visibility cache.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum CacheCall {
    /// `ml_visibility_cache_commit`.
    Commit,
    /// `ml_visibility_cache_clear`.
    Clear,
    /// `ml_visibility_cache_set_recording` (`on` as drawn: 0, 1 or another value).
    SetRecording(u8),
    /// `ml_visibility_cache_stats`.
    Stats(Ptr),
    /// `ml_visibility_cache_bytes`.
    Bytes(Ptr),
}

/// Points and lights compared per operation between a tree loaded with its lights and the
/// tree it was saved from.
pub const MAX_COMPARE: usize = 4;
/// Shading points of one `ml_direct_estimate_batch`.
pub const MAX_ESTIMATE_BATCH: usize = 8;

/// `threads` of `ml_tree_build_parallel`: `b mod 4` (0: one per core) for `b` < 248, else
/// `1025 + b − 248` (above the limit, 1024).
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct Threads(pub u8);

impl Threads {
    /// The value.
    pub fn value(self) -> u32 {
        if self.0 < 248 {
            u32::from(self.0 % 4)
        } else {
            1025 + u32::from(self.0 - 248)
        }
    }
}

/// The light descriptors passed to `ml_tree_load_with_lights`.
#[derive(Arbitrary, Debug, Clone)]
pub enum LightsArg {
    /// Those of the tree last serialized (skipped when they are not known: a tree loaded
    /// without them).
    Own,
    /// Those, light `i` mod their number replaced by each `Light` (the first [`MAX_LEN`]).
    Edited(Vec<(u8, Light)>),
    /// Drawn ones (the first [`MAX_LEN`]).
    Drawn(Vec<Light>),
}

/// The host's environment (`ml_environment`, given to a build): uniform over the sphere (the
/// direction from `u0`, `u1`), grey radiance from `radiance` (its magnitude, at most 1e4; 1
/// if not finite), pdf 1/4π from both callbacks, irradiance bounds π times that radiance;
/// `sample` gives no direction for the numbers whose bit of `misses` (the first eight) is
/// set. `raw` passes the radiance and the pdf `pdf` as drawn (NaN, negative, infinite
/// included), and `zero` a zero direction.
#[derive(Arbitrary, Debug, Clone)]
pub struct EnvDesc {
    /// `sample` NULL (rarely).
    pub no_sample: Rare,
    /// `eval` NULL (rarely).
    pub no_eval: Rare,
    /// The radiance.
    pub radiance: F,
    /// `sample`'s answers: `true` for no direction (the first eight, chosen by the numbers).
    pub misses: Vec<bool>,
    /// Radiance and pdf as drawn (rarely).
    pub raw: Rare,
    /// The pdf of both callbacks when `raw`.
    pub pdf: F,
    /// `sample` gives a zero direction (rarely).
    pub zero: Rare,
}

/// `len` numbers: the drawn ones, then 0.5.
pub(super) fn numbers(us: &[F], len: usize) -> Vec<f32> {
    (0..len)
        .map(|i| us.get(i).map_or(0.5, |f| f.value()))
        .collect()
}

/// `len` light indices for `n` lights: the drawn ones, then 0.
pub(super) fn indices(ls: &[Index], len: usize, n: usize) -> Vec<u32> {
    (0..len)
        .map(|i| ls.get(i).map_or(0, |l| l.value(n)))
        .collect()
}
