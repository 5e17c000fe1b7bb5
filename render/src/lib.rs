//! The std side of manylights: the test renderer and the project's instruments, shared by the
//! `mlrender` binary and the core's benches.

pub mod bench;
pub mod compare;
pub mod estimator;
pub mod font;
pub mod ggx;
pub mod random_scene;
pub mod render;
pub mod scene;
pub mod sptd_accuracy;
pub mod sptd_fit;
pub mod vpl;
