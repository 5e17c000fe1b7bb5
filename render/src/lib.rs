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

/// The tree build's fork-join on rayon's thread pool ([`manylights::Join`]): what
/// [`manylights::LightTree::build_parallel`] is given here.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayonJoin;

impl manylights::Join for RayonJoin {
    fn join<A, B, RA, RB>(&self, a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA + Send,
        B: FnOnce() -> RB + Send,
        RA: Send,
        RB: Send,
    {
        rayon::join(a, b)
    }
}
