//! The limits the library enforces, as the header's `ML_` macros (each checked against the
//! core's constant at compile time). An input beyond one is `ML_ERR_INVALID_ARGUMENT` with a
//! message naming the macro, its value and the field's own value, e.g.
//! `lights[3].point.intensity gives an energy of 5e25 W, above ML_MAX_LIGHT_ENERGY (1e24)
//! (got 3.9788735e24)`.

use manylights::cut::{MAX_CUT_SIZE, MIN_CUT_SIZE};

/// Largest magnitude of a light's coordinates (positions, centres, vertices) and radii, and of
/// a VPL candidate's position.
pub const ML_MAX_COORDINATE: f32 = 1e15;
const _: () = assert!(ML_MAX_COORDINATE.to_bits() == manylights::MAX_COORDINATE.to_bits());

/// Largest energy (flux, W) of one light: 4π·I for a point light of intensity I,
/// 2π(1 − cos θs)·I for a spot, π·I for a VPL, L·π·area per emitting side for an area light of
/// radiance L (see the README's units table). A VPL acceptor keeps accepted VPLs within it.
pub const ML_MAX_LIGHT_ENERGY: f32 = 1e24;
const _: () = assert!(ML_MAX_LIGHT_ENERGY.to_bits() == manylights::MAX_LIGHT_ENERGY.to_bits());

/// Largest sum of the energies of a tree's lights.
pub const ML_MAX_TOTAL_ENERGY: f32 = 1e26;
const _: () = assert!(ML_MAX_TOTAL_ENERGY.to_bits() == manylights::MAX_TOTAL_ENERGY.to_bits());

/// The smallest pmf a sampled light has (f32's smallest normal number, 2⁻¹²⁶). The one way a
/// light that can contribute at a point gets pmf 0: its probability there would be below this
/// (at some node on its path, the probability of reaching its slot would fall below it;
/// those lights are never sampled and the others share their probability).
///
/// How far apart neighbours' energies may be: at each node on a light's path the descent
/// takes the light's slot with probability w / Σw over the node's four slots, w being the
/// slots' importances (TL or BL: a slot's energy times a factor of how the point sees it —
/// distance, angles, the BRDF; below a node whose slots all have importance 0, their
/// energies), and the light's pmf is the product of those ratios along its path (times the
/// root's choice of the node tree against the lights at infinity). A slot is dropped where
/// that product, in f32, would fall below 2⁻¹²⁶. So of two neighbours a point sees alike (the
/// same factor: at one position, or far away against their spread) the weaker keeps pmf > 0
/// exactly while E_strong / E_weak ≤ 2¹²⁶ ≈ 8.5e37 (up to the 2⁻¹¹ relative rounding of the
/// energies a node stores); among many lights seen alike the ratios multiply to about
/// E_light / E_total, so a light keeps pmf > 0 while the tree's total energy is at most 2¹²⁶
/// times its own: with `ML_MAX_TOTAL_ENERGY`, every light of energy ≥ 1e26 · 2⁻¹²⁶ ≈ 1.2e-12 W
/// seen alike with the others. A light the point sees k times more weakly than its neighbours
/// (farther, at a grazing angle) needs k times more energy.
// Written as C's FLT_MIN is, so that the header's macro reads as the C constant.
#[allow(clippy::excessive_precision)]
pub const ML_MIN_PMF: f32 = 1.17549435e-38;
const _: () = assert!(ML_MIN_PMF.to_bits() == manylights::MIN_PMF.to_bits());

/// Deepest tree (levels of nodes) a build may give; a deeper one is `ML_ERR_INVALID_ARGUMENT`.
pub const ML_MAX_DEPTH: u32 = 31;
const _: () = assert!(ML_MAX_DEPTH == manylights::tree::MAX_DEPTH);

/// Fewest SAOH buckets per axis of `ml_build_options.buckets` (0 is the default, 12).
pub const ML_MIN_BUCKETS: u32 = 12;
/// Most SAOH buckets per axis of `ml_build_options.buckets`.
pub const ML_MAX_BUCKETS: u32 = 64;

/// Fewest clusters a cut's `max_size` may ask for (the root's four slots); the most is
/// `ML_MAX_CUT_SIZE`.
pub const ML_MIN_CUT_SIZE: usize = 4;
const _: () = assert!(ML_MIN_CUT_SIZE == MIN_CUT_SIZE);

/// Most clusters of the node tree a cut's `max_size` may ask for (the lights at infinity add
/// one cluster each: a cut holds at most `ML_CUT_CAPACITY`).
pub const ML_MAX_CUT_SIZE: usize = 64;
const _: () = assert!(ML_MAX_CUT_SIZE == MAX_CUT_SIZE);

/// Largest `ml_direct_params.n_max`, the BRDF-aware budget's Nmax (the smallest is 1).
pub const ML_MAX_BUDGET: u32 = 64;
const _: () = assert!(ML_MAX_BUDGET == manylights::MAX_BUDGET);

/// Largest `ml_direct_params.bl_light_samples`, the light samples of one `bl-mis` estimate
/// (the smallest is 1).
pub const ML_MAX_LIGHT_SAMPLES: u32 = 64;
const _: () = assert!(ML_MAX_LIGHT_SAMPLES == manylights::direct::MAX_LIGHT_SAMPLES);

/// The GGX roughness floor: a material's α (accepted in (0, 1]) is used as max(α,
/// `ML_MIN_ALPHA`) by the BRDFs, the BRDF-oriented importance and the estimators.
pub const ML_MIN_ALPHA: f32 = 5e-3;
const _: () = assert!(ML_MIN_ALPHA.to_bits() == manylights::material::MIN_ALPHA.to_bits());
