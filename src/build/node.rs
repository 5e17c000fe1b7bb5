//! A node of the binary tree the SAOH build makes ([`BinNode`]): its cluster's bounds and its
//! children, 56 bytes; the leaves are the build's working set.

use crate::bounds::{Cone, LightBounds, Sphere};
use bytemuck::Zeroable;
use glam::Vec3;

/// What a node of the binary tree keeps of its cluster's bounds: the box is needed only while
/// building, so it is not kept.
#[derive(Clone, Copy, Debug, PartialEq, Zeroable)]
pub(crate) struct NodeBounds {
    /// A sphere holding the emitting geometry.
    pub sphere: Sphere,
    /// Orientation cone.
    pub cone: Cone,
    /// Energy.
    pub energy: f32,
}

/// A node of the binary tree (56 bytes). In [`BinTree::nodes`] the inner
/// nodes come first, in depth-first order, then the leaves in left-to-right order; [`children`]
/// finds the left and right child of an inner node. All zeros is an inner node not yet built.
#[derive(Clone, Copy, Debug, Zeroable)]
pub(crate) struct BinNode {
    pub bounds: NodeBounds,
    /// `E · M_A · M_Ω`: how much the node costs; the collapse opens the costliest first.
    pub cost: f32,
    pub count: u32,
    /// The light of a leaf plus one; 0 for an inner node.
    pub(super) leaf: u32,
    /// Position of the subtree's first light among the leaves.
    pub(super) first: u32,
}

// 56 bytes, 4-byte aligned: an array of nodes aligned to 64 would be zeroed by writing it,
// where one of 4-byte alignment is zeroed memory as allocated.
const _: () = assert!(core::mem::size_of::<BinNode>() == 56);

impl BinNode {
    /// An inner node not yet built.
    pub(super) const PLACEHOLDER: BinNode = BinNode {
        bounds: NodeBounds {
            sphere: Sphere {
                center: Vec3::ZERO,
                radius: 0.0,
            },
            cone: Cone::SPHERE,
            energy: 0.0,
        },
        cost: 0.0,
        count: 0,
        leaf: 0,
        first: 0,
    };

    /// `Some(light)` for a leaf, `None` for an inner node.
    #[inline(always)]
    pub(crate) fn light(&self) -> Option<u32> {
        self.leaf.checked_sub(1)
    }

    /// The leaf of light `light` with bounds `b`.
    pub(crate) fn leaf(b: &LightBounds, light: u32) -> BinNode {
        BinNode {
            bounds: NodeBounds {
                sphere: b.sphere,
                cone: b.cone,
                energy: b.energy,
            },
            cost: b.energy * b.aabb.measure() * b.cone.measure_fast(),
            count: 1,
            leaf: light + 1,
            first: 0,
        }
    }

    /// Position of the subtree's first light among the leaves: the leaves of a subtree of
    /// `count` lights are `first .. first + count`, left to right.
    #[inline]
    pub(crate) fn first(&self) -> usize {
        self.first as usize
    }
}
