//! Disk lights: uniform area sampling through the concentric map (Shirley & Chiu, "A
//! Low Distortion Map Between Disk and Square", 1997), converted to solid angle with
//! `p_ω = p_A · d² / |cos θy|` (the geometry factor of Liu et al. 2019, Eqn. 3),
//! `p_A = 1 / (πR²)`.
//!
//! Area sampling ignores the `cos θy / d²` variation over the disk: for x close to a large disk
//! (height h ≪ R) the relative variance of an irradiance estimate grows like R²/h², where
//! solid-angle sampling (spherical ellipses, Guillén et al. 2017) would stay bounded.
//!
//! Points seen exactly edge-on (x in the disk's plane) have no finite density: the sample is
//! `None` and their pdf 0; they carry no light anyway.

use super::vec64::V64;
use super::LightPoint;
use crate::colour::Rgb;
use crate::math;
use core::f64::consts::{FRAC_PI_4, PI};
use glam::Vec3;

/// The unit normal of a disk in f64 (the light stores it unnormalised).
fn unit_normal(normal: Vec3) -> Option<V64> {
    V64::from_f32(normal).normalize()
}

/// Shirley–Chiu concentric map of [0, 1)² onto the unit disk.
pub(crate) fn concentric(u: [f64; 2]) -> (f64, f64) {
    let (a, b) = (2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, FRAC_PI_4 * (b / a))
    } else {
        (b, 2.0 * FRAC_PI_4 - FRAC_PI_4 * (a / b))
    };
    let (s, c) = math::sin_cos64(phi);
    (r * c, r * s)
}

#[allow(clippy::too_many_arguments)] // the fields of `Light::Disk`, plus x and u
pub(super) fn sample(
    center: Vec3,
    normal: Vec3,
    radius: f32,
    radiance: Rgb,
    two_sided: bool,
    x: Vec3,
    u: [f64; 2],
) -> Option<LightPoint> {
    let n = unit_normal(normal)?;
    let (t, b) = n.basis();
    let (dx, dy) = concentric(u);
    let r = f64::from(radius);
    let p = (V64::from_f32(center) + (t * dx + b * dy) * r).to_f32();
    at_point(center, n, radius, radiance, two_sided, x, p)
}

/// The light point at `p` (on the disk) seen from x.
fn at_point(
    center: Vec3,
    n: V64,
    radius: f32,
    radiance: Rgb,
    two_sided: bool,
    x: Vec3,
    p: Vec3,
) -> Option<LightPoint> {
    let xv = V64::from_f32(x);
    let d = V64::from_f32(p) - xv;
    let dist = d.length();
    let w = d.normalize()?;
    let cos_y = n.dot(w);
    let r = f64::from(radius);
    let pdf = dist * dist / (PI * r * r * cos_y.abs());
    // x's side of the plane, decided once for the whole disk.
    let side = n.dot(xv - V64::from_f32(center));
    if side == 0.0 {
        return None;
    }
    let lit = two_sided || side > 0.0;
    let facing = if side > 0.0 { n } else { -n };
    LightPoint::checked(
        p,
        math::normalize((if two_sided { facing } else { n }).to_f32()),
        math::normalize(w.to_f32()),
        dist as f32,
        pdf as f32,
        false,
        if lit { radiance } else { Rgb::ZERO },
    )
}

pub(super) fn pdf_point(center: Vec3, normal: Vec3, radius: f32, x: Vec3, p: Vec3) -> f64 {
    unit_normal(normal)
        .and_then(|n| at_point(center, n, radius, Rgb::ZERO, true, x, p))
        .map_or(0.0, |lp| f64::from(lp.pdf))
}

#[allow(clippy::too_many_arguments)] // the fields of `Light::Disk`, plus x and the direction
pub(super) fn intersect(
    center: Vec3,
    normal: Vec3,
    radius: f32,
    radiance: Rgb,
    two_sided: bool,
    x: Vec3,
    w: V64,
) -> Option<LightPoint> {
    let n = unit_normal(normal)?;
    let c = V64::from_f32(center);
    let xv = V64::from_f32(x);
    let t = n.dot(c - xv) / n.dot(w);
    if !(t > 0.0 && t < f64::INFINITY) {
        return None;
    }
    let p = xv + w * t;
    let r = f64::from(radius);
    let on_disk = (p - c).length_squared() <= r * r;
    if !on_disk {
        return None;
    }
    at_point(center, n, radius, radiance, two_sided, x, p.to_f32())
}
