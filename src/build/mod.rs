//! Building a [`LightTree`]: validate the lights, bound them, build a binary tree with the
//! binned SAOH (module `saoh`), collapse it to 4-wide nodes (module `collapse`).
//!
//! This module holds the constructors of [`LightTree`]'s API: [`LightTree::build`] and
//! [`LightTree::build_with`] (with [`BuildOptions`]). A tree can also be read back from bytes
//! ([`LightTree::from_bytes`], in [`crate::tree`], which holds the layout and accessors).
//! Both stages split their recursion over a host-supplied fork-join ([`Join`]); the tree is
//! the same, byte for byte, whichever [`Join`] runs it.

mod bins;
pub(crate) mod collapse;
mod node;
pub(crate) mod saoh;

use crate::bounds::Aabb;
use crate::error::BuildError;
use crate::light::{Light, MAX_TOTAL_ENERGY};
use crate::tree::{LightTree, MAX_LIGHTS};
use alloc::vec::Vec;
use saoh::{BinNode, BinTree};

/// Options of the build.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildOptions {
    /// SAOH buckets per axis, clamped to 12..=64.
    pub buckets: usize,
    /// Pack subtrees of at most 16 lights free-form so that their nodes are full: fewer nodes,
    /// so less memory, for more variance (it mixes lights across the SAOH's clusters; both
    /// are measured in docs/measurements.md). Off by default.
    pub compact: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            buckets: 12,
            compact: false,
        }
    }
}

/// A fork-join the build splits its work over: `join(a, b)` runs both closures, possibly at
/// the same time on two threads, and returns both results (as `rayon::join` does). The
/// default method runs `a`, then `b`, on the calling thread.
///
/// The build's result does not depend on the implementation: each half of a split works on
/// its own part of the tree, and the halves are put together in a fixed order.
pub trait Join: Sync {
    /// Runs `a` and `b`, returns their results.
    fn join<A, B, RA, RB>(&self, a: A, b: B) -> (RA, RB)
    where
        A: FnOnce() -> RA + Send,
        B: FnOnce() -> RB + Send,
        RA: Send,
        RB: Send,
    {
        let ra = a();
        (ra, b())
    }

    /// Whether the two closures of [`Join::join`] may run at the same time. Where it is
    /// `false` the build does not set work apart to hand it to the other closure (which
    /// costs a copy), and does it in place instead; the tree is the same either way. The
    /// default is `true`.
    fn is_parallel(&self) -> bool {
        true
    }
}

/// The serial [`Join`]: both closures on the calling thread, one after the other.
#[derive(Clone, Copy, Debug, Default)]
pub struct Serial;

impl Join for Serial {
    fn is_parallel(&self) -> bool {
        false
    }
}

/// Lights per block of the leaves' making: the first pass notes how many lights of positive
/// energy precede each block, so that runs of blocks can be bounded apart.
const LEAF_BLOCK: usize = 1 << 12;

/// Runs of at least this many lights are bounded as a [`Join`]'s two halves.
const LEAF_PARALLEL_MIN: usize = 1 << 15;

/// Validates every light and returns the binary SAOH tree of the ones with positive energy
/// (empty when there are none).
///
/// Two passes over the lights, their runs split over `join`: the first validates them and
/// notes their energies (the first invalid light's error is the one returned), then the
/// ones with energy are counted and their energies summed in order, so that the second can
/// bound them straight into the leaves of the tree's one array (zeroed, so that no pass but
/// the build's own writes the inner nodes).
pub(crate) fn binary<J: Join>(
    lights: &[Light],
    opts: &BuildOptions,
    join: &J,
) -> Result<BinTree, BuildError> {
    if lights.len() > MAX_LIGHTS as usize {
        return Err(BuildError::TooManyLights {
            count: lights.len(),
        });
    }
    let mut energies: Vec<f32> = bytemuck::zeroed_vec(lights.len());
    validate(lights, 0, &mut energies, join)?;
    let mut n = 0usize;
    let mut total = 0.0f64;
    let mut starts = Vec::with_capacity(lights.len().div_ceil(LEAF_BLOCK));
    for (i, &e) in energies.iter().enumerate() {
        if i % LEAF_BLOCK == 0 {
            starts.push(n);
        }
        if e > 0.0 {
            n += 1;
            total += f64::from(e);
        }
    }
    if total > f64::from(MAX_TOTAL_ENERGY) {
        return Err(BuildError::TotalEnergyTooLarge);
    }
    if n == 0 {
        return Ok(BinTree { nodes: Vec::new() });
    }
    let mut nodes: Vec<BinNode> = bytemuck::zeroed_vec(2 * n - 1);
    let mut boxes: Vec<Aabb> = bytemuck::zeroed_vec(n);
    bound_leaves(
        lights,
        &energies,
        0,
        &starts,
        &mut nodes[n - 1..],
        &mut boxes,
        join,
    );
    drop(energies);
    saoh::build(
        &mut nodes,
        &mut boxes,
        opts.buckets.clamp(12, bins::MAX_BUCKETS),
        join,
    );
    Ok(BinTree { nodes })
}

/// Validates `lights` (the input's from index `first` on) and writes their energies
/// ([`Light::energy`]) to `energies`; the error of the first invalid one.
fn validate<J: Join>(
    lights: &[Light],
    first: usize,
    energies: &mut [f32],
    join: &J,
) -> Result<(), BuildError> {
    if lights.len() >= LEAF_PARALLEL_MIN {
        let half = lights.len() / 2;
        let (la, lb) = lights.split_at(half);
        let (ea, eb) = energies.split_at_mut(half);
        let (ra, rb) = join.join(
            || validate(la, first, ea, join),
            || validate(lb, first + half, eb, join),
        );
        return ra.and(rb);
    }
    for (i, (l, e)) in lights.iter().zip(energies).enumerate() {
        *e = l.validated_energy(first + i)?;
    }
    Ok(())
}

/// Bounds the lights of positive energy among `lights` (validated, with energies
/// `energies`; the lights from block `block` on, whole blocks but for the last one) into
/// `leaves` and `boxes`, in order; `starts[b]` is the number of lights of positive energy
/// before block `b`.
fn bound_leaves<J: Join>(
    lights: &[Light],
    energies: &[f32],
    block: usize,
    starts: &[usize],
    leaves: &mut [BinNode],
    boxes: &mut [Aabb],
    join: &J,
) {
    if lights.len() >= LEAF_PARALLEL_MIN {
        let half = lights.len().div_ceil(2 * LEAF_BLOCK);
        let (la, lb) = lights.split_at(half * LEAF_BLOCK);
        let (ea, eb) = energies.split_at(half * LEAF_BLOCK);
        let k = starts[block + half] - starts[block];
        let (na, nb) = leaves.split_at_mut(k);
        let (ba, bb) = boxes.split_at_mut(k);
        join.join(
            || bound_leaves(la, ea, block, starts, na, ba, join),
            || bound_leaves(lb, eb, block + half, starts, nb, bb, join),
        );
        return;
    }
    let mut out = leaves.iter_mut().zip(boxes.iter_mut());
    for (i, (l, &e)) in lights.iter().zip(energies).enumerate() {
        if e > 0.0 {
            let bounds = l.bounds_with_energy(e);
            if let Some((leaf, aabb)) = out.next() {
                *leaf = BinNode::leaf(&bounds, (block * LEAF_BLOCK + i) as u32);
                *aabb = bounds.aabb;
            }
        }
    }
    debug_assert!(out.next().is_none());
}

impl LightTree {
    /// Builds the tree with default options. Lights of zero energy (zero power or area) are
    /// accepted and never sampled; an empty slice gives a tree that samples nothing.
    pub fn build(lights: &[Light]) -> Result<LightTree, BuildError> {
        LightTree::build_with(lights, &BuildOptions::default())
    }

    /// Builds the tree with `opts`.
    pub fn build_with(lights: &[Light], opts: &BuildOptions) -> Result<LightTree, BuildError> {
        LightTree::build_parallel(lights, opts, &Serial)
    }

    /// [`LightTree::build_with`], its work split over `join` (e.g. a thread pool's fork-join):
    /// the same tree, byte for byte ([`LightTree::as_bytes`]), as the serial build.
    pub fn build_parallel<J: Join>(
        lights: &[Light],
        opts: &BuildOptions,
        join: &J,
    ) -> Result<LightTree, BuildError> {
        // The lights' checksums and the lights at infinity do not depend on the tree: they are
        // made as the other half of a join, beside the tree's serial start.
        let (tree, (light_checks, infinite)) = join.join(
            || {
                let bin = binary(lights, opts, join)?;
                collapse::collapse(bin, lights.len(), opts.compact, join)
            },
            || {
                (
                    crate::tree::light_checks(lights),
                    crate::infinite_light::collect(lights),
                )
            },
        );
        let mut tree = tree?;
        tree.light_checks = light_checks;
        tree.infinite = infinite?;
        #[cfg(debug_assertions)]
        if let Err(e) = tree.validate() {
            panic!("manylights: internal error, built tree fails validation: {e}");
        }
        Ok(tree)
    }
}
