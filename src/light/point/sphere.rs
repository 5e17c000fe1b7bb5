//! Sphere lights.
//!
//! From outside, the visible cap is sampled uniformly in solid angle (the cone of half-angle
//! θmax with sin θmax = R/d around the direction to the centre; Shirley, Wang, Zimmerman,
//! "Monte Carlo Techniques for Direct Lighting Calculations", 1996): pdf = 1 / (2π(1 − cos θmax)),
//! the same for every point of the cap. `1 − cos θmax` is computed as
//! `sin²θmax / (1 + cos θmax)` and the distance to the sampled point without cancellation, so
//! that caps of any size keep an exact pdf.
//!
//! From inside or on the surface there is no cap: points are sampled uniformly by area over the
//! whole sphere and converted with `p_ω = d² / (A |cos θy|)`. The sphere emits outwards only, so
//! from strictly inside every sample carries zero radiance (the sphere is dark from inside).

use super::vec64::V64;
use super::LightPoint;
use crate::colour::Rgb;
use crate::math;
use core::f64::consts::PI;
use glam::Vec3;

/// Where x is: outside (with the cone of the cap), or inside / on the sphere.
enum View {
    Outside {
        /// Unit direction x → centre.
        axis: V64,
        /// Distance x → centre.
        dc: f64,
        /// 1 − cos θmax.
        omc_max: f64,
    },
    Inside,
}

fn view(center: V64, radius: f64, x: V64) -> View {
    let v = center - x;
    let dc2 = v.length_squared();
    let r2 = radius * radius;
    if dc2 > r2 {
        let dc = math::sqrt64(dc2);
        let sin2 = r2 / dc2;
        View::Outside {
            axis: v * (1.0 / dc),
            dc,
            omc_max: sin2 / (1.0 + math::sqrt64(1.0 - sin2)),
        }
    } else {
        View::Inside
    }
}

fn cap_pdf(omc_max: f64) -> f64 {
    1.0 / (2.0 * PI * omc_max)
}

pub(super) fn sample(
    center: Vec3,
    radius: f32,
    radiance: Rgb,
    x: Vec3,
    u: [f64; 2],
) -> Option<LightPoint> {
    let (c, r, xv) = (V64::from_f32(center), f64::from(radius), V64::from_f32(x));
    match view(c, r, xv) {
        View::Outside { axis, dc, omc_max } => {
            let omc = u[0] * omc_max;
            let cos = 1.0 - omc;
            let sin = math::sqrt64((omc * (2.0 - omc)).max(0.0));
            let (t, b) = axis.basis();
            let (sp, cp) = math::sin_cos64(2.0 * PI * u[1]);
            let w = (axis * cos + (t * cp + b * sp) * sin).normalize()?;
            // R² − dc² sin²θ = dc² (sin²θmax − sin²θ), written without cancellation.
            let disc = omc_max * (1.0 - u[0]) * (2.0 - omc_max * (1.0 + u[0]));
            let dist = dc * (cos - math::sqrt64(disc.max(0.0)));
            let p = xv + w * dist;
            let n = (p - c).normalize().unwrap_or(-axis);
            let pf = p.to_f32();
            // x on the sphere (to rounding): the point under x has no finite density.
            if pf == x {
                return None;
            }
            LightPoint::checked(
                pf,
                math::normalize(n.to_f32()),
                math::normalize(w.to_f32()),
                dist as f32,
                cap_pdf(omc_max) as f32,
                false,
                radiance,
            )
        }
        View::Inside => {
            let z = 1.0 - 2.0 * u[0];
            let s = math::sqrt64((1.0 - z * z).max(0.0));
            let (sp, cp) = math::sin_cos64(2.0 * PI * u[1]);
            let n = V64::new(s * cp, s * sp, z);
            let p = (c + n * r).to_f32();
            at_point_inside(c, r, radiance, xv, p)
        }
    }
}

/// The light point at `p` (on the sphere) seen from x inside or on the sphere.
fn at_point_inside(c: V64, r: f64, radiance: Rgb, x: V64, p: Vec3) -> Option<LightPoint> {
    let pv = V64::from_f32(p);
    let d = pv - x;
    let dist = d.length();
    let w = d.normalize()?;
    let n = (pv - c).normalize()?;
    let cos_y = -n.dot(w);
    let area = 4.0 * PI * r * r;
    let pdf = dist * dist / (area * cos_y.abs());
    let l = if cos_y > 0.0 { radiance } else { Rgb::ZERO };
    LightPoint::checked(
        p,
        math::normalize(n.to_f32()),
        math::normalize(w.to_f32()),
        dist as f32,
        pdf as f32,
        false,
        l,
    )
}

/// The pdf of a point `p` of the sphere (the first hit of the ray x → p).
pub(super) fn pdf_point(center: Vec3, radius: f32, x: Vec3, p: Vec3) -> f64 {
    let (c, r, xv) = (V64::from_f32(center), f64::from(radius), V64::from_f32(x));
    match view(c, r, xv) {
        // Every point of the sphere is reached through the cap.
        View::Outside { omc_max, .. } => {
            if V64::from_f32(p) == xv {
                0.0
            } else {
                cap_pdf(omc_max)
            }
        }
        View::Inside => at_point_inside(c, r, Rgb::ZERO, xv, p).map_or(0.0, |lp| f64::from(lp.pdf)),
    }
}

/// The point where the ray from x along the unit `w` first leaves x's side of the sphere, with
/// its pdf and radiance.
pub(super) fn intersect(
    center: Vec3,
    radius: f32,
    radiance: Rgb,
    x: Vec3,
    w: V64,
) -> Option<LightPoint> {
    let (c, r, xv) = (V64::from_f32(center), f64::from(radius), V64::from_f32(x));
    let v = c - xv;
    let b = w.dot(v);
    // Squared distance from the centre to the ray's line, computed directly (no cancellation).
    let perp2 = (v - w * b).length_squared();
    let r2 = r * r;
    let hits = perp2 <= r2;
    if !hits {
        return None;
    }
    let h = math::sqrt64(r2 - perp2);
    match view(c, r, xv) {
        View::Outside { omc_max, .. } => {
            let ahead = b > 0.0;
            if !ahead {
                return None;
            }
            let dist = b - h;
            let p = xv + w * dist;
            let n = (p - c).normalize()?;
            LightPoint::checked(
                p.to_f32(),
                math::normalize(n.to_f32()),
                math::normalize(w.to_f32()),
                dist as f32,
                cap_pdf(omc_max) as f32,
                false,
                radiance,
            )
        }
        View::Inside => {
            let dist = b + h;
            let ahead = dist > 0.0;
            if !ahead {
                return None;
            }
            at_point_inside(c, r, radiance, xv, (xv + w * dist).to_f32())
        }
    }
}
