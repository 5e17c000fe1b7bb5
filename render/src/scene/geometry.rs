//! Triangles with a material each, their BVH (the `bvh` crate) for the camera's rays and the
//! shadow rays, and the mesh builders the built-in scenes share (quads, boxes, cylinders,
//! superellipsoids, tori).

use bvh::aabb::{Aabb, Bounded};
use bvh::bounding_hierarchy::BHShape;
use bvh::bvh::Bvh;
use glam::Vec3;
use manylights::Occluder;
use manylights::Rgb;
use manylights::{Light, Material};
use nalgebra::{Point3, Vector3};
use std::f32::consts::PI;

/// One triangle with its material.
#[derive(Clone, Copy, Debug)]
pub struct Triangle {
    /// Vertices.
    pub v: [Vec3; 3],
    /// Material.
    pub material: Material,
    node_index: usize,
}

impl Bounded<f32, 3> for Triangle {
    fn aabb(&self) -> Aabb<f32, 3> {
        let lo = self.v[0].min(self.v[1]).min(self.v[2]) - Vec3::splat(1e-5);
        let hi = self.v[0].max(self.v[1]).max(self.v[2]) + Vec3::splat(1e-5);
        Aabb::with_bounds(Point3::new(lo.x, lo.y, lo.z), Point3::new(hi.x, hi.y, hi.z))
    }
}

impl BHShape<f32, 3> for Triangle {
    fn set_bh_node_index(&mut self, index: usize) {
        self.node_index = index;
    }

    fn bh_node_index(&self) -> usize {
        self.node_index
    }
}

impl Triangle {
    /// The triangle `a b c` with material `material`.
    pub fn new(a: Vec3, b: Vec3, c: Vec3, material: Material) -> Triangle {
        Triangle {
            v: [a, b, c],
            material,
            node_index: 0,
        }
    }

    /// Möller–Trumbore: the distance along the ray, if it hits in (`t_min`, `t_max`).
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let e1 = self.v[1] - self.v[0];
        let e2 = self.v[2] - self.v[0];
        let p = d.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let inv = 1.0 / det;
        let s = o - self.v[0];
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = d.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = e2.dot(q) * inv;
        (t > t_min && t < t_max).then_some(t)
    }

    /// Unit geometric normal.
    pub fn normal(&self) -> Vec3 {
        (self.v[1] - self.v[0])
            .cross(self.v[2] - self.v[0])
            .normalize()
    }
}

/// The triangles and their BVH.
pub struct Geometry {
    /// The triangles.
    pub triangles: Vec<Triangle>,
    bvh: Bvh<f32, 3>,
}

impl std::fmt::Debug for Geometry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Geometry")
            .field("triangles", &self.triangles.len())
            .finish()
    }
}

/// A surface hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f32,
    /// Unit geometric normal of the triangle hit.
    pub normal: Vec3,
    /// Its material.
    pub material: Material,
}

/// Shadow rays stop this far (relative) before the light point.
const SHADOW_EPS: f32 = 1e-4;

impl Geometry {
    /// Builds the BVH (the vertices must be finite).
    pub fn new(mut triangles: Vec<Triangle>) -> Geometry {
        let bvh = Bvh::build(&mut triangles);
        Geometry { triangles, bvh }
    }

    fn ray(o: Vec3, d: Vec3) -> bvh::ray::Ray<f32, 3> {
        bvh::ray::Ray::new(Point3::new(o.x, o.y, o.z), Vector3::new(d.x, d.y, d.z))
    }

    /// The diagonal of the triangles' bounding box (0 without triangles).
    pub fn extent(&self) -> f32 {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for t in &self.triangles {
            for v in t.v {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        if lo.x <= hi.x {
            (hi - lo).length()
        } else {
            0.0
        }
    }

    /// The nearest hit along the ray from `o` along the unit `d`, beyond `t_min`.
    pub fn nearest(&self, o: Vec3, d: Vec3, t_min: f32) -> Option<Hit> {
        let ray = Self::ray(o, d);
        let mut best: Option<Hit> = None;
        for tri in self.bvh.traverse_iterator(&ray, &self.triangles) {
            let t_max = best.map_or(f32::INFINITY, |h| h.t);
            if let Some(t) = tri.intersect(o, d, t_min, t_max) {
                best = Some(Hit {
                    t,
                    normal: tri.normal(),
                    material: tri.material,
                });
            }
        }
        best
    }
}

impl Occluder for Geometry {
    fn occluded(&self, x: Vec3, d: Vec3, t: f32) -> bool {
        let ray = Self::ray(x, d);
        let t_max = t * (1.0 - SHADOW_EPS);
        self.bvh
            .traverse_iterator(&ray, &self.triangles)
            .any(|tri| tri.intersect(x, d, 0.0, t_max).is_some())
    }
}

/// Two triangles of the quad a b c d (in order around it).
pub(crate) fn quad(out: &mut Vec<Triangle>, a: Vec3, b: Vec3, c: Vec3, d: Vec3, m: Material) {
    out.push(Triangle::new(a, b, c, m));
    out.push(Triangle::new(a, c, d, m));
}

/// A box of half sizes `h` centred at `c` (bottom at `c.y - h.y`), turned by `angle` about y.
pub(crate) fn cuboid(out: &mut Vec<Triangle>, c: Vec3, h: Vec3, angle: f32, m: Material) {
    let (s, co) = angle.sin_cos();
    let p = |x: f32, y: f32, z: f32| {
        let (x, z) = (x * h.x, z * h.z);
        c + Vec3::new(co * x + s * z, y * h.y, -s * x + co * z)
    };
    let v = [
        p(-1.0, -1.0, -1.0),
        p(1.0, -1.0, -1.0),
        p(1.0, 1.0, -1.0),
        p(-1.0, 1.0, -1.0),
        p(-1.0, -1.0, 1.0),
        p(1.0, -1.0, 1.0),
        p(1.0, 1.0, 1.0),
        p(-1.0, 1.0, 1.0),
    ];
    for f in [
        [0, 1, 2, 3],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [3, 2, 6, 7],
        [0, 3, 7, 4],
        [1, 2, 6, 5],
    ] {
        quad(out, v[f[0]], v[f[1]], v[f[2]], v[f[3]], m);
    }
}

/// A grid of `nu × nv` quads over the parameter square `[0, 1]²`, mapped by `f`; `wrap_u`
/// joins the last column to the first (a closed surface of revolution).
fn grid(out: &mut Vec<Triangle>, nu: usize, nv: usize, m: Material, f: impl Fn(f32, f32) -> Vec3) {
    for i in 0..nu {
        let (u0, u1) = (i as f32 / nu as f32, (i + 1) as f32 / nu as f32);
        for j in 0..nv {
            let (v0, v1) = (j as f32 / nv as f32, (j + 1) as f32 / nv as f32);
            let (a, b, c, d) = (f(u0, v0), f(u1, v0), f(u1, v1), f(u0, v1));
            // Skip the zero-area halves at the poles.
            if (b - a).cross(c - a).length_squared() > 0.0 {
                out.push(Triangle::new(a, b, c, m));
            }
            if (c - a).cross(d - a).length_squared() > 0.0 {
                out.push(Triangle::new(a, c, d, m));
            }
        }
    }
}

/// A closed cylinder: axis from `base` along the unit `axis` for `length`, radius `radius`,
/// `segments` sides, with both caps.
pub(crate) fn cylinder(
    out: &mut Vec<Triangle>,
    base: Vec3,
    axis: Vec3,
    radius: f32,
    length: f32,
    segments: usize,
    m: Material,
) {
    let t = axis.any_orthonormal_vector();
    let b = axis.cross(t);
    let rim = |u: f32| {
        let phi = 2.0 * PI * u;
        (t * phi.cos() + b * phi.sin()) * radius
    };
    let top = base + axis * length;
    grid(out, segments, 1, m, |u, v| {
        base + rim(u) + axis * (length * v)
    });
    for k in 0..segments {
        let (u0, u1) = (k as f32 / segments as f32, (k + 1) as f32 / segments as f32);
        out.push(Triangle::new(base, base + rim(u0), base + rim(u1), m));
        out.push(Triangle::new(top, top + rim(u1), top + rim(u0), m));
    }
}

/// `sign(c) |c|^e`.
fn spow(c: f32, e: f32) -> f32 {
    c.signum() * c.abs().powf(e)
}

/// A superellipsoid `|x/hx|^p + |y/hy|^p + |z/hz|^p = 1` centred at `c`: a rounded box for
/// large `p` (4 to 10), an ellipsoid for `p = 2`. `segments` around y, `rings` from pole to
/// pole.
pub(crate) fn superellipsoid(
    out: &mut Vec<Triangle>,
    c: Vec3,
    h: Vec3,
    p: f32,
    segments: usize,
    rings: usize,
    m: Material,
) {
    let e = 2.0 / p;
    grid(out, segments, rings, m, |u, v| {
        let phi = 2.0 * PI * u;
        let theta = PI * (v - 0.5);
        let (ct, st) = (spow(theta.cos(), e), spow(theta.sin(), e));
        let (cp, sp) = (spow(phi.cos(), e), spow(phi.sin(), e));
        c + Vec3::new(h.x * ct * cp, h.y * st, h.z * ct * sp)
    });
}

/// A torus centred at `c` around the unit `axis`: ring radius `big`, tube radius `small`.
pub(crate) fn torus(
    out: &mut Vec<Triangle>,
    c: Vec3,
    axis: Vec3,
    big: f32,
    small: f32,
    (segments, sides): (usize, usize),
    m: Material,
) {
    let t = axis.any_orthonormal_vector();
    let b = axis.cross(t);
    grid(out, segments, sides, m, |u, v| {
        let (phi, psi) = (2.0 * PI * u, 2.0 * PI * v);
        let radial = t * phi.cos() + b * phi.sin();
        c + radial * (big + small * psi.cos()) + axis * (small * psi.sin())
    });
}

/// Sphere light of total power (luminance) `power` in the colour `tint` (a colour of
/// luminance 1, [`Rgb::ONE`] for grey: the radiance is `tint` times the grey radiance).
pub fn sphere_light(center: Vec3, radius: f32, power: f32, tint: Rgb) -> Light {
    Light::Sphere {
        center,
        radius,
        radiance: tint * (power / (PI * 4.0 * PI * radius * radius)),
    }
}

/// One-sided disk light facing along `normal` (unit) with total power `power` in the colour
/// `tint` (as [`sphere_light`]).
pub fn disk_light(center: Vec3, normal: Vec3, radius: f32, power: f32, tint: Rgb) -> Light {
    Light::Disk {
        center,
        normal,
        radius,
        radiance: tint * (power / (PI * PI * radius * radius)),
        two_sided: false,
    }
}
