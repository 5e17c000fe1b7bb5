//! Bounded lights, shading points and materials for the targets that check sampling, so that
//! they test pdf consistency rather than overflow (the build's bad-input target takes raw
//! floats), and the values with a range of their own that the `sptd` and `vpl` targets draw.

use arbitrary::Arbitrary;
use glam::Vec3;
use manylights::Rgb;
use manylights::{Light, Material, ShadingPoint};

/// Coordinates and sizes are bounded to ±`LIMIT`.
pub const LIMIT: f32 = 100.0;

fn b(x: f32) -> f32 {
    if x.is_finite() {
        x.clamp(-LIMIT, LIMIT)
    } else {
        0.0
    }
}

fn pos(x: f32, lo: f32) -> f32 {
    b(x).abs().max(lo)
}

fn v(a: [f32; 3]) -> Vec3 {
    Vec3::new(b(a[0]), b(a[1]), b(a[2]))
}

/// A normal that is never zero.
fn n(a: [f32; 3]) -> Vec3 {
    let d = v(a);
    if d.length_squared() > 1e-6 {
        d
    } else {
        Vec3::Z
    }
}

/// A light of any kind with bounded fields.
#[derive(Arbitrary, Debug, Clone)]
pub enum BLight {
    /// Point.
    Point([f32; 3], f32),
    /// Spot.
    Spot([f32; 3], [f32; 3], f32, f32, f32),
    /// Sphere.
    Sphere([f32; 3], f32, f32),
    /// Disk.
    Disk([f32; 3], [f32; 3], f32, f32, bool),
    /// Triangle.
    Triangle([[f32; 3]; 3], f32, bool),
    /// VPL.
    Vpl([f32; 3], [f32; 3], f32),
}

impl BLight {
    /// The light.
    pub fn light(&self) -> Light {
        match *self {
            BLight::Point(p, i) => Light::Point {
                position: v(p),
                intensity: Rgb::grey(pos(i, 0.0)),
            },
            // Just under π, not π: the spot's angle as the targets have always drawn it.
            #[allow(clippy::approx_constant)]
            BLight::Spot(p, d, i, h, f) => {
                let half = pos(h, 1e-3).min(3.14);
                Light::Spot {
                    position: v(p),
                    direction: n(d),
                    intensity: Rgb::grey(pos(i, 0.0)),
                    half_angle: half,
                    falloff_start: pos(f, 0.0).min(half),
                }
            }
            BLight::Sphere(c, r, l) => Light::Sphere {
                center: v(c),
                radius: pos(r, 1e-3),
                radiance: Rgb::grey(pos(l, 0.0)),
            },
            BLight::Disk(c, d, r, l, two_sided) => Light::Disk {
                center: v(c),
                normal: n(d),
                radius: pos(r, 1e-3),
                radiance: Rgb::grey(pos(l, 0.0)),
                two_sided,
            },
            BLight::Triangle(t, l, two_sided) => Light::Triangle {
                vertices: [v(t[0]), v(t[1]), v(t[2])],
                radiance: Rgb::grey(pos(l, 0.0)),
                two_sided,
            },
            BLight::Vpl(p, d, i) => Light::Vpl {
                position: v(p),
                normal: n(d),
                intensity: Rgb::grey(pos(i, 0.0)),
            },
        }
    }
}

/// A material with parameters in range.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum BMaterial {
    /// Lambert.
    Lambert(u8),
    /// GGX.
    Ggx(u8, u8),
    /// Plastic.
    Plastic(u8, u8, u8),
}

impl BMaterial {
    /// The material.
    pub fn material(self) -> Material {
        let unit = |x: u8| f32::from(x) / 255.0;
        match self {
            BMaterial::Lambert(a) => Material::Lambert {
                albedo: Rgb::grey(unit(a)),
            },
            BMaterial::Ggx(a, s) => Material::Ggx {
                alpha: 0.01 + 0.99 * unit(a),
                specular: unit(s),
            },
            BMaterial::Plastic(a, s, r) => Material::Plastic {
                albedo: Rgb::grey(0.5 * unit(a)),
                specular: 0.5 * unit(s),
                alpha: 0.01 + 0.99 * unit(r),
            },
        }
    }
}

/// A shading point with bounded fields.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub struct BPoint {
    /// Position.
    pub position: [f32; 3],
    /// Normal.
    pub normal: [f32; 3],
    /// ωo.
    pub wo: [f32; 3],
    /// Material.
    pub material: BMaterial,
}

impl BPoint {
    /// The shading point.
    pub fn point(&self) -> ShadingPoint {
        ShadingPoint {
            position: v(self.position),
            normal: n(self.normal),
            wo: n(self.wo),
            material: self.material.material(),
        }
    }
}

/// A uniform number in [0, 1) from any f32.
pub fn unit(u: f32) -> f32 {
    if u.is_finite() {
        u.abs().fract().min(1.0 - f32::EPSILON / 2.0)
    } else {
        0.0
    }
}

/// A number: as given (any f32, NaN and ±∞ included), or `k/65535`, in [0, 1].
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Real {
    /// As given.
    Raw(f32),
    /// `k/65535`.
    Unit(u16),
}

impl Real {
    /// The number.
    pub fn value(self) -> f32 {
        match self {
            Real::Raw(x) => x,
            Real::Unit(k) => f32::from(k) / 65535.0,
        }
    }
}

/// A direction: components as given (zero, NaN, huge and tiny included), or a unit vector at
/// the polar angle `θ = a/65535 · π` from +z and the azimuth `φ = b/65536 · 2π`.
#[derive(Arbitrary, Debug, Clone, Copy)]
pub enum Dir {
    /// As given.
    Raw([f32; 3]),
    /// Polar angles `(a, b)`.
    Polar(u16, u16),
}

impl Dir {
    /// The vector.
    pub fn vector(self) -> Vec3 {
        match self {
            Dir::Raw(a) => Vec3::from_array(a),
            Dir::Polar(a, b) => {
                let theta = f32::from(a) / 65535.0 * core::f32::consts::PI;
                let phi = f32::from(b) / 65536.0 * core::f32::consts::TAU;
                Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                )
            }
        }
    }
}

/// The unit vector of `v`, normalised in f64 (so that tiny and huge vectors keep their
/// direction); `None` when `v` is zero or not finite.
pub fn unit64(v: Vec3) -> Option<Vec3> {
    let d = [v.x, v.y, v.z].map(f64::from);
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if l > 0.0 && l.is_finite() {
        Some(Vec3::new((d[0] / l) as f32, (d[1] / l) as f32, (d[2] / l) as f32).normalize())
    } else {
        None
    }
}
