//! Traditional light importance, TL (Conty & Kulla, "Importance Function"; Liu et al. 2019
//! Eqn. 6 with the G and E terms; docs/formulas.md, section 4):
//!
//! ```text
//! θu  = asin(min(r/d, 1))            (π when x is inside the bounding sphere)
//! θ'  = max(0, θ − θo − θu)          θ = angle between the cone axis and the direction cluster → x
//! θi' = max(0, θi − θu)              θi = angle between n and the direction x → cluster
//! I   = E · cos θ' · cos θi' / max(d², d_min²)     and 0 when θ' ≥ θe or θi' ≥ π/2
//! ```
//!
//! Cosines of differences come from the subtraction identity (no `acos`). Choices made here:
//! - `d_min = r / 2` ([`DISTANCE_CLAMP_FRACTION`]): clusters around x are not ranked by a
//!   distance that means nothing inside them; `d²` also never drops below [`MIN_DISTANCE2`]
//!   (x on a point light), which with the energy caps of the build keeps importances finite.
//!   The floor is the falloff's only: the direction x → cluster and θu come from the true
//!   distance, however small (a cluster 1e-7 away is still seen in its direction).
//! - Conservative under f32 rounding: a cluster within [`COS_SLACK`] of a zero boundary
//!   keeps a small positive importance ([`COS_FLOOR`] as its cosine) instead of 0.
//! - The receiver is reflective (cos θi' clamped at 0), transmissive (|cos θi|), or
//!   omnidirectional (no cosine; a medium or a point with no normal).

use super::Importance;
use crate::infinite_light::{InfiniteKind, InfiniteLight};
use crate::lanes::{self, Lanes};
use crate::math;
use crate::quantize;
use crate::tree::{Node4, SlotBounds};
use glam::Vec3;
use wide::{f32x4, f32x8, i32x4};

/// `d_min = DISTANCE_CLAMP_FRACTION · r`.
pub(crate) const DISTANCE_CLAMP_FRACTION: f32 = 0.5;
/// Floor of the squared distance.
pub(crate) const MIN_DISTANCE2: f32 = 1e-12;
/// A cosine this far past a zero boundary still counts as inside it.
pub(crate) const COS_SLACK: f32 = 2e-6;
/// The cosine used for a cluster at the boundary.
pub(crate) const COS_FLOOR: f32 = 1e-6;

const CLAMP2: f32 = DISTANCE_CLAMP_FRACTION * DISTANCE_CLAMP_FRACTION;

/// `2^100`: a vector whose squared length is below `f32::MIN_POSITIVE` (length below about
/// 1e-19) is scaled by it, exactly, before it is normalised; its squared length is then at
/// least about 3e-30 and at most about 2e22.
const TINY_SCALE: f32 = 1.267_650_6e30;

/// How the shading point receives light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Receiver {
    /// Only from the side of the normal.
    Reflective,
    /// From both sides of the surface.
    Transmissive,
    /// From every direction (no normal).
    Omnidirectional,
}

/// TL importance at one shading point.
#[derive(Clone, Copy, Debug)]
pub struct TlImportance {
    position: Vec3,
    normal: Vec3,
    receiver: Receiver,
    /// False for a non-finite position: every importance is then 0 (nothing is sampled).
    valid: bool,
}

impl TlImportance {
    /// A reflective surface point. `normal` is normalised here, whatever its finite non-zero
    /// length (in f64 where f32 would overflow or underflow); the zero vector or a non-finite
    /// normal makes the point omnidirectional; a non-finite position makes every importance 0.
    #[inline]
    #[must_use]
    pub fn new(position: Vec3, normal: Vec3) -> TlImportance {
        TlImportance::with_receiver(position, normal, Receiver::Reflective)
    }

    /// A point with the given kind of receiver.
    #[inline]
    #[must_use]
    pub fn with_receiver(position: Vec3, normal: Vec3, receiver: Receiver) -> TlImportance {
        let l2 = normal.length_squared();
        let unit = if math::len2_is_safe(l2) {
            Some(normal * (1.0 / math::sqrt(l2)))
        } else {
            math::unit(normal)
        };
        let (normal, receiver) = match unit {
            Some(n) => (n, receiver),
            None => (Vec3::ZERO, Receiver::Omnidirectional),
        };
        TlImportance {
            position,
            normal,
            receiver,
            valid: position.is_finite(),
        }
    }

    /// The shading position.
    #[must_use]
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// The unit normal (zero for an omnidirectional point).
    #[must_use]
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// The kind of receiver.
    #[must_use]
    pub fn receiver(&self) -> Receiver {
        self.receiver
    }

    /// The scalar reference: the importance of one cluster.
    #[must_use]
    pub fn eval(&self, b: &SlotBounds) -> f32 {
        if !self.valid {
            return 0.0;
        }
        let v = ClusterView::new(self.position, b);
        let cos_ip = self.receiver_cos(&v);
        if !v.emits || cos_ip <= -COS_SLACK {
            return 0.0;
        }
        b.energy * v.cos_tp.max(COS_FLOOR) * cos_ip.max(COS_FLOOR) / v.d2c
    }

    /// The function of [`eval`] (`TlImportance::eval`, the scalar reference the binary
    /// baseline uses) in the scaled form `eval4` documents, on the slot's decoded unit axis
    /// (`la` = 1 within rounding). [`Importance::eval_lane`] applies the same operations to the
    /// axis before its normalisation, which is lane `k` of `eval4` operation for operation.
    ///
    /// [`eval`]: TlImportance::eval
    #[inline]
    #[must_use]
    pub fn eval_scaled(&self, b: &SlotBounds) -> f32 {
        self.scaled(b, b.axis)
    }

    /// The scaled form with the cone axis `a` (unit, or as the octahedral decode gives it).
    #[inline]
    fn scaled(&self, b: &SlotBounds, a: Vec3) -> f32 {
        if !self.valid {
            return 0.0;
        }
        let p = self.position;
        let (vx, vy, vz) = (b.center.x - p.x, b.center.y - p.y, b.center.z - p.z);
        let d2 = vx * vx + vy * vy + vz * vz;
        let r2 = b.radius * b.radius;
        let d2c = d2.max(CLAMP2 * r2).max(MIN_DISTANCE2);
        let inv_d2c = 1.0 / d2c;
        let inside = d2 <= r2;
        let (vx, vy, vz, l2, k) = if d2 >= f32::MIN_POSITIVE {
            (vx, vy, vz, d2, 1.0)
        } else {
            let (x, y, z) = (vx * TINY_SCALE, vy * TINY_SCALE, vz * TINY_SCALE);
            (x, y, z, x * x + y * y + z * z, TINY_SCALE)
        };
        let l2 = l2.max(f32::MIN_POSITIVE);
        let inv_l2 = 1.0 / l2;
        let d = math::sqrt(l2);
        let rk = b.radius * k;
        let su = rk.min(d);
        let cu = math::sqrt((l2 - rk * rk).max(0.0));
        let la = math::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
        let inv_la = 1.0 / la;
        let at = -(a.x * vx + a.y * vy + a.z * vz);
        let (cx, cy, cz) = (
            a.y * vz - a.z * vy,
            a.z * vx - a.x * vz,
            a.x * vy - a.y * vx,
        );
        let st = math::sqrt(cx * cx + cy * cy + cz * cz);
        let c1 = at * b.cos_o + st * b.sin_o;
        let s1 = (st * b.cos_o - at * b.sin_o).max(0.0);
        let mut cos_tp = if c1 >= cu * la {
            1.0
        } else {
            (c1 * cu + s1 * su) * (inv_l2 * inv_la)
        };
        if at >= b.cos_o * d * la || inside {
            cos_tp = 1.0;
        }
        let emits = cos_tp > b.cos_e - COS_SLACK;
        let cos_ip = if self.receiver == Receiver::Omnidirectional {
            1.0
        } else {
            let n = self.normal;
            let mut ci = n.x * vx + n.y * vy + n.z * vz;
            if self.receiver == Receiver::Transmissive {
                ci = ci.abs();
            }
            let si = math::sqrt((l2 - ci * ci).max(0.0));
            let cos_ip = if ci >= cu {
                1.0
            } else {
                (ci * cu + si * su) * inv_l2
            };
            if inside {
                1.0
            } else {
                cos_ip
            }
        };
        if !emits || cos_ip <= -COS_SLACK {
            return 0.0;
        }
        b.energy * inv_d2c * cos_tp.max(COS_FLOOR) * cos_ip.max(COS_FLOOR)
    }

    /// cos θi' = cos(max(0, θi − θu)) for this receiver (1 inside the cluster).
    #[inline]
    fn receiver_cos(&self, v: &ClusterView) -> f32 {
        let n = self.normal;
        let mut cos_i = n.x * v.w.x + n.y * v.w.y + n.z * v.w.z;
        if self.receiver == Receiver::Transmissive {
            cos_i = cos_i.abs();
        }
        let sin_i = math::sqrt((1.0 - cos_i * cos_i).max(0.0));
        let cos_ip = if cos_i >= v.cos_u {
            1.0
        } else {
            cos_i * v.cos_u + sin_i * v.sin_u
        };
        if self.receiver == Receiver::Omnidirectional || v.inside {
            1.0
        } else {
            cos_ip
        }
    }
}

/// What every importance needs to know of one cluster seen from a shading point: the clamped
/// squared distance, the direction, the uncertainty angle θu and the emitter's orientation
/// factor cos θ' (Conty & Kulla, "Importance Function"). The scalar reference.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ClusterView {
    /// `max(d², (r/2)², MIN_DISTANCE2)`.
    pub d2c: f32,
    /// x is inside the bounding sphere.
    pub inside: bool,
    /// Unit direction x → centre.
    pub w: Vec3,
    /// sin θu = min(r/d, 1).
    pub sin_u: f32,
    /// cos θu.
    pub cos_u: f32,
    /// cos θ' (1 inside).
    pub cos_tp: f32,
    /// θ' < θe (within the rounding slack): the cluster may emit towards x.
    pub emits: bool,
}

impl ClusterView {
    #[inline]
    pub(crate) fn new(p: Vec3, b: &SlotBounds) -> ClusterView {
        let (vx, vy, vz) = (b.center.x - p.x, b.center.y - p.y, b.center.z - p.z);
        let d2 = vx * vx + vy * vy + vz * vz;
        let r2 = b.radius * b.radius;
        let d2c = d2.max(CLAMP2 * r2).max(MIN_DISTANCE2);
        let inside = d2 <= r2;
        // The direction and r/d from the true distance (MIN_DISTANCE2 floors only the
        // falloff): a d² below f32's normal range is first scaled by TINY_SCALE², exactly.
        let (vx, vy, vz, l2, k) = if d2 >= f32::MIN_POSITIVE {
            (vx, vy, vz, d2, 1.0)
        } else {
            let (x, y, z) = (vx * TINY_SCALE, vy * TINY_SCALE, vz * TINY_SCALE);
            (x, y, z, x * x + y * y + z * z, TINY_SCALE)
        };
        let inv_d = 1.0 / math::sqrt(l2.max(f32::MIN_POSITIVE));
        let (wx, wy, wz) = (vx * inv_d, vy * inv_d, vz * inv_d);
        let sin_u = (b.radius * k * inv_d).min(1.0);
        let cos_u = math::sqrt((1.0 - sin_u * sin_u).max(0.0));
        // cos θ' = cos(max(0, θ − θo − θu)) from the subtraction identity.
        let a = b.axis;
        let cos_t = -(a.x * wx + a.y * wy + a.z * wz);
        let sin_t = math::sqrt((1.0 - cos_t * cos_t).max(0.0));
        let c1 = cos_t * b.cos_o + sin_t * b.sin_o;
        let s1 = (sin_t * b.cos_o - cos_t * b.sin_o).max(0.0);
        let mut cos_tp = if c1 >= cos_u {
            1.0
        } else {
            c1 * cos_u + s1 * sin_u
        };
        if cos_t >= b.cos_o || inside {
            cos_tp = 1.0;
        }
        ClusterView {
            d2c,
            inside,
            w: Vec3::new(wx, wy, wz),
            sin_u,
            cos_u,
            cos_tp,
            emits: cos_tp > b.cos_e - COS_SLACK,
        }
    }
}

/// [`ClusterView`] for the four slots of a node, lane by lane the same operations, except
/// that a node whose four cones have θo = π ([`all_omni`]) skips the emitter's orientation:
/// cos θ' is then 1 and every lane emits. That is bit for bit what the decoded cones give
/// wherever the direction `w` is finite (cos θo = −1 and sin θo = 0 exactly, so either
/// cos θ ≥ −1, the test that sets 1, or c1 = −cos θ > 1 ≥ cos θu, the other test that sets 1;
/// and 1 emits, as `cos θe − COS_SLACK < 1`). Where `w` is NaN (a centre at infinity) the
/// decoded form does not emit, and this one does, but the receiver's cosine n·w is NaN there
/// too, so no importance built on the view takes such a lane.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ClusterView4 {
    pub d2c: f32x4,
    /// |c − x|² of the decoded sphere, unclamped.
    pub d2: f32x4,
    /// The decoded sphere's r².
    pub r2: f32x4,
    pub inside: f32x4,
    pub wx: f32x4,
    pub wy: f32x4,
    pub wz: f32x4,
    pub sin_u: f32x4,
    pub cos_u: f32x4,
    pub cos_tp: f32x4,
    pub emits: f32x4,
}

/// The cone words of a node's four slots, decoded: the axis as `quantize::decode_axis_raw`
/// gives it (not normalised), cos θo and sin θo as `quantize::decode_angle`, cos θe as
/// `quantize::decode_emission` ((255² − q²) / 255²).
struct Cones<L> {
    x: L,
    y: L,
    z: L,
    cos_o: L,
    sin_o: L,
    cos_e: L,
}

/// One node's [`Cones`].
type Cones4 = Cones<f32x4>;

impl Cones4 {
    #[inline(always)]
    fn new(node: &Node4) -> Cones4 {
        let zero = f32x4::ZERO;
        let one = f32x4::ONE;
        let two = f32x4::splat(2.0);
        let q = i32x4::new(bytemuck::cast(node.cone));
        let scale = f32x4::splat(2.0 / 255.0);
        let x = quantize::byte_lanes(q, 0) * scale - one;
        let y = quantize::byte_lanes(q, 8) * scale - one;
        let z = one - x.abs() - y.abs();
        let t = (-z).fast_max(zero);
        // `x ≥ 0 ? x − t : x + t` as `x − (t with the sign of x)` (t ≥ 0): x is never ±0 (no
        // code decodes to exactly 0) and x − (−t) is x + t, so the lanes are the same numbers
        // (the tests compare every code with `decode_axis_raw`).
        let sign = f32x4::splat(-0.0);
        let x = x - (t | (x & sign));
        let y = y - (t | (y & sign));
        let so = quantize::byte_lanes(q, 16) * f32x4::splat(1.0 / 255.0);
        let qe = quantize::byte_lanes(q, 24);
        Cones4 {
            x,
            y,
            z,
            cos_o: one - two * so * so,
            sin_o: two * so * (one - so * so).fast_max(zero).sqrt(),
            cos_e: (f32x4::splat(65025.0) - qe * qe) * f32x4::splat(1.0 / 65025.0),
        }
    }

    /// Two nodes' cones side by side.
    #[inline(always)]
    fn pair(self, b: Cones4) -> Cones<f32x8> {
        Cones {
            x: lanes::pair(self.x, b.x),
            y: lanes::pair(self.y, b.y),
            z: lanes::pair(self.z, b.z),
            cos_o: lanes::pair(self.cos_o, b.cos_o),
            sin_o: lanes::pair(self.sin_o, b.sin_o),
            cos_e: lanes::pair(self.cos_e, b.cos_e),
        }
    }
}

/// A point's offsets to the four sphere centres of a node, as both 4-wide importances start
/// from them (and as their scalar forms do): `v` = centre − point, rescaled by `k`
/// (`TINY_SCALE` in the lanes where |v|² is below the smallest normal f32, else 1) so that
/// its direction survives; `l2` = |k·v|², at least the smallest normal; `rk` = the radius
/// times `k`; `d2c` = |v|² clamped below at `CLAMP2 · r²` and `MIN_DISTANCE2`; `d2` = |v|²
/// and `r2` = r² unscaled; `inside` where |v| ≤ r (`d2 ≤ r2`).
struct Offsets<L> {
    vx: L,
    vy: L,
    vz: L,
    l2: L,
    rk: L,
    d2c: L,
    d2: L,
    r2: L,
    inside: L,
}

/// One node's [`Offsets`].
type Offsets4 = Offsets<f32x4>;

impl<L: Lanes> Offsets<L> {
    /// From the centre − point differences `(vx, vy, vz)` and the radii `r`.
    #[inline(always)]
    fn from_differences(vx: L, vy: L, vz: L, r: L) -> Offsets<L> {
        let one = L::ONE;
        let d2 = vx * vx + vy * vy + vz * vz;
        let r2 = r * r;
        let d2c = d2
            .fast_max(L::splat(CLAMP2) * r2)
            .fast_max(L::splat(MIN_DISTANCE2));
        let min_normal = L::splat(f32::MIN_POSITIVE);
        let tiny = d2.simd_lt(min_normal);
        let (vx, vy, vz, l2, k) = if tiny.any() {
            let k = tiny.select(L::splat(TINY_SCALE), one);
            let (x, y, z) = (vx * k, vy * k, vz * k);
            (x, y, z, x * x + y * y + z * z, k)
        } else {
            (vx, vy, vz, d2, one)
        };
        Offsets {
            vx,
            vy,
            vz,
            l2: l2.fast_max(min_normal),
            rk: r * k,
            d2c,
            d2,
            r2,
            inside: d2.simd_le(r2),
        }
    }
}

/// The centre − point differences of a node's four slots and their radii.
#[inline(always)]
fn differences(p: Vec3, node: &Node4) -> [f32x4; 4] {
    let s = node.spheres4();
    [
        s.x - f32x4::splat(p.x),
        s.y - f32x4::splat(p.y),
        s.z - f32x4::splat(p.z),
        s.r,
    ]
}

impl Offsets4 {
    #[inline(always)]
    fn new(p: Vec3, node: &Node4) -> Offsets4 {
        let [vx, vy, vz, r] = differences(p, node);
        Offsets::from_differences(vx, vy, vz, r)
    }
}

impl ClusterView4 {
    #[inline(always)]
    pub(crate) fn new(p: Vec3, node: &Node4) -> ClusterView4 {
        let zero = f32x4::ZERO;
        let one = f32x4::ONE;
        let Offsets4 {
            vx,
            vy,
            vz,
            l2,
            rk,
            d2c,
            d2,
            r2,
            inside,
        } = Offsets4::new(p, node);
        let inv_d = one / l2.sqrt();
        let (wx, wy, wz) = (vx * inv_d, vy * inv_d, vz * inv_d);
        let sin_u = (rk * inv_d).fast_min(one);
        let cos_u = (one - sin_u * sin_u).fast_max(zero).sqrt();

        let (cos_tp, emits) = if all_omni(node) {
            (one, ALL_LANES)
        } else {
            let Cones4 {
                x,
                y,
                z,
                cos_o,
                sin_o,
                cos_e,
            } = Cones4::new(node);
            let inv = one / (x * x + y * y + z * z).sqrt();
            let (ax, ay, az) = (x * inv, y * inv, z * inv);

            let cos_t = -(ax * wx + ay * wy + az * wz);
            let sin_t = (one - cos_t * cos_t).fast_max(zero).sqrt();
            let c1 = cos_t * cos_o + sin_t * sin_o;
            let s1 = (sin_t * cos_o - cos_t * sin_o).fast_max(zero);
            let whole = c1.simd_ge(cos_u) | cos_t.simd_ge(cos_o) | inside;
            let cos_tp = whole.select(one, c1 * cos_u + s1 * sin_u);
            (cos_tp, cos_tp.simd_gt(cos_e - f32x4::splat(COS_SLACK)))
        };
        ClusterView4 {
            d2c,
            d2,
            r2,
            inside,
            wx,
            wy,
            wz,
            sin_u,
            cos_u,
            cos_tp,
            emits,
        }
    }
}

/// The mask of all four lanes.
const ALL_LANES: f32x4 = f32x4::new([f32::from_bits(u32::MAX); 4]);

impl Importance for TlImportance {
    /// [`TlImportance::eval`] for the four slots of `node` at once, in a scaled form that
    /// keeps square roots and divisions off the chain from the node's load to its weights.
    /// With `v` the vector x → centre, `d = |v|`, the cone axis `a` as the octahedral decode
    /// gives it before normalising (`la = |a|`) and the unit normal `n`:
    ///
    /// ```text
    /// cos θ · d·la = −a·v        sin θ · d·la = |a × v|
    /// cos θu · d   = √(d² − r²)  sin θu · d   = min(r, d)
    /// cos θi · d   = n·v         sin θi · d   = √(d² − (n·v)²)
    /// ```
    ///
    /// so no direction is normalised: the square roots depend on `v` and the node alone and
    /// run side by side, and the divisions (1/d², 1/la, 1/max(d², d_min²)) start as soon as
    /// their inputs are loaded. The cross product keeps sin θ accurate where θ is small, so
    /// lanes equal [`TlImportance::eval_scaled`] (its unit axis, `la` ≈ 1) within rounding,
    /// and the function is the scalar reference's within the rounding of the two forms.
    #[inline(always)]
    fn eval4(&self, node: &Node4) -> f32x4 {
        if !self.valid {
            return f32x4::ZERO;
        }
        let n = self.normal;
        let normal = [n.x, n.y, n.z].map(f32x4::splat);
        scaled4(
            self.receiver,
            normal,
            Offsets4::new(self.position, node),
            (!all_omni(node)).then(|| Cones4::new(node)),
            node.energy4(),
        )
    }

    /// Both points' `eval4` in the lanes of one `f32x8` (see `lanes`), bit for bit the two
    /// calls' results. Two points of different receivers, or an invalid one, take the two
    /// calls.
    #[inline(always)]
    fn eval4_pair(&self, a: &Node4, other: &Self, b: &Node4) -> (f32x4, f32x4)
    where
        Self: Sized,
    {
        if !(self.valid && other.valid) || self.receiver != other.receiver {
            return (self.eval4(a), other.eval4(b));
        }
        let [ax, ay, az, ar] = differences(self.position, a);
        let [bx, by, bz, br] = differences(other.position, b);
        let offsets = Offsets::from_differences(
            lanes::pair(ax, bx),
            lanes::pair(ay, by),
            lanes::pair(az, bz),
            lanes::pair(ar, br),
        );
        let (n, m) = (self.normal, other.normal);
        let normal = [(n.x, m.x), (n.y, m.y), (n.z, m.z)]
            .map(|(p, q)| lanes::pair(f32x4::splat(p), f32x4::splat(q)));
        let energy = lanes::pair(a.energy4(), b.energy4());
        let cones = (!(all_omni(a) && all_omni(b))).then(|| Cones4::new(a).pair(Cones4::new(b)));
        lanes::halves(scaled4(self.receiver, normal, offsets, cones, energy))
    }

    /// [`TlImportance::eval`]. Lane `k` of `eval4` equals it within `1e-5` relative plus `1e-30`
    /// absolute: the two perform the same operations, so any larger difference is a bug.
    #[inline]
    fn eval_slot(&self, b: &SlotBounds) -> f32 {
        self.eval_scaled(b)
    }

    /// [`TlImportance::eval_scaled`] on slot `k`'s axis as `eval4` decodes it (before its
    /// normalisation): lane `k` of `eval4`, operation for operation.
    #[inline]
    fn eval_lane(&self, node: &Node4, k: usize) -> f32 {
        let k = k & 3;
        self.scaled(&node.bounds(k), quantize::decode_axis_raw(node.cone[k]))
    }

    /// A distant light's `4π E cos⁺(max(0, θi − γ))` (θi from the normal, γ its angular
    /// radius: the cone of section 4 with no distance term and no emitter orientation), the
    /// environment's `4π` times its irradiance bound at the normal
    /// ([`InfiniteLight::environment_bound`]); 0 for a non-finite position.
    #[inline]
    fn eval_infinite(&self, light: &InfiniteLight) -> f32 {
        if !self.valid {
            return 0.0;
        }
        light.tl(self.normal, self.receiver)
    }
}

/// The angle byte of a cone word in which θo = π: [`Cones4::new`] (as
/// `quantize::decode_angle`) decodes it to cos θo = −1 and sin θo = 0 exactly.
const OMNI_ANGLE: u32 = 0xFF << 16;

/// Every slot of `node` has θo = π (all directions), as point lights and most clusters near
/// the root do: [`scaled4`] then skips the emitter's orientation, whose factor cos θ' is 1 in
/// every lane (see there).
#[inline(always)]
fn all_omni(node: &Node4) -> bool {
    let c = node.cone;
    c[0] & c[1] & c[2] & c[3] & OMNI_ANGLE == OMNI_ANGLE
}

/// The body of [`TlImportance::eval4`] (documented there), on one node's lanes or two nodes'
/// (see `lanes`), for a valid point of the given receiver and unit `normal` (splatted).
///
/// `cones` is `None` when every lane has θo = π ([`all_omni`]); the result is then bit for
/// bit what the decoded cones give, since with cos θo = −1 and sin θo = 0 exactly:
/// - where |v|² is finite, every product below is finite, and cos θ' is 1: either
///   `at ≥ −(d·la)`, or `c1 = −at > d·la ≥ cu·la` (cu ≤ d, both roundings monotonic); and 1
///   always emits, as `cos θe − COS_SLACK < 1`;
/// - where |v|² is ∞, `1 / d2c` is +0, and both forms give +0: a lane whose cos θ' (decoded
///   form) or cos θi' is NaN is not live, and in the others the product is +0 times finite
///   non-negative factors (each cosine is then 1, +0 or NaN).
#[inline(always)]
fn scaled4<L: Lanes>(
    receiver: Receiver,
    normal: [L; 3],
    offsets: Offsets<L>,
    cones: Option<Cones<L>>,
    energy: L,
) -> L {
    let zero = L::ZERO;
    let one = L::ONE;
    let Offsets {
        vx,
        vy,
        vz,
        l2,
        rk,
        d2c,
        inside,
        ..
    } = offsets;
    let inv_d2c = one / d2c;
    let inv_l2 = one / l2;
    let d = l2.sqrt();
    // sin θu · d and cos θu · d.
    let su = rk.fast_min(d);
    let cu = (l2 - rk * rk).fast_max(zero).sqrt();

    // cos θ' = cos(max(0, θ − θo − θu)) and where it emits (None: everywhere).
    let (cos_tp, emits) = match cones {
        None => (one, None),
        Some(Cones {
            x: ax,
            y: ay,
            z: az,
            cos_o,
            sin_o,
            cos_e,
        }) => {
            // The axis is not normalised: its length `la` divides the one product that
            // needs it.
            let la = (ax * ax + ay * ay + az * az).sqrt();
            let inv_la = one / la;
            // Scaled by d · la before the last product.
            let at = -(ax * vx + ay * vy + az * vz);
            let (cx, cy, cz) = (ay * vz - az * vy, az * vx - ax * vz, ax * vy - ay * vx);
            let st = (cx * cx + cy * cy + cz * cz).sqrt();
            let c1 = at * cos_o + st * sin_o;
            let s1 = (st * cos_o - at * sin_o).fast_max(zero);
            // One select of 1 where any of the three conditions holds (the two selects in
            // turn of the scalar form): the masks come off the chain, in parallel.
            let whole = c1.simd_ge(cu * la) | at.simd_ge(cos_o * d * la) | inside;
            let cos_tp = whole.select(one, (c1 * cu + s1 * su) * (inv_l2 * inv_la));
            (cos_tp, Some(cos_tp.simd_gt(cos_e - L::splat(COS_SLACK))))
        }
    };

    // cos θi' = cos(max(0, θi − θu)), scaled by d.
    let cos_ip = if receiver == Receiver::Omnidirectional {
        one
    } else {
        let [nx, ny, nz] = normal;
        let mut ci = nx * vx + ny * vy + nz * vz;
        if receiver == Receiver::Transmissive {
            ci = ci.abs();
        }
        let si = (l2 - ci * ci).fast_max(zero).sqrt();
        (ci.simd_ge(cu) | inside).select(one, (ci * cu + si * su) * inv_l2)
    };

    let floor = L::splat(COS_FLOOR);
    let received = cos_ip.simd_gt(L::splat(-COS_SLACK));
    let live = emits.map_or(received, |e| e & received);
    let value = energy * inv_d2c * cos_tp.fast_max(floor) * cos_ip.fast_max(floor);
    live.select(value, zero)
}

/// `4π`: the node tree's importances are `flux / d²`, 4π times an irradiance; a light at
/// infinity's are its irradiance times this, so that all are in the same units.
const FOUR_PI: f32 = 4.0 * core::f32::consts::PI;

/// The TL importance of the lights at infinity (docs/formulas.md, section 16).
impl InfiniteLight {
    /// The environment's irradiance bound at the unit normal `n` for `receiver`:
    /// `Σ |n_i| E(sign(n_i) e_i)` for a reflective receiver (with `max(0, n·ω) ≤
    /// Σ |n_i| max(0, sign(n_i) e_i·ω)` it bounds the irradiance), the bounds of both
    /// sides for a transmissive one, all six for an omnidirectional one (`1 ≤ Σ |ω_i|`).
    #[must_use]
    pub fn environment_bound(&self, n: Vec3, receiver: Receiver) -> f32 {
        let e = &self.irradiance;
        let pick = |c: f32, pos: f32, neg: f32| if c >= 0.0 { pos } else { neg };
        match receiver {
            Receiver::Omnidirectional => e.iter().sum(),
            Receiver::Reflective => {
                n.x.abs() * pick(n.x, e[0], e[1])
                    + n.y.abs() * pick(n.y, e[2], e[3])
                    + n.z.abs() * pick(n.z, e[4], e[5])
            }
            Receiver::Transmissive => {
                n.x.abs() * (e[0] + e[1]) + n.y.abs() * (e[2] + e[3]) + n.z.abs() * (e[4] + e[5])
            }
        }
    }

    /// The TL importance of the entry at a point of unit normal `n`: for a distant light
    /// `4π E cos⁺(max(0, θi − γ))` with θi the angle between `n` and its direction (the
    /// cosine floored at `COS_FLOOR` within `COS_SLACK` of the horizon, as the node tree's:
    /// conservative), for the environment `4π` times its bound at `n`.
    pub(crate) fn tl(&self, n: Vec3, receiver: Receiver) -> f32 {
        match self.kind() {
            Some(InfiniteKind::Distant) => {
                let cos_ip = match receiver {
                    Receiver::Omnidirectional => 1.0,
                    _ => {
                        let mut ci = n.dot(self.direction());
                        if receiver == Receiver::Transmissive {
                            ci = ci.abs();
                        }
                        math::cos_minus(ci, self.cos_radius, self.sin_radius)
                    }
                };
                if cos_ip <= -COS_SLACK {
                    return 0.0;
                }
                FOUR_PI * self.irradiance[0] * cos_ip.max(COS_FLOOR)
            }
            Some(InfiniteKind::Environment) => FOUR_PI * self.environment_bound(n, receiver),
            None => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use manylights_testkit::SplitMix64 as Rng;

    #[test]
    fn omni_angle_decodes_to_all_directions() {
        assert_eq!(quantize::decode_angle(OMNI_ANGLE >> 16), (-1.0, 0.0));
        let c = Cones4::new(&Node4 {
            cone: [OMNI_ANGLE; 4],
            ..Node4::EMPTY
        });
        assert_eq!(c.cos_o.to_array(), [-1.0; 4]);
        assert_eq!(c.sin_o.to_array(), [0.0; 4]);
    }

    #[test]
    fn omni_nodes_skip_the_cones_bit_for_bit() {
        // Nodes whose four cones have θo = π (random axes and emission angles), at points
        // near, inside, on the centres of, and far from their spheres (|v|² = ∞ included),
        // for every receiver: the importances without the cones are those with them.
        let mut rng = Rng(0x0DDC_0FFE);
        let receivers = [
            Receiver::Reflective,
            Receiver::Transmissive,
            Receiver::Omnidirectional,
        ];
        for i in 0..20_000 {
            let mut node = Node4::EMPTY;
            node.exponent = 110 + (rng.next_u32() % 30) as u8;
            node.origin = [0; 3].map(|_| rng.signed(50.0));
            for k in 0..4 {
                node.sphere[k] = rng.next_u32();
                node.cone[k] = rng.next_u32() | OMNI_ANGLE;
                node.set_energy_code(k, rng.next_u32() % 0x7F7FF);
            }
            assert!(all_omni(&node));
            let s = node.spheres4();
            let k = i % 4;
            let centre = Vec3::new(s.x.to_array()[k], s.y.to_array()[k], s.z.to_array()[k]);
            // Every receiver meets every distance (i % 3 and i / 3 % 3 run independently).
            let far = [1e3, 1e19, 3e38][i % 3];
            let p = match i % 5 {
                0 => centre,
                1 => centre + Vec3::new(1e-25, -3e-24, 0.0),
                2 => Vec3::new(rng.signed(far), rng.signed(far), rng.signed(far)),
                _ => Vec3::new(rng.signed(60.0), rng.signed(60.0), rng.signed(60.0)),
            };
            let normal = Vec3::new(rng.signed(1.0), rng.signed(1.0), rng.signed(1.0));
            let imp = TlImportance::with_receiver(p, normal, receivers[i / 3 % 3]);
            let n = imp.normal;
            let eval = |cones| {
                scaled4(
                    imp.receiver,
                    [n.x, n.y, n.z].map(f32x4::splat),
                    Offsets4::new(p, &node),
                    cones,
                    node.energy4(),
                )
                .to_array()
                .map(f32::to_bits)
            };
            assert_eq!(
                eval(None),
                eval(Some(Cones4::new(&node))),
                "node {node:?} at {p}"
            );
        }
    }

    #[test]
    fn cones4_decodes_as_the_scalar_decoders() {
        // Every axis code in some lane; the angle bytes run through all 256 values with it.
        let mut node = Node4::EMPTY;
        for code in 0..1u32 << 16 {
            for k in 0..4 {
                let q = (code + 0x3F1D * k as u32) & 0xFFFF;
                let angles = ((code + 101 * k as u32) & 0xFF) << 16 | (code >> 8 ^ k as u32) << 24;
                node.cone[k] = q | angles;
            }
            let c = Cones4::new(&node);
            let (x, y, z) = (c.x.to_array(), c.y.to_array(), c.z.to_array());
            let (co, so, ce) = (c.cos_o.to_array(), c.sin_o.to_array(), c.cos_e.to_array());
            for k in 0..4 {
                let w = node.cone[k];
                let a = quantize::decode_axis_raw(w);
                let (cos_o, sin_o) = quantize::decode_angle(w >> 16);
                let lane = [x[k], y[k], z[k], co[k], so[k], ce[k]].map(f32::to_bits);
                let scalar = [
                    a.x,
                    a.y,
                    a.z,
                    cos_o,
                    sin_o,
                    quantize::decode_emission(w >> 24),
                ];
                assert_eq!(lane, scalar.map(f32::to_bits), "cone word {w:#x}");
            }
        }
    }
}
