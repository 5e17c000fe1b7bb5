//! The std side of manylights: the test renderer (scenes, ray casts, the render loop, images)
//! and the project's instruments, shared by the `mlrender` binary.

pub mod alloc_count;
pub mod image;
pub mod instruments;
pub mod params;
pub mod render;
pub mod scene;
pub mod uniforms;
