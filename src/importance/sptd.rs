//! Spherical Pivot Transformed Distributions (Dupuy, Heitz & Belcour 2017, "A Spherical Cap
//! Preserving Parameterization for Spherical Distributions"), as Liu et al. 2019 use them for
//! the BRDF-oriented importance (their Eqn. 5 and 6: the cosine-weighted BRDF integrated over
//! the cap a cluster's bounding sphere subtends); docs/formulas.md, sections 7 and 8.
//!
//! - [`trig`]: polynomial `atan2`/`asin`/`acos`, scalar and 4-wide, with measured errors.
//! - [`Cap`], [`intersection_area`]: caps that keep `1 ∓ cos σ` exact, and the exact area of
//!   the intersection of two caps in a form that does not cancel for tiny caps.
//! - [`Pivot`]: the pivot transform `P`, its Jacobian, the SPTD density and the closed-form
//!   cap-to-cap map with the stable `1 − z'`.
//! - [`SptdGgx`]: GGX's cap integral (height-correlated Smith, no Fresnel): an SPTD fitted
//!   per (α, θo) by `sptd-fit` (tools/sptd-fit) into the generated table [`table`], horizon-clipped
//!   through `P(H)` (computed once per shading point), with a fitted Lambert share and a
//!   masking correction for caps that graze the horizon, for large caps; for small ones the
//!   exact `f cos` averaged in closed form across the plane of incidence, where GGX's lobe is
//!   far narrower than along it at oblique views (see the `ggx` submodule's docs).
//! - [`lambert_cap`], [`lambert_visible`]: the exact horizon-clipped cosine integral over a cap
//!   (Lambert BRDFs), and the solid angle of the cap's visible part.
//!
//! ```
//! use manylights::internals::sptd::SptdGgx;
//! use glam::Vec3;
//!
//! // Once per shading point: roughness, normal, direction to the viewer.
//! let ggx = SptdGgx::oriented(0.2, Vec3::Z, Vec3::new(0.6, 0.0, 0.8));
//! // Per cluster: the cap its bounding sphere subtends (axis, sin σ = r/d).
//! let mirror = Vec3::new(-0.6, 0.0, 0.8);
//! let near = ggx.integral(mirror, 0.1);
//! let away = ggx.integral(Vec3::new(0.6, 0.0, 0.8), 0.1);
//! assert!(near > 10.0 * away);
//! // Inside the bounding sphere: the whole hemisphere, the directional albedo.
//! assert_eq!(ggx.integral(mirror, 1.0), ggx.albedo());
//! ```
//!
//! Each per-cluster evaluator has a scalar reference and a 4-wide twin over [`Cap4`]; tests
//! hold them equal lane by lane. Nothing allocates; NaN input gives 0 (or the documented
//! value), never NaN.

mod cap;
mod ggx;
mod ggx_table;
mod lambert;
mod pivot;
pub mod trig;

pub mod table;

pub use ggx::SptdGgx;
pub(crate) use ggx::SptdGgx4;
pub use lambert::{lambert_visible, lambert_visible4};
// What the fit and the tests reach through `internals`.
#[cfg(any(test, feature = "internals"))]
pub use cap::{intersection_area, intersection_area4, Cap, Cap4};
#[cfg(any(test, feature = "internals"))]
pub use ggx::{CapIntegrals, CapIntegrals4};
#[cfg(any(test, feature = "internals"))]
pub use ggx_table::{ggx_params, table_node, GgxParams, TABLE_SIZE, THETA_O_MAX};
#[cfg(any(test, feature = "internals"))]
pub use lambert::{lambert_cap, lambert_cap4};
#[cfg(any(test, feature = "internals"))]
pub use pivot::{Pivot, MAX_NORM};

#[cfg(test)]
mod tests;
