//! Importons: the camera-ray hit points through which a VPL candidate's image contribution is
//! estimated (Georgiev & Slusallek 2010, section 3.3), four to an f32x4 in each field.

use super::{check_position, err, unit, Visibility};
use crate::brdf::{Brdf, Frame};
use crate::error::{Problem, VplError, VplField};
use crate::material::Material;
use crate::math;
use alloc::vec::Vec;
use core::f32::consts::FRAC_1_PI;
use glam::Vec3;
use wide::f32x4;

/// The paper's number of importons per frame, N_C = 100.
pub const DEFAULT_IMPORTONS: usize = 100;

/// An importon with a glossy lobe: its BRDF needs the view direction, evaluated per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Lobe {
    /// Index of the importon.
    index: usize,
    material: Material,
    frame: Frame,
    /// ωo in the local frame (unit, above the horizon).
    wo: Vec3,
}

/// The importons of one frame, structure of arrays (position, unit normal, diffuse BRDF value
/// `albedo/π`), four per f32x4; lanes past the last importon, and importons whose camera ray
/// missed ([`Importons::push_miss`]), contribute 0 but count in N_C.
///
/// The count N_C ([`Importons::len`]) is the host's choice: [`DEFAULT_IMPORTONS`] as in the
/// paper. An importon is diffuse ([`Importons::push_diffuse`]) or carries one of the core's
/// materials with its view direction ωo ([`Importons::push`]); the 4-wide evaluation covers
/// the diffuse lobe, and a block holding a glossy importon evaluates that lane's BRDF on its own.
#[derive(Clone, Debug, Default)]
pub struct Importons {
    px: Vec<f32x4>,
    py: Vec<f32x4>,
    pz: Vec<f32x4>,
    nx: Vec<f32x4>,
    ny: Vec<f32x4>,
    nz: Vec<f32x4>,
    /// albedo/π for a diffuse importon; 0 for a glossy one (see `lobes`), a miss or padding.
    kd: Vec<f32x4>,
    /// The glossy importons, by increasing index.
    lobes: Vec<Lobe>,
    len: usize,
}

/// Lane `lane` of `v` set to `x`.
fn with_lane(v: f32x4, lane: usize, x: f32) -> f32x4 {
    let mut a = v.to_array();
    a[lane] = x;
    f32x4::new(a)
}

impl Importons {
    /// No importons.
    #[must_use]
    pub fn new() -> Importons {
        Importons::default()
    }

    /// No importons, with room for `n` without reallocating.
    #[must_use]
    pub fn with_capacity(n: usize) -> Importons {
        let blocks = n.div_ceil(4);
        let v = || Vec::with_capacity(blocks);
        Importons {
            px: v(),
            py: v(),
            pz: v(),
            nx: v(),
            ny: v(),
            nz: v(),
            kd: v(),
            lobes: Vec::new(),
            len: 0,
        }
    }

    /// Removes every importon (keeps the storage, for the next frame).
    pub fn clear(&mut self) {
        for v in [
            &mut self.px,
            &mut self.py,
            &mut self.pz,
            &mut self.nx,
            &mut self.ny,
            &mut self.nz,
            &mut self.kd,
        ] {
            v.clear();
        }
        self.lobes.clear();
        self.len = 0;
    }

    /// N_C: the importons stored, misses included.
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there is none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Number of f32x4 blocks (`len` rounded up to a multiple of 4, over 4).
    #[must_use]
    pub fn blocks(&self) -> usize {
        self.px.len()
    }

    /// Position of importon `j` (`j < len`).
    #[must_use]
    pub fn position(&self, j: usize) -> Vec3 {
        let (b, l) = (j / 4, j % 4);
        Vec3::new(
            self.px[b].to_array()[l],
            self.py[b].to_array()[l],
            self.pz[b].to_array()[l],
        )
    }

    fn push_raw(&mut self, p: Vec3, n: Vec3, kd: f32) {
        let lane = self.len % 4;
        if lane == 0 {
            for v in [
                &mut self.px,
                &mut self.py,
                &mut self.pz,
                &mut self.nx,
                &mut self.ny,
                &mut self.nz,
                &mut self.kd,
            ] {
                v.push(f32x4::ZERO);
            }
        }
        let b = self.px.len() - 1;
        self.px[b] = with_lane(self.px[b], lane, p.x);
        self.py[b] = with_lane(self.py[b], lane, p.y);
        self.pz[b] = with_lane(self.pz[b], lane, p.z);
        self.nx[b] = with_lane(self.nx[b], lane, n.x);
        self.ny[b] = with_lane(self.ny[b], lane, n.y);
        self.nz[b] = with_lane(self.nz[b], lane, n.z);
        self.kd[b] = with_lane(self.kd[b], lane, kd);
        self.len += 1;
    }

    /// Adds a diffuse importon: camera-ray hit at `position`, surface `normal` (need not be
    /// unit length; the side facing the camera), diffuse `albedo` in [0, 1] (f = albedo/π).
    pub fn push_diffuse(
        &mut self,
        position: Vec3,
        normal: Vec3,
        albedo: f32,
    ) -> Result<(), VplError> {
        check_position(VplField::ImportonPosition, position)?;
        let n = unit(VplField::ImportonNormal, normal)?;
        check_unit_range(albedo)?;
        self.push_raw(position, n, albedo * FRAC_1_PI);
        Ok(())
    }

    /// Adds an importon with one of the core's materials, seen from the direction `wo`
    /// (towards the camera, need not be unit length). A diffuse-only material takes the 4-wide
    /// path; one with a glossy lobe is evaluated in its lane by [`Brdf::eval`].
    pub fn push(
        &mut self,
        position: Vec3,
        normal: Vec3,
        wo: Vec3,
        material: Material,
    ) -> Result<(), VplError> {
        check_position(VplField::ImportonPosition, position)?;
        let n = unit(VplField::ImportonNormal, normal)?;
        let wo = unit(VplField::ImportonWo, wo)?;
        let (albedo, specular, alpha) = material.lobes();
        check_unit_range(albedo)?;
        check_unit_range(specular)?;
        if !(alpha > 0.0 && alpha <= 1.0) {
            return Err(err(VplField::ImportonMaterial, Problem::OutOfRange, alpha));
        }
        if material.is_diffuse_only() {
            self.push_raw(position, n, albedo * FRAC_1_PI);
            return Ok(());
        }
        // Unit, finite normal: the frame exists.
        let frame =
            Frame::from_normal(n).ok_or(err(VplField::ImportonNormal, Problem::ZeroLength, 0.0))?;
        self.lobes.push(Lobe {
            index: self.len,
            material,
            frame,
            wo: frame.to_local(wo),
        });
        self.push_raw(position, n, 0.0);
        Ok(())
    }

    /// Adds a camera sample whose ray hit nothing: it contributes 0 and counts in N_C.
    pub fn push_miss(&mut self) {
        self.push_raw(Vec3::ZERO, Vec3::Z, 0.0);
    }

    /// The unoccluded contributions `f · G · I` of the VPL at `y` with unit normal `m` and
    /// intensity `intensity` to the four importons of block `b`, G clamped to `g_max`. The
    /// scalar twin is [`Importons::contribution`]; lanes agree to the bit.
    #[must_use]
    pub fn contribution4(&self, b: usize, y: Vec3, m: Vec3, intensity: f32, g_max: f32) -> f32x4 {
        let zero = f32x4::ZERO;
        let dx = f32x4::splat(y.x) - self.px[b];
        let dy = f32x4::splat(y.y) - self.py[b];
        let dz = f32x4::splat(y.z) - self.pz[b];
        let d2 = dx * dx + dy * dy + dz * dz;
        let cos_x = (self.nx[b] * dx + self.ny[b] * dy + self.nz[b] * dz).max(zero);
        let cos_y =
            (-(f32x4::splat(m.x) * dx + f32x4::splat(m.y) * dy + f32x4::splat(m.z) * dz)).max(zero);
        let den = (d2 * d2).max(f32x4::splat(f32::MIN_POSITIVE));
        let g = ((cos_x * cos_y) / den).min(f32x4::splat(g_max));
        // (f · G) · I, not f · (G · I): G · I may overflow to +∞ (G reaches ~1e19 a nanometre
        // from an importon), and a miss's or a glossy lane's f = 0 must then give 0, not NaN.
        let i = f32x4::splat(intensity);
        let mut c = (self.kd[b] * g) * i;
        // Glossy lanes: their BRDF, one lane at a time.
        let first = self.lobes.partition_point(|l| l.index < 4 * b);
        for lobe in self.lobes[first..]
            .iter()
            .take_while(|l| l.index < 4 * b + 4)
        {
            let lane = lobe.index % 4;
            let f = lobe_f(lobe, y, self.position(lobe.index));
            c = with_lane(c, lane, (f * g.to_array()[lane]) * intensity);
        }
        c
    }

    /// The unoccluded contribution `f · G · I` of the VPL at `y` (unit normal `m`, intensity
    /// `intensity`) to importon `j`, G clamped to `g_max`: the scalar twin of
    /// [`Importons::contribution4`]. 0 for a miss or `j ≥ len`.
    #[must_use]
    pub fn contribution(&self, j: usize, y: Vec3, m: Vec3, intensity: f32, g_max: f32) -> f32 {
        if j >= self.len {
            return 0.0;
        }
        let (b, l) = (j / 4, j % 4);
        let lane = |v: &Vec<f32x4>| v[b].to_array()[l];
        let (dx, dy, dz) = (
            y.x - lane(&self.px),
            y.y - lane(&self.py),
            y.z - lane(&self.pz),
        );
        let d2 = dx * dx + dy * dy + dz * dz;
        let cos_x = (lane(&self.nx) * dx + lane(&self.ny) * dy + lane(&self.nz) * dz).max(0.0);
        let cos_y = (-(m.x * dx + m.y * dy + m.z * dz)).max(0.0);
        let den = (d2 * d2).max(f32::MIN_POSITIVE);
        let g = ((cos_x * cos_y) / den).min(g_max);
        // (f · G) · I, as the 4-wide form (see there).
        match self.lobes.binary_search_by_key(&j, |l| l.index) {
            Ok(k) => (lobe_f(&self.lobes[k], y, self.position(j)) * g) * intensity,
            Err(_) => (lane(&self.kd) * g) * intensity,
        }
    }

    /// Σ_j V_ij · c_ij over every importon, for the candidate at `y` (unit normal `m`): the
    /// 4-wide contributions, then the host's visibility test for the lanes that contribute.
    /// With visibility, stops early (returning a partial sum) once `enough(partial sum)` holds;
    /// `enough` must be monotone, so that it then holds for the whole sum too.
    pub(crate) fn total<V: Visibility + ?Sized>(
        &self,
        y: Vec3,
        m: Vec3,
        intensity: f32,
        g_max: f32,
        visibility: Option<&mut V>,
        enough: impl Fn(f32) -> bool,
    ) -> f32 {
        let mut sum = f32x4::ZERO;
        match visibility {
            None => {
                for b in 0..self.blocks() {
                    sum += self.contribution4(b, y, m, intensity, g_max);
                }
            }
            Some(vis) => {
                for b in 0..self.blocks() {
                    let mut c = self.contribution4(b, y, m, intensity, g_max).to_array();
                    for (lane, v) in c.iter_mut().enumerate() {
                        if *v > 0.0 && !vis.visible(self.position(4 * b + lane), y) {
                            *v = 0.0;
                        }
                    }
                    sum += f32x4::new(c);
                    let partial = sum.reduce_add();
                    if enough(partial) {
                        return partial; // the rest cannot change the decision
                    }
                }
            }
        }
        sum.reduce_add()
    }
}

/// The BRDF value of a glossy importon at `x` for light arriving from the VPL at `y`.
fn lobe_f(lobe: &Lobe, y: Vec3, x: Vec3) -> f32 {
    let wi = math::normalize_or_zero(y - x);
    lobe.material.eval(lobe.wo, lobe.frame.to_local(wi))
}

fn check_unit_range(v: f32) -> Result<(), VplError> {
    if !v.is_finite() {
        return Err(err(VplField::ImportonMaterial, Problem::NotFinite, v));
    }
    if !(0.0..=1.0).contains(&v) {
        return Err(err(VplField::ImportonMaterial, Problem::OutOfRange, v));
    }
    Ok(())
}
