// compare's report is one `json!` literal, more keys deep than the default limit expands.
#![recursion_limit = "256"]
//! The std side of manylights: the test renderer (scenes, ray casts, the render loop, images)
//! and [`compare`], behind the `mlrender` binary; the instruments build on it.

pub mod cli;
pub mod compare;
pub mod image;
pub mod params;
pub mod render;
pub mod scene;
pub mod uniforms;
