//! [`Memo`]: an importance that remembers what it computed for the nodes of one tree.
//!
//! A renderer that takes many samples at one shading point (split sampling's one descent per
//! cluster, repeated for every sample of a pixel; the pmf walks that MIS needs for every
//! sample) evaluates the same upper nodes again and again. [`Memo`] keeps the last value of
//! each node in a small direct-mapped table, so a repeated evaluation is a table read. The
//! values are the wrapped importance's, bit for bit: sampling and pmfs are unchanged.
//!
//! The table is tied to one tree by a borrow, so a node is recognised by its index in it.
//! Nodes of other trees are evaluated without the table. Not `Sync` (the table is in
//! `Cell`s): one per shading point, per thread.

use super::Importance;
use crate::tree::{LightTree, Node4, SlotBounds};
use core::cell::Cell;
use wide::f32x4;

/// Slots of a [`Memo`]'s table.
pub const MEMO_SLOTS: usize = 1024;

/// A slot's key when it holds nothing.
const NO_NODE: u32 = u32::MAX;

/// `imp` with a table of its values for the nodes of `tree` (see the module documentation).
#[derive(Clone, Debug)]
pub struct Memo<'t, I> {
    imp: I,
    tree: &'t LightTree,
    slots: [Cell<(u32, [f32; 4])>; MEMO_SLOTS],
}

impl<'t, I: Importance> Memo<'t, I> {
    /// `imp` for the nodes of `tree`, with an empty table.
    pub fn new(imp: I, tree: &'t LightTree) -> Memo<'t, I> {
        Memo {
            imp,
            tree,
            slots: core::array::from_fn(|_| Cell::new((NO_NODE, [0.0; 4]))),
        }
    }

    /// The wrapped importance.
    pub fn inner(&self) -> &I {
        &self.imp
    }

    /// The tree whose nodes are remembered.
    pub fn tree(&self) -> &'t LightTree {
        self.tree
    }

    /// The index of `node` in the tree's node array, if it is one of them.
    #[inline(always)]
    fn index_of(&self, node: &Node4) -> Option<u32> {
        let nodes = self.tree.nodes.as_slice();
        let base = nodes.as_ptr() as usize;
        let offset = (node as *const Node4 as usize).wrapping_sub(base);
        let size = core::mem::size_of::<Node4>();
        let i = offset / size;
        (offset % size == 0 && i < nodes.len()).then_some(i as u32)
    }
}

impl<I: Importance> Importance for Memo<'_, I> {
    #[inline]
    fn eval4(&self, node: &Node4) -> f32x4 {
        let Some(i) = self.index_of(node) else {
            return self.imp.eval4(node);
        };
        let slot = &self.slots[i as usize % MEMO_SLOTS];
        let (key, value) = slot.get();
        if key == i {
            return f32x4::new(value);
        }
        let v = self.imp.eval4(node);
        slot.set((i, v.to_array()));
        v
    }

    /// The inner importance's, not memoised (a slot's bounds do not name their node).
    #[inline]
    fn eval_slot(&self, b: &SlotBounds) -> f32 {
        self.imp.eval_slot(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::importance::TlImportance;
    use crate::math;
    use crate::{BuildOptions, Light};
    use alloc::vec::Vec;
    use glam::Vec3;

    fn tree(n: usize) -> LightTree {
        let lights: Vec<Light> = (0..n)
            .map(|i| {
                let t = i as f32 * 0.37;
                Light::Point {
                    position: Vec3::new(math::sin(t) * 5.0, math::cos(t * 1.3) * 5.0, t * 0.1),
                    intensity: 1.0 + (i % 7) as f32,
                }
            })
            .collect();
        LightTree::build_with(&lights, &BuildOptions::default()).unwrap()
    }

    #[test]
    fn same_values_as_the_wrapped_importance() {
        let t = tree(3000);
        let imp = TlImportance::new(Vec3::new(0.5, -1.0, 0.2), Vec3::new(0.0, 0.3, 1.0));
        let memo = Memo::new(imp, &t);
        // Twice over every node: the second pass reads the table (3000 lights need more
        // nodes than there are slots, so slots are also overwritten).
        for _ in 0..2 {
            for node in t.nodes() {
                assert_eq!(memo.eval4(node).to_array(), imp.eval4(node).to_array());
            }
        }
        // A node that is not the tree's (a copy) is evaluated directly.
        let copy = t.nodes()[0];
        assert_eq!(memo.eval4(&copy).to_array(), imp.eval4(&copy).to_array());
        for i in 0..100u32 {
            let u = (i as f32 + 0.5) / 100.0;
            assert_eq!(t.sample(&memo, u), t.sample(&imp, u));
        }
        for l in (0..3000).step_by(37) {
            assert_eq!(t.pmf(&memo, l).to_bits(), t.pmf(&imp, l).to_bits());
        }
    }
}
