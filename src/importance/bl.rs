//! BRDF-oriented light importance, BL (Liu et al. 2019, Eqn. 6; docs/formulas.md, section 7):
//!
//! ```text
//! I_BL(C) = E · cos θ' / d²  ·  B_C,      B_C = (1/|Ω_C ∩ H|) ∫_{Ω_C ∩ H} f cos θi dωi
//! ```
//!
//! `Ω_C` is the cap the cluster's bounding sphere subtends at x (the whole hemisphere when x is
//! inside it), θ' and the distance clamp are those of the TL importance. The cap integral
//! `SC = ∫_{Ω_C ∩ H} f cos θi dωi` is exact for the Lambert lobe (the horizon-clipped form factor)
//! and approximated for the GGX lobe ([`SptdGgx`]: an SPTD for large caps, the exact `f cos`
//! averaged across the plane of incidence for small ones); plastic is the weighted sum. SC also
//! drives the light cut ([`crate::LightCut::build_bl`]): a cluster is split when SC > δ.
//!
//! **Staying unbiased.** The approximation can round a cap's integral to 0 (in f32, or the
//! SPTD part for a cap that only grazes the horizon) while a light in it still contributes.
//! So every BL importance carries a defensive share of the TL importance:
//! `B_C + DEFENSIVE · (ρ/π) · cos θi'`, with ρ the material's total albedo and cos θi' TL's
//! receiver factor. It is positive wherever TL is, so every light with a positive contribution
//! keeps a positive pmf; at 5 % of a Lambert lobe of the same albedo it does not change the
//! ranking of clusters the model sees.

use super::sptd::{lambert_visible, lambert_visible4, SptdGgx, SptdGgx4};
use super::tl::{ClusterView, ClusterView4, Receiver, COS_FLOOR, COS_SLACK};
use super::Importance;
use crate::error::Problem;
use crate::infinite_light::{InfiniteKind, InfiniteLight};
use crate::material::{ShadingError, ShadingField, ShadingPoint, MIN_ALPHA};
use crate::math;
use crate::tree::{Node4, SlotBounds};
use core::f32::consts::{FRAC_1_PI, PI};
use glam::Vec3;
use wide::f32x4;

/// Weight of the defensive TL share (see the module documentation).
pub const DEFENSIVE: f32 = 0.05;

/// Caps with `sin σ` below this are points: their average `f cos` over the cap is its limit,
/// `f cos` in the cap's direction (the ratio of two vanishing integrals would be 0/0, and for
/// point and spot lights both are exactly 0).
pub(crate) const POINT_LIMIT_SIN: f32 = 1e-3;

/// The mask of all four lanes.
const ALL_LANES: f32x4 = f32x4::new([f32::from_bits(u32::MAX); 4]);

/// Largest importance returned: the GGX lobe of a near-mirror surface times `E/d²` could
/// otherwise overflow f32 where TL does not; four clamped lanes still sum to a finite value.
pub const MAX_IMPORTANCE: f32 = 1e37;

/// `(∫_{C∩H} cos, |C ∩ H|)` of a cap: closed forms for a cap wholly above the horizon
/// (`π s² cos ω`, `2π(1 − cos σ)`) or below it (0, 0), the exact lens otherwise.
#[inline]
fn lambert_pair(cos_omega: f32, sin_sigma: f32) -> (f32, f32) {
    let s = sin_sigma.max(0.0);
    if s < 1.0 && (s - cos_omega) * (s + cos_omega) <= 0.0 {
        if cos_omega > 0.0 {
            let a = s * s / (1.0 + math::sqrt((1.0 - s) * (1.0 + s)));
            (s * s * cos_omega * PI, 2.0 * (a * PI))
        } else {
            (0.0, 0.0)
        }
    } else {
        lambert_visible(cos_omega, sin_sigma)
    }
}

/// The 4-wide twin of [`lambert_pair`], with the same per-lane choice, in the lanes of the
/// mask `lanes` (a cap across the horizon outside them gets the closed forms of one that does
/// not cross it: values of no meaning, and no lens to pay for).
#[inline]
fn lambert_pair4(cos_omega: f32x4, sin_sigma: f32x4, lanes: f32x4) -> (f32x4, f32x4) {
    let zero = f32x4::ZERO;
    let one = f32x4::ONE;
    let pi = f32x4::splat(PI);
    let s = sin_sigma.fast_max(zero);
    // The whole hemisphere (x inside the sphere, `s ≥ 1` exactly where `sin_sigma ≥ 1`) is
    // a crossing cap whose lens `lambert_visible4` gives as `(π, 2π)`: no need to call it
    // for that alone.
    let whole = s.simd_ge(one);
    let crossing = ((s - cos_omega) * (s + cos_omega)).simd_gt(zero) | whole;
    let above = cos_omega.simd_gt(zero);
    let a = s * s / (one + ((one - s) * (one + s)).fast_max(zero).sqrt());
    let l = above.select(s * s * cos_omega * pi, zero);
    let v = above.select(f32x4::splat(2.0) * (a * pi), zero);
    if (crossing & !whole & lanes).any() {
        let (lc, vc) = lambert_visible4(cos_omega, sin_sigma);
        (crossing.select(lc, l), crossing.select(vc, v))
    } else {
        (whole.select(pi, l), whole.select(f32x4::splat(2.0 * PI), v))
    }
}

/// BL importance at one shading point.
#[derive(Clone, Copy, Debug)]
pub struct BlImportance {
    position: Vec3,
    /// Unit normal, on the side of ωo.
    normal: Vec3,
    /// Lambert weight ρd/π.
    kd: f32,
    /// GGX weight.
    ks: f32,
    ggx: SptdGgx,
    /// DEFENSIVE · ρ/π.
    defensive: f32,
    /// ρd + ks · (GGX albedo): SC of the whole hemisphere.
    albedo: f32,
    /// The constants of the 4-wide evaluation, in four lanes.
    lanes: Lanes,
}

/// [`BlImportance`]'s constants in four lanes (loaded, not splatted, by every 4-wide
/// evaluation).
#[derive(Clone, Copy, Debug)]
struct Lanes {
    nx: f32x4,
    ny: f32x4,
    nz: f32x4,
    kd: f32x4,
    ks: f32x4,
    defensive: f32x4,
    ggx: SptdGgx4,
}

/// One cluster's BL evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlEval {
    /// The importance I_BL (with the defensive share).
    pub importance: f32,
    /// SC = ∫ f cos over the cluster's cap ∩ H (the whole hemisphere's when x is inside).
    pub cap_integral: f32,
}

/// The unit vector of a validated direction: normalised in f32 where that is accurate (the
/// ordinary case), else in f64, so that a huge or tiny (non-zero, finite) vector keeps its
/// direction instead of collapsing to zero or losing precision.
fn unit_direction(field: ShadingField, v: Vec3) -> Result<Vec3, ShadingError> {
    if math::len2_is_safe(v.length_squared()) {
        return Ok(math::normalize(v));
    }
    math::unit(v).ok_or(ShadingError {
        field,
        problem: Problem::ZeroLength,
        value: 0.0,
    })
}

impl BlImportance {
    /// Sets up the importance for `sp` (validated: the error names the bad field). The
    /// normal and ωo may have any finite, non-zero length.
    pub fn new(sp: &ShadingPoint) -> Result<BlImportance, ShadingError> {
        sp.validate()?;
        let (n, wo) = BlImportance::directions(sp)?;
        Ok(BlImportance::with_directions(sp, n, wo))
    }

    /// The checks [`BlImportance::new`] makes after validating `sp`: the unit normal, turned
    /// to the side of ωo, and the unit ωo.
    #[inline]
    pub(crate) fn directions(sp: &ShadingPoint) -> Result<(Vec3, Vec3), ShadingError> {
        let mut n = unit_direction(ShadingField::Normal, sp.normal)?;
        let wo = unit_direction(ShadingField::Wo, sp.wo)?;
        if n.dot(wo) < 0.0 {
            n = -n;
        }
        Ok((n, wo))
    }

    /// [`BlImportance::new`] for the validated `sp` and its [`BlImportance::directions`]: what
    /// is left of it cannot fail.
    #[inline(always)]
    pub(crate) fn with_directions(sp: &ShadingPoint, n: Vec3, wo: Vec3) -> BlImportance {
        let (albedo_d, specular, alpha) = sp.material.lobes();
        let ks = if specular > 0.0 { specular } else { 0.0 };
        // Without a glossy lobe no evaluation reads the SPTD (each asks for `ks > 0` first)
        // and `ks · ρ_GGX` is +0 (ρ_GGX is finite and ≥ 0): its set-up is skipped.
        let (ggx, glossy_albedo) = if ks > 0.0 {
            let ggx = SptdGgx::oriented(alpha.max(MIN_ALPHA), n, wo);
            (ggx, ks * ggx.albedo())
        } else {
            (SptdGgx::zero(), 0.0)
        };
        let albedo = albedo_d + glossy_albedo;
        let kd = albedo_d * FRAC_1_PI;
        let defensive = DEFENSIVE * albedo * FRAC_1_PI;
        BlImportance {
            position: sp.position,
            normal: n,
            kd,
            ks,
            ggx,
            defensive,
            albedo,
            lanes: Lanes {
                nx: f32x4::splat(n.x),
                ny: f32x4::splat(n.y),
                nz: f32x4::splat(n.z),
                kd: f32x4::splat(kd),
                ks: f32x4::splat(ks),
                defensive: f32x4::splat(defensive),
                ggx: SptdGgx4::new(&ggx),
            },
        }
    }

    /// The shading position.
    #[must_use]
    pub fn position(&self) -> Vec3 {
        self.position
    }

    /// The unit normal, turned to the side of ωo.
    #[must_use]
    pub fn normal(&self) -> Vec3 {
        self.normal
    }

    /// The whole hemisphere's ∫ f cos (the material's directional albedo, as approximated).
    #[must_use]
    pub fn albedo(&self) -> f32 {
        self.albedo
    }

    /// `f cos θi` in direction `w` (cosine `cos_omega` with the normal): the limit of the cap
    /// average for a vanishing cap.
    #[inline]
    fn point_value(&self, w: Vec3, cos_omega: f32) -> f32 {
        if cos_omega <= 0.0 {
            return 0.0;
        }
        let mut v = self.kd * cos_omega;
        if self.ks > 0.0 {
            v += self.ks * self.ggx.lobe(w);
        }
        v
    }

    /// The scalar reference: importance and cap integral of one cluster.
    #[must_use]
    pub fn eval(&self, b: &SlotBounds) -> BlEval {
        let v = ClusterView::new(self.position, b);
        let n = self.normal;
        let cos_omega = n.x * v.w.x + n.y * v.w.y + n.z * v.w.z;
        let sin_i = math::sqrt((1.0 - cos_omega * cos_omega).max(0.0));
        let cos_ip = if cos_omega >= v.cos_u {
            1.0
        } else {
            cos_omega * v.cos_u + sin_i * v.sin_u
        };
        let cos_ip = if v.inside { 1.0 } else { cos_ip };
        let sin_sigma = if v.inside { 1.0 } else { v.sin_u };
        let (sc, omega) = if self.ks > 0.0 {
            let c = self.ggx.cap_integrals(v.w, sin_sigma);
            (self.kd * c.lambert + self.ks * c.ggx, c.visible)
        } else {
            let (l, vis) = lambert_pair(cos_omega, sin_sigma);
            (self.kd * l, vis)
        };
        let avg = if sin_sigma < POINT_LIMIT_SIN {
            self.point_value(v.w, cos_omega)
        } else if omega > 0.0 {
            sc / omega
        } else {
            0.0
        };
        // Never below 0 (nor NaN): the importance of a live cluster is then at least that of
        // the defensive term alone ([`BlImportance::surely_positive4`]).
        let avg = if avg >= 0.0 { avg } else { 0.0 };
        if !v.emits || cos_ip <= -COS_SLACK {
            return BlEval {
                importance: 0.0,
                cap_integral: sc,
            };
        }
        let brdf = avg + self.defensive * cos_ip.max(COS_FLOOR);
        BlEval {
            importance: (b.energy * v.cos_tp.max(COS_FLOOR) / v.d2c * brdf).min(MAX_IMPORTANCE),
            cap_integral: sc,
        }
    }

    /// The BL importance of a distant or environment light with its BRDF integral (the
    /// `cap_integral` of [`BlEval`]). A distant light of irradiance E and angular radius γ is
    /// the cap of half-angle γ about its direction: `4π E (SC / |Ω ∩ H| + defensive ·
    /// cos θi')`, with the cap integral SC of the Lambert and GGX lobes as for a cluster
    /// (the limit `f cos` in its direction below `POINT_LIMIT_SIN`, a delta direction
    /// included), so a glossy lobe facing away from a sun gives it only the defensive share and
    /// a surface facing away from it 0. The environment, of irradiance bound E_n at the
    /// normal, as a uniform environment of radiance E_n/π: `4π (E_n/π) ρ (1 + DEFENSIVE)`, ρ
    /// the whole hemisphere's ∫ f cos ([`BlImportance::albedo`]).
    #[must_use]
    pub fn eval_infinite_with_integral(&self, light: &InfiniteLight) -> BlEval {
        let four_pi = 4.0 * PI;
        match light.kind() {
            Some(InfiniteKind::Distant) => {
                let n = self.normal;
                let w = light.direction();
                let cos_omega = n.x * w.x + n.y * w.y + n.z * w.z;
                let (cos_g, sin_g) = (light.cos_radius, light.sin_radius);
                let cos_ip = math::cos_minus(cos_omega, cos_g, sin_g);
                let (sc, omega) = if self.ks > 0.0 {
                    let c = self.ggx.cap_integrals(w, sin_g);
                    (self.kd * c.lambert + self.ks * c.ggx, c.visible)
                } else {
                    let (l, vis) = lambert_pair(cos_omega, sin_g);
                    (self.kd * l, vis)
                };
                let avg = if sin_g < POINT_LIMIT_SIN {
                    self.point_value(w, cos_omega)
                } else if omega > 0.0 {
                    sc / omega
                } else {
                    0.0
                };
                if cos_ip <= -COS_SLACK {
                    return BlEval {
                        importance: 0.0,
                        cap_integral: sc,
                    };
                }
                let brdf = avg + self.defensive * cos_ip.max(COS_FLOOR);
                BlEval {
                    importance: (four_pi * light.irradiance[0] * brdf).min(MAX_IMPORTANCE),
                    cap_integral: sc,
                }
            }
            Some(InfiniteKind::Environment) => {
                let bound = light.environment_bound(self.normal, Receiver::Reflective);
                let i = four_pi * (bound * FRAC_1_PI) * (self.albedo * (1.0 + DEFENSIVE));
                BlEval {
                    importance: i.min(MAX_IMPORTANCE),
                    cap_integral: self.albedo,
                }
            }
            None => BlEval {
                importance: 0.0,
                cap_integral: 0.0,
            },
        }
    }

    /// The 4-wide twin of [`BlImportance::eval`]: `(importances, cap integrals)`.
    #[inline]
    #[must_use]
    pub fn eval4_with_integrals(&self, node: &Node4) -> (f32x4, f32x4) {
        let (w, sc, _) = self.eval4_with_lobe_integrals(node);
        (w, sc)
    }

    /// [`BlImportance::eval4_with_integrals`] plus the glossy lobe's part of each cap integral
    /// (`ks ∫ f_GGX cos`, 0 for Lambert): `(importances, cap integrals, glossy parts)`.
    #[inline]
    #[must_use]
    pub fn eval4_with_lobe_integrals(&self, node: &Node4) -> (f32x4, f32x4, f32x4) {
        let (w, sc, glossy, _) = self.eval4_core::<true>(node);
        (w, sc, glossy)
    }

    /// [`BlImportance::eval4_with_lobe_integrals`] and, per slot, `|c − x|²` and `r²` of the
    /// decoded bounding sphere ([`Node4::sphere`]), as `(c − x).length_squared()` and `r * r`
    /// give them: `(importances, cap integrals, glossy parts, [|c − x|², r²])`.
    #[inline(always)]
    pub(crate) fn eval4_for_cut(&self, node: &Node4) -> (f32x4, f32x4, f32x4, [f32x4; 2]) {
        self.eval4_core::<true>(node)
    }

    /// The 4-wide twin of [`BlImportance::point_value`].
    #[inline(always)]
    fn point_value4(&self, wx: f32x4, wy: f32x4, wz: f32x4, cos_omega: f32x4) -> f32x4 {
        let l = &self.lanes;
        let v = l.kd * cos_omega;
        let v = if self.ks > 0.0 {
            v + l.ks * l.ggx.lobe(wx, wy, wz)
        } else {
            v
        };
        cos_omega.simd_le(f32x4::ZERO).select(f32x4::ZERO, v)
    }

    /// What every 4-wide evaluation starts from: the view of the node's slots, cos θi = n·ω
    /// of their directions, cos θi' (1 inside a sphere) and the live lanes (emitting towards
    /// x, and θi' short of the horizon by `COS_SLACK`).
    #[inline(always)]
    fn view4(&self, node: &Node4) -> (ClusterView4, f32x4, f32x4, f32x4) {
        let one = f32x4::ONE;
        let l = &self.lanes;
        let v = ClusterView4::new(self.position, node);
        let cos_omega = l.nx * v.wx + l.ny * v.wy + l.nz * v.wz;
        let sin_i = (one - cos_omega * cos_omega).fast_max(f32x4::ZERO).sqrt();
        let cos_ip = cos_omega
            .simd_ge(v.cos_u)
            .select(one, cos_omega * v.cos_u + sin_i * v.sin_u);
        let cos_ip = v.inside.select(one, cos_ip);
        let live = v.emits & cos_ip.simd_gt(f32x4::splat(-COS_SLACK));
        (v, cos_omega, cos_ip, live)
    }

    /// The factor of the importance before the BRDF: `E · max(cos θ', COS_FLOOR) / d²`.
    #[inline(always)]
    fn emitted4(node: &Node4, v: &ClusterView4) -> f32x4 {
        node.energy4() * v.cos_tp.fast_max(f32x4::splat(COS_FLOOR)) / v.d2c
    }

    /// The slots of `node` (bit k for slot k) whose importance ([`Importance::eval4`]) is
    /// certainly positive, found without the cap integrals. A live slot's importance is
    /// `min(p · B, MAX_IMPORTANCE)` with `p` [`BlImportance::emitted4`] and `B = avg +
    /// defensive · max(cos θi', COS_FLOOR) ≥ defensive · COS_FLOOR` (the cap average is never
    /// negative, and products and sums of non-negative numbers round monotonically), so it is
    /// positive where `p · defensive · COS_FLOOR` is; slots for which that bound underflows or
    /// is not a number are left out. A subset of the positive slots, never more.
    #[inline(always)]
    pub(crate) fn surely_positive4(&self, node: &Node4) -> u32 {
        let (v, _, _, live) = self.view4(node);
        let bound = Self::emitted4(node, &v) * (self.lanes.defensive * f32x4::splat(COS_FLOOR));
        (live & bound.simd_gt(f32x4::ZERO)).to_bitmask()
    }

    /// The body of the 4-wide evaluations: `(importances, cap integrals, glossy parts,
    /// [|c − x|², r²] of the decoded spheres)`. With
    /// `INTEGRALS` false only the importances are asked for, and the cap integrals are
    /// computed only where an importance depends on them (lanes that take the point limit
    /// or are not live do not): the other two results then have no meaning, and the
    /// importances are bit for bit those of `INTEGRALS` true.
    #[inline(always)]
    fn eval4_core<const INTEGRALS: bool>(&self, node: &Node4) -> (f32x4, f32x4, f32x4, [f32x4; 2]) {
        let zero = f32x4::ZERO;
        let one = f32x4::ONE;
        let l = &self.lanes;
        let (v, cos_omega, cos_ip, live) = self.view4(node);
        let sin_sigma = v.inside.select(one, v.sin_u);
        let small = sin_sigma.simd_lt(f32x4::splat(POINT_LIMIT_SIN));
        // The lanes whose importance takes the cap average (all of them for the integrals).
        let needed = if INTEGRALS { ALL_LANES } else { live & !small };
        let (sc, glossy, avg) = if !INTEGRALS && !needed.any() {
            (zero, zero, zero)
        } else {
            let (sc, glossy, omega) = if self.ks > 0.0 {
                let c = l.ggx.cap_integrals(v.wx, v.wy, v.wz, sin_sigma, needed);
                let glossy = l.ks * c.ggx;
                (l.kd * c.lambert + glossy, glossy, c.visible)
            } else {
                let (lam, vis) = lambert_pair4(cos_omega, sin_sigma, needed);
                (l.kd * lam, zero, vis)
            };
            (sc, glossy, omega.simd_gt(zero).select(sc / omega, zero))
        };
        let avg = if small.any() {
            small.select(self.point_value4(v.wx, v.wy, v.wz, cos_omega), avg)
        } else {
            avg
        };
        let avg = avg & avg.simd_ge(zero);
        let floor = f32x4::splat(COS_FLOOR);
        let brdf = avg + l.defensive * cos_ip.fast_max(floor);
        let value = (Self::emitted4(node, &v) * brdf).fast_min(f32x4::splat(MAX_IMPORTANCE));
        (live.select(value, zero), sc, glossy, [v.d2, v.r2])
    }
}

impl Importance for BlImportance {
    #[inline]
    fn eval4(&self, node: &Node4) -> f32x4 {
        self.eval4_core::<false>(node).0
    }

    /// The importance of [`BlImportance::eval`]. Lane `k` of `eval4` equals it within `1e-4`
    /// relative plus `1e-37` absolute: the same operations, but through the ill-conditioned
    /// area of the lens of a cap straddling the horizon, which amplifies a single legitimately
    /// different rounding.
    #[inline]
    fn eval_slot(&self, b: &SlotBounds) -> f32 {
        self.eval(b).importance
    }

    /// [`BlImportance::eval_infinite_with_integral`]'s importance.
    #[inline]
    fn eval_infinite(&self, light: &InfiniteLight) -> f32 {
        self.eval_infinite_with_integral(light).importance
    }
}
