//! Errors of the core: what was wrong, with the light's index and the field.

use core::fmt;

/// The field of a [`crate::Light`] that failed validation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum LightField {
    /// `position` of a point or spot light.
    Position,
    /// `direction` of a spot light.
    Direction,
    /// `center` of a sphere or disk light.
    Center,
    /// `normal` of a disk light.
    Normal,
    /// `radius` of a sphere or disk light.
    Radius,
    /// One of the three `vertices` of a triangle light (0, 1 or 2).
    Vertex(u8),
    /// `intensity` of a point or spot light.
    Intensity,
    /// `radiance` of an area light.
    Radiance,
    /// `half_angle` of a spot light.
    HalfAngle,
    /// `falloff_start` of a spot light.
    FalloffStart,
    /// `angular_radius` of a distant light.
    AngularRadius,
    /// `irradiance` of a distant or environment light.
    Irradiance,
}

impl LightField {
    /// The field's name as written in the API.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            LightField::Position => "position",
            LightField::Direction => "direction",
            LightField::Center => "center",
            LightField::Normal => "normal",
            LightField::Radius => "radius",
            LightField::Vertex(0) => "vertices[0]",
            LightField::Vertex(1) => "vertices[1]",
            LightField::Vertex(_) => "vertices[2]",
            LightField::Intensity => "intensity",
            LightField::Radiance => "radiance",
            LightField::HalfAngle => "half_angle",
            LightField::FalloffStart => "falloff_start",
            LightField::AngularRadius => "angular_radius",
            LightField::Irradiance => "irradiance",
        }
    }
}

/// What is wrong with a light's field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Problem {
    /// NaN or infinite.
    NotFinite,
    /// Negative where only non-negative values make sense (power, radiance).
    Negative,
    /// Zero or negative where a positive value is required (radius).
    NotPositive,
    /// A direction or normal of zero length.
    ZeroLength,
    /// Outside the documented range (coordinates beyond ±1e15, spot angles outside (0, π],
    /// a uniform number outside [0, 1), a count of 0).
    OutOfRange,
    /// The light's energy ([`crate::Light::energy`], its flux) exceeds
    /// [`crate::MAX_LIGHT_ENERGY`] (1e24); the error's value is the field's own (the
    /// intensity or radiance that sets it).
    EnergyTooLarge,
}

impl Problem {
    fn describe(self) -> &'static str {
        match self {
            Problem::NotFinite => "is NaN or infinite",
            Problem::Negative => "is negative",
            Problem::NotPositive => "must be positive",
            Problem::ZeroLength => "has zero length",
            Problem::OutOfRange => "is out of range",
            Problem::EnergyTooLarge => "gives an energy above MAX_LIGHT_ENERGY (1e24)",
        }
    }
}

/// A number as messages print it: plainly, or in scientific notation when it is very large
/// or very small (`5e25` rather than 26 digits).
#[derive(Clone, Copy, Debug)]
pub struct Num(pub f32);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        if v != 0.0 && v.is_finite() && !(1e-4..1e9).contains(&v.abs()) {
            write!(f, "{v:e}")
        } else {
            write!(f, "{v}")
        }
    }
}

/// What is wrong with a light's field, in words, naming the limit a range refers to.
fn light_problem(field: LightField, problem: Problem) -> &'static str {
    match (field, problem) {
        (
            LightField::Position | LightField::Center | LightField::Vertex(_) | LightField::Radius,
            Problem::OutOfRange,
        ) => "exceeds MAX_COORDINATE (1e15) in magnitude",
        (LightField::HalfAngle, Problem::OutOfRange) => "must be in (0, π]",
        (LightField::FalloffStart, Problem::OutOfRange) => "must be in [0, half_angle]",
        _ => problem.describe(),
    }
}

/// Why a [`crate::LightTree`] could not be built.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum BuildError {
    /// Light `index` has a bad `field`; `value` is the offending number (a vector's first bad
    /// component, or its length).
    InvalidLight {
        /// Index of the light in the slice passed to the build.
        index: usize,
        /// The field that is wrong.
        field: LightField,
        /// What is wrong with it.
        problem: Problem,
        /// The offending value.
        value: f32,
    },
    /// More lights than the tree can index ([`crate::tree::MAX_LIGHTS`], 2³¹ − 2).
    TooManyLights {
        /// The number passed.
        count: usize,
    },
    /// The lights' energies add up beyond [`crate::MAX_TOTAL_ENERGY`] (1e26).
    TotalEnergyTooLarge,
    /// The collapsed tree is deeper than the 31 levels a 64-bit path can encode.
    TooDeep {
        /// The depth reached.
        depth: u32,
    },
    /// More distant and environment lights than
    /// [`MAX_INFINITE_LIGHTS`](crate::limits::MAX_INFINITE_LIGHTS).
    TooManyInfiniteLights {
        /// The number passed.
        count: usize,
    },
    /// Light `index` is a second environment light (a light set holds at most one).
    SecondEnvironment {
        /// Index of the second environment light.
        index: usize,
    },
    /// Light `index` of a [`crate::LightSet`]'s list is an environment light: a light set's
    /// environment is the host's, given with
    /// [`crate::LightSet::build_with_environment`], which adds its light.
    EnvironmentLight {
        /// Index of the environment light.
        index: usize,
    },
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            BuildError::InvalidLight {
                index,
                field,
                problem,
                value,
            } => write!(
                f,
                "light {index}: field `{}` {} (got {})",
                field.name(),
                light_problem(field, problem),
                Num(value)
            ),
            BuildError::TooManyLights { count } => write!(
                f,
                "{count} lights: at most MAX_LIGHTS (2147483646) are supported"
            ),
            BuildError::TotalEnergyTooLarge => write!(
                f,
                "the lights' total energy exceeds MAX_TOTAL_ENERGY (1e26)"
            ),
            BuildError::TooDeep { depth } => write!(
                f,
                "tree depth {depth} exceeds MAX_DEPTH (31), the levels a path can encode"
            ),
            BuildError::TooManyInfiniteLights { count } => write!(
                f,
                "{count} distant and environment lights: at most {} are supported",
                crate::limits::MAX_INFINITE_LIGHTS
            ),
            BuildError::SecondEnvironment { index } => write!(
                f,
                "light {index}: a second environment light (at most one is supported)"
            ),
            BuildError::EnvironmentLight { index } => write!(
                f,
                "light {index}: field `kind` is environment: a light set takes the host's environment itself (build_with_environment), not its light"
            ),
        }
    }
}

impl core::error::Error for BuildError {}

/// Why bytes given to [`crate::LightTree::from_bytes`] were rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum FormatError {
    /// Shorter than the header or than the arrays the header announces.
    Truncated,
    /// Not a manylights tree (bad magic) or a different format version or byte order.
    BadHeader,
    /// Bytes left over after the arrays the header announces.
    TrailingBytes,
    /// A manylights tree of another format version than the one this build reads.
    UnsupportedVersion {
        /// The version the bytes carry.
        found: u8,
        /// The version this build reads.
        supported: u8,
    },
    /// The payload's CRC-64 is not the one its header stores: the bytes were changed after
    /// they were written.
    Checksum {
        /// The checksum the header stores.
        stored: u64,
        /// The checksum of the payload as it is.
        computed: u64,
    },
    /// The arrays decode but break an invariant of the tree.
    Invalid(ValidationError),
    /// The tree is sound but the lights it was loaded with are not the ones it was built
    /// from.
    Lights(LightMismatch),
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FormatError::Truncated => write!(f, "tree bytes are truncated"),
            FormatError::BadHeader => write!(f, "not a manylights tree of this format version"),
            FormatError::TrailingBytes => write!(f, "tree bytes have trailing data"),
            FormatError::UnsupportedVersion { found, supported } => write!(
                f,
                "tree bytes are of format version {found}; this build reads version {supported} (rebuild the tree)"
            ),
            FormatError::Checksum { stored, computed } => write!(
                f,
                "tree bytes are corrupt: their checksum is {computed:#018x}, the header says {stored:#018x}"
            ),
            FormatError::Invalid(e) => write!(f, "tree bytes decode to an invalid tree: {e}"),
            FormatError::Lights(e) => write!(f, "tree bytes do not match the lights: {e}"),
        }
    }
}

impl core::error::Error for FormatError {}

/// Why lights are not the ones a tree was built from ([`crate::LightTree::check_lights`]): the
/// first mismatch, in index order.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum LightMismatch {
    /// Not as many lights as the tree was built from.
    Count {
        /// The number the tree was built from.
        tree: u32,
        /// The number given.
        given: usize,
    },
    /// A light that no tree could have been built from (the error names it and its field).
    Invalid(BuildError),
    /// A light of positive energy that the tree does not hold, or one of zero energy that it
    /// holds.
    Sampled {
        /// The light.
        light: u32,
        /// Whether the tree holds it.
        in_tree: bool,
    },
    /// A light whose exact bounds (sphere, cone, energy) are not inside its leaf slot's.
    Escapes {
        /// The light.
        light: u32,
    },
    /// Lights `first..end` each lie inside their slots, but their checksum is not the one the
    /// tree stores: one of them changed within its slot's bounds, or they were reordered.
    Changed {
        /// The first light of the block.
        first: u32,
        /// One past its last.
        end: u32,
    },
}

impl fmt::Display for LightMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            LightMismatch::Count { tree, given } => write!(
                f,
                "{given} lights given, the tree was built from {tree}"
            ),
            LightMismatch::Invalid(e) => e.fmt(f),
            LightMismatch::Sampled {
                light,
                in_tree: true,
            } => write!(
                f,
                "light {light} has no energy but the tree holds it: not the light the tree was built from"
            ),
            LightMismatch::Sampled { light, .. } => write!(
                f,
                "light {light} has energy but the tree does not hold it: not the light the tree was built from"
            ),
            LightMismatch::Escapes { light } => write!(
                f,
                "light {light} lies outside its slot's bounds: not the light the tree was built from (moved, turned, grown or brighter)"
            ),
            LightMismatch::Changed { first, end } => write!(
                f,
                "lights {first} to {} differ from the ones the tree was built from (their checksum), though each lies inside its slot",
                end.saturating_sub(1)
            ),
        }
    }
}

impl core::error::Error for LightMismatch {}

/// An invariant of a [`crate::LightTree`] that does not hold (see
/// [`crate::LightTree::validate`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ValidationError {
    /// A child index points outside the node array, or a node is referenced twice.
    BadChild {
        /// The node holding the slot.
        node: u32,
        /// The slot (0..4).
        slot: u8,
    },
    /// A node exists that no slot references.
    UnreachableNode {
        /// The node.
        node: u32,
    },
    /// A leaf slot names a light index out of range, or a light appears twice.
    BadLeaf {
        /// The node holding the slot.
        node: u32,
        /// The slot.
        slot: u8,
    },
    /// A slot has a non-finite or negative number, or an empty slot carries energy.
    BadNumber {
        /// The node holding the slot.
        node: u32,
        /// The slot.
        slot: u8,
    },
    /// An internal slot's energy is not the sum of its children's.
    EnergyMismatch {
        /// The node holding the slot.
        node: u32,
        /// The slot.
        slot: u8,
    },
    /// A slot's sphere or cone does not contain a light below it.
    BoundsViolation {
        /// The light that escapes.
        light: u32,
        /// The depth (0 = root) of the slot that fails to contain it.
        level: u32,
    },
    /// A light's stored path does not lead to its leaf.
    BadPath {
        /// The light.
        light: u32,
    },
    /// The tree is deeper than 31 levels.
    TooDeep,
    /// The recorded statistics (depth, counts) disagree with the arrays.
    BadStats,
    /// An entry of the distant and environment lights is malformed (kind, light index,
    /// numbers), names a light twice or a light of the node tree, or disagrees with the
    /// light it names.
    BadInfinite {
        /// The entry.
        entry: u32,
    },
}

impl fmt::Display for ValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ValidationError::BadChild { node, slot } => {
                write!(f, "node {node} slot {slot}: bad or shared child index")
            }
            ValidationError::UnreachableNode { node } => write!(f, "node {node} is unreachable"),
            ValidationError::BadLeaf { node, slot } => {
                write!(f, "node {node} slot {slot}: bad or repeated light index")
            }
            ValidationError::BadNumber { node, slot } => {
                write!(f, "node {node} slot {slot}: non-finite or negative value")
            }
            ValidationError::EnergyMismatch { node, slot } => {
                write!(
                    f,
                    "node {node} slot {slot}: energy is not the sum of its children"
                )
            }
            ValidationError::BoundsViolation { light, level } => {
                write!(
                    f,
                    "light {light} escapes the bounds of its ancestor at level {level}"
                )
            }
            ValidationError::BadPath { light } => {
                write!(f, "light {light}: stored path does not lead to it")
            }
            ValidationError::TooDeep => write!(f, "tree deeper than 31 levels"),
            ValidationError::BadStats => write!(f, "statistics disagree with the arrays"),
            ValidationError::BadInfinite { entry } => {
                write!(f, "distant or environment entry {entry} is malformed")
            }
        }
    }
}

impl core::error::Error for ValidationError {}

/// The input of the VPL acceptance ([`crate::vpl`]) that was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum VplField {
    /// A candidate's `position`.
    Position,
    /// A candidate's `normal`.
    Normal,
    /// A candidate's `intensity`.
    Intensity,
    /// The acceptor's `epsilon` ε.
    Epsilon,
    /// The acceptor's pixel count P.
    Pixels,
    /// The acceptor's wanted VPL count N.
    Wanted,
    /// The uniform number ξ of an acceptance decision.
    Xi,
    /// An estimate of the total VPL illumination luminance Φ̃_total (or of one frame's).
    Luminance,
    /// The acceptor's geometry-term clamp.
    GeometryClamp,
    /// An importon's `position`.
    ImportonPosition,
    /// An importon's `normal`.
    ImportonNormal,
    /// An importon's view direction `wo`.
    ImportonWo,
    /// An importon's diffuse `albedo`, or a lobe weight or roughness of its material.
    ImportonMaterial,
}

impl VplField {
    /// The field's name as written in the API.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            VplField::Position => "position",
            VplField::Normal => "normal",
            VplField::Intensity => "intensity",
            VplField::Epsilon => "epsilon",
            VplField::Pixels => "pixels",
            VplField::Wanted => "wanted",
            VplField::Xi => "xi",
            VplField::Luminance => "luminance",
            VplField::GeometryClamp => "geometry_clamp",
            VplField::ImportonPosition => "importon position",
            VplField::ImportonNormal => "importon normal",
            VplField::ImportonWo => "importon wo",
            VplField::ImportonMaterial => "importon material",
        }
    }
}

/// Why an input of the VPL acceptance was rejected: the field, what is wrong with it, the
/// offending value (a vector's first bad component, or its length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VplError {
    /// The field that is wrong.
    pub field: VplField,
    /// What is wrong with it.
    pub problem: Problem,
    /// The offending value.
    pub value: f32,
}

impl fmt::Display for VplError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "VPL acceptance: `{}` {} (got {})",
            self.field.name(),
            self.problem.describe(),
            self.value
        )
    }
}

impl core::error::Error for VplError {}

/// A batch call was given slices of different lengths.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LengthMismatch {
    /// The argument whose length is wrong.
    pub what: &'static str,
    /// The length it must have (that of the first slice).
    pub expected: usize,
    /// Its length.
    pub got: usize,
}

impl LengthMismatch {
    /// `Err` unless `got == expected`.
    pub(crate) fn check(what: &'static str, expected: usize, got: usize) -> Result<(), Self> {
        if got == expected {
            Ok(())
        } else {
            Err(LengthMismatch {
                what,
                expected,
                got,
            })
        }
    }
}

impl fmt::Display for LengthMismatch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "argument `{}` has length {}, expected {} (one entry per shading point)",
            self.what, self.got, self.expected
        )
    }
}

impl core::error::Error for LengthMismatch {}

/// Why an estimator refused its input.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum DirectError {
    /// The shading point is invalid.
    Shading(ShadingError),
    /// A uniform number from the host is NaN or outside [0, 1).
    Uniform {
        /// The number.
        value: f64,
    },
    /// The host's BSDF pdf is NaN, negative or infinite.
    BsdfPdf {
        /// The pdf.
        value: f32,
    },
    /// The host's BSDF direction is not finite or has zero length.
    Direction {
        /// Its squared length.
        length_squared: f32,
    },
    /// The host's hit distance is NaN or negative.
    HitDistance {
        /// The distance.
        value: f32,
    },
    /// The host environment's pdf ([`crate::light::Environment::sample`] or
    /// [`crate::light::Environment::eval`]) is NaN, negative or infinite (or not positive for
    /// a sample).
    EnvironmentPdf {
        /// The pdf.
        value: f32,
    },
    /// A channel of the host environment's radiance (of a sample or of `eval`) is NaN,
    /// negative or infinite.
    EnvironmentRadiance {
        /// The channel's value.
        value: f32,
    },
    /// The visibility cache was made for another light set
    /// ([`crate::direct::VisibilityCache::fits`]).
    VisibilityCache,
}

impl From<ShadingError> for DirectError {
    fn from(e: ShadingError) -> Self {
        DirectError::Shading(e)
    }
}

impl fmt::Display for DirectError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            DirectError::Shading(e) => e.fmt(f),
            DirectError::Uniform { value } => {
                write!(f, "uniform number: must be in [0, 1) (got {value})")
            }
            DirectError::BsdfPdf { value } => {
                write!(f, "bsdf_pdf: must be finite and non-negative (got {value})")
            }
            DirectError::Direction { length_squared } => write!(
                f,
                "direction: must be finite and non-zero (squared length {length_squared})"
            ),
            DirectError::HitDistance { value } => {
                write!(
                    f,
                    "hit_distance: must be non-negative or +inf (got {value})"
                )
            }
            DirectError::EnvironmentPdf { value } => write!(
                f,
                "the environment's pdf (of its sample or eval): must be finite and non-negative, and positive for a sample (got {value})"
            ),
            DirectError::EnvironmentRadiance { value } => write!(
                f,
                "the environment's radiance (of its sample or eval): every channel must be finite and non-negative (got {value})"
            ),
            DirectError::VisibilityCache => f.write_str(
                "visibility: the cache was made for another light set (its light count, tree depth or lights at infinity differ)"
            ),
        }
    }
}

impl core::error::Error for DirectError {}

/// A field of a [`crate::ShadingPoint`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ShadingField {
    /// `position`.
    Position,
    /// `normal`.
    Normal,
    /// `wo`.
    Wo,
    /// The material's `albedo`.
    Albedo,
    /// The material's `specular` weight.
    Specular,
    /// The material's `alpha`.
    Alpha,
}

impl ShadingField {
    /// The field's name as written in the API.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ShadingField::Position => "position",
            ShadingField::Normal => "normal",
            ShadingField::Wo => "wo",
            ShadingField::Albedo => "albedo",
            ShadingField::Specular => "specular",
            ShadingField::Alpha => "alpha",
        }
    }
}

/// Why a shading point was rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingError {
    /// The field that is wrong.
    pub field: ShadingField,
    /// What is wrong with it.
    pub problem: Problem,
    /// The offending value.
    pub value: f32,
}

impl fmt::Display for ShadingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let what = match self.problem {
            Problem::NotFinite => "is NaN or infinite",
            Problem::Negative => "is negative",
            Problem::ZeroLength => "has zero length",
            _ => "is out of range",
        };
        write!(
            f,
            "shading point: field `{}` {what} (got {})",
            self.field.name(),
            self.value
        )
    }
}

impl core::error::Error for ShadingError {}
