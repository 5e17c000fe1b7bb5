//! The synthetic configurations of `mlmeasure estimator`: small sphere and disk lights in a
//! shell around a cluster of shading points, direct illumination without visibility.
//!
//! - **Shading points**: positions uniform in a ball of radius [`POINT_REGION`] around the
//!   origin, normals uniform on the sphere, ωo uniform over the hemisphere of the normal (its
//!   cosine with the normal at least 0.02, so that no view is exactly grazing).
//! - **Lights** (index i): centre in a uniformly random direction from the origin at a distance
//!   d in [`LIGHT_DISTANCE`] with density ∝ d (uniform in d²; so at least 0.5 from every
//!   shading point, and every light surface at least 0.2 away), radius log-uniform in
//!   [`LIGHT_RADIUS`], power log-uniform in [0.1, 10] times d (so that a light's contribution
//!   falls as 1/d and, with the density ∝ d, every distance shell contributes about equally).
//!   Together the lights cover about 0.9 sr of the 4π around a shading point (Σ π r²/d²): a
//!   BRDF ray hits a light now and then, not always. Kinds cycle with i mod 8: 0, 1, 4, 5
//!   spheres; 2, 6, 7 one-sided disks whose normal is the direction to the origin tilted by up
//!   to 60° (so a few shading points see some of them edge-on or from behind); 3 two-sided disks
//!   with a uniformly random normal. Radiances are set so the power is the drawn one.
//! - **Materials** ([`MATERIALS`]): Lambert (albedo 0.8), GGX α ∈ {0.05, 0.2, 0.6}
//!   (specular 1) and plastic (albedo 0.5 + 0.5 × GGX α = 0.1). With the default plan,
//!   point i gets material `i mod 5` (64 points → 13 Lambert, 13 × GGX 0.05, 13 × GGX 0.2,
//!   13 × GGX 0.6, 12 plastic configurations); `all_materials` evaluates every point with every
//!   material instead (5× the configurations and the run time).

use glam::Vec3;
use manylights::Rgb;
use manylights::{Light, LightSet, Material, ShadingPoint};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::f32::consts::PI;

/// Radius of the ball holding the shading points.
pub const POINT_REGION: f32 = 0.2;
/// Range of the lights' distances from the origin (log-uniform).
pub const LIGHT_DISTANCE: (f32, f32) = (0.7, 20.0);
/// Range of the lights' radii (log-uniform).
pub const LIGHT_RADIUS: (f32, f32) = (0.02, 0.3);

/// The five materials: a name (used in reports) and the material.
pub const MATERIALS: [(&str, Material); 5] = [
    (
        "lambert",
        Material::Lambert {
            albedo: Rgb::grey(0.8),
        },
    ),
    (
        "ggx-0.05",
        Material::Ggx {
            alpha: 0.05,
            specular: 1.0,
        },
    ),
    (
        "ggx-0.2",
        Material::Ggx {
            alpha: 0.2,
            specular: 1.0,
        },
    ),
    (
        "ggx-0.6",
        Material::Ggx {
            alpha: 0.6,
            specular: 1.0,
        },
    ),
    (
        "plastic",
        Material::Plastic {
            albedo: Rgb::grey(0.5),
            specular: 0.5,
            alpha: 0.1,
        },
    ),
];

/// One configuration: a shading point with its material.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// Index of the shading point.
    pub point: usize,
    /// Index into [`MATERIALS`].
    pub material: usize,
    /// The shading point (unit normal, unit ωo with ωo·n > 0).
    pub sp: ShadingPoint,
}

impl Config {
    /// The material's name.
    pub fn material_name(&self) -> &'static str {
        MATERIALS[self.material].0
    }

    /// GGX with α ≤ 0.2 (the "glossy" set of the equal-time ratio).
    pub fn is_glossy(&self) -> bool {
        matches!(self.sp.material, Material::Ggx { alpha, .. } if alpha <= 0.2)
    }

    /// Lambert (the "diffuse" set).
    pub fn is_diffuse(&self) -> bool {
        matches!(self.sp.material, Material::Lambert { .. })
    }
}

/// The lights (with their tree and power distribution) and the configurations.
#[derive(Debug)]
pub struct Scene {
    /// The lights.
    pub set: LightSet,
    /// The configurations.
    pub configs: Vec<Config>,
}

fn log_uniform(rng: &mut Pcg64Mcg, (lo, hi): (f32, f32)) -> f32 {
    (rng.random_range(lo.ln()..hi.ln())).exp()
}

/// A uniformly random unit vector.
pub fn unit_vector(rng: &mut Pcg64Mcg) -> Vec3 {
    let z = rng.random_range(-1.0f32..=1.0);
    let phi = rng.random_range(0.0..2.0 * PI);
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// `n` lights as described in the module documentation.
pub fn lights(n: usize, seed: u64) -> Vec<Light> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x11_6475);
    (0..n)
        .map(|i| {
            let dir = unit_vector(&mut rng);
            let (d0, d1) = LIGHT_DISTANCE;
            let dist = rng.random_range(d0 * d0..d1 * d1).sqrt();
            let center = dir * dist;
            let radius = log_uniform(&mut rng, LIGHT_RADIUS);
            let power = log_uniform(&mut rng, (0.1, 10.0)) * dist;
            match i % 8 {
                0 | 1 | 4 | 5 => {
                    manylights_render::scene::sphere_light(center, radius, power, Rgb::ONE)
                }
                3 => Light::Disk {
                    center,
                    normal: unit_vector(&mut rng),
                    radius,
                    radiance: Rgb::grey(power / (2.0 * PI * PI * radius * radius)),
                    two_sided: true,
                },
                _ => {
                    // The direction to the origin, tilted by up to 60°.
                    let to_origin = -dir;
                    let tilt = rng.random_range(0.0f32..1.0).sqrt() * 60f32.to_radians();
                    let phi = rng.random_range(0.0..2.0 * PI);
                    let t = to_origin.any_orthonormal_vector();
                    let b = to_origin.cross(t);
                    let normal = (to_origin * tilt.cos()
                        + (t * phi.cos() + b * phi.sin()) * tilt.sin())
                    .normalize();
                    manylights_render::scene::disk_light(center, normal, radius, power, Rgb::ONE)
                }
            }
        })
        .collect()
}

/// `m` shading points (positions, normals, ωo) as described in the module documentation,
/// without materials.
pub fn points(m: usize, seed: u64) -> Vec<(Vec3, Vec3, Vec3)> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed ^ 0x5_0141_7500);
    (0..m)
        .map(|_| {
            let position = loop {
                let p = Vec3::new(
                    rng.random_range(-1.0f32..1.0),
                    rng.random_range(-1.0f32..1.0),
                    rng.random_range(-1.0f32..1.0),
                );
                if p.length_squared() <= 1.0 {
                    break p * POINT_REGION;
                }
            };
            let normal = unit_vector(&mut rng);
            let wo = loop {
                let w = unit_vector(&mut rng);
                let c = w.dot(normal);
                if c.abs() >= 0.02 {
                    break if c > 0.0 { w } else { -w };
                }
            };
            (position, normal, wo)
        })
        .collect()
}

/// How shading points and materials are combined.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plan {
    /// Point i gets material `i mod 5`.
    Cycle,
    /// Every point with every material.
    All,
}

impl Scene {
    /// Builds the scene: `n_lights` lights, `n_points` shading points combined with the
    /// materials by `plan`.
    pub fn new(n_lights: usize, n_points: usize, plan: Plan, seed: u64) -> Scene {
        let lights = lights(n_lights, seed);
        let mut configs = Vec::new();
        for (i, (position, normal, wo)) in points(n_points, seed).into_iter().enumerate() {
            let mats: Vec<usize> = match plan {
                Plan::Cycle => vec![i % MATERIALS.len()],
                Plan::All => (0..MATERIALS.len()).collect(),
            };
            for m in mats {
                configs.push(Config {
                    point: i,
                    material: m,
                    sp: ShadingPoint {
                        position,
                        normal,
                        wo,
                        material: MATERIALS[m].1,
                    },
                });
            }
        }
        Scene::with_lights(lights, configs)
    }

    /// A scene of the given lights (spheres and disks, x outside every sphere) and
    /// configurations.
    pub fn with_lights(lights: Vec<Light>, configs: Vec<Config>) -> Scene {
        let set = LightSet::build(lights).expect("the estimator scene is valid");
        Scene { set, configs }
    }
}
