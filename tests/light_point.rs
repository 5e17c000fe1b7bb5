//! A point on a chosen light: the pdf returned with a sample is the pdf queried for its point,
//! every pdf integrates to 1 over directions, the distributions are the claimed ones (χ² over
//! cells of known probability), the irradiance estimator matches closed forms and quadratures,
//! and degenerate inputs give `None` or 0, never NaN or a panic.
//!
//! Every statistical tolerance is a number of standard errors computed from the samples
//! themselves (`K_SIGMA`), plus a tiny absolute slack for f32 rounding; seeds are fixed.

mod common;

use common::{Rng, Stats};
use glam::{DVec3, Vec3};
use manylights::internals::light::LightExt;
use manylights::light::{intersect, pdf_direction, pdf_point, sample_point};
use manylights::Rgb;
use manylights::{Light, LightPoint};
use std::f64::consts::PI;

/// Tolerance of the Monte Carlo checks, in standard errors.
const K_SIGMA: f64 = 5.0;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

fn d(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

/// Orthonormal basis around a unit vector.
fn basis(n: DVec3) -> (DVec3, DVec3) {
    let t = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let t = (t - n * n.dot(t)).normalize();
    (t, n.cross(t))
}

/// Uniform direction in the cone of half-angle acos(cos_max) around the unit `axis`.
fn in_cone(rng: &mut Rng, axis: DVec3, cos_max: f64) -> DVec3 {
    let z = 1.0 - rng.f64() * (1.0 - cos_max);
    let s = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * rng.f64();
    let (t, b) = basis(axis);
    (axis * z + (t * phi.cos() + b * phi.sin()) * s).normalize()
}

fn sphere(c: [f32; 3], r: f32, l: f32) -> Light {
    Light::Sphere {
        center: Vec3::from(c),
        radius: r,
        radiance: Rgb::grey(l),
    }
}

fn disk(c: [f32; 3], n: [f32; 3], r: f32, two_sided: bool) -> Light {
    Light::Disk {
        center: Vec3::from(c),
        normal: Vec3::from(n),
        radius: r,
        radiance: Rgb::grey(1.5),
        two_sided,
    }
}

fn tri(v: [[f32; 3]; 3], two_sided: bool) -> Light {
    Light::Triangle {
        vertices: v.map(Vec3::from),
        radiance: Rgb::grey(2.0),
        two_sided,
    }
}

/// The red channel of a light's emission (the lights of these tests are grey).
fn radiance_of(l: &Light) -> f32 {
    match *l {
        Light::Sphere { radiance, .. }
        | Light::Disk { radiance, .. }
        | Light::Triangle { radiance, .. } => radiance.r,
        Light::Point { intensity, .. }
        | Light::Spot { intensity, .. }
        | Light::Vpl { intensity, .. } => intensity.r,
        Light::Distant { .. } | Light::Environment { .. } => {
            unreachable!("lights at infinity are tested in tests/infinite.rs")
        }
        _ => unimplemented!("a light kind the tests do not know"),
    }
}

/// Area lights and shading points covering every sampling branch: caps of all sizes, x inside
/// and on a sphere, disks and triangles facing, behind, oblique, grazing, close and far, both
/// triangle strategies.
fn area_cases() -> Vec<(&'static str, Light, Vec3)> {
    let o = Vec3::ZERO;
    vec![
        ("sphere, far", sphere([0.3, -0.2, 40.0], 0.5, 2.0), o),
        ("sphere, mid", sphere([1.0, 2.0, 3.0], 1.0, 2.0), o),
        ("sphere, near", sphere([0.0, 0.0, 1.01], 1.0, 2.0), o),
        ("sphere, tiny", sphere([5.0, 5.0, 5.0], 1e-4, 2.0), o),
        ("sphere, inside", sphere([0.2, 0.1, 0.3], 1.0, 2.0), o),
        (
            "disk, facing",
            disk([0.0, 0.0, 2.0], [0.0, 0.0, -1.0], 1.0, false),
            o,
        ),
        (
            "disk, oblique",
            disk([1.0, 0.5, 1.0], [-1.0, 0.2, -0.5], 0.7, false),
            o,
        ),
        (
            "disk, behind",
            disk([0.0, 0.0, 2.0], [0.0, 0.0, 1.0], 1.0, false),
            o,
        ),
        (
            "disk, two-sided",
            disk([0.0, 0.0, 2.0], [0.0, 0.0, 1.0], 1.0, true),
            o,
        ),
        (
            "disk, close",
            disk([0.3, 0.0, 0.05], [0.0, 0.0, -1.0], 1.0, true),
            o,
        ),
        (
            "disk, grazing",
            disk([3.0, 0.0, 0.05], [0.0, 0.0, -1.0], 1.0, false),
            o,
        ),
        (
            "tri, small (area)",
            tri(
                [[0.3, 0.2, 20.0], [0.6, 0.2, 20.0], [0.3, 0.5, 20.0]],
                false,
            ),
            o,
        ),
        (
            "tri, medium",
            tri([[0.3, 0.2, 3.0], [0.3, 1.2, 3.0], [1.3, 0.2, 3.0]], false),
            o,
        ),
        (
            "tri, close",
            tri(
                [[-1.0, -1.0, 0.05], [-1.0, 2.0, 0.05], [2.0, -1.0, 0.05]],
                false,
            ),
            o,
        ),
        (
            "tri, wall",
            tri([[0.2, -1.0, 0.0], [0.2, 1.0, 0.0], [0.2, -1.0, 2.0]], true),
            o,
        ),
        (
            "tri, grazing",
            tri(
                [[1.0, -1.0, 0.02], [1.0, 1.0, 0.02], [3.0, -1.0, 0.02]],
                true,
            ),
            o,
        ),
        (
            "tri, behind",
            tri([[0.3, 0.2, 3.0], [1.3, 0.2, 3.0], [0.3, 1.2, 3.0]], false),
            o,
        ),
        (
            "tri, huge coords",
            tri(
                [
                    [1e6, 1e6, 1e6 + 3.0],
                    [1e6, 1e6 + 1.0, 1e6 + 3.0],
                    [1e6 + 1.0, 1e6, 1e6 + 3.0],
                ],
                false,
            ),
            Vec3::splat(1e6),
        ),
    ]
}

/// A point inside the light's surface (centre or centroid) and its size.
fn centre_and_size(l: &Light) -> (Vec3, f32) {
    match *l {
        Light::Sphere { center, radius, .. } | Light::Disk { center, radius, .. } => {
            (center, radius)
        }
        Light::Triangle { vertices, .. } => {
            let g = (vertices[0] + vertices[1] + vertices[2]) / 3.0;
            let size = vertices
                .iter()
                .map(|v| (*v - g).length())
                .fold(0.0, f32::max);
            (g, size)
        }
        Light::Point { position, .. }
        | Light::Spot { position, .. }
        | Light::Vpl { position, .. } => (position, 0.0),
        Light::Distant { .. } | Light::Environment { .. } => {
            unreachable!("lights at infinity are tested in tests/infinite.rs")
        }
        _ => unimplemented!("a light kind the tests do not know"),
    }
}

fn assert_valid(lp: &LightPoint, x: Vec3, what: &str) {
    assert!(lp.position.is_finite(), "{what}: {lp:?}");
    assert!(lp.normal.is_finite(), "{what}: {lp:?}");
    assert!(
        (lp.direction.length() - 1.0).abs() < 1e-5,
        "{what}: direction not unit: {lp:?}"
    );
    assert!(
        lp.distance > 0.0 && lp.distance.is_finite(),
        "{what}: {lp:?}"
    );
    assert!(lp.pdf > 0.0 && lp.pdf.is_finite(), "{what}: {lp:?}");
    assert!(
        lp.radiance.r >= 0.0 && lp.radiance.is_finite(),
        "{what}: {lp:?}"
    );
    // position = x + distance·direction, up to f32 rounding of the coordinates.
    let err = (d(x) + d(lp.direction) * f64::from(lp.distance) - d(lp.position)).length();
    let scale = f64::from(lp.distance) + d(x).length() + d(lp.position).length();
    assert!(err <= 1e-5 * scale, "{what}: position off by {err}: {lp:?}");
}

/// Relative difference.
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(f64::MIN_POSITIVE)
}

// ---------------------------------------------------------------------------------------------
// Consistency of sample and pdf
// ---------------------------------------------------------------------------------------------

#[test]
fn sample_pdf_equals_pdf_point_and_pdf_direction() {
    let mut rng = Rng::new(1);
    for (name, light, x) in area_cases() {
        let (mut misses, n) = (0, 20_000);
        for i in 0..n {
            // Include the corners of the unit square.
            let u = match i {
                0 => [0.0, 0.0],
                1 => [1.0 - f32::EPSILON / 2.0, 1.0 - f32::EPSILON / 2.0],
                2 => [0.0, 1.0 - f32::EPSILON / 2.0],
                3 => [1.0 - f32::EPSILON / 2.0, 0.0],
                _ => rng.u2(),
            };
            let s = sample_point(&light, x, u).unwrap_or_else(|| panic!("{name}: no sample"));
            assert_valid(&s, x, name);
            assert!(!s.delta, "{name}");
            let q = pdf_point(&light, x, s.position);
            assert!(
                rel(f64::from(s.pdf), f64::from(q)) <= 1e-4,
                "{name}: sample pdf {} vs pdf_point {q} at u={u:?}",
                s.pdf
            );
            match intersect(&light, x, s.direction) {
                Some(h) => {
                    assert!(
                        rel(f64::from(s.pdf), f64::from(h.pdf)) <= 1e-4,
                        "{name}: sample pdf {} vs intersect {} (u={u:?})",
                        s.pdf,
                        h.pdf
                    );
                    assert_eq!(h.pdf, pdf_direction(&light, x, s.direction));
                    assert_eq!(h.radiance, s.radiance, "{name}");
                    assert!(
                        rel(f64::from(h.distance), f64::from(s.distance)) <= 1e-3,
                        "{name}: hit at {} vs sampled {}",
                        h.distance,
                        s.distance
                    );
                }
                // Only a sample on the very rim can be missed by the ray through it (f32
                // rounding of the direction): the ray through a point moved slightly inwards
                // must hit.
                None => {
                    let (centre, size) = centre_and_size(&light);
                    // 1e-3 of the way to the centre, or a few ulps of the coordinates.
                    let ulps = 64.0 * f32::EPSILON * s.position.abs().max_element() / size;
                    let inner = s.position + (centre - s.position) * ulps.clamp(1e-3, 0.5);
                    assert!(
                        intersect(&light, x, inner - x).is_some(),
                        "{name}: a sample away from the rim is missed: {s:?}"
                    );
                    misses += 1;
                }
            }
        }
        // Coordinates of 1e6 quantise a unit triangle's points to 1/16: more rim samples.
        let allowed = if name.contains("huge") {
            n / 10
        } else {
            n / 100
        };
        assert!(
            misses <= allowed,
            "{name}: {misses} sampled directions miss the light"
        );
    }
}

#[test]
fn radiance_and_normals_follow_sidedness() {
    let mut rng = Rng::new(2);
    for (name, light, x) in area_cases() {
        let l = radiance_of(&light);
        for _ in 0..2000 {
            let s = sample_point(&light, x, rng.u2()).unwrap();
            let expected = match (name, &light) {
                ("sphere, inside", _) => 0.0,
                (_, Light::Sphere { .. }) => l,
                (_, Light::Disk { two_sided, .. }) | (_, Light::Triangle { two_sided, .. }) => {
                    // Lit iff two-sided or x on the emitting side of the plane.
                    let facing = s.normal.dot(s.direction) < 0.0;
                    if *two_sided {
                        assert!(facing, "{name}: two-sided normal must face x: {s:?}");
                    }
                    if *two_sided || facing {
                        l
                    } else {
                        0.0
                    }
                }
                _ => unreachable!(),
            };
            assert_eq!(s.radiance, expected.into(), "{name}: {s:?}");
            assert!((s.normal.length() - 1.0).abs() < 1e-5, "{name}: {s:?}");
        }
    }
    // The behind cases are dark, the facing ones lit.
    let cases = area_cases();
    let find = |n: &str| cases.iter().find(|c| c.0 == n).unwrap();
    for (n, lit) in [
        ("disk, behind", false),
        ("tri, behind", false),
        ("disk, facing", true),
        ("tri, medium", true),
    ] {
        let (_, light, x) = find(n);
        let s = sample_point(light, *x, [0.4, 0.6]).unwrap();
        assert_eq!(s.radiance.r > 0.0, lit, "{n}");
    }
}

// ---------------------------------------------------------------------------------------------
// Normalisation
// ---------------------------------------------------------------------------------------------

/// ∫ pdf_direction dω = 1, estimated with directions uniform in a cone holding the light (the
/// bounding sphere's cap, or the whole sphere when x is inside it).
#[test]
fn pdf_direction_integrates_to_one() {
    let mut rng = Rng::new(3);
    for (name, light, x) in area_cases() {
        let b = light.bounds().sphere;
        let v = d(b.center) - d(x);
        let dist = v.length();
        let r = f64::from(b.radius) * 1.001;
        let (axis, cos_max) = if dist > r * 1.0001 {
            (v / dist, (1.0 - (r / dist).powi(2)).sqrt())
        } else {
            (DVec3::Z, -1.0)
        };
        let q = 1.0 / (2.0 * PI * (1.0 - cos_max));
        let mut st = Stats::default();
        for _ in 0..200_000 {
            let w = in_cone(&mut rng, axis, cos_max);
            st.add(f64::from(pdf_direction(&light, x, w.as_vec3())) / q);
        }
        let (m, se) = (st.mean(), st.se());
        // The tiny sphere's cap is ~200 f32 ulps of direction across: rounding the query
        // directions to f32 alone loses 6e-4 of it (measured against an f64 hit test).
        let slack = if name.contains("tiny") { 2e-3 } else { 1e-4 };
        assert!(
            (m - 1.0).abs() <= K_SIGMA * se + slack,
            "{name}: ∫pdf = {m} ± {se}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Distributions: χ² over cells of known probability
// ---------------------------------------------------------------------------------------------

/// Pearson's χ² of `observed` against `expected` counts (cells with fewer than 5 expected
/// merged into one), and whether it is below the Wilson–Hilferty quantile at z = 4.
fn chi2_ok(observed: &[u64], expected: &[f64]) -> (bool, f64, f64) {
    let (mut chi2, mut k) = (0.0, 0usize);
    let (mut small_o, mut small_e) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < 5.0 {
            small_o += o as f64;
            small_e += e;
        } else {
            chi2 += (o as f64 - e).powi(2) / e;
            k += 1;
        }
    }
    if small_e > 0.0 {
        chi2 += (small_o - small_e).powi(2) / small_e.max(1.0);
        k += 1;
    }
    let dof = (k - 1) as f64;
    let z = 4.0;
    let a = 2.0 / (9.0 * dof);
    let crit = dof * (1.0 - a + z * a.sqrt()).powi(3);
    (chi2 <= crit, chi2, crit)
}

/// Solid angle of the triangle (a, b, c) seen from the origin (Van Oosterom & Strackee).
fn solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (a, b, c) = (a.normalize(), b.normalize(), c.normalize());
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// Triangle samples fall into the 4^levels midpoint-subdivision cells with probability
/// proportional to each cell's solid angle (spherical sampling) or area (area sampling).
#[test]
fn triangle_samples_are_distributed_as_claimed() {
    let mut rng = Rng::new(4);
    let levels = 3; // 64 cells
    for (name, light, x) in area_cases() {
        let Light::Triangle { vertices, .. } = light else {
            continue;
        };
        if name.contains("huge") {
            continue; // points are quantised to 1/16 there: too coarse for 64 cells
        }
        let v = vertices.map(|p| d(p) - d(x));
        let omega = solid_angle(v[0], v[1], v[2]);
        let spherical = omega >= manylights::internals::light_point::MIN_SPHERICAL_SOLID_ANGLE;
        // Cells in barycentric (b1, b2) coordinates: an m×m grid of upward and downward
        // triangles, m = 2^levels.
        let m = 1usize << levels;
        let mut cells = Vec::new();
        for i in 0..m {
            for j in 0..m - i {
                cells.push([(i, j), (i + 1, j), (i, j + 1)]);
                if i + j + 1 < m {
                    cells.push([(i + 1, j), (i + 1, j + 1), (i, j + 1)]);
                }
            }
        }
        let at = |(i, j): (usize, usize)| {
            v[0] + (v[1] - v[0]) * (i as f64 / m as f64) + (v[2] - v[0]) * (j as f64 / m as f64)
        };
        let weights: Vec<f64> = cells
            .iter()
            .map(|c| {
                let (a, b, cc) = (at(c[0]), at(c[1]), at(c[2]));
                if spherical {
                    solid_angle(a, b, cc)
                } else {
                    (b - a).cross(cc - a).length()
                }
            })
            .collect();
        let total: f64 = weights.iter().sum();
        let n = 200_000u64;
        let mut counts = vec![0u64; cells.len()];
        let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
        let (a11, a12, a22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        for _ in 0..n {
            let s = sample_point(&light, x, rng.u2()).unwrap();
            let p = d(s.position) - d(x) - v[0];
            let (r1, r2) = (p.dot(e1), p.dot(e2));
            let det = a11 * a22 - a12 * a12;
            let b1 = ((r1 * a22 - r2 * a12) / det * m as f64).clamp(0.0, m as f64 - 1e-9);
            let b2 = ((r2 * a11 - r1 * a12) / det * m as f64).clamp(0.0, m as f64 - 1e-9);
            let i = b1.floor() as usize;
            let j = (b2.floor() as usize).min(m - 1 - i);
            let (fi, fj) = (b1 - i as f64, b2 - j as f64);
            // Upward cell (i, j) if fi + fj < 1, else the downward one; clamp at the rim.
            let up = fi + fj < 1.0 || i + j + 1 >= m;
            let idx = cells
                .iter()
                .position(|c| {
                    if up {
                        c[0] == (i, j) && c[1] == (i + 1, j)
                    } else {
                        c[0] == (i + 1, j) && c[1] == (i + 1, j + 1)
                    }
                })
                .unwrap_or_else(|| panic!("{name}: no cell for ({b1}, {b2})"));
            counts[idx] += 1;
        }
        let expected: Vec<f64> = weights.iter().map(|w| w / total * n as f64).collect();
        let (ok, chi2, crit) = chi2_ok(&counts, &expected);
        assert!(
            ok,
            "{name} ({}): χ² = {chi2:.1} > {crit:.1}",
            if spherical { "spherical" } else { "area" }
        );
    }
}

/// Sphere caps: cos θ to the centre uniform in [cos θmax, 1] and the azimuth uniform; disks:
/// uniform in area (equal cells in r² and φ); sphere from inside: uniform on the sphere.
#[test]
fn sphere_and_disk_samples_are_uniform() {
    let mut rng = Rng::new(5);
    let (nb_r, nb_phi) = (12usize, 12usize);
    let n = 150_000u64;
    for (name, light, x) in area_cases() {
        // (centre, axis, radial coordinate in [0, 1) from a sample)
        let (c, axis): (DVec3, DVec3) = match light {
            Light::Sphere { center, .. } => {
                let v = d(center) - d(x);
                if name.contains("inside") {
                    (d(center), DVec3::Z)
                } else {
                    (d(center), -v.normalize())
                }
            }
            Light::Disk { center, normal, .. } => (d(center), d(normal).normalize()),
            Light::Triangle { .. } => continue,
            _ => unreachable!(),
        };
        let (t, b) = basis(axis);
        let mut counts = vec![0u64; nb_r * nb_phi];
        for _ in 0..n {
            let s = sample_point(&light, x, rng.u2()).unwrap();
            let p = d(s.position) - c;
            let radial = match light {
                Light::Sphere { radius, .. } => {
                    let z = (p.normalize().dot(axis)).clamp(-1.0, 1.0);
                    if name.contains("inside") {
                        // Uniform on the sphere: z uniform in [−1, 1].
                        (z + 1.0) / 2.0
                    } else {
                        // The cap seen from x: uniform in solid angle at x, i.e. cos of the
                        // angle at x uniform. Recompute it from the direction.
                        let v = d(light_center(&light)) - d(x);
                        let cmax = (1.0 - (f64::from(radius) / v.length()).powi(2)).sqrt();
                        let cos = d(s.direction).dot(v.normalize());
                        ((1.0 - cos) / (1.0 - cmax)).clamp(0.0, 1.0 - 1e-12)
                    }
                }
                Light::Disk { radius, .. } => {
                    (p.length_squared() / f64::from(radius).powi(2)).min(1.0 - 1e-12)
                }
                _ => unreachable!(),
            };
            let phi_vec = if matches!(light, Light::Sphere { .. }) && !name.contains("inside") {
                let v = (d(light_center(&light)) - d(x)).normalize();
                let (tt, bb) = basis(v);
                let w = d(s.direction);
                (w.dot(tt), w.dot(bb))
            } else {
                (p.dot(t), p.dot(b))
            };
            let phi = (phi_vec.1.atan2(phi_vec.0) + PI) / (2.0 * PI);
            let ir = ((radial * nb_r as f64) as usize).min(nb_r - 1);
            let ip = ((phi * nb_phi as f64) as usize).min(nb_phi - 1);
            counts[ir * nb_phi + ip] += 1;
        }
        let expected = vec![n as f64 / (nb_r * nb_phi) as f64; nb_r * nb_phi];
        let (ok, chi2, crit) = chi2_ok(&counts, &expected);
        // The "tiny" sphere's cap is below f32 resolution of the directions; skip its χ².
        if name != "sphere, tiny" {
            assert!(ok, "{name}: χ² = {chi2:.1} > {crit:.1}");
        }
    }
}

fn light_center(l: &Light) -> Vec3 {
    match *l {
        Light::Sphere { center, .. } | Light::Disk { center, .. } => center,
        _ => unreachable!(),
    }
}

// ---------------------------------------------------------------------------------------------
// Irradiance against independent references
// ---------------------------------------------------------------------------------------------

/// The estimate E[L·max(0, n·ω)/pdf] of the irradiance at x (normal n) from `light`.
fn estimate(light: &Light, x: Vec3, n: DVec3, samples: usize, rng: &mut Rng) -> Stats {
    let mut st = Stats::default();
    for _ in 0..samples {
        let v = sample_point(light, x, rng.u2()).map_or(0.0, |s| {
            f64::from(s.radiance.r) * n.dot(d(s.direction)).max(0.0) / f64::from(s.pdf)
        });
        st.add(v);
    }
    st
}

/// Irradiance at the origin (normal n) from a unit-radiance polygon entirely above the horizon:
/// Lambert's formula `E = ½ |Σ Θ_i n·normalize(v_i × v_{i+1})|`.
fn lambert_polygon(v: &[DVec3], n: DVec3) -> f64 {
    let mut s = 0.0;
    for i in 0..v.len() {
        let (a, b) = (v[i].normalize(), v[(i + 1) % v.len()].normalize());
        let c = a.cross(b);
        let theta = c.length().atan2(a.dot(b));
        s += theta * n.dot(c.normalize());
    }
    0.5 * s.abs()
}

/// Irradiance at x (normal n) from a unit-radiance disk, by a midpoint rule in (r², φ) with
/// `k`×`4k` cells (each of area πR²/(4k²)); only the side of the disk facing x counts
/// (two-sided radiance).
fn disk_quadrature(c: DVec3, nd: DVec3, r: f64, x: DVec3, n: DVec3, k: usize) -> f64 {
    let (t, b) = basis(nd);
    let da = PI * r * r / (4 * k * k) as f64;
    let mut e = 0.0;
    for i in 0..k {
        let rr = ((i as f64 + 0.5) / k as f64).sqrt() * r;
        for j in 0..4 * k {
            let phi = 2.0 * PI * (j as f64 + 0.5) / (4 * k) as f64;
            let p = c + (t * phi.cos() + b * phi.sin()) * rr;
            let v = p - x;
            let d2 = v.length_squared();
            let w = v / d2.sqrt();
            e += n.dot(w).max(0.0) * nd.dot(w).abs() / d2 * da;
        }
    }
    e
}

#[test]
fn irradiance_matches_closed_forms_and_quadrature() {
    let mut rng = Rng::new(6);
    let n_samples = 100_000;
    let check = |name: &str, st: &Stats, reference: f64| {
        let (m, se) = (st.mean(), st.se());
        assert!(
            (m - reference).abs() <= K_SIGMA * se + 1e-5 * reference.abs() + 1e-12,
            "{name}: estimate {m} ± {se}, reference {reference}"
        );
    };

    // Sphere, cap fully above the horizon: E = π L sin²θmax cos β (β: normal to axis).
    for (c, r, normal) in [
        ([0.0, 0.0, 5.0], 1.0, [0.0, 0.0, 1.0]),
        ([1.0, 2.0, 3.0], 1.0, [0.3, 0.5, 1.0]),
        ([0.0, 0.0, 1.5], 1.0, [0.0, 0.0, 1.0]),
        ([0.0, 0.0, 1.001], 1.0, [0.0, 0.0, 1.0]),
        ([0.3, -0.2, 400.0], 0.5, [0.0, 0.1, 1.0]),
    ] {
        let light = sphere(c, r, 2.0);
        let n = DVec3::from(normal.map(f64::from)).normalize();
        let v = DVec3::from(c.map(f64::from));
        let sin2 = (f64::from(r) / v.length()).powi(2);
        let cos_beta = n.dot(v.normalize());
        assert!(cos_beta > sin2.sqrt(), "cap must be above the horizon");
        let reference = PI * 2.0 * sin2 * cos_beta;
        let st = estimate(&light, Vec3::ZERO, n, n_samples, &mut rng);
        check(&format!("sphere {c:?}"), &st, reference);
    }

    // Disk on its axis: E = π L R² / (R² + h²).
    for (h, r) in [(2.0f32, 1.0f32), (0.3, 1.0), (10.0, 0.5), (0.1, 0.3)] {
        let light = disk([0.0, 0.0, h], [0.0, 0.0, -1.0], r, false);
        let (r, h) = (f64::from(r), f64::from(h));
        let reference = PI * 1.5 * r * r / (r * r + h * h);
        let st = estimate(&light, Vec3::ZERO, DVec3::Z, n_samples, &mut rng);
        check(&format!("disk on axis h={h}"), &st, reference);
    }

    // Disks off axis: midpoint quadrature in f64.
    for (c, nd, r, normal) in [
        ([1.0, 0.5, 1.0], [-1.0, 0.2, -0.5], 0.7, [0.0, 0.0, 1.0]),
        ([2.0, 0.0, 0.3], [0.0, 0.0, -1.0], 1.0, [0.0, 0.0, 1.0]),
        ([0.0, 1.0, 1.0], [0.0, -1.0, -1.0], 0.5, [0.2, 0.3, 1.0]),
    ] {
        let light = disk(c, nd, r, true);
        let n = DVec3::from(normal.map(f64::from)).normalize();
        let (cd, ndd) = (
            DVec3::from(c.map(f64::from)),
            DVec3::from(nd.map(f64::from)).normalize(),
        );
        let reference = 1.5 * disk_quadrature(cd, ndd, f64::from(r), DVec3::ZERO, n, 400);
        let st = estimate(&light, Vec3::ZERO, n, n_samples, &mut rng);
        check(&format!("disk {c:?}"), &st, reference);
    }

    // Triangles above the horizon: Lambert's polygon formula, both strategies.
    for (v, normal) in [
        (
            [[0.3, 0.2, 20.0], [0.6, 0.2, 20.0], [0.3, 0.5, 20.0]],
            [0.0, 0.0, 1.0],
        ),
        (
            [[0.3, 0.2, 3.0], [0.3, 1.2, 3.0], [1.3, 0.2, 3.0]],
            [0.1, 0.0, 1.0],
        ),
        (
            [[-1.0, -1.0, 0.05], [-1.0, 2.0, 0.05], [2.0, -1.0, 0.05]],
            [0.0, 0.0, 1.0],
        ),
        (
            [[-1.0, -1.0, 0.01], [-1.0, 2.0, 0.01], [2.0, -1.0, 0.01]],
            [0.0, 0.0, 1.0],
        ),
        (
            [[0.2, -1.0, 0.01], [0.2, 1.0, 0.01], [0.2, -1.0, 2.0]],
            [0.0, 0.0, 1.0],
        ),
        (
            [[1.0, -1.0, 0.02], [1.0, 1.0, 0.02], [3.0, -1.0, 0.02]],
            [0.0, 0.0, 1.0],
        ),
        (
            [[0.0, 0.0, 1.0], [1e-3, 0.0, 1.0], [0.0, 1e-3, 1.0]],
            [0.0, 0.0, 1.0],
        ),
    ] {
        let light = tri(v, true);
        let n = DVec3::from(normal.map(f64::from)).normalize();
        let vd: Vec<DVec3> = v.iter().map(|p| DVec3::from(p.map(f64::from))).collect();
        let reference = 2.0 * lambert_polygon(&vd, n);
        let st = estimate(&light, Vec3::ZERO, n, n_samples, &mut rng);
        check(&format!("triangle {v:?}"), &st, reference);
    }

    // Nothing from behind a one-sided emitter or from inside a sphere.
    for (name, light, x) in area_cases() {
        if name.contains("behind") || name.contains("inside") {
            let st = estimate(&light, x, DVec3::Z, 1000, &mut rng);
            assert_eq!(st.mean(), 0.0, "{name}");
        }
    }
}

#[test]
fn point_and_spot_lights_are_deltas() {
    let x = Vec3::new(0.1, 0.2, 0.3);
    let p = Light::Point {
        position: Vec3::new(1.0, 2.0, 3.0),
        intensity: Rgb::grey(5.0),
    };
    let s = sample_point(&p, x, [0.3, 0.9]).unwrap();
    assert_valid(&s, x, "point");
    let dist2 = d(Vec3::new(1.0, 2.0, 3.0) - x).length_squared();
    assert!(s.delta && s.pdf == 1.0 && s.normal == Vec3::ZERO);
    assert!(rel(f64::from(s.radiance.r), 5.0 / dist2) < 1e-6, "{s:?}");
    // One convention: the delta's weight, reported as 1 at the light's position, 0 elsewhere.
    assert_eq!(pdf_point(&p, x, s.position), 1.0);
    assert_eq!(pdf_point(&p, x, s.position + Vec3::X), 0.0);
    assert_eq!(
        pdf_point(&p, s.position, s.position),
        0.0,
        "x at the light: no sample"
    );
    assert_eq!(pdf_direction(&p, x, s.direction), 0.0);
    assert!(intersect(&p, x, s.direction).is_none());

    // Spot along −z from (0, 0, 2): θf = 0.3, θs = 0.6; the profile is smoothstep in cos θ.
    let (tf, ts) = (0.3f64, 0.6f64);
    let spot = Light::Spot {
        position: Vec3::new(0.0, 0.0, 2.0),
        direction: Vec3::new(0.0, 0.0, -3.0),
        intensity: Rgb::grey(4.0),
        half_angle: ts as f32,
        falloff_start: tf as f32,
    };
    for k in 0..=40 {
        let theta = 0.8 * k as f64 / 40.0;
        let xs = DVec3::new(2.0 * theta.tan(), 0.0, 0.0);
        let s = sample_point(&spot, xs.as_vec3(), [0.5, 0.5]).unwrap();
        let th = (xs.x / 2.0).atan();
        let t = ((th.cos() - ts.cos()) / (tf.cos() - ts.cos())).clamp(0.0, 1.0);
        let profile = if th.cos() < ts.cos() {
            0.0
        } else {
            t * t * (3.0 - 2.0 * t)
        };
        let expected = 4.0 * profile / (xs - DVec3::new(0.0, 0.0, 2.0)).length_squared();
        assert!(
            (f64::from(s.radiance.r) - expected).abs() <= 1e-5 * expected.max(1e-3),
            "θ = {th}: {} vs {expected}",
            s.radiance.r
        );
        assert!(s.delta && s.pdf == 1.0);
    }
    // A hard-edged spot (θf = θs) and a spot lighting everything (θs = π).
    for (half_angle, falloff_start, at, lit) in [
        (0.5f32, 0.5f32, [0.5f32, 0.0, 0.0], true),
        (0.5, 0.5, [1.5, 0.0, 0.0], false),
        (std::f32::consts::PI, 0.0, [1.0, 0.0, 2.5], true),
        (
            std::f32::consts::PI,
            std::f32::consts::PI,
            [0.0, 0.0, 5.0],
            true,
        ),
        (std::f32::consts::PI, 3.0, [0.0, 0.0, 5.0], false),
    ] {
        let spot = Light::Spot {
            position: Vec3::new(0.0, 0.0, 2.0),
            direction: -Vec3::Z,
            intensity: Rgb::grey(1.0),
            half_angle,
            falloff_start,
        };
        let s = sample_point(&spot, Vec3::from(at), [0.0, 0.0]).unwrap();
        assert_eq!(s.radiance.r > 0.0, lit, "{half_angle} {at:?}: {s:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// Degenerate inputs
// ---------------------------------------------------------------------------------------------

#[test]
fn degenerate_inputs_give_none_or_finite_values() {
    let mut rng = Rng::new(7);
    let c = Vec3::new(0.0, 0.0, 1.0);
    let mut lights = vec![
        sphere([0.0, 0.0, 1.0], 1.0, 1.0),
        sphere([0.0, 0.0, 0.0], 1e-30, 1.0),
        sphere([0.0, 0.0, 1e-20], 1e30, 1.0),
        disk([0.0, 0.0, 1.0], [0.0, 0.0, 1.0], 1.0, false),
        disk([0.0, 0.0, 0.0], [1e-30, 0.0, 0.0], 1e-20, true),
        tri([[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], false),
        tri([[1.0; 3], [1.0; 3], [1.0; 3]], true),
        tri([[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], false),
        tri([[0.0; 3], [1e-30, 0.0, 0.0], [0.0, 1e-30, 0.0]], true),
        tri(
            [[-1e15, -1e15, 0.0], [1e15, -1e15, 0.0], [0.0, 1e15, 0.0]],
            true,
        ),
        Light::Point {
            position: Vec3::ZERO,
            intensity: Rgb::grey(1.0),
        },
        Light::Spot {
            position: Vec3::ZERO,
            direction: Vec3::X,
            intensity: Rgb::grey(1.0),
            half_angle: 0.1,
            falloff_start: 0.0,
        },
    ];
    lights.extend(area_cases().into_iter().map(|c| c.1));
    let xs = [
        Vec3::ZERO,
        c,
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::new(0.0, 0.0, 1e-30),
        Vec3::new(0.5, 0.5, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.6, 0.8, 1.0),
        Vec3::new(3.0, 4.0, 0.0),
        Vec3::splat(1e15),
        Vec3::new(f32::NAN, 0.0, 0.0),
        Vec3::new(f32::INFINITY, 0.0, 0.0),
    ];
    let one = 1.0 - f32::EPSILON / 2.0;
    let us = [
        [0.0, 0.0],
        [one, one],
        [1.0, 1.0],
        [0.5, 0.5],
        [-1.0, 2.0],
        [f32::NAN, 0.5],
        [0.5, f32::INFINITY],
    ];
    let dirs = [
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        Vec3::ZERO,
        Vec3::splat(f32::NAN),
    ];
    for light in &lights {
        for &x in &xs {
            for u in us.iter().copied().chain((0..20).map(|_| rng.u2())) {
                if let Some(s) = sample_point(light, x, u) {
                    assert!(x.is_finite() && !u[0].is_nan(), "{light:?} {x} {u:?}");
                    assert_valid(&s, x, &format!("{light:?} from {x} u={u:?}"));
                    let q = pdf_point(light, x, s.position);
                    assert!(q.is_finite() && q >= 0.0, "{light:?} {x}: {q}");
                    if s.delta {
                        assert_eq!(q.to_bits(), s.pdf.to_bits(), "{light:?} {x}");
                    } else {
                        assert!(rel(f64::from(q), f64::from(s.pdf)) <= 1e-4, "{light:?} {x}");
                    }
                }
            }
            for w in dirs.iter().copied().chain(
                (0..20).map(|_| Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5)),
            ) {
                let p = pdf_direction(light, x, w);
                assert!(p.is_finite() && p >= 0.0, "{light:?} {x} {w}: {p}");
                if let Some(h) = intersect(light, x, w) {
                    assert_valid(&h, x, &format!("hit {light:?} from {x} along {w}"));
                }
                let q = pdf_point(light, x, w);
                assert!(q.is_finite() && q >= 0.0, "{light:?} {x} {w}: {q}");
            }
        }
    }
    // The documented None cases.
    let zero_area = tri([[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], true);
    assert!(sample_point(&zero_area, Vec3::Z, [0.5, 0.5]).is_none());
    assert_eq!(pdf_point(&zero_area, Vec3::Z, Vec3::X), 0.0);
    let t = tri([[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], true);
    assert!(sample_point(&t, Vec3::new(3.0, 4.0, 0.0), [0.5, 0.5]).is_none());
    assert!(sample_point(&t, Vec3::new(0.2, 0.2, 0.0), [0.5, 0.5]).is_none());
    let dk = disk([0.0; 3], [0.0, 0.0, 1.0], 1.0, true);
    assert!(sample_point(&dk, Vec3::new(3.0, 0.0, 0.0), [0.5, 0.5]).is_none());
    let pt = Light::Point {
        position: Vec3::ONE,
        intensity: Rgb::grey(1.0),
    };
    assert!(sample_point(&pt, Vec3::ONE, [0.5, 0.5]).is_none());
    assert!(sample_point(&t, Vec3::Z, [f32::NAN, 0.5]).is_none());
    // x on a sphere: area sampling; the whole outward-emitting surface lies behind x's tangent
    // plane, so nothing is lit.
    let s = sphere([0.0, 0.0, 1.0], 1.0, 3.0);
    for _ in 0..10_000 {
        if let Some(p) = sample_point(&s, Vec3::ZERO, rng.u2()) {
            assert_valid(&p, Vec3::ZERO, "on sphere");
            assert_eq!(p.radiance, 0.0.into(), "{p:?}");
        }
    }
}

/// Regression: the spot's falloff was computed from cosines, which for half-angles below
/// about 1e-8 all round to 1 (and lose most of their digits well above that). A narrow cone's
/// profile now comes from `1 − cos` of each angle: for θs = 1e-6 and θf = 5e-7 it is the
/// smoothstep of `(θs² − θ²)/(θs² − θf²)` (to O(θ²) ≈ 1e-12 relative, so within 1e-5 as the
/// ordinary spot's test allows), full inside θf and 0 beyond θs; a hard-edged 1e-9 cone lights
/// its axis and nothing 2e-9 off it.
#[test]
fn narrow_spot_profile_keeps_its_falloff() {
    let (tf, ts) = (5e-7f64, 1e-6f64);
    let spot = Light::Spot {
        position: Vec3::new(0.0, 0.0, 2.0),
        direction: -Vec3::Z,
        intensity: Rgb::grey(4.0),
        half_angle: ts as f32,
        falloff_start: tf as f32,
    };
    for k in 0..=15 {
        let xs = DVec3::new(2.0 * (k as f64 * 1e-7), 0.0, 0.0);
        let s = sample_point(&spot, xs.as_vec3(), [0.5, 0.5]).unwrap();
        let th = (f64::from(xs.as_vec3().x) / 2.0).atan();
        let (ts, tf) = (f64::from(ts as f32), f64::from(tf as f32));
        let t = ((ts * ts - th * th) / (ts * ts - tf * tf)).clamp(0.0, 1.0);
        let profile = if th > ts {
            0.0
        } else {
            t * t * (3.0 - 2.0 * t)
        };
        let expected = 4.0 * profile / (xs - DVec3::new(0.0, 0.0, 2.0)).length_squared();
        assert!(
            (f64::from(s.radiance.r) - expected).abs() <= 1e-5 * expected.max(1e-3),
            "θ = {th}: {} vs {expected}",
            s.radiance.r
        );
    }
    let hard = Light::Spot {
        position: Vec3::new(0.0, 0.0, 2.0),
        direction: -Vec3::Z,
        intensity: Rgb::grey(1.0),
        half_angle: 1e-9,
        falloff_start: 1e-9,
    };
    let on_axis = sample_point(&hard, Vec3::ZERO, [0.0, 0.0]).unwrap();
    assert!((on_axis.radiance.r - 0.25).abs() < 1e-7, "{on_axis:?}");
    let off = sample_point(&hard, Vec3::new(4e-9, 0.0, 0.0), [0.0, 0.0]).unwrap();
    assert_eq!(off.radiance, 0.0.into(), "{off:?}");
}

/// A sun whose cone is too narrow for f32 (its pdf or its radiance would overflow) is the delta
/// direction it tends to: `sample_point` gives its direction with pdf 1, `delta` set and
/// radiance E; `pdf_point` there is 1; a BSDF ray never hits it (`intersect` `None`,
/// `pdf_direction` 0). Every technique's estimate on a Lambert plane of albedo 0.8 facing it at
/// θ is 0.8·E·cos θ / π, within 5 standard errors of the estimates' mean (and the f32
/// rounding, 1e-5 relative), as it is for a sun of 1e-15 rad that f32 can still sample.
#[test]
fn a_sun_too_narrow_for_f32_is_a_delta_direction() {
    use manylights::direct::{Estimator, Params, Technique, Unoccluded};
    use manylights::{LightSet, Material, ShadingPoint};
    use manylights_testkit::TestUniforms;
    let axis = Vec3::new(0.3, -0.2, 1.0);
    let x = Vec3::new(0.5, 0.25, 0.0);
    for (gamma, e) in [
        (1e-20f32, 2.0f32),
        (1e-10, 1e20),
        (1e-30, 1.0),
        (1e-45, 3.0),
    ] {
        let sun = Light::Distant {
            direction: axis,
            angular_radius: gamma,
            irradiance: Rgb::grey(e),
        };
        let ctx = format!("γ {gamma}, E {e}");
        let p = sample_point(&sun, x, [0.3, 0.7]).unwrap_or_else(|| panic!("no point, {ctx}"));
        assert!(p.delta && p.pdf == 1.0, "{p:?}, {ctx}");
        assert_eq!(p.radiance, Rgb::grey(e), "{ctx}");
        assert!(
            (p.direction - axis.normalize()).length() < 1e-6,
            "{p:?}, {ctx}"
        );
        assert_eq!(pdf_point(&sun, x, p.position), 1.0, "{ctx}");
        assert!(intersect(&sun, x, p.direction).is_none(), "{ctx}");
        assert_eq!(pdf_direction(&sun, x, p.direction), 0.0, "{ctx}");
    }
    let cos = f64::from(axis.normalize().z);
    for (gamma, e) in [(1e-20f32, 2.0f32), (1e-10, 1e20), (1e-15, 2.0)] {
        let exact = 0.8 * f64::from(e) * cos / PI;
        let set = LightSet::build(vec![Light::Distant {
            direction: axis,
            angular_radius: gamma,
            irradiance: Rgb::grey(e),
        }])
        .unwrap();
        let sp = ShadingPoint {
            position: Vec3::ZERO,
            normal: Vec3::Z,
            wo: Vec3::new(0.1, 0.2, 1.0),
            material: Material::Lambert {
                albedo: Rgb::grey(0.8),
            },
        };
        for (i, &t) in Technique::ALL.iter().enumerate() {
            let mut est = Estimator::new(&set, &sp, t, &Params::default()).unwrap();
            let mut u = TestUniforms::new(500 + i as u64);
            let mut st = Stats::default();
            for _ in 0..2000 {
                st.add(est.estimate(&Unoccluded, &mut u).unwrap()[0]);
            }
            let tol = 5.0 * st.se() + 1e-5 * exact;
            assert!(
                (st.mean() - exact).abs() <= tol,
                "{t}, γ {gamma}, E {e}: mean {} exact {exact} (tolerance {tol})",
                st.mean()
            );
        }
    }
}
