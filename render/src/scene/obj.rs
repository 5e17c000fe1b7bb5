//! Scenes from Wavefront OBJ + MTL files (read with the `tobj` crate).
//!
//! Faces are triangulated. Each material becomes (colours are linear RGB; where a choice
//! needs one number it takes the luminance `0.2126 R + 0.7152 G + 0.0722 B`; albedos are
//! clamped to [0, 1] per channel, the specular weight is the luminance of `Ks`):
//! - **emissive** (`Ke` of non-zero luminance): every triangle is a one-sided
//!   [`Light::Triangle`] (emitting on the side of `(v1 − v0) × (v2 − v0)`, i.e. towards a
//!   viewer that sees the face counter-clockwise) of radiance `Ke`. Emitters are
//!   not surfaces: they do not block light (as every light of the renderer) and are not seen;
//! - **glossy** (`Ks` of non-zero luminance and a roughness, `Pr` or `Ns`): GGX of
//!   `α = Pr²` when `Pr` is given (the usual roughness-to-α mapping), else
//!   `α = sqrt(2 / (Ns + 2))` (the Phong exponent of the same lobe width), clamped to
//!   [[`MIN_ALPHA`], 1]. Plastic (`albedo` `Kd`, `specular` from `Ks`) if `Kd` is not
//!   black, GGX (`specular` from `Ks`) if it is;
//! - anything else: Lambert of `albedo` `Kd` (0.5 grey if absent).
//!
//! Faces without a material are Lambert 0.5. The camera looks at the centre of the bounding box
//! of all vertices from +z, far enough that the box's bounding sphere fits the 45° field of
//! view, y up. The scene's name is the file's stem.

use super::geometry::{Geometry, Triangle};
use super::{Camera, LightSet, RenderScene};
use glam::Vec3;
use manylights::material::MIN_ALPHA;
use manylights::Rgb;
use manylights::{BuildError, Light, LightTree, Material, MAX_COORDINATE};
use std::path::Path;

/// Luminance of a linear RGB colour.
pub fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// What one MTL material turns into.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Surface {
    /// A surface that reflects (and blocks) light.
    Reflector(Material),
    /// An emitter of this radiance: its triangles are lights.
    Emitter(Rgb),
}

/// The surface of an MTL material (see the module documentation); `Err` names the field
/// that is not finite.
pub fn surface(m: &tobj::Material) -> Result<Surface, String> {
    let colour = |name: &str, c: Option<[f32; 3]>| -> Result<[f32; 3], String> {
        let c = c.unwrap_or([0.0; 3]);
        if c.iter().all(|v| v.is_finite()) {
            Ok(c)
        } else {
            Err(format!("material {:?}: {name} is not finite", m.name))
        }
    };
    let ke = colour("Ke", m.emissive)?;
    if luminance(ke) > 0.0 {
        return Ok(Surface::Emitter(Rgb::from_array(ke.map(|v| v.max(0.0)))));
    }
    let kd =
        Rgb::from_array(colour("Kd", m.diffuse.or(Some([0.5; 3])))?.map(|v| v.clamp(0.0, 1.0)));
    let ks = luminance(colour("Ks", m.specular)?).clamp(0.0, 1.0);
    let pr = match m.unknown_param.get("Pr") {
        Some(s) => match s.trim().parse::<f32>() {
            Ok(v) if v.is_finite() => Some(v),
            _ => return Err(format!("material {:?}: Pr {s:?} is not a number", m.name)),
        },
        None => None,
    };
    if let Some(ns) = m.shininess {
        if !ns.is_finite() {
            return Err(format!("material {:?}: Ns is not finite", m.name));
        }
    }
    let alpha = match (pr, m.shininess) {
        (Some(r), _) => Some(r * r),
        (None, Some(ns)) => Some((2.0 / (ns.max(0.0) + 2.0)).sqrt()),
        (None, None) => None,
    };
    Ok(Surface::Reflector(match alpha {
        Some(alpha) if ks > 0.0 => {
            let alpha = alpha.clamp(MIN_ALPHA, 1.0);
            if kd.max_channel() > 0.0 {
                Material::Plastic {
                    albedo: kd,
                    specular: ks,
                    alpha,
                }
            } else {
                Material::Ggx {
                    alpha,
                    specular: ks,
                }
            }
        }
        _ => Material::Lambert { albedo: kd },
    }))
}

/// The material of faces that name none.
const DEFAULT_MATERIAL: Material = Material::Lambert {
    albedo: Rgb::grey(0.5),
};

/// A file-name-safe scene name from the file's stem (`fallback` when it has none).
pub(crate) fn scene_name(path: &Path, fallback: &str) -> String {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name: String = stem
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if name.is_empty() {
        fallback.into()
    } else {
        name
    }
}

/// Loads the OBJ file at `path` and its MTL libraries into a scene (see the module
/// documentation). Every error is returned, naming the file: the file cannot be read or
/// parsed, a material library cannot, a vertex or material value is not finite or out of
/// range, there is no reflecting triangle, no emitting triangle of non-zero area, or the
/// lights are rejected by [`LightTree::build`] (the message names the light's object, material
/// and field).
pub fn load(path: &Path) -> Result<RenderScene, String> {
    let file = path.display();
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, materials) = tobj::load_obj(path, &options).map_err(|e| format!("{file}: {e}"))?;
    let materials = materials.map_err(|e| format!("{file}: material library: {e}"))?;
    let surfaces: Vec<Surface> = materials
        .iter()
        .map(surface)
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{file}: {e}"))?;

    let mut triangles = Vec::new();
    let mut lights = Vec::new();
    // Object and material name of each light, for error messages.
    let mut light_origin: Vec<(usize, Option<usize>)> = Vec::new();
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for (mi, model) in models.iter().enumerate() {
        let mesh = &model.mesh;
        let surface = match mesh.material_id {
            Some(id) => *surfaces.get(id).ok_or_else(|| {
                format!("{file}: object {:?}: material {id} is missing", model.name)
            })?,
            None => Surface::Reflector(DEFAULT_MATERIAL),
        };
        let vertex = |k: u32| -> Result<Vec3, String> {
            let i = k as usize * 3;
            let p = mesh.positions.get(i..i + 3).ok_or_else(|| {
                format!("{file}: object {:?}: vertex index out of range", model.name)
            })?;
            Ok(Vec3::new(p[0], p[1], p[2]))
        };
        for face in mesh.indices.chunks_exact(3) {
            let v = [vertex(face[0])?, vertex(face[1])?, vertex(face[2])?];
            for p in v {
                lo = lo.min(p);
                hi = hi.max(p);
            }
            // Lights are checked by the tree build below (which names the bad field).
            if let (Surface::Reflector(_), Some(p)) = (
                surface,
                v.iter()
                    .find(|p| !p.is_finite() || p.abs().max_element() > MAX_COORDINATE),
            ) {
                return Err(format!(
                    "{file}: object {:?}: vertex {p} is not finite or out of range",
                    model.name
                ));
            }
            match surface {
                Surface::Emitter(radiance) => {
                    lights.push(Light::Triangle {
                        vertices: v,
                        radiance,
                        two_sided: false,
                    });
                    light_origin.push((mi, mesh.material_id));
                }
                Surface::Reflector(material) => {
                    // Zero-area triangles are never hit: leave them out.
                    let n = (v[1] - v[0]).cross(v[2] - v[0]);
                    if n.length_squared() > 0.0 && n.is_finite() {
                        triangles.push(Triangle::new(v[0], v[1], v[2], material));
                    }
                }
            }
        }
    }
    if triangles.is_empty() {
        return Err(format!("{file}: no reflecting triangle (of non-zero area)"));
    }
    if lights.is_empty() {
        return Err(format!(
            "{file}: no light (no triangle with an emissive material: Ke of non-zero luminance)"
        ));
    }
    if let Err(e) = LightTree::build(&lights) {
        let origin = match e {
            BuildError::InvalidLight { index, .. } => match light_origin.get(index) {
                Some(&(mi, mat)) => {
                    let mat = mat.and_then(|id| materials.get(id)).map_or("", |m| &m.name);
                    format!(" (object {:?}, material {mat:?})", models[mi].name)
                }
                None => String::new(),
            },
            _ => String::new(),
        };
        return Err(format!("{file}: {e}{origin}"));
    }
    if !lights.iter().any(|l| l.energy() > 0.0) {
        return Err(format!(
            "{file}: no light (every emissive triangle has zero area)"
        ));
    }

    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let fov_y: f32 = 45.0;
    let distance = radius / (fov_y.to_radians() * 0.5).sin();
    Ok(RenderScene {
        name: scene_name(path, "obj"),
        geometry: Geometry::new(triangles),
        lights: LightSet::build(lights).map_err(|e| format!("{}: {e}", path.display()))?,
        sky: None,
        camera: Camera {
            eye: centre + Vec3::Z * distance,
            target: centre,
            up: Vec3::Y,
            fov_y,
        },
    })
}
