//! Triangle lights: spherical-triangle sampling (Arvo, "Stratified Sampling of Spherical
//! Triangles", SIGGRAPH 1995) where the triangle subtends a solid angle Ω of at least
//! [`MIN_SPHERICAL_SOLID_ANGLE`], uniform area sampling (converted with `p_ω = d²/(A |cos θy|)`)
//! below it.
//!
//! Spherical sampling has a constant pdf 1/Ω, so the estimate of a triangle that fills much of
//! the hemisphere (a close or large emitter) is not spoilt by the `d²/cos θy` factor of area
//! sampling, which is unbounded near the triangle and at grazing angles; a spherical sample
//! costs about twice an area one. Below [`MIN_SPHERICAL_SOLID_ANGLE`] both estimates are nearly
//! exact, so the cheaper area sampling is used there (docs/measurements.md has the variances
//! behind the threshold). The choice depends on x and the light only, so
//! [`sample_point`](super::sample_point) and [`pdf_point`](super::pdf_point) always agree on it.
//!
//! Ω comes from the formula of Van Oosterom & Strackee ("The Solid Angle of a Plane Triangle",
//! 1983), `tan(Ω/2) = |a·(b×c)| / (1 + a·b + b·c + c·a)`, which keeps its precision for small
//! triangles; the spherical construction runs in f64. x exactly in the triangle's plane and
//! zero-area triangles give no sample (pdf 0).

use super::vec64::V64;
use super::LightPoint;
use crate::colour::Rgb;
use crate::math;
use glam::Vec3;

/// Solid angle (sr) from which a triangle is sampled by solid angle rather than by area.
pub const MIN_SPHERICAL_SOLID_ANGLE: f64 = 1e-3;

/// How a triangle is sampled from a given x.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Mode {
    /// Uniform in the spherical triangle of the unit directions a, b, c of solid angle `omega`.
    Spherical { a: V64, b: V64, c: V64, omega: f64 },
    /// Uniform in area.
    Area { area: f64 },
}

/// The triangle as seen from x.
#[derive(Clone, Copy, Debug)]
pub(crate) struct View {
    v0: V64,
    e1: V64,
    e2: V64,
    /// Unit normal along (v1 − v0) × (v2 − v0).
    n: V64,
    /// n · (x − v0): which side x is on (never 0).
    side: f64,
    pub mode: Mode,
}

/// `None` for a zero-area triangle or x in its plane.
pub(crate) fn view(vertices: &[Vec3; 3], x: Vec3, spherical: Option<bool>) -> Option<View> {
    let v = vertices.map(V64::from_f32);
    let xv = V64::from_f32(x);
    let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
    let nn = e1.cross(e2);
    let n = nn.normalize()?;
    let side = n.dot(xv - v[0]);
    if !(side != 0.0 && side.is_finite()) {
        return None;
    }
    let a = (v[0] - xv).normalize()?;
    let b = (v[1] - xv).normalize()?;
    let c = (v[2] - xv).normalize()?;
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    let omega = 2.0 * math::atan2_64(num, den);
    let use_spherical = spherical.unwrap_or(omega >= MIN_SPHERICAL_SOLID_ANGLE);
    let mode = if use_spherical && omega > 0.0 {
        Mode::Spherical { a, b, c, omega }
    } else {
        Mode::Area {
            area: 0.5 * nn.length(),
        }
    };
    Some(View {
        v0: v[0],
        e1,
        e2,
        n,
        side,
        mode,
    })
}

impl View {
    /// A point of the triangle for `u` in [0, 1)².
    pub(crate) fn sample(&self, x: Vec3, u: [f64; 2]) -> Option<Vec3> {
        match self.mode {
            Mode::Spherical { a, b, c, omega } => {
                let w = arvo(a, b, c, omega, u)?;
                let (b1, b2) = self.barycentrics(V64::from_f32(x), w)?;
                Some((self.v0 + self.e1 * b1 + self.e2 * b2).to_f32())
            }
            Mode::Area { .. } => {
                let s = math::sqrt64(u[0]);
                let (b1, b2) = (s * (1.0 - u[1]), s * u[1]);
                Some((self.v0 + self.e1 * b1 + self.e2 * b2).to_f32())
            }
        }
    }

    /// Barycentrics (b1, b2) of the hit of the ray x + t·w with the triangle's plane, clamped
    /// into the triangle (Möller & Trumbore, "Fast, Minimum Storage Ray/Triangle
    /// Intersection", 1997).
    fn barycentrics(&self, x: V64, w: V64) -> Option<(f64, f64)> {
        let p = w.cross(self.e2);
        let det = self.e1.dot(p);
        if !(det != 0.0 && det.is_finite()) {
            return None;
        }
        let s = x - self.v0;
        let b1 = (s.dot(p) / det).clamp(0.0, 1.0);
        let b2 = (w.dot(s.cross(self.e1)) / det).clamp(0.0, 1.0);
        let sum = b1 + b2;
        if sum > 1.0 {
            Some((b1 / sum, b2 / sum))
        } else {
            Some((b1, b2))
        }
    }

    /// The light point at `p` (on the triangle) seen from x.
    pub(crate) fn at_point(
        &self,
        radiance: Rgb,
        two_sided: bool,
        x: Vec3,
        p: Vec3,
    ) -> Option<LightPoint> {
        let d = V64::from_f32(p) - V64::from_f32(x);
        let dist = d.length();
        let w = d.normalize()?;
        let pdf = match self.mode {
            Mode::Spherical { omega, .. } => 1.0 / omega,
            Mode::Area { area } => dist * dist / (area * self.n.dot(w).abs()),
        };
        let lit = two_sided || self.side > 0.0;
        let normal = if two_sided && self.side < 0.0 {
            -self.n
        } else {
            self.n
        };
        LightPoint::checked(
            p,
            math::normalize(normal.to_f32()),
            math::normalize(w.to_f32()),
            dist as f32,
            pdf as f32,
            false,
            if lit { radiance } else { Rgb::ZERO },
        )
    }

    /// The first hit of the ray x + t·w (t > 0) with the triangle.
    pub(crate) fn intersect(&self, x: Vec3, w: V64) -> Option<Vec3> {
        let xv = V64::from_f32(x);
        let p = w.cross(self.e2);
        let det = self.e1.dot(p);
        if !(det != 0.0 && det.is_finite()) {
            return None;
        }
        let s = xv - self.v0;
        let b1 = s.dot(p) / det;
        let q = s.cross(self.e1);
        let b2 = w.dot(q) / det;
        let t = self.e2.dot(q) / det;
        if !(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 && t > 0.0) {
            return None;
        }
        Some((xv + w * t).to_f32())
    }
}

/// Arvo's construction: a direction uniformly distributed in the spherical triangle (a, b, c)
/// of area `omega`. The sub-triangle (a, b, ĉ) with ĉ on the arc a–c has area u0·Ω; the
/// direction is then placed on the arc b–ĉ with `1 − cos` proportional to u1.
fn arvo(a: V64, b: V64, c: V64, omega: f64, u: [f64; 2]) -> Option<V64> {
    // Angle at vertex a between the great arcs a–b and a–c.
    let (nab, nac) = (a.cross(b), a.cross(c));
    let alpha = math::atan2_64(nab.cross(nac).length(), nab.dot(nac));
    let (sa, ca) = math::sin_cos64(alpha);
    let cos_ab = a.dot(b);
    let (s, t) = math::sin_cos64(u[0] * omega - alpha);
    let uu = t - ca;
    let vv = s + sa * cos_ab;
    let q = ((vv * t - uu * s) * ca - vv) / ((vv * s + uu * t) * sa);
    if !q.is_finite() {
        return None;
    }
    let q = q.clamp(-1.0, 1.0);
    let c_perp = (c - a * c.dot(a)).normalize()?;
    let c_hat = a * q + c_perp * math::sqrt64((1.0 - q * q).max(0.0));
    let z = 1.0 - u[1] * (1.0 - c_hat.dot(b));
    let z = z.clamp(-1.0, 1.0);
    let perp = (c_hat - b * c_hat.dot(b)).normalize()?;
    (b * z + perp * math::sqrt64((1.0 - z * z).max(0.0))).normalize()
}
