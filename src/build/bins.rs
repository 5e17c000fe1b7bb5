//! The binning of the SAOH build ([`super::saoh`]): each light's centroid falls into one of
//! `buckets` buckets on each axis ([`ToBucket`]); a bucket gathers its lights' box, energy,
//! count and cone ([`Buckets`], [`Acc`]), so that every bucket boundary of a node can be costed
//! from prefix and suffix sums.

use super::node::BinNode;
use super::Join;
use crate::bounds::{Aabb, Cone};
use glam::{Vec3, Vec3A};
use wide::f32x4;

/// Largest number of buckets per axis.
pub(crate) const MAX_BUCKETS: usize = 64;

/// What binning gathers in one bucket of one axis: the box (`lo`, `hi`), energy and count of
/// its lights and whether one of them is omnidirectional; its cone is in [`Buckets::cone`],
/// and `directed` counts the lights united into it so far ([`fill_bins`]).
#[derive(Clone, Copy)]
pub(super) struct Bucket {
    pub(super) lo: Vec3A,
    pub(super) hi: Vec3A,
    pub(super) energy: f32,
    pub(super) count: u32,
    pub(super) directed: u32,
    pub(super) omni: bool,
}

impl Bucket {
    pub(super) const EMPTY: Bucket = Bucket {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
        energy: 0.0,
        count: 0,
        directed: 0,
        omni: false,
    };
}

/// The buckets of the three axes. Only the buckets in `used` hold lights; the others are
/// empty, so a node resets only the ones the previous node used.
pub(super) struct Buckets {
    pub(super) acc: [[Bucket; MAX_BUCKETS]; 3],
    pub(super) cone: [[Cone; MAX_BUCKETS]; 3],
    pub(super) used: [u64; 3],
}

/// The indices of the set bits of `mask`, in increasing order.
#[inline(always)]
pub(super) fn bits(mut mask: u64) -> impl Iterator<Item = usize> {
    core::iter::from_fn(move || {
        (mask != 0).then(|| {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            i
        })
    })
}

/// Lights (or buckets of lights) added in turn, as the SAOH costs a bucket or one side of a
/// boundary: the union of the boxes, the f32 sum of the energies in that order, the count,
/// and a cone that is the first light's, then its [`Cone::union_fast`] with each next one,
/// or the whole sphere (`omni`, the cone no longer read) from the first omnidirectional light
/// or union on. Its cost is `E · M_A · M_Ω` with the fast `M_Ω`. Sums and unions round, so
/// the order is part of the result.
#[derive(Clone, Copy)]
pub(super) struct Acc {
    pub(super) lo: Vec3A,
    pub(super) hi: Vec3A,
    pub(super) cone: Cone,
    pub(super) omni: bool,
    pub(super) energy: f32,
    pub(super) count: u32,
}

impl Acc {
    pub(super) const EMPTY: Acc = Acc {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
        cone: Cone::SPHERE,
        omni: false,
        energy: 0.0,
        count: 0,
    };

    /// Adds the lights of bucket `b` (not empty), whose cone is `cone` unless it is
    /// omnidirectional.
    #[inline(always)]
    pub(super) fn add(&mut self, b: &Bucket, cone: &Cone) {
        if b.omni {
            self.omni = true;
        } else if !self.omni {
            if cone.is_sphere() {
                self.omni = true;
            } else if self.count == 0 {
                self.cone = *cone;
            } else {
                self.cone = self.cone.union_fast(*cone);
            }
        }
        self.lo = self.lo.min(b.lo);
        self.hi = self.hi.max(b.hi);
        self.energy += b.energy;
        self.count += b.count;
    }

    /// [`Acc::add`] once the sum is omnidirectional.
    #[inline(always)]
    pub(super) fn add_omni(&mut self, b: &Bucket) {
        debug_assert!(self.omni);
        self.lo = self.lo.min(b.lo);
        self.hi = self.hi.max(b.hi);
        self.energy += b.energy;
        self.count += b.count;
    }

    /// [`Acc::cost`] once the sum is omnidirectional.
    #[inline(always)]
    pub(super) fn cost_omni(&self) -> f32 {
        self.energy * measure_full(self.lo, self.hi) * (4.0 * core::f32::consts::PI)
    }

    /// Adds one light.
    #[inline(always)]
    pub(super) fn add_light(&mut self, leaf: &BinNode, aabb: &Aabb) {
        let c = &leaf.bounds.cone;
        if !self.omni {
            if c.is_sphere() {
                self.omni = true;
            } else if self.count == 0 {
                self.cone = *c;
            } else {
                self.cone = self.cone.union_fast(*c);
            }
        }
        self.lo = self.lo.min(aabb.min);
        self.hi = self.hi.max(aabb.max);
        self.energy += leaf.bounds.energy;
        self.count += 1;
    }

    /// The cost, `E · M_A · M_Ω` (at least one light added).
    #[inline(always)]
    pub(super) fn cost(&self) -> f32 {
        let m = if self.omni {
            4.0 * core::f32::consts::PI
        } else {
            self.cone.measure_fast()
        };
        self.energy * measure_full(self.lo, self.hi) * m
    }
}

/// [`Aabb::measure`] of the box from `lo` to `hi`, which holds a point.
#[inline(always)]
pub(super) fn measure_full(lo: Vec3A, hi: Vec3A) -> f32 {
    let e = Vec3::from((hi - lo).max(Vec3A::ZERO));
    let area = 2.0 * (e.x * e.y + e.y * e.z + e.z * e.x);
    if area > 0.0 {
        area
    } else {
        crate::math::length(e)
    }
}

/// Where a centroid falls: `min((c − min) · scale, top)`, truncated, on each axis.
pub(super) struct ToBucket {
    pub(super) min: Vec3A,
    pub(super) scale: Vec3A,
    pub(super) top: Vec3A,
}

impl ToBucket {
    /// The buckets of centroid `c` on the three axes.
    #[inline(always)]
    pub(super) fn of(&self, c: Vec3A) -> [usize; 3] {
        // In [0, top], so the truncation is that of `as usize`, and the mask (a no-op)
        // bounds the index.
        let f = ((c - self.min) * self.scale).min(self.top);
        let k = f32x4::new(f.extend(0.0).to_array())
            .fast_trunc_int()
            .to_array();
        [
            k[0] as usize & (MAX_BUCKETS - 1),
            k[1] as usize & (MAX_BUCKETS - 1),
            k[2] as usize & (MAX_BUCKETS - 1),
        ]
    }
}

/// Bins the lights of a node (buckets on all three axes in one pass); returns the radius of
/// the sphere around `center` holding every light's sphere. A bucket is its lights added in
/// turn ([`Acc`]); but one that receives an omnidirectional light has the whole sphere for
/// cone whatever came before, so the cone unions are made in a second pass, only for the
/// buckets without one (and of those only the ones [`Ctx::best_boundary`] reads).
///
/// With `split`, the first pass is split over it by axes: one half bins axis 0 and finds the
/// radius, the other bins axes 1 and 2; each bucket receives its lights in the same order.
pub(super) fn fill_bins<J: Join>(
    bins: &mut Buckets,
    leaves: &[BinNode],
    boxes: &[Aabb],
    to_bucket: &ToBucket,
    center: Vec3,
    split: Option<&J>,
) -> f32 {
    for (acc, used) in bins.acc.iter_mut().zip(bins.used.iter_mut()) {
        for i in bits(*used) {
            acc[i] = Bucket::EMPTY;
        }
        *used = 0;
    }
    let radius = match split {
        Some(join) => bin_by_axes(bins, leaves, boxes, to_bucket, center, join),
        None => bin(bins, leaves, boxes, to_bucket, center),
    };
    cone_pass(bins, leaves, boxes, to_bucket);
    radius
}

/// The first pass of [`fill_bins`]: every light into its bucket on each axis; returns the
/// radius.
#[inline(always)]
pub(super) fn bin(
    bins: &mut Buckets,
    leaves: &[BinNode],
    boxes: &[Aabb],
    to_bucket: &ToBucket,
    center: Vec3,
) -> f32 {
    let mut radius = 0.0f32;
    for (leaf, aabb) in leaves.iter().zip(boxes) {
        let s = &leaf.bounds.sphere;
        let r = crate::math::length(s.center - center) + s.radius;
        radius = if r > radius { r } else { radius };
        let k = to_bucket.of(aabb.center_a());
        let omni = leaf.bounds.cone.is_sphere();
        let e = leaf.bounds.energy;
        for ((acc, used), &k) in bins.acc.iter_mut().zip(bins.used.iter_mut()).zip(&k) {
            let b = &mut acc[k];
            b.lo = b.lo.min(aabb.min);
            b.hi = b.hi.max(aabb.max);
            b.energy += e;
            b.count += 1;
            b.omni |= omni;
            *used |= 1 << k;
        }
    }
    radius
}

/// Adds a light (`leaf`, `aabb`) to bucket `k` of an axis whose used buckets are `used`.
#[inline(always)]
pub(super) fn add_light(
    acc: &mut [Bucket; MAX_BUCKETS],
    used: &mut u64,
    k: usize,
    leaf: &BinNode,
    aabb: &Aabb,
) {
    let b = &mut acc[k];
    b.lo = b.lo.min(aabb.min);
    b.hi = b.hi.max(aabb.max);
    b.energy += leaf.bounds.energy;
    b.count += 1;
    b.omni |= leaf.bounds.cone.is_sphere();
    *used |= 1 << k;
}

/// [`bin`] as `join`'s two halves: axis 0 and the radius, then axes 1 and 2.
pub(super) fn bin_by_axes<J: Join>(
    bins: &mut Buckets,
    leaves: &[BinNode],
    boxes: &[Aabb],
    to_bucket: &ToBucket,
    center: Vec3,
    join: &J,
) -> f32 {
    let [a0, a1, a2] = &mut bins.acc;
    let [u0, u1, u2] = &mut bins.used;
    let (radius, ()) = join.join(
        || {
            let mut radius = 0.0f32;
            for (leaf, aabb) in leaves.iter().zip(boxes) {
                let s = &leaf.bounds.sphere;
                let r = crate::math::length(s.center - center) + s.radius;
                radius = if r > radius { r } else { radius };
                let k = to_bucket.of(aabb.center_a());
                add_light(a0, u0, k[0], leaf, aabb);
            }
            radius
        },
        || {
            for (leaf, aabb) in leaves.iter().zip(boxes) {
                let k = to_bucket.of(aabb.center_a());
                add_light(a1, u1, k[1], leaf, aabb);
                add_light(a2, u2, k[2], leaf, aabb);
            }
        },
    );
    radius
}

/// The second pass of [`fill_bins`]: the cones of the buckets that need them.
pub(super) fn cone_pass(
    bins: &mut Buckets,
    leaves: &[BinNode],
    boxes: &[Aabb],
    to_bucket: &ToBucket,
) {
    // The cones of buckets without an omnidirectional light (all of whose lights have a
    // cone of their own); `directed` counts the lights already united. Only the buckets
    // before the first omnidirectional one and after the last one need theirs: the scans of
    // `best_boundary` stop reading cones at an omnidirectional bucket.
    let mut needed = [0u64; 3];
    for ((acc, &used), needed) in bins.acc.iter().zip(&bins.used).zip(needed.iter_mut()) {
        let mut omni = 0u64;
        for i in bits(used) {
            omni |= u64::from(acc[i].omni) << i;
        }
        *needed = if omni == 0 {
            used
        } else {
            let (first, last) = (omni.trailing_zeros(), 63 - omni.leading_zeros());
            let below = (1u64 << first) - 1;
            let above = !((2u64 << last).wrapping_sub(1));
            used & (below | above)
        };
    }
    if needed.iter().any(|&m| m != 0) {
        for (leaf, aabb) in leaves.iter().zip(boxes) {
            let c = &leaf.bounds.cone;
            if c.is_sphere() {
                continue;
            }
            let k = to_bucket.of(aabb.center_a());
            for axis in 0..3 {
                if needed[axis] & (1 << k[axis]) == 0 {
                    continue;
                }
                let b = &mut bins.acc[axis][k[axis] & (MAX_BUCKETS - 1)];
                let cone = &mut bins.cone[axis][k[axis] & (MAX_BUCKETS - 1)];
                *cone = if b.directed == 0 {
                    *c
                } else {
                    cone.union_fast(*c)
                };
                b.directed += 1;
            }
        }
    }
}
