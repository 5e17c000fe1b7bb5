//! Binned SAOH build of a binary light tree (Conty & Kulla, "Surface Area Orientation
//! Heuristic"; docs/formulas.md, section 3).
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

/// The binary tree; node 0 is the root.
pub(crate) struct BinTree {
    pub nodes: Vec<BinNode>,
}

/// A SAOH bucket. Its cone is an estimate (see [`Cone::union_fast`]); `omni` short-cuts the
/// common case of a bucket holding an omnidirectional light, whose cone is the whole sphere.
#[derive(Clone, Copy)]
struct Bin {
    aabb: Aabb,
    cone: Cone,
    omni: bool,
    energy: f32,
    count: u32,
}

impl Bin {
    const EMPTY: Bin = Bin {
        aabb: Aabb::EMPTY,
        cone: Cone::SPHERE,
        omni: false,
        energy: 0.0,
        count: 0,
    };

    #[inline(always)]
    fn add_cone(&mut self, c: &Cone) {
        if self.omni {
            return;
        }
        if c.is_sphere() {
            self.omni = true;
            self.cone = Cone::SPHERE;
        } else if self.count == 0 {
            self.cone = *c;
        } else {
            self.cone = self.cone.union_fast(*c);
        }
    }

    #[inline(always)]
    fn add(&mut self, p: &Prim) {
        self.aabb = self.aabb.union(p.bounds.aabb);
        self.add_cone(&p.bounds.cone);
        self.energy += p.bounds.energy;
        self.count += 1;
    }

    #[inline(always)]
    fn merge(&self, o: &Bin) -> Bin {
        if o.count == 0 {
            return *self;
        }
        let mut m = *self;
        if o.omni {
            m.omni = true;
            m.cone = Cone::SPHERE;
        } else {
            m.add_cone(&o.cone);
        }
        m.aabb = m.aabb.union(o.aabb);
        m.energy += o.energy;
        m.count += o.count;
        m
    }

    #[inline(always)]
    fn cost(&self) -> f32 {
        if self.count == 0 {
            return 0.0;
        }
        let m = if self.omni {
            4.0 * core::f32::consts::PI
        } else {
            self.cone.measure_fast()
        };
        self.energy * self.aabb.measure() * m
    }
}

/// Nodes of at most this many lights are split by sorting them on each axis and costing every
/// boundary ([`sweep_split`]); larger ones are binned.
const SWEEP_MAX: usize = 4;

/// Largest number of buckets per axis.
pub(crate) const MAX_BUCKETS: usize = 64;

/// Scratch space reused by every node of one build.
struct Ctx {
    buckets: usize,
    bins: [[Bin; MAX_BUCKETS]; 3],
}

/// Box of the geometry and box of the centroids of `prims`.
fn bounds_of(prims: &[Prim]) -> (Aabb, Aabb) {
    let mut geo = Aabb::EMPTY;
    let mut cbox = Aabb::EMPTY;
    for p in prims {
        geo = geo.union(p.bounds.aabb);
        cbox = cbox.grow(p.centroid);
    }
    (geo, cbox)
}

/// Builds the binary tree over `prims` (reordered in place). `prims` must not be empty.
pub(crate) fn build(prims: &mut [Prim], buckets: usize) -> BinTree {
    let mut nodes = Vec::with_capacity(2 * prims.len());
    let mut ctx = Ctx {
        buckets: buckets.clamp(2, MAX_BUCKETS),
        bins: [[Bin::EMPTY; MAX_BUCKETS]; 3],
    };
    let (geo, cbox) = bounds_of(prims);
    build_rec(prims, 0, geo, cbox, &mut ctx, &mut nodes);
    BinTree { nodes }
}

fn leaf(p: &Prim) -> BinNode {
    let e = f64::from(p.bounds.energy);
    BinNode {
        bounds: p.bounds,
        cost: p.bounds.energy * p.bounds.aabb.measure() * p.bounds.cone.measure_fast(),
        count: 1,
        energy_sum: e,
        energy_sq_sum: e * e,
        light: Some(p.light),
        right: 0,
    }
}

#[inline]
fn bin_of(c: f32, min: f32, scale: f32, buckets: usize) -> usize {
    let b = ((c - min) * scale) as usize;
    b.min(buckets - 1)
}

/// A chosen split: where it is and the boxes of both sides.
struct Split {
    mid: usize,
    left: (Aabb, Aabb),
    right: (Aabb, Aabb),
}

/// `geo`: box of the node's geometry; `cbox`: box of its centroids (both from the parent).
fn build_rec(
    prims: &mut [Prim],
    depth: u32,
    geo: Aabb,
    cbox: Aabb,
    ctx: &mut Ctx,
    out: &mut Vec<BinNode>,
) -> u32 {
    let index = out.len();
    if prims.len() == 1 {
        out.push(leaf(&prims[0]));
        return index as u32;
    }
    let center = geo.center();
    let (split, radius) = if prims.len() <= SWEEP_MAX {
        sweep_split(prims, depth, geo)
    } else {
        choose_split(prims, depth, geo, cbox, ctx)
    };
    // Placeholder, overwritten once both children exist.
    out.push(BinNode {
        bounds: prims[0].bounds,
        cost: 0.0,
        count: 0,
        energy_sum: 0.0,
        energy_sq_sum: 0.0,
        light: None,
        right: 0,
    });
    let (l, r) = prims.split_at_mut(split.mid);
    let li = build_rec(l, depth + 1, split.left.0, split.left.1, ctx, out) as usize;
    let ri = build_rec(r, depth + 1, split.right.0, split.right.1, ctx, out) as usize;
    let (a, b) = (&out[li], &out[ri]);
    let cone = a.bounds.cone.union(b.bounds.cone);
    let energy_sum = a.energy_sum + b.energy_sum;
    let energy_sq_sum = a.energy_sq_sum + b.energy_sq_sum;
    let count = a.count + b.count;
    let energy = energy_sum as f32;
    out[index] = BinNode {
        bounds: LightBounds {
            aabb: geo,
            sphere: Sphere {
                center,
                // f32 distances are within a few ulps; `outward` adds 1e-6 relative.
                radius: outward(f64::from(radius) * (1.0 + 1e-6)),
            },
            cone,
            energy,
        },
        cost: energy * geo.measure() * cone.measure_fast(),
        count,
        energy_sum,
        energy_sq_sum,
        light: None,
        right: ri as u32,
    };
    index as u32
}

/// Chooses a split and partitions `prims` around it. Also returns the radius of the sphere
/// around the box centre holding every light's own sphere, found in the same pass as the bins.
fn choose_split(
    prims: &mut [Prim],
    depth: u32,
    geo: Aabb,
    cbox: Aabb,
    ctx: &mut Ctx,
) -> (Split, f32) {
    let center = geo.center();
    let mut radius = 0.0f32;
    let n = prims.len();
    let buckets = ctx.buckets;
    let ext = cbox.extent();
    let node_ext = geo.extent();
    let max_ext = node_ext.max_element();
    // Largest child that still fits in the remaining depth.
    let remaining = MAX_BINARY_DEPTH.saturating_sub(depth + 1).min(62);
    let limit = 1usize.checked_shl(remaining).unwrap_or(usize::MAX);

    let scale = Vec3::new(
        if ext.x > 0.0 {
            buckets as f32 / ext.x
        } else {
            0.0
        },
        if ext.y > 0.0 {
            buckets as f32 / ext.y
        } else {
            0.0
        },
        if ext.z > 0.0 {
            buckets as f32 / ext.z
        } else {
            0.0
        },
    );
    let axes: [bool; 3] = [ext.x > 0.0, ext.y > 0.0, ext.z > 0.0];
    for bins in ctx.bins.iter_mut() {
        bins[..buckets].fill(Bin::EMPTY);
    }
    // Axes of zero extent have scale 0: everything lands in bucket 0 and the axis is skipped.
    let top = (buckets - 1) as f32;
    for p in prims.iter() {
        let s = &p.bounds.sphere;
        radius = radius.max((s.center - center).length() + s.radius);
        let f = ((p.centroid - Vec3::from(cbox.min)) * scale).min(Vec3::splat(top));
        ctx.bins[0][f.x as usize].add(p);
        ctx.bins[1][f.y as usize].add(p);
        ctx.bins[2][f.z as usize].add(p);
    }

    let mut best: Option<(f32, usize, usize)> = None; // cost, axis, boundary
    for axis in 0..3 {
        if !axes[axis] {
            continue;
        }
        let bins = &ctx.bins[axis];
        // Costs of the left parts, bins[0..=i], for every boundary i.
        let mut left_cost = [0.0f32; MAX_BUCKETS];
        let mut left_count = [0u32; MAX_BUCKETS];
        // An empty bin changes neither side, so its boundary repeats the previous costs:
        // only bins with lights cost a union and a measure.
        let mut acc = Bin::EMPTY;
        let mut cost = 0.0;
        for i in 0..buckets - 1 {
            if bins[i].count > 0 {
                acc = acc.merge(&bins[i]);
                cost = acc.cost();
            }
            left_cost[i] = cost;
            left_count[i] = acc.count;
        }
        let kr = if node_ext[axis] > 0.0 {
            max_ext / node_ext[axis]
        } else {
            1.0
        };
        let mut acc = Bin::EMPTY;
        let mut right_cost = 0.0;
        for i in (0..buckets - 1).rev() {
            if bins[i + 1].count > 0 {
                acc = acc.merge(&bins[i + 1]);
                right_cost = acc.cost();
            }
            let (nl, nr) = (left_count[i] as usize, acc.count as usize);
            if nl == 0 || nr == 0 || nl.max(nr) > limit {
                continue;
            }
            let cost = kr * (left_cost[i] + right_cost);
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, i));
            }
        }
    }
    match best {
        Some((_, axis, boundary)) => {
            let (min, sc) = (cbox.min[axis], scale[axis]);
            let (mid, lc, rc) = partition(prims, |p| {
                bin_of(p.centroid[axis], min, sc, buckets) <= boundary
            });
            debug_assert!(mid > 0 && mid < n);
            let bins = &ctx.bins[axis];
            let l = bins[..=boundary]
                .iter()
                .fold(Aabb::EMPTY, |a, b| a.union(b.aabb));
            let r = bins[boundary + 1..buckets]
                .iter()
                .fold(Aabb::EMPTY, |a, b| a.union(b.aabb));
            let split = Split {
                mid,
                left: (l, lc),
                right: (r, rc),
            };
            (split, radius)
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
            prims.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
            (split_at(prims, mid), radius)
        }
    }
}

/// The split of a node with no more lights than buckets: every boundary between the lights
/// sorted on each axis is costed exactly (binning would mostly cost empty buckets).
fn sweep_split(prims: &mut [Prim], depth: u32, geo: Aabb) -> (Split, f32) {
    let n = prims.len();
    let center = geo.center();
    let mut radius = 0.0f32;
    for p in prims.iter() {
        let s = &p.bounds.sphere;
        radius = radius.max((s.center - center).length() + s.radius);
    }
    let node_ext = geo.extent();
    let max_ext = node_ext.max_element();
    let remaining = MAX_BINARY_DEPTH.saturating_sub(depth + 1).min(62);
    let limit = 1usize.checked_shl(remaining).unwrap_or(usize::MAX);

    let mut best: Option<(f32, usize, usize)> = None; // cost, axis, left size
    let mut best_order = [0u8; MAX_BUCKETS];
    if n > 2 {
        for axis in 0..3 {
            let mut order = [0u8; MAX_BUCKETS];
            for (i, o) in order[..n].iter_mut().enumerate() {
                *o = i as u8;
            }
            order[..n].sort_by(|&a, &b| {
                prims[usize::from(a)].centroid[axis]
                    .total_cmp(&prims[usize::from(b)].centroid[axis])
            });
            let kr = if node_ext[axis] > 0.0 {
                max_ext / node_ext[axis]
            } else {
                1.0
            };
            let mut left_cost = [0.0f32; MAX_BUCKETS];
            let mut acc = Bin::EMPTY;
            for i in 0..n - 1 {
                acc.add(&prims[usize::from(order[i])]);
                left_cost[i] = acc.cost();
            }
            let mut acc = Bin::EMPTY;
            for i in (0..n - 1).rev() {
                acc.add(&prims[usize::from(order[i + 1])]);
                let nl = i + 1;
                if nl.max(n - nl) > limit {
                    continue;
                }
                let cost = kr * (left_cost[i] + acc.cost());
                if best.is_none_or(|b| cost < b.0) {
                    best = Some((cost, axis, nl));
                    best_order = order;
                }
            }
        }
    }
    let mid = match best {
        Some((_, _, nl)) => {
            let mut sorted = [prims[0]; MAX_BUCKETS];
            for (dst, &src) in sorted[..n].iter_mut().zip(&best_order[..n]) {
                *dst = prims[usize::from(src)];
            }
            prims.copy_from_slice(&sorted[..n]);
            nl
        }
        None => n / 2,
    };
    (split_at(prims, mid), radius)
}

/// The split of `prims` (already ordered) after the first `mid`, with both sides' boxes.
fn split_at(prims: &[Prim], mid: usize) -> Split {
    let (l, r) = prims.split_at(mid);
    Split {
        mid,
        left: bounds_of(l),
        right: bounds_of(r),
    }
}

/// Moves the elements for which `left` holds to the front; returns how many there are and
/// the boxes of the centroids of both parts.
fn partition(prims: &mut [Prim], left: impl Fn(&Prim) -> bool) -> (usize, Aabb, Aabb) {
    let mut i = 0;
    let mut j = prims.len();
    let (mut lc, mut rc) = (Aabb::EMPTY, Aabb::EMPTY);
    loop {
        while i < j && left(&prims[i]) {
            lc = lc.grow(prims[i].centroid);
            i += 1;
        }
        while i < j && !left(&prims[j - 1]) {
            rc = rc.grow(prims[j - 1].centroid);
            j -= 1;
        }
        if i >= j {
            return (i, lc, rc);
        }
        prims.swap(i, j - 1);
        lc = lc.grow(prims[i].centroid);
        rc = rc.grow(prims[j - 1].centroid);
        i += 1;
        j -= 1;
    }
}
