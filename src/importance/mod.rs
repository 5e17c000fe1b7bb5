//! Cluster importances: how much a cluster of lights may contribute at a shading point.
//!
//! An importance is set up once per shading point, then evaluated for the four slots of a
//! [`Node4`] at once ([`Importance::eval4`]). Every importance also has a readable scalar form
//! ([`Importance::eval_slot`]) and a scalar twin of one lane ([`Importance::eval_lane`],
//! usually the same), and one generic test holds `eval4` equal to the twin lane by lane for
//! every importance. Importances are conservative: a cluster holding a light that can contribute at
//! the shading point gets a positive value.

pub(crate) mod bl;
mod memo;
pub(crate) mod sptd;
pub(crate) mod tl;

pub use bl::{BlEval, BlImportance};
pub use memo::{Memo, MemoTable, MEMO_SLOTS};
pub use tl::{Receiver, TlImportance};
/// The lane type of the 4-wide importances: [`Importance::eval4`] returns one (a node's four
/// slots), so a host that implements [`Importance`] or reads its lanes needs it. It is `wide`'s
/// `f32x4` (version 1), re-exported so that hosts need not depend on `wide` themselves.
pub use wide::f32x4;

use crate::infinite_light::InfiniteLight;
use crate::tree::{Node4, SlotBounds};

/// A per-shading-point importance, evaluated four slots at a time.
pub trait Importance {
    /// The importances of the four slots of `node` (0 for empty slots). Never negative or
    /// NaN for a shading point with finite coordinates.
    fn eval4(&self, node: &Node4) -> f32x4;

    /// The importance of one slot from its decoded bounds: the scalar twin of
    /// [`Importance::eval4`], written to be read: the same function of the slot's bounds as
    /// lane `k` of `eval4(node)` for `b = node.bounds(k)`, equal to it within rounding where
    /// the function is well conditioned (each implementation says how its forms differ); the
    /// same range: never negative or NaN for a shading point with finite coordinates, 0 for a
    /// slot of zero energy.
    fn eval_slot(&self, b: &SlotBounds) -> f32;

    /// Lane `k` of [`Importance::eval4`] computed alone, operation for operation: the one
    /// generic test holds `eval4` equal to it lane by lane within `1e-5` relative (`1e-30`
    /// absolute). By default [`Importance::eval_slot`] of the decoded slot; an importance
    /// whose `eval4` works on a form of the bounds other than [`SlotBounds`] (TL: the cone
    /// axis before its normalisation) overrides it.
    fn eval_lane(&self, node: &Node4, k: usize) -> f32 {
        self.eval_slot(&node.bounds(k))
    }

    /// The importance of a distant or environment light at the shading point, in the units
    /// of the node tree's importances (4π times an irradiance; see [`crate::light_set`]), so
    /// that the root weighs it against the tree: never negative or NaN, and positive wherever
    /// the light can contribute (for the environment: wherever the host's bounds are).
    fn eval_infinite(&self, light: &InfiniteLight) -> f32;

    /// `(self.eval4(a), other.eval4(b))`, bit for bit: the importances at two shading points
    /// (of two nodes) at once, as the batch calls take their descents two by two. The
    /// default makes the two calls; an importance may interleave the two computations so
    /// that one's latencies hide behind the other's work (TL does, in `f32x8` lanes).
    #[inline(always)]
    fn eval4_pair(&self, a: &Node4, other: &Self, b: &Node4) -> (f32x4, f32x4)
    where
        Self: Sized,
    {
        (self.eval4(a), other.eval4(b))
    }
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

    #[inline(always)]
    fn eval_lane(&self, node: &Node4, k: usize) -> f32 {
        (**self).eval_lane(node, k)
    }

    #[inline(always)]
    fn eval_infinite(&self, light: &InfiniteLight) -> f32 {
        (**self).eval_infinite(light)
    }
}
