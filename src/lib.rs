//! # manylights
//!
//! Picks, for a point being shaded, which of thousands to millions of lights to sample, with
//! exactly known probabilities.
//!
//! Lights ([`Light`]) are built into a [`LightTree`] with the SAOH heuristic and packed into
//! flat 4-wide [`Node4`](tree::Node4) arrays. At a shading point an [`Importance`] (here the classic
//! [`TlImportance`] of Conty & Kulla) ranks the four children of a node at once in f32x4
//! lanes, and [`LightTree::sample`] descends the tree with one uniform number, reporting the
//! light's probability; [`LightTree::pmf`] gives that same probability for any light.
//!
//! ```
//! use manylights::{Light, LightTree, Rgb, TlImportance};
//! use glam::Vec3;
//!
//! let lights = [
//!     Light::Point { position: Vec3::new(0.0, 0.0, 2.0), intensity: Rgb::grey(1.0) },
//!     Light::Sphere {
//!         center: Vec3::new(3.0, 0.0, 1.0),
//!         radius: 0.5,
//!         radiance: Rgb::new(2.0, 1.5, 1.0),
//!     },
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
//!
//! # Units and limits
//!
//! Radiometric throughout: lengths in the scene's unit (m below), intensity I in W/sr,
//! radiance L in W/(m²·sr). A light's energy ([`Light::energy`]) is its flux in W; the tree
//! ranks clusters by it and [`LightTree::total_energy`] adds it up.
//!
//! | light | fields | emission | energy (flux) |
//! |---|---|---|---|
//! | [`Light::Point`] | `position` | `intensity` I, every direction | 4πI |
//! | [`Light::Spot`] | `position`, `direction` (axis), `half_angle` θs ∈ (0, π], `falloff_start` θf ∈ [0, θs] | `intensity` I on the axis, I·smoothstep(cos θs, cos θf, cos θ) off it | 2π(1 − cos θs)·I (a bound of the flux with the falloff) |
//! | [`Light::Sphere`] | `center`, `radius` | `radiance` L outwards | L·π·4πr² |
//! | [`Light::Disk`] | `center`, `normal`, `radius`, `two_sided` | `radiance` L on the normal's side (both if two-sided) | L·π·πr² per side |
//! | [`Light::Triangle`] | `vertices`, `two_sided` | `radiance` L on the side of (v1 − v0) × (v2 − v0) | L·π·area per side |
//! | [`Light::Vpl`] | `position`, `normal` | `intensity` I·max(0, cos θ) about the normal | πI |
//!
//! A point on a light ([`LightPoint`]) carries `radiance`: the radiance arriving at x for area
//! lights; for point, spot and VPL lights `I · falloff / d²` (W/m²), already divided by the
//! squared distance, with `pdf` = 1 (the delta's weight).
//!
//! Materials ([`Material`]): Lambert f = albedo/π; GGX f = specular · D·G/(4 cos θo cos θi),
//! the GGX (Trowbridge–Reitz) distribution with roughness α used as given (clamped below at
//! [`material::MIN_ALPHA`]), height-correlated Smith masking–shadowing, no Fresnel; plastic
//! their sum. Estimates are of the reflected radiance `∫ f L cos θi dω`, W/(m²·sr).
//!
//! VPL acceptance ([`vpl`]): the total luminance Φ̃_total is the sum over the image's P pixels
//! of each pixel's radiance due to the VPLs, in the units of `f·G·I` (W/(m²·sr), before
//! exposure or tone mapping); [`VplAcceptor::update`] takes each frame's sum (the running mean
//! is the estimate); before the first frame, P times the mean over the importons j of
//! `Σ_i c_ij` over a walk's candidates i (c_ij the radiance candidate i sends through importon
//! j towards the camera) is a fair one, and 0 accepts every candidate of the first frame.
//!
//! What the build accepts (more is an error naming the light, the field and its value): lights
//! at most [`tree::MAX_LIGHTS`] (2³¹ − 2); coordinates and radii of magnitude at most
//! [`MAX_COORDINATE`] (1e15); a light's energy at most [`MAX_LIGHT_ENERGY`] (1e24) and their
//! sum at most [`MAX_TOTAL_ENERGY`] (1e26); a tree at most [`tree::MAX_DEPTH`] (31) levels
//! deep. A light that emits has a positive energy however small (at least 2⁻¹⁴⁹), so it is
//! in the tree.
//!
//! Probabilities: a sampled light's pmf is at least [`MIN_PMF`] (2⁻¹²⁶). A light that
//! can contribute at a point has pmf > 0 there except in one case: its probability would be
//! below `MIN_PMF` (at some node on its path the probability of reaching its slot falls below
//! it; such slots get weight 0 and their siblings share their probability, so the pmfs still
//! sum to 1).

#![no_std]
#![cfg_attr(not(feature = "prefetch"), forbid(unsafe_code))]
#![cfg_attr(feature = "prefetch", deny(unsafe_code))]
#![deny(missing_docs)]
// Pure functions and builders say so: a result dropped by mistake is a warning.
#![warn(clippy::must_use_candidate)]
// What only the tests, the fuzz checks and the tools reach (through `internals`) is compiled
// where it is defined under `cfg(any(test, feature = "internals"))`: a product build has no
// code it does not use, and no lint is silenced crate-wide.

/// The README, whose Rust example `cargo test --doc` compiles and runs.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

extern crate alloc;

/// The binary light tree the 4-wide tree is measured against (the benches' and instruments'
/// yardstick), with the cargo feature `baseline`; not part of the default API.
#[cfg(feature = "baseline")]
pub mod baseline;
mod bounds;
mod brdf;
mod build;
mod checksum;
mod colour;
pub mod cut;
pub mod direct;
pub mod error;
pub mod importance;
mod infinite;
mod infinite_light;
mod lanes;
pub mod light;
pub mod light_set;
mod limits;
pub mod material;
mod math;
mod mis;
mod packed;
mod prefetch;
mod quantize;
mod sample;
mod trace;
pub mod tree;
pub mod vpl;
pub mod wavefront;

pub use brdf::{Brdf, Frame, Ggx, Lambert};
pub use build::{BuildOptions, Join, Serial};
pub use colour::Rgb;
pub use cut::{BlCutOptions, LightCut, SplitCutOptions};
pub use direct::{Estimator, LightSampler, Occluder, Params, Technique, Uniforms};
pub use error::{
    BuildError, DirectError, FormatError, LengthMismatch, ShadingError, ValidationError, VplError,
};
pub use importance::{BlImportance, Importance, Memo, TlImportance};
pub use light::{Light, LightPoint, MAX_COORDINATE, MAX_LIGHT_ENERGY, MAX_TOTAL_ENERGY};
pub use light_set::LightSet;
pub use material::{Material, ShadingPoint};
pub use mis::{Heuristic, MAX_BUDGET};
pub use sample::{SampledLight, MIN_PMF};
pub use tree::LightTree;
pub use vpl::{Importons, Vpl, VplAcceptor};

#[cfg(feature = "internals")]
#[doc(hidden)]
pub mod internals;
