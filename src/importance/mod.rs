//! Cluster importances: how much a cluster of lights may contribute at a shading point.
//!
//! An importance is set up once per shading point, then evaluated for the four slots of a
//! [`Node4`] at once ([`Importance::eval4`]). Every importance also has a readable scalar form
//! ([`Importance::eval_slot`]), and one generic test holds the two equal lane by lane for every
//! importance. Importances are conservative: a cluster holding a light that can contribute at
//! the shading point gets a positive value.

pub mod brdf_oriented;
pub mod conty_kulla;
pub mod memo;
pub mod sptd;

pub use brdf_oriented::BlImportance;
pub use conty_kulla::TlImportance;
pub use memo::{Memo, MemoTable, MEMO_SLOTS};

use crate::tree::{Node4, SlotBounds};
use wide::f32x4;

/// A per-shading-point importance, evaluated four slots at a time.
pub trait Importance {
    /// The importances of the four slots of `node` (0 for empty slots). Never negative or
    /// NaN for a shading point with finite coordinates.
    fn eval4(&self, node: &Node4) -> f32x4;

    /// The importance of one slot from its decoded bounds: the scalar twin of
    /// [`Importance::eval4`], written to be read. For every node and slot `k`, lane `k` of
    /// `eval4(node)` equals `eval_slot(&node.bounds(k))` within `1e-4 · max(|a|, |b|) + 1e-30`
    /// (each implementation states its own, possibly tighter, tolerance); the same range: never
    /// negative or NaN for a shading point with finite coordinates, 0 for a slot of zero energy.
    fn eval_slot(&self, b: &SlotBounds) -> f32;
}

impl<I: Importance + ?Sized> Importance for &I {
    #[inline(always)]
    fn eval4(&self, node: &Node4) -> f32x4 {
        (**self).eval4(node)
    }

    #[inline(always)]
    fn eval_slot(&self, b: &SlotBounds) -> f32 {
        (**self).eval_slot(b)
    }
}
