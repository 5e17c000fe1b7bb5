//! [`Memo`]: an importance that remembers what it computed for the nodes of one tree.
//!
//! A renderer that takes many samples at one shading point (split sampling's one descent per
//! cluster, repeated for every sample of a pixel; the pmf walks that MIS needs for every
//! sample) evaluates the same upper nodes again and again. [`Memo`] keeps the last value of
//! each node in a small direct-mapped table, so a repeated evaluation is a table read. The
//! values are the wrapped importance's, bit for bit: sampling and pmfs are unchanged.
//!
//! The table is a [`MemoTable`] the caller keeps (one per thread) and lends to one [`Memo`]
//! per shading point. Starting a `Memo` does not clear the table: each `Memo` takes a new
//! generation number, and a slot counts only if it was written in the current generation, so
//! the set-up costs one increment instead of rewriting the table's 24 KB. A node is recognised by its index in the `Memo`'s tree;
//! nodes of other trees are evaluated without the table. Neither type is `Sync` (the table is
//! in `Cell`s).

use super::Importance;
use crate::infinite_light::InfiniteLight;
use crate::tree::{LightTree, Node4, SlotBounds};
use core::cell::Cell;
use wide::f32x4;

/// Slots of a [`MemoTable`].
pub const MEMO_SLOTS: usize = 1024;

/// A slot: node index, generation, the four values.
type Entry = (u32, u32, [f32; 4]);

/// The reusable storage of [`Memo`]s: keep one per thread and pass it to [`Memo::new`] at
/// every shading point.
#[derive(Debug)]
pub struct MemoTable {
    slots: [Cell<Entry>; MEMO_SLOTS],
    generation: Cell<u32>,
}

impl Default for MemoTable {
    fn default() -> Self {
        MemoTable::new()
    }
}

impl MemoTable {
    /// An empty table.
    #[must_use]
    pub fn new() -> MemoTable {
        MemoTable {
            slots: core::array::from_fn(|_| Cell::new((0, 0, [0.0; 4]))),
            generation: Cell::new(0),
        }
    }

    /// A generation no slot was written in (clearing the table when the counter wraps).
    fn next_generation(&self) -> u32 {
        let g = self.generation.get().wrapping_add(1);
        if g == 0 {
            for s in &self.slots {
                s.set((0, 0, [0.0; 4]));
            }
            self.generation.set(1);
            return 1;
        }
        self.generation.set(g);
        g
    }
}

/// `imp` with a table of its values for the nodes of `tree` (see the module documentation).
#[derive(Clone, Debug)]
pub struct Memo<'t, I> {
    imp: I,
    tree: &'t LightTree,
    table: &'t MemoTable,
    generation: u32,
}

impl<'t, I: Importance> Memo<'t, I> {
    /// `imp` for the nodes of `tree`, remembering in `table` (whose earlier contents no longer
    /// count: O(1), nothing is cleared).
    pub fn new(imp: I, tree: &'t LightTree, table: &'t MemoTable) -> Memo<'t, I> {
        Memo {
            imp,
            tree,
            table,
            generation: table.next_generation(),
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
        let slot = &self.table.slots[i as usize % MEMO_SLOTS];
        let (key, generation, value) = slot.get();
        if key == i && generation == self.generation {
            return f32x4::new(value);
        }
        let v = self.imp.eval4(node);
        slot.set((i, self.generation, v.to_array()));
        v
    }

    /// The inner importance's, not memoised (a slot's bounds do not name their node).
    #[inline]
    fn eval_slot(&self, b: &SlotBounds) -> f32 {
        self.imp.eval_slot(b)
    }

    /// The inner importance's, not memoised.
    #[inline]
    fn eval_lane(&self, node: &Node4, k: usize) -> f32 {
        self.imp.eval_lane(node, k)
    }

    /// The inner importance's, not memoised.
    #[inline]
    fn eval_infinite(&self, light: &InfiniteLight) -> f32 {
        self.imp.eval_infinite(light)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::Rgb;
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
                    intensity: Rgb::grey(1.0 + (i % 7) as f32),
                }
            })
            .collect();
        LightTree::build_with(&lights, &BuildOptions::default()).unwrap()
    }

    #[test]
    fn same_values_as_the_wrapped_importance() {
        let t = tree(3000);
        let imp = TlImportance::new(Vec3::new(0.5, -1.0, 0.2), Vec3::new(0.0, 0.3, 1.0));
        let table = MemoTable::new();
        let memo = Memo::new(imp, &t, &table);
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
        // A new point reusing the table sees none of the old values.
        let other = TlImportance::new(Vec3::new(-2.0, 4.0, 1.0), Vec3::new(1.0, 0.0, 0.2));
        let memo2 = Memo::new(other, &t, &table);
        for node in t.nodes() {
            assert_eq!(memo2.eval4(node).to_array(), other.eval4(node).to_array());
        }
    }

    #[test]
    fn generations_wrap_by_clearing() {
        let t = tree(50);
        let table = MemoTable::new();
        table.generation.set(u32::MAX - 1);
        let a = TlImportance::new(Vec3::new(0.5, -1.0, 0.2), Vec3::Z);
        let b = TlImportance::new(Vec3::new(3.0, 1.0, -0.2), Vec3::X);
        let m1 = Memo::new(a, &t, &table);
        for node in t.nodes() {
            m1.eval4(node);
        }
        // The counter wraps: the table is cleared and generation 1 starts.
        let m2 = Memo::new(b, &t, &table);
        assert_eq!(m2.generation, 1);
        for node in t.nodes() {
            assert_eq!(m2.eval4(node).to_array(), b.eval4(node).to_array());
        }
    }
}
