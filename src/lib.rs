//! # manylights
//!
//! Picks, for a point being shaded, which of thousands to millions of lights to sample, with
//! exactly known probabilities.
//!
//! Lights ([`Light`]) are built into a [`LightTree`] with the SAOH heuristic and packed into
//! flat 4-wide [`Node4`] arrays. At a shading point an [`Importance`] (here the classic
//! [`TlImportance`] of Conty & Kulla) ranks the four children of a node at once in f32x4
//! lanes, and [`LightTree::sample`] descends the tree with one uniform number, reporting the
//! light's probability; [`LightTree::pmf`] gives that same probability for any light.
//!
//! ```
//! use manylights::{Light, LightTree, TlImportance};
//! use glam::Vec3;
//!
//! let lights = [
//!     Light::Point { position: Vec3::new(0.0, 0.0, 2.0), intensity: 1.0 },
//!     Light::Sphere { center: Vec3::new(3.0, 0.0, 1.0), radius: 0.5, radiance: 2.0 },
//! ];
//! let tree = LightTree::build(&lights)?;
//! let at = TlImportance::new(Vec3::ZERO, Vec3::Z);
//! let s = tree.sample(&at, 0.3).expect("both lights are above the horizon");
//! assert_eq!(s.pmf, tree.pmf(&at, s.light));
//! # Ok::<(), manylights::BuildError>(())
//! ```
//!
//! Split sampling takes one light in each cluster of a [`LightCut`]
//! ([`LightCut::sample_each`], the descents interleaved four at a time); a renderer that takes
//! many samples at one shading point wraps its importance in a [`Memo`].
//!
//! Instant radiosity hosts keep their virtual point lights ([`Light::Vpl`]) by the
//! probabilistic acceptance of Georgiev & Slusallek 2010 ([`vpl`]: [`Importons`],
//! [`VplAcceptor`]) and sample the accepted ones through a tree like any other lights.
//!
//! The crate is `no_std` (it needs `alloc`). Its one `unsafe` is the cache prefetch hint of the
//! descents, behind the cargo feature `prefetch` (on by default); without that feature the
//! crate forbids `unsafe` code.

#![no_std]
#![cfg_attr(not(feature = "prefetch"), forbid(unsafe_code))]
#![cfg_attr(feature = "prefetch", deny(unsafe_code))]
#![deny(missing_docs)]

extern crate alloc;

/// The binary light tree the 4-wide tree is measured against (the benches' and instruments'
/// yardstick), with the cargo feature `baseline`; not part of the default API.
#[cfg(feature = "baseline")]
pub mod baseline;
pub mod bounds;
pub mod brdf;
pub mod build;
pub mod cut;
pub mod direct;
pub mod error;
pub mod importance;
mod lanes;
pub mod light;
pub mod light_sample;
pub mod light_set;
pub mod material;
mod math;
pub mod mis;
mod packed;
mod prefetch;
pub mod quantize;
pub mod sample;
pub mod trace;
pub mod tree;
pub mod vpl;

pub use brdf::{Brdf, Frame, Ggx, Lambert};
pub use build::{BuildOptions, Join, Serial};
pub use cut::{BlCutOptions, Cluster, LightCut, SplitCutOptions, CUT_CAPACITY};
pub use direct::{Estimator, LightSampler, Occluder, Params, Technique, Uniforms};
pub use error::{
    BuildError, DirectError, FormatError, LengthMismatch, LightField, Problem, ShadingError,
    ShadingField, ValidationError, VplError, VplField,
};
pub use importance::conty_kulla::Receiver;
pub use importance::{BlImportance, Importance, Memo, MemoTable, TlImportance};
pub use light::{Light, MAX_COORDINATE, MAX_LIGHT_ENERGY, MAX_TOTAL_ENERGY};
pub use light_sample::LightPoint;
pub use light_set::{AliasTable, LightSet};
pub use material::{Material, ShadingPoint};
pub use mis::Heuristic;
pub use sample::{LightSample, BATCH_LANES};
pub use tree::{Child, LightTree, Node4, Slot, SlotBounds, Spheres4, TreeStats};
pub use vpl::{Importons, Vpl, VplAcceptor};
/// The lane type of the 4-wide importances: [`Importance::eval4`] returns one (a node's four
/// slots), so a host that implements [`Importance`] or reads its lanes needs it. It is `wide`'s
/// `f32x4` (version 1), re-exported so that hosts need not depend on `wide` themselves.
pub use wide::f32x4;
