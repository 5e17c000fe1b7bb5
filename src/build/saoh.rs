//! Binned SAOH build of a binary light tree (Conty & Kulla, "Surface Area Orientation
//! Heuristic"; MATH.md section 3).
//!
//! Light centroids are binned into `buckets` buckets on each of the three axes; every bucket
//! boundary is costed with
//! `K_r · (E_l · M_A(l) · M_Ω(l) + E_r · M_A(r) · M_Ω(r))` (the parent's `M_A · M_Ω` is the
//! same for every candidate of a node, so it is left out), and the cheapest is taken. When all
//! centroids coincide the lights are split by count. A split that would push a subtree past
//! the depth a path can encode is replaced by a split at the median, so every tree fits.

use crate::bounds::{Aabb, Cone, LightBounds, Sphere};
use crate::light::outward;
use alloc::vec::Vec;
use glam::Vec3;

/// Deepest binary level allowed; the collapsed tree is never deeper than the binary one.
pub(crate) const MAX_BINARY_DEPTH: u32 = crate::tree::MAX_DEPTH;

/// One light entering the build.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Prim {
    pub bounds: LightBounds,
    pub centroid: Vec3,
    pub light: u32,
}

/// A node of the binary tree, in depth-first order (the left child follows its parent).
#[derive(Clone, Copy, Debug)]
pub(crate) struct BinNode {
    pub bounds: LightBounds,
    /// `E · M_A · M_Ω`: how much the node costs; the collapse opens the costliest first.
    pub cost: f32,
    pub count: u32,
    pub energy_sum: f64,
    pub energy_sq_sum: f64,
    /// `Some(light)` for a leaf.
    pub light: Option<u32>,
    /// Index of the right child (inner nodes).
    pub right: u32,
}

impl BinNode {
    pub fn energy_variance(&self) -> f32 {
        let n = f64::from(self.count);
        let mean = self.energy_sum / n;
        ((self.energy_sq_sum / n - mean * mean).max(0.0)) as f32
    }
}

/// The binary tree; node 0 is the root.
pub(crate) struct BinTree {
    pub nodes: Vec<BinNode>,
}

#[derive(Clone, Copy)]
struct Bin {
    aabb: Aabb,
    cone: Option<Cone>,
    energy: f32,
    count: u32,
}

impl Bin {
    const EMPTY: Bin = Bin {
        aabb: Aabb::EMPTY,
        cone: None,
        energy: 0.0,
        count: 0,
    };

    #[inline]
    fn add(&mut self, b: &LightBounds) {
        self.aabb = self.aabb.union(b.aabb);
        self.cone = Some(match self.cone {
            None => b.cone,
            Some(c) => c.union(b.cone),
        });
        self.energy += b.energy;
        self.count += 1;
    }

    fn merge(&self, o: &Bin) -> Bin {
        Bin {
            aabb: self.aabb.union(o.aabb),
            cone: match (self.cone, o.cone) {
                (None, c) | (c, None) => c,
                (Some(a), Some(b)) => Some(a.union(b)),
            },
            energy: self.energy + o.energy,
            count: self.count + o.count,
        }
    }

    fn cost(&self) -> f32 {
        match self.cone {
            Some(c) if self.count > 0 => self.energy * self.aabb.measure() * c.measure(),
            _ => 0.0,
        }
    }
}

/// Builds the binary tree over `prims` (reordered in place). `prims` must not be empty.
pub(crate) fn build(prims: &mut [Prim], buckets: usize) -> BinTree {
    let mut nodes = Vec::with_capacity(2 * prims.len());
    let mut scratch = Vec::with_capacity(buckets);
    build_rec(prims, 0, buckets, &mut nodes, &mut scratch);
    BinTree { nodes }
}

fn leaf(p: &Prim) -> BinNode {
    let e = f64::from(p.bounds.energy);
    BinNode {
        bounds: p.bounds,
        cost: p.bounds.energy * p.bounds.aabb.measure() * p.bounds.cone.measure(),
        count: 1,
        energy_sum: e,
        energy_sq_sum: e * e,
        light: Some(p.light),
        right: 0,
    }
}

fn build_rec(
    prims: &mut [Prim],
    depth: u32,
    buckets: usize,
    out: &mut Vec<BinNode>,
    scratch: &mut Vec<Bin>,
) -> u32 {
    let index = out.len();
    if prims.len() == 1 {
        out.push(leaf(&prims[0]));
        return index as u32;
    }
    let mid = split(prims, depth, buckets, scratch);
    // Placeholder, overwritten once both children exist.
    out.push(leaf(&prims[0]));
    let (l, r) = prims.split_at_mut(mid);
    let li = build_rec(l, depth + 1, buckets, out, scratch) as usize;
    let ri = build_rec(r, depth + 1, buckets, out, scratch) as usize;
    let (a, b) = (&out[li], &out[ri]);
    let aabb = a.bounds.aabb.union(b.bounds.aabb);
    let cone = a.bounds.cone.union(b.bounds.cone);
    let energy_sum = a.energy_sum + b.energy_sum;
    let energy_sq_sum = a.energy_sq_sum + b.energy_sq_sum;
    let count = a.count + b.count;
    // The tightest sphere centred on the box centre that holds every light's own sphere.
    let center = aabb.center();
    let mut r = 0.0f64;
    for p in prims.iter() {
        let s = &p.bounds.sphere;
        let d = (s.center - center).as_dvec3().length() + f64::from(s.radius);
        r = r.max(d);
    }
    let energy = energy_sum as f32;
    out[index] = BinNode {
        bounds: LightBounds {
            aabb,
            sphere: Sphere {
                center,
                radius: outward(r),
            },
            cone,
            energy,
        },
        cost: energy * aabb.measure() * cone.measure(),
        count,
        energy_sum,
        energy_sq_sum,
        light: None,
        right: ri as u32,
    };
    index as u32
}

#[inline]
fn bin_of(c: f32, min: f32, scale: f32, buckets: usize) -> usize {
    let b = ((c - min) * scale) as usize;
    b.min(buckets - 1)
}

/// Chooses a split and partitions `prims` around it; returns the size of the left part
/// (in 1..len).
fn split(prims: &mut [Prim], depth: u32, buckets: usize, bins: &mut Vec<Bin>) -> usize {
    let n = prims.len();
    let mut cb = Aabb::EMPTY;
    let mut nb = Aabb::EMPTY;
    for p in prims.iter() {
        cb = cb.grow(p.centroid);
        nb = nb.union(p.bounds.aabb);
    }
    let ext = cb.extent();
    let node_ext = nb.extent();
    let max_ext = node_ext.max_element();
    // Largest child that still fits in the remaining depth.
    let remaining = MAX_BINARY_DEPTH.saturating_sub(depth + 1).min(62);
    let limit = 1usize.checked_shl(remaining).unwrap_or(usize::MAX);

    let mut best: Option<(f32, usize, usize, f32, f32)> = None; // cost, axis, boundary, min, scale
    for axis in 0..3 {
        let e = ext[axis];
        if !(e > 0.0) {
            continue;
        }
        let min = cb.min[axis];
        let scale = buckets as f32 / e;
        bins.clear();
        bins.resize(buckets, Bin::EMPTY);
        for p in prims.iter() {
            bins[bin_of(p.centroid[axis], min, scale, buckets)].add(&p.bounds);
        }
        // Costs of the left parts, bins[0..=i], for every boundary i.
        let mut left_cost = [0.0f32; 64];
        let mut left_count = [0u32; 64];
        let mut acc = Bin::EMPTY;
        for i in 0..buckets - 1 {
            acc = acc.merge(&bins[i]);
            left_cost[i] = acc.cost();
            left_count[i] = acc.count;
        }
        let kr = if node_ext[axis] > 0.0 {
            max_ext / node_ext[axis]
        } else {
            1.0
        };
        let mut acc = Bin::EMPTY;
        for i in (0..buckets - 1).rev() {
            acc = acc.merge(&bins[i + 1]);
            let (nl, nr) = (left_count[i] as usize, acc.count as usize);
            if nl == 0 || nr == 0 || nl.max(nr) > limit {
                continue;
            }
            let cost = kr * (left_cost[i] + acc.cost());
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, i, min, scale));
            }
        }
    }
    match best {
        Some((_, axis, boundary, min, scale)) => {
            let mid = partition(prims, |p| {
                bin_of(p.centroid[axis], min, scale, buckets) <= boundary
            });
            debug_assert!(mid > 0 && mid < n);
            mid
        }
        None => {
            // No usable boundary: coincident centroids, or the depth budget forbids every
            // candidate. Split at the median of the widest centroid axis.
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = n / 2;
            prims.select_nth_unstable_by(mid, |a, b| {
                a.centroid[axis].total_cmp(&b.centroid[axis])
            });
            mid
        }
    }
}

/// Moves the elements for which `left` holds to the front; returns how many there are.
fn partition(prims: &mut [Prim], left: impl Fn(&Prim) -> bool) -> usize {
    let mut i = 0;
    let mut j = prims.len();
    loop {
        while i < j && left(&prims[i]) {
            i += 1;
        }
        while i < j && !left(&prims[j - 1]) {
            j -= 1;
        }
        if i >= j {
            return i;
        }
        prims.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}
