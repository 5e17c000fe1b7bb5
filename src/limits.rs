//! The numeric limits of what the build accepts (more is an error naming the light, the field
//! and its value), in one place below every layer that checks or reports them.

/// Largest accepted coordinate magnitude.
pub const MAX_COORDINATE: f32 = 1e15;
/// Largest accepted energy of one light (see [`crate::Light::energy`]).
pub const MAX_LIGHT_ENERGY: f32 = 1e24;
/// Largest accepted sum of all lights' energies.
pub const MAX_TOTAL_ENERGY: f32 = 1e26;
/// Most distant and environment lights a tree holds (at most one of them an environment).
pub const MAX_INFINITE_LIGHTS: usize = 16;
