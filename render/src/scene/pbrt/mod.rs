//! Scenes from pbrt-v4 scene files (`.pbrt`): the subset of the scene description that direct
//! lighting needs, mapped onto the renderer's triangles, materials and lights. The mapping is
//! written down in `docs/instruments.md` ("pbrt-v4 scenes").
//!
//! **Why a parser of our own.** The `pbrt4` crate (0.2) reads the format, but its errors carry
//! no position (`Error::UnknownDirective`, `Error::InvalidToken`, … name neither the file nor
//! the line), so neither a malformed file nor an unsupported directive could be reported with
//! its line; it also pins an older `glam` (0.24) than the renderer's. The format is small
//! (a directive, positional arguments, a list of `"type name" value` parameters), so
//! [`parse`] tokenizes it against pbrt-v4's file-format documentation, keeping the file and
//! line of every token. PLY meshes are read by the `ply-rs-bw` crate ([`ply`]).
//!
//! Read: `Camera "perspective"` with the transform directives (`Identity`, `Translate`,
//! `Scale`, `Rotate`, `LookAt`, `Transform`, `ConcatTransform`, `CoordinateSystem`,
//! `CoordSysTransform`), `Film` resolution, `WorldBegin`, `AttributeBegin/End`,
//! `TransformBegin/End`, `ReverseOrientation`, `Include` / `Import`, `ObjectBegin` / `ObjectEnd`
//! / `ObjectInstance` (flattened: each instance copies the object's triangles and lights
//! under its transform), `Material`, `MakeNamedMaterial` / `NamedMaterial`, constant
//! `Texture`s; shapes `trianglemesh`, `plymesh`, `sphere`, `disk`, `bilinearmesh`;
//! `AreaLightSource "diffuse"`; `LightSource` `point`, `spot`, `distant`, `infinite`.
//! Anything else — a directive, a shape, light or material type, a parameter the mapping does
//! not use — is a warning naming the directive and `file:line` ([`PbrtScene::warnings`]),
//! never a silent skip; a malformed file is an error with `file:line`.
//!
//! **Handedness.** pbrt's camera space is left-handed: the image's right is the camera's +x,
//! which a plain `LookAt` turns into `up × view` — the mirror of the renderer's camera, whose
//! right is `view × up`. When the file's camera is mirrored so (a plain `LookAt`, the default
//! camera), the whole scene is loaded with world x negated (geometry, lights and camera), so
//! that the image is pbrt's; [`PbrtScene::mirrored`] says so, and a `--camera` given for
//! such a file is in the negated coordinates. A camera under `Scale -1 1 1` (as exporters
//! write) keeps the file's coordinates.

mod colour;
pub mod parse;
pub mod ply;

pub use colour::blackbody;

use super::geometry::{Geometry, Triangle};
use super::{Camera, RenderScene};
use glam::{DMat3, DMat4, DVec3, Vec3};
use manylights::light::UniformSky;
use manylights::material::MIN_ALPHA;
use manylights::{BuildError, BuildOptions, Light, LightSet, LightTree, Material, Rgb, Serial};
use parse::{Loc, Param, Stmt, Tok, Values};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// A pbrt-v4 file loaded: the scene, the warnings about what was not mapped, and the film.
#[derive(Debug)]
pub struct PbrtScene {
    /// The scene.
    pub scene: RenderScene,
    /// One line per unsupported directive, type or parameter, each naming the directive and
    /// `file:line` (`scene.pbrt:12: Shape "curve": …`).
    pub warnings: Vec<String>,
    /// The `Film`'s `xresolution` and `yresolution`, if the file has a `Film`.
    pub film: Option<(usize, usize)>,
    /// Whether the scene was loaded with world x negated (see the module documentation).
    pub mirrored: bool,
}

/// pbrt-v4's film resolution when the file gives none (its aspect sets the field of view).
const DEFAULT_FILM: (usize, usize) = (1280, 720);

/// Triangle tessellation of non-emissive spheres (segments around, rings pole to pole) and
/// disks (segments).
const SPHERE_SEGMENTS: usize = 48;
const SPHERE_RINGS: usize = 24;
const DISK_SEGMENTS: usize = 48;

/// Object-space points, in double precision and as the file's single-precision numbers.
type Points = Vec<(DVec3, [f32; 3])>;

/// Deepest `Include` nesting.
const MAX_INCLUDE_DEPTH: usize = 32;

/// A surface: a material, or pbrt's `interface` (no surface: its shapes are left out).
#[derive(Clone, Copy, Debug)]
enum Surf {
    Material(Material),
    Interface,
}

/// The current material.
#[derive(Clone, Debug)]
enum MatSel {
    Anon(Surf),
    Named(String),
}

/// The current area light.
#[derive(Clone, Copy, Debug)]
struct Area {
    radiance: Rgb,
    two_sided: bool,
}

/// The graphics state that `AttributeBegin` saves.
#[derive(Clone, Debug)]
struct GState {
    ctm: DMat4,
    reverse: bool,
    material: MatSel,
    area: Option<Area>,
}

/// What a block saves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Block {
    Attribute,
    Transform,
    Object,
}

/// Triangles and lights, with where each light comes from.
#[derive(Clone, Debug, Default)]
struct Content {
    triangles: Vec<Triangle>,
    lights: Vec<Light>,
    origins: Vec<String>,
}

/// A constant texture's value.
#[derive(Clone, Copy, Debug)]
enum TexVal {
    Float(f32),
    Colour(Rgb),
}

/// The reader's state.
struct Reader {
    dir: PathBuf,
    warnings: Vec<String>,
    gs: GState,
    stack: Vec<(GState, Block, Loc)>,
    named: HashMap<String, Surf>,
    textures: HashMap<String, Option<TexVal>>,
    coords: HashMap<String, DMat4>,
    objects: HashMap<String, Content>,
    object: Option<(String, Content)>,
    world: Content,
    sky: Option<Rgb>,
    /// Camera-from-world, the field of view and, when the camera's transform is a `LookAt`
    /// after the identity or `Scale -1 1 1`, its eye, target and up (and whether it is
    /// mirrored), kept exactly.
    camera: Option<(DMat4, f32, Option<LookAt>)>,
    lookat: Option<LookAt>,
    film: Option<(usize, usize)>,
    active_start: bool,
    depth: usize,
}

/// A `LookAt`'s numbers.
#[derive(Clone, Copy, Debug)]
struct LookAt {
    eye: [f32; 3],
    target: [f32; 3],
    up: [f32; 3],
    mirrored: bool,
}

/// Loads the pbrt-v4 file at `path` (see the module documentation). `Err` names `file:line`:
/// the file or an included one cannot be read, it is malformed (a token, a parameter list, a
/// number of arguments, an unbalanced block), it names an undefined material or object, a
/// value is out of range, there is no reflecting triangle or no light, or the lights are
/// rejected by [`LightTree::build`].
pub fn load(path: &Path) -> Result<PbrtScene, String> {
    let mut r = Reader {
        dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        warnings: Vec::new(),
        gs: GState {
            ctm: DMat4::IDENTITY,
            reverse: false,
            material: MatSel::Anon(Surf::Material(DEFAULT_MATERIAL)),
            area: None,
        },
        stack: Vec::new(),
        named: HashMap::new(),
        textures: HashMap::new(),
        coords: HashMap::new(),
        objects: HashMap::new(),
        object: None,
        world: Content::default(),
        sky: None,
        camera: None,
        lookat: None,
        film: None,
        active_start: true,
        depth: 0,
    };
    r.file(path, None)?;
    if let Some((_, _, loc)) = r.stack.last() {
        return Err(format!("{loc}: block opened here is never closed"));
    }
    r.finish(path)
}

/// pbrt-v4's default material: `diffuse` of reflectance 0.5.
const DEFAULT_MATERIAL: Material = Material::Lambert {
    albedo: Rgb::grey(0.5),
};

/// The numbers of a statement's positional arguments; `Err` if there are not `n` of them.
fn numbers(st: &Stmt, n: usize) -> Result<Vec<f64>, String> {
    let v: Vec<f64> = st
        .args
        .iter()
        .filter_map(|t| match t {
            Tok::Num(d, _) => Some(*d),
            _ => None,
        })
        .collect();
    if v.len() != n || st.args.len() != n {
        return Err(format!(
            "{}: {} takes {n} numbers (got {} arguments)",
            st.loc,
            st.dir,
            st.args.len()
        ));
    }
    Ok(v)
}

/// The `k`-th positional string of a statement.
fn arg(st: &Stmt, k: usize) -> &str {
    match st.args.get(k) {
        Some(Tok::Str(s)) => s,
        _ => "",
    }
}

/// The 3×3 part of `m`.
fn linear(m: &DMat4) -> DMat3 {
    DMat3::from_mat4(*m)
}

/// `m` applied to the point `p` (given in double and single precision): the single-precision
/// value itself under the identity, so that untransformed coordinates are the file's.
fn point(m: &DMat4, p: (DVec3, [f32; 3])) -> Vec3 {
    if *m == DMat4::IDENTITY {
        Vec3::from_array(p.1)
    } else {
        m.transform_point3(p.0).as_vec3()
    }
}

/// `m` applied to a single-precision point.
fn point32(m: &DMat4, p: Vec3) -> Vec3 {
    if *m == DMat4::IDENTITY {
        p
    } else {
        m.transform_point3(p.as_dvec3()).as_vec3()
    }
}

/// `m` applied to the normal `n` (the inverse transpose).
fn normal(m: &DMat4, n: DVec3) -> DVec3 {
    linear(m).inverse().transpose() * n
}

/// The uniform scale of `m` (the geometric mean of its axes' lengths) and whether it is
/// uniform.
fn uniform_scale(m: &DMat4) -> (f64, bool) {
    let l = linear(m);
    let s = [l.x_axis.length(), l.y_axis.length(), l.z_axis.length()];
    let mean = (s[0] * s[1] * s[2]).cbrt();
    let uniform = s.iter().all(|&v| (v - mean).abs() <= 1e-4 * mean)
        && l.x_axis.dot(l.y_axis).abs() <= 1e-4 * mean * mean
        && l.x_axis.dot(l.z_axis).abs() <= 1e-4 * mean * mean
        && l.y_axis.dot(l.z_axis).abs() <= 1e-4 * mean * mean;
    (mean, uniform)
}

/// `light` under `m` (an instance's transform); `None` if `m` does not keep a sphere or a
/// disk round (non-uniform scale).
fn transform_light(light: &Light, m: &DMat4) -> Option<Light> {
    if *m == DMat4::IDENTITY {
        return Some(*light);
    }
    let (s, uniform) = uniform_scale(m);
    let swaps = linear(m).determinant() < 0.0;
    Some(match *light {
        Light::Triangle {
            vertices,
            radiance,
            two_sided,
        } => {
            let v = vertices.map(|p| point32(m, p));
            Light::Triangle {
                // A reflection keeps the emitting side on the transformed normal's side.
                vertices: if swaps { [v[0], v[2], v[1]] } else { v },
                radiance,
                two_sided,
            }
        }
        Light::Sphere {
            center,
            radius,
            radiance,
        } if uniform => Light::Sphere {
            center: point32(m, center),
            radius: (f64::from(radius) * s) as f32,
            radiance,
        },
        Light::Disk {
            center,
            normal: n,
            radius,
            radiance,
            two_sided,
        } if uniform => Light::Disk {
            center: point32(m, center),
            normal: normal(m, n.as_dvec3()).normalize().as_vec3(),
            radius: (f64::from(radius) * s) as f32,
            radiance,
            two_sided,
        },
        _ => return None,
    })
}

/// `light` with world x negated.
fn mirror_light(light: &Light) -> Light {
    let m = |v: Vec3| Vec3::new(-v.x, v.y, v.z);
    match *light {
        Light::Point {
            position,
            intensity,
        } => Light::Point {
            position: m(position),
            intensity,
        },
        Light::Spot {
            position,
            direction,
            intensity,
            half_angle,
            falloff_start,
        } => Light::Spot {
            position: m(position),
            direction: m(direction),
            intensity,
            half_angle,
            falloff_start,
        },
        Light::Sphere {
            center,
            radius,
            radiance,
        } => Light::Sphere {
            center: m(center),
            radius,
            radiance,
        },
        Light::Disk {
            center,
            normal,
            radius,
            radiance,
            two_sided,
        } => Light::Disk {
            center: m(center),
            normal: m(normal),
            radius,
            radiance,
            two_sided,
        },
        Light::Triangle {
            vertices,
            radiance,
            two_sided,
        } => {
            let v = vertices.map(m);
            Light::Triangle {
                vertices: [v[0], v[2], v[1]],
                radiance,
                two_sided,
            }
        }
        Light::Distant {
            direction,
            angular_radius,
            irradiance,
        } => Light::Distant {
            direction: m(direction),
            angular_radius,
            irradiance,
        },
        other => other,
    }
}

/// GGX α of a pbrt roughness: `sqrt(roughness)` when `remaproughness` (pbrt-v4's
/// `RoughnessToAlpha`), the roughness itself otherwise, clamped to [[`MIN_ALPHA`], 1].
fn alpha_of(roughness: f32, remap: bool) -> f32 {
    let a = if remap {
        roughness.max(0.0).sqrt()
    } else {
        roughness
    };
    a.clamp(MIN_ALPHA, 1.0)
}

impl Reader {
    /// Warns about `what` at `st`.
    fn warn(&mut self, st: &Stmt, what: &str) {
        self.warnings
            .push(format!("{}: {}: {what}", st.loc, st.dir));
    }

    /// Warns about every parameter of `st` the reader did not use.
    fn unused(&mut self, st: &Stmt) {
        let what = match st.args.first() {
            Some(Tok::Str(s)) if st.dir != "Texture" => format!("{} \"{s}\"", st.dir),
            _ => st.dir.clone(),
        };
        for p in &st.params {
            if !p.used.get() {
                self.warnings.push(format!(
                    "{}: {what}: parameter \"{} {}\" is not supported (ignored)",
                    st.loc, p.ty, p.name
                ));
            }
        }
    }

    /// Reads one file (the main one, or an `Include`d one from `from`).
    fn file(&mut self, path: &Path, from: Option<&Loc>) -> Result<(), String> {
        let at = from.map_or(String::new(), |l| format!("{l}: "));
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{at}cannot read {}: {e}", path.display()))?;
        let name: Rc<str> = path.display().to_string().into();
        let stmts = parse::statements(parse::tokenize(&text, &name)?)?;
        for st in &stmts {
            self.statement(st)?;
        }
        Ok(())
    }

    /// A path named in the file, relative to the main file's directory.
    fn resolve(&self, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.dir.join(p)
        }
    }

    /// The parameter `name` of `st`, marked used.
    fn param<'a>(st: &'a Stmt, name: &str) -> Option<&'a Param> {
        let p = st.params.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    /// The numbers of parameter `name` (of type `types`), if present.
    fn nums(st: &Stmt, name: &str, types: &[&str]) -> Result<Option<Vec<(f64, f32)>>, String> {
        let Some(p) = Self::param(st, name) else {
            return Ok(None);
        };
        match &p.values {
            Values::Nums(v) if types.contains(&p.ty.as_str()) => Ok(Some(v.clone())),
            _ => Err(format!(
                "{}: {}: parameter \"{} {name}\" must be numbers of type {}",
                st.loc,
                st.dir,
                p.ty,
                types.join(" or ")
            )),
        }
    }

    /// A float parameter (or a float texture's constant value).
    fn float(&mut self, st: &Stmt, name: &str, default: f32) -> Result<f32, String> {
        if let Some(p) = st
            .params
            .iter()
            .find(|p| p.name == name && p.ty == "texture")
        {
            p.used.set(true);
            return Ok(match self.texture(st, p)? {
                Some(TexVal::Float(v)) => v,
                Some(TexVal::Colour(c)) => c.luminance(),
                None => default,
            });
        }
        match Self::nums(st, name, &["float"])? {
            Some(v) if v.len() == 1 => Ok(v[0].1),
            Some(_) => Err(format!(
                "{}: {}: \"float {name}\" takes one value",
                st.loc, st.dir
            )),
            None => Ok(default),
        }
    }

    /// An integer parameter.
    fn int(st: &Stmt, name: &str) -> Result<Option<i64>, String> {
        match Self::nums(st, name, &["integer"])? {
            Some(v) if v.len() == 1 && v[0].0.fract() == 0.0 => Ok(Some(v[0].0 as i64)),
            Some(_) => Err(format!(
                "{}: {}: \"integer {name}\" takes one integer",
                st.loc, st.dir
            )),
            None => Ok(None),
        }
    }

    /// A boolean parameter.
    fn boolean(st: &Stmt, name: &str, default: bool) -> Result<bool, String> {
        let Some(p) = Self::param(st, name) else {
            return Ok(default);
        };
        match &p.values {
            Values::Bools(b) if b.len() == 1 && p.ty == "bool" => Ok(b[0]),
            _ => Err(format!(
                "{}: {}: \"{} {name}\" must be one bool",
                st.loc, st.dir, p.ty
            )),
        }
    }

    /// A string parameter.
    fn string(st: &Stmt, name: &str) -> Result<Option<String>, String> {
        let Some(p) = Self::param(st, name) else {
            return Ok(None);
        };
        match &p.values {
            Values::Strs(s) if s.len() == 1 && p.ty == "string" => Ok(Some(s[0].clone())),
            _ => Err(format!(
                "{}: {}: \"{} {name}\" must be one string",
                st.loc, st.dir, p.ty
            )),
        }
    }

    /// A point parameter (`point3`/`point`, or a vector), if present: exactly one point.
    fn point3(st: &Stmt, name: &str, default: [f64; 3]) -> Result<DVec3, String> {
        match Self::nums(st, name, &["point3", "point", "vector3", "vector"])? {
            Some(v) if v.len() == 3 => Ok(DVec3::new(v[0].0, v[1].0, v[2].0)),
            Some(_) => Err(format!(
                "{}: {}: \"{name}\" takes three numbers",
                st.loc, st.dir
            )),
            None => Ok(DVec3::from_array(default)),
        }
    }

    /// A texture reference's constant value (`None`, with a warning, for an unknown or
    /// non-constant texture).
    fn texture(&mut self, st: &Stmt, p: &Param) -> Result<Option<TexVal>, String> {
        let name = match &p.values {
            Values::Strs(s) if s.len() == 1 => s[0].clone(),
            _ => {
                return Err(format!(
                    "{}: {}: \"texture {}\" must name one texture",
                    st.loc, st.dir, p.name
                ))
            }
        };
        match self.textures.get(&name) {
            Some(Some(v)) => Ok(Some(*v)),
            Some(None) => {
                self.warn(
                    st,
                    &format!(
                        "parameter \"{}\": texture \"{name}\" is not constant: the default value",
                        p.name
                    ),
                );
                Ok(None)
            }
            None => Err(format!(
                "{}: {}: texture \"{name}\" is not defined",
                st.loc, st.dir
            )),
        }
    }

    /// A colour parameter: `rgb`, `blackbody` (luminance 1), a float (grey), a texture's
    /// constant value; a `spectrum` gets a warning and `default`.
    fn colour(&mut self, st: &Stmt, name: &str, default: Rgb) -> Result<Rgb, String> {
        let Some(p) = Self::param(st, name) else {
            return Ok(default);
        };
        let bad = || {
            format!(
                "{}: {}: parameter \"{} {name}\" has the wrong number or kind of values",
                st.loc, st.dir, p.ty
            )
        };
        match (p.ty.as_str(), &p.values) {
            ("rgb" | "color", Values::Nums(v)) if v.len() == 3 => {
                Ok(Rgb::new(v[0].1, v[1].1, v[2].1))
            }
            ("blackbody", Values::Nums(v)) if !v.is_empty() && v[0].0 > 0.0 => {
                Ok(blackbody(v[0].0))
            }
            ("float", Values::Nums(v)) if v.len() == 1 => Ok(Rgb::grey(v[0].1)),
            ("texture", _) => Ok(match self.texture(st, p)? {
                Some(TexVal::Colour(c)) => c,
                Some(TexVal::Float(v)) => Rgb::grey(v),
                None => default,
            }),
            ("spectrum", _) => {
                self.warn(
                    st,
                    &format!(
                        "parameter \"spectrum {name}\": spectra are not supported: {default:?}"
                    ),
                );
                Ok(default)
            }
            _ => Err(bad()),
        }
    }

    /// Applies a transform directive to the CTM (unless only the end time is active).
    fn transform(&mut self, m: DMat4, replace: bool) {
        if self.active_start {
            self.gs.ctm = if replace { m } else { self.gs.ctm * m };
            self.lookat = None;
        }
    }

    /// The material that `st` describes with its type `ty`.
    fn material(&mut self, st: &Stmt, ty: &str) -> Result<Surf, String> {
        let remap = Self::boolean(st, "remaproughness", true)?;
        let roughness = |r: &mut Reader| -> Result<f32, String> {
            let rough = r.float(st, "roughness", 0.0)?;
            let u = r.float(st, "uroughness", rough)?;
            let v = r.float(st, "vroughness", rough)?;
            if u != v {
                r.warn(
                    st,
                    &format!("anisotropic roughness {u}, {v}: their mean (the library's GGX is isotropic)"),
                );
            }
            Ok(alpha_of(0.5 * (u + v), remap))
        };
        let clamp = |c: Rgb| c.map(|v| v.clamp(0.0, 1.0));
        Ok(Surf::Material(match ty {
            "diffuse" => Material::Lambert {
                albedo: clamp(self.colour(st, "reflectance", Rgb::grey(0.5))?),
            },
            "diffusetransmission" => Material::Lambert {
                albedo: clamp(self.colour(st, "reflectance", Rgb::grey(0.25))?),
            },
            "coateddiffuse" => {
                let eta = self.float(st, "eta", 1.5)?;
                let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
                Material::Plastic {
                    albedo: clamp(self.colour(st, "reflectance", Rgb::grey(0.5))?),
                    specular: if f0.is_finite() {
                        f0.clamp(0.0, 1.0)
                    } else {
                        1.0
                    },
                    alpha: roughness(self)?,
                }
            }
            "conductor" => {
                let alpha = roughness(self)?;
                let specular = if st.params.iter().any(|p| p.name == "reflectance") {
                    self.colour(st, "reflectance", Rgb::ONE)?.luminance()
                } else if st
                    .params
                    .iter()
                    .any(|p| p.name == "eta" && p.ty != "spectrum")
                {
                    let eta = self.colour(st, "eta", Rgb::ONE)?;
                    let k = self.colour(st, "k", Rgb::ZERO)?;
                    let f =
                        |n: f32, k: f32| ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
                    Rgb::new(f(eta.r, k.r), f(eta.g, k.g), f(eta.b, k.b)).luminance()
                } else {
                    if st.params.iter().any(|p| p.name == "eta" || p.name == "k") {
                        self.warn(
                            st,
                            "named or sampled spectra for eta and k are not supported: specular 1",
                        );
                        for p in &st.params {
                            if p.name == "eta" || p.name == "k" {
                                p.used.set(true);
                            }
                        }
                    }
                    1.0
                };
                Material::Ggx {
                    alpha,
                    specular: if specular.is_finite() {
                        specular.clamp(0.0, 1.0)
                    } else {
                        1.0
                    },
                }
            }
            "dielectric" | "thindielectric" => {
                // The index of refraction does not change a mirror-like reflection's lobe.
                if let Some(p) = st.params.iter().find(|p| p.name == "eta") {
                    p.used.set(true);
                }
                Material::Ggx {
                    alpha: roughness(self)?,
                    specular: 1.0,
                }
            }
            "interface" | "" | "none" => {
                self.warn(st, "an interface (no surface): its shapes are left out");
                return Ok(Surf::Interface);
            }
            other => {
                self.warn(
                    st,
                    &format!("material \"{other}\" is not supported: diffuse of reflectance 0.5"),
                );
                for p in &st.params {
                    p.used.set(true);
                }
                DEFAULT_MATERIAL
            }
        }))
    }

    /// Where new triangles and lights go: the object being defined, or the world.
    fn content(&mut self) -> &mut Content {
        match &mut self.object {
            Some((_, c)) => c,
            None => &mut self.world,
        }
    }

    /// The current surface; `Err` if a named material is not defined.
    fn surface(&self, st: &Stmt) -> Result<Surf, String> {
        match &self.gs.material {
            MatSel::Anon(s) => Ok(*s),
            MatSel::Named(n) => self.named.get(n).copied().ok_or_else(|| {
                format!(
                    "{}: {}: named material \"{n}\" is not defined",
                    st.loc, st.dir
                )
            }),
        }
    }

    /// Adds the triangles `tris` (object-space vertices, with optional per-vertex normals)
    /// under the CTM: area lights if an area light is active, reflecting triangles
    /// otherwise.
    fn mesh(
        &mut self,
        st: &Stmt,
        pos: &[(DVec3, [f32; 3])],
        normals: Option<&[DVec3]>,
        tris: &[[u32; 3]],
    ) -> Result<(), String> {
        let m = self.gs.ctm;
        let world: Vec<Vec3> = pos.iter().map(|&p| point(&m, p)).collect();
        let origin = format!("{}: {} \"{}\"", st.loc, st.dir, arg(st, 0));
        if let Some(area) = self.gs.area {
            let flip = self.gs.reverse ^ (linear(&m).determinant() < 0.0);
            let content = self.content();
            for t in tris {
                let v = t.map(|i| world[i as usize]);
                let flip = match normals {
                    Some(ns) => {
                        let ns: DVec3 = t.iter().map(|&i| normal(&m, ns[i as usize])).sum();
                        let g = (v[1] - v[0]).cross(v[2] - v[0]).as_dvec3();
                        g.dot(ns) < 0.0
                    }
                    None => flip,
                };
                content.lights.push(Light::Triangle {
                    vertices: if flip { [v[0], v[2], v[1]] } else { v },
                    radiance: area.radiance,
                    two_sided: area.two_sided,
                });
                content.origins.push(origin.clone());
            }
            return Ok(());
        }
        let material = match self.surface(st)? {
            Surf::Material(mat) => mat,
            Surf::Interface => return Ok(()),
        };
        if let Some(p) = world
            .iter()
            .find(|p| !p.is_finite() || p.abs().max_element() > manylights::MAX_COORDINATE)
        {
            return Err(format!(
                "{}: {}: vertex {p} is not finite or out of range",
                st.loc, st.dir
            ));
        }
        let content = self.content();
        for t in tris {
            let v = t.map(|i| world[i as usize]);
            // Zero-area triangles are never hit: leave them out.
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            if n.length_squared() > 0.0 && n.is_finite() {
                content
                    .triangles
                    .push(Triangle::new(v[0], v[1], v[2], material));
            }
        }
        Ok(())
    }

    /// `P` and `indices` of a mesh shape: the points, and the index list (checked against
    /// the points; `implicit` is the index list when `indices` is absent).
    fn points_indices(st: &Stmt, per: usize) -> Result<(Points, Vec<u32>), String> {
        let p = Self::nums(st, "P", &["point3", "point"])?.ok_or_else(|| {
            format!(
                "{}: Shape \"{}\": \"point3 P\" is missing",
                st.loc,
                arg(st, 0)
            )
        })?;
        if p.len() % 3 != 0 {
            return Err(format!(
                "{}: Shape \"{}\": \"P\" has {} numbers, not a multiple of 3",
                st.loc,
                arg(st, 0),
                p.len()
            ));
        }
        let pos: Vec<(DVec3, [f32; 3])> = p
            .chunks_exact(3)
            .map(|c| (DVec3::new(c[0].0, c[1].0, c[2].0), [c[0].1, c[1].1, c[2].1]))
            .collect();
        let idx: Vec<u32> = match Self::nums(st, "indices", &["integer"])? {
            Some(v) => {
                let mut out = Vec::with_capacity(v.len());
                for (k, &(d, _)) in v.iter().enumerate() {
                    if d.fract() != 0.0 || d < 0.0 || d >= pos.len() as f64 {
                        return Err(format!(
                            "{}: Shape \"{}\": index {k} ({d}) is not a vertex (0..{})",
                            st.loc,
                            arg(st, 0),
                            pos.len()
                        ));
                    }
                    out.push(d as u32);
                }
                out
            }
            None if pos.len() == per => (0..per as u32).collect(),
            None => {
                return Err(format!(
                    "{}: Shape \"{}\": \"integer indices\" is missing (needed unless there are {per} points)",
                    st.loc,
                    arg(st, 0)
                ))
            }
        };
        if idx.len() % per != 0 {
            return Err(format!(
                "{}: Shape \"{}\": {} indices, not a multiple of {per}",
                st.loc,
                arg(st, 0),
                idx.len()
            ));
        }
        Ok((pos, idx))
    }

    /// Per-vertex normals `N`, if given (one per point).
    fn normals(st: &Stmt, n_points: usize) -> Result<Option<Vec<DVec3>>, String> {
        match Self::nums(st, "N", &["normal", "normal3"])? {
            Some(v) if v.len() == 3 * n_points => Ok(Some(
                v.chunks_exact(3)
                    .map(|c| DVec3::new(c[0].0, c[1].0, c[2].0))
                    .collect(),
            )),
            Some(v) => Err(format!(
                "{}: Shape \"{}\": \"N\" has {} numbers for {n_points} points",
                st.loc,
                arg(st, 0),
                v.len()
            )),
            None => Ok(None),
        }
    }

    /// A `Shape` directive.
    fn shape(&mut self, st: &Stmt) -> Result<(), String> {
        // Shading attributes the mapping does not need.
        for p in &st.params {
            if matches!(p.name.as_str(), "uv" | "S" | "faceIndices") {
                p.used.set(true);
            }
        }
        match arg(st, 0) {
            "trianglemesh" => {
                let (pos, idx) = Self::points_indices(st, 3)?;
                let normals = Self::normals(st, pos.len())?;
                let tris: Vec<[u32; 3]> = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
                self.mesh(st, &pos, normals.as_deref(), &tris)?;
            }
            "bilinearmesh" => {
                let (pos, idx) = Self::points_indices(st, 4)?;
                Self::normals(st, pos.len())?;
                // Patch (p00, p10, p01, p11): triangles (p00, p10, p11) and (p00, p11, p01),
                // on the side of dp/du × dp/dv.
                let tris: Vec<[u32; 3]> = idx
                    .chunks_exact(4)
                    .flat_map(|c| [[c[0], c[1], c[3]], [c[0], c[3], c[2]]])
                    .collect();
                self.mesh(st, &pos, None, &tris)?;
            }
            "plymesh" => {
                let name = Self::string(st, "filename")?.ok_or_else(|| {
                    format!(
                        "{}: Shape \"plymesh\": \"string filename\" is missing",
                        st.loc
                    )
                })?;
                let path = self.resolve(&name);
                let ply = ply::read(&path).map_err(|e| {
                    format!("{}: Shape \"plymesh\": {}: {e}", st.loc, path.display())
                })?;
                self.mesh(st, &ply.positions, ply.normals.as_deref(), &ply.triangles)?;
            }
            "sphere" => {
                let radius = self.float(st, "radius", 1.0)?;
                let zmin = self.float(st, "zmin", -radius)?;
                let zmax = self.float(st, "zmax", radius)?;
                let phimax = self.float(st, "phimax", 360.0)?;
                if !(radius.is_finite() && radius > 0.0) {
                    return Err(format!(
                        "{}: Shape \"sphere\": radius must be positive (got {radius})",
                        st.loc
                    ));
                }
                if zmin > -radius || zmax < radius || phimax < 360.0 {
                    self.warn(
                        st,
                        "partial spheres (zmin, zmax, phimax) are not supported: the whole sphere",
                    );
                }
                if let Some(area) = self.gs.area {
                    let (s, uniform) = uniform_scale(&self.gs.ctm);
                    if !uniform {
                        self.warn(
                            st,
                            "a sphere light under a non-uniform scale: a sphere of the mean scale",
                        );
                    }
                    if self.gs.reverse {
                        self.warn(st, "ReverseOrientation: sphere lights emit outwards only");
                    }
                    let light = Light::Sphere {
                        center: self.gs.ctm.transform_point3(DVec3::ZERO).as_vec3(),
                        radius: (f64::from(radius) * s) as f32,
                        radiance: area.radiance,
                    };
                    let origin = format!("{}: Shape \"sphere\"", st.loc);
                    let c = self.content();
                    c.lights.push(light);
                    c.origins.push(origin);
                } else {
                    let (pos, tris) = sphere_mesh(f64::from(radius));
                    self.mesh(st, &pos, None, &tris)?;
                }
            }
            "disk" => {
                let height = self.float(st, "height", 0.0)?;
                let radius = self.float(st, "radius", 1.0)?;
                let inner = self.float(st, "innerradius", 0.0)?;
                let phimax = self.float(st, "phimax", 360.0)?;
                if !(radius.is_finite() && radius > 0.0) {
                    return Err(format!(
                        "{}: Shape \"disk\": radius must be positive (got {radius})",
                        st.loc
                    ));
                }
                if inner > 0.0 || phimax < 360.0 {
                    self.warn(
                        st,
                        "partial disks (innerradius, phimax) are not supported: the whole disk",
                    );
                }
                if let Some(area) = self.gs.area {
                    let m = self.gs.ctm;
                    let (s, uniform) = uniform_scale(&m);
                    if !uniform {
                        self.warn(
                            st,
                            "a disk light under a non-uniform scale: a disk of the mean scale",
                        );
                    }
                    let mut n = normal(&m, DVec3::Z).normalize();
                    if self.gs.reverse {
                        n = -n;
                    }
                    let light = Light::Disk {
                        center: m
                            .transform_point3(DVec3::new(0.0, 0.0, f64::from(height)))
                            .as_vec3(),
                        normal: n.as_vec3(),
                        radius: (f64::from(radius) * s) as f32,
                        radiance: area.radiance,
                        two_sided: area.two_sided,
                    };
                    let origin = format!("{}: Shape \"disk\"", st.loc);
                    let c = self.content();
                    c.lights.push(light);
                    c.origins.push(origin);
                } else {
                    let (pos, tris) = disk_mesh(f64::from(radius), f64::from(height));
                    self.mesh(st, &pos, None, &tris)?;
                }
            }
            other => {
                self.warn(
                    st,
                    &format!("shape \"{other}\" is not supported (left out)"),
                );
                for p in &st.params {
                    p.used.set(true);
                }
            }
        }
        Ok(())
    }

    /// A `LightSource` directive.
    fn light_source(&mut self, st: &Stmt) -> Result<(), String> {
        let m = self.gs.ctm;
        let scale = self.float(st, "scale", 1.0)?;
        if self.object.is_some() {
            self.warn(
                st,
                "a LightSource inside ObjectBegin is added once, not per instance",
            );
        }
        let light = match arg(st, 0) {
            "point" => {
                let i = self.colour(st, "I", Rgb::ONE)? * scale;
                let from = Self::point3(st, "from", [0.0; 3])?;
                Light::Point {
                    position: m.transform_point3(from).as_vec3(),
                    intensity: i,
                }
            }
            "spot" => {
                let i = self.colour(st, "I", Rgb::ONE)? * scale;
                let from = Self::point3(st, "from", [0.0; 3])?;
                let to = Self::point3(st, "to", [0.0, 0.0, 1.0])?;
                let cone = self.float(st, "coneangle", 30.0)?;
                let delta = self.float(st, "conedelta", 5.0)?;
                if !(cone > 0.0 && cone <= 180.0) {
                    return Err(format!(
                        "{}: LightSource \"spot\": coneangle must be in (0, 180] (got {cone})",
                        st.loc
                    ));
                }
                Light::Spot {
                    position: m.transform_point3(from).as_vec3(),
                    direction: m.transform_vector3(to - from).as_vec3(),
                    intensity: i,
                    half_angle: cone.to_radians(),
                    falloff_start: (cone - delta).clamp(0.0, cone).to_radians(),
                }
            }
            "distant" => {
                let l = self.colour(st, "L", Rgb::ONE)? * scale;
                let from = Self::point3(st, "from", [0.0; 3])?;
                let to = Self::point3(st, "to", [0.0, 0.0, 1.0])?;
                Light::Distant {
                    direction: m.transform_vector3(from - to).as_vec3(),
                    angular_radius: 0.0,
                    irradiance: l,
                }
            }
            "infinite" => {
                let l = if let Some(f) = Self::string(st, "filename")? {
                    self.warn(
                        st,
                        &format!("image map \"{f}\" is not read: a uniform sky of radiance 1 (times scale)"),
                    );
                    Rgb::ONE
                } else {
                    self.colour(st, "L", Rgb::ONE)?
                } * scale;
                if let Some(old) = self.sky {
                    self.warn(
                        st,
                        "a second infinite light: the skies' radiances are added",
                    );
                    self.sky = Some(old + l);
                } else {
                    self.sky = Some(l);
                }
                self.unused(st);
                return Ok(());
            }
            other => {
                self.warn(
                    st,
                    &format!("light \"{other}\" is not supported (left out)"),
                );
                for p in &st.params {
                    p.used.set(true);
                }
                return Ok(());
            }
        };
        self.unused(st);
        self.world.lights.push(light);
        self.world
            .origins
            .push(format!("{}: LightSource \"{}\"", st.loc, arg(st, 0)));
        Ok(())
    }

    /// One statement.
    fn statement(&mut self, st: &Stmt) -> Result<(), String> {
        let loc = &st.loc;
        if matches!(
            st.dir.as_str(),
            "WorldBegin"
                | "WorldEnd"
                | "AttributeBegin"
                | "AttributeEnd"
                | "TransformBegin"
                | "TransformEnd"
                | "ObjectEnd"
                | "ReverseOrientation"
                | "Identity"
        ) && !st.args.is_empty()
        {
            return Err(format!("{loc}: {} takes no arguments", st.dir));
        }
        match st.dir.as_str() {
            "Identity" => {
                numbers(st, 0)?;
                self.transform(DMat4::IDENTITY, true);
            }
            "Translate" => {
                let v = numbers(st, 3)?;
                self.transform(DMat4::from_translation(DVec3::new(v[0], v[1], v[2])), false);
            }
            "Scale" => {
                let v = numbers(st, 3)?;
                self.transform(DMat4::from_scale(DVec3::new(v[0], v[1], v[2])), false);
            }
            "Rotate" => {
                let v = numbers(st, 4)?;
                let axis = DVec3::new(v[1], v[2], v[3]);
                if axis.length_squared() == 0.0 {
                    return Err(format!("{loc}: Rotate: the axis is zero"));
                }
                self.transform(
                    DMat4::from_axis_angle(axis.normalize(), v[0].to_radians()),
                    false,
                );
            }
            "LookAt" => {
                let v = numbers(st, 9)?;
                let eye = DVec3::new(v[0], v[1], v[2]);
                let look = DVec3::new(v[3], v[4], v[5]);
                let up = DVec3::new(v[6], v[7], v[8]);
                let dir = look - eye;
                let right = up.normalize_or_zero().cross(dir.normalize_or_zero());
                if dir.length_squared() == 0.0 || right.length_squared() <= 1e-20 {
                    return Err(format!(
                        "{loc}: LookAt: the eye is on the target, or up is along the view"
                    ));
                }
                let dir = dir.normalize();
                let right = right.normalize();
                let new_up = dir.cross(right);
                let world_from_camera = DMat4::from_cols(
                    right.extend(0.0),
                    new_up.extend(0.0),
                    dir.extend(0.0),
                    eye.extend(1.0),
                );
                let before = self.gs.ctm;
                let f32s = |k: usize| -> [f32; 3] {
                    let g = |i: usize| match &st.args[i] {
                        Tok::Num(_, s) => *s,
                        _ => 0.0,
                    };
                    [g(k), g(k + 1), g(k + 2)]
                };
                self.transform(world_from_camera.inverse(), false);
                let flip = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
                if self.active_start && (before == DMat4::IDENTITY || before == flip) {
                    self.lookat = Some(LookAt {
                        eye: f32s(0),
                        target: f32s(3),
                        up: f32s(6),
                        mirrored: before == DMat4::IDENTITY,
                    });
                }
            }
            "Transform" | "ConcatTransform" => {
                let v = numbers(st, 16)?;
                let mut a = [0f64; 16];
                a.copy_from_slice(&v);
                // The numbers are the matrix's columns (pbrt transposes what it reads).
                let m = DMat4::from_cols_array(&a);
                self.transform(m, st.dir == "Transform");
            }
            "CoordinateSystem" => {
                self.coords.insert(arg(st, 0).to_string(), self.gs.ctm);
            }
            "CoordSysTransform" => match self.coords.get(arg(st, 0)) {
                Some(&m) => self.transform(m, true),
                None => {
                    let what = format!(
                        "coordinate system \"{}\" is not defined (ignored)",
                        arg(st, 0)
                    );
                    self.warn(st, &what);
                }
            },
            "ActiveTransform" => match st.args.first() {
                Some(Tok::Word(w)) if w == "StartTime" || w == "All" => self.active_start = true,
                Some(Tok::Word(w)) if w == "EndTime" => {
                    self.active_start = false;
                    self.warn(
                        st,
                        "motion is not supported: transforms for the end time are ignored",
                    );
                }
                _ => {
                    return Err(format!(
                        "{loc}: ActiveTransform takes StartTime, EndTime or All"
                    ))
                }
            },
            "TransformTimes" => self.warn(st, "motion is not supported (ignored)"),
            "ReverseOrientation" => self.gs.reverse = !self.gs.reverse,
            "AttributeBegin" | "TransformBegin" => {
                let kind = if st.dir == "AttributeBegin" {
                    Block::Attribute
                } else {
                    Block::Transform
                };
                self.stack.push((self.gs.clone(), kind, loc.clone()));
            }
            "AttributeEnd" | "TransformEnd" | "ObjectEnd" => {
                let want = match st.dir.as_str() {
                    "AttributeEnd" => Block::Attribute,
                    "TransformEnd" => Block::Transform,
                    _ => Block::Object,
                };
                match self.stack.pop() {
                    Some((gs, kind, _)) if kind == want => {
                        if kind == Block::Transform {
                            self.gs.ctm = gs.ctm;
                        } else {
                            self.gs = gs;
                        }
                    }
                    Some((_, _, open)) => {
                        return Err(format!(
                            "{loc}: {} does not close the block opened at {open}",
                            st.dir
                        ))
                    }
                    None => return Err(format!("{loc}: {} without a block to close", st.dir)),
                }
                if want == Block::Object {
                    if let Some((name, content)) = self.object.take() {
                        self.objects.insert(name, content);
                    }
                }
            }
            "Attribute" => {
                self.warn(st, "attribute defaults are not supported (ignored)");
                for p in &st.params {
                    p.used.set(true);
                }
            }
            "Camera" => {
                let fov = self.float(st, "fov", 90.0)?;
                if arg(st, 0) != "perspective" {
                    let what = format!(
                        "camera \"{}\" is not supported: a perspective camera of its transform",
                        arg(st, 0)
                    );
                    self.warn(st, &what);
                    for p in &st.params {
                        p.used.set(true);
                    }
                }
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(format!(
                        "{loc}: Camera: fov must be in (0, 180) (got {fov})"
                    ));
                }
                self.camera = Some((self.gs.ctm, fov, self.lookat));
                self.coords.insert("camera".into(), self.gs.ctm.inverse());
                self.unused(st);
            }
            "Film" => {
                let x = Self::int(st, "xresolution")?.unwrap_or(DEFAULT_FILM.0 as i64);
                let y = Self::int(st, "yresolution")?.unwrap_or(DEFAULT_FILM.1 as i64);
                if !(1..=1 << 16).contains(&x) || !(1..=1 << 16).contains(&y) {
                    return Err(format!(
                        "{loc}: Film: resolution {x} x {y} is out of range (1 to 65536)"
                    ));
                }
                self.film = Some((x as usize, y as usize));
                self.unused(st);
            }
            "Sampler" | "Integrator" | "Accelerator" | "PixelFilter" | "ColorSpace" | "Option"
            | "MakeNamedMedium" | "MediumInterface" => {
                let what = format!(
                    "{}ignored (mlrender's own direct lighting, no media)",
                    if arg(st, 0).is_empty() {
                        String::new()
                    } else {
                        format!("\"{}\" ", arg(st, 0))
                    }
                );
                self.warn(st, &what);
            }
            "WorldBegin" => {
                self.gs.ctm = DMat4::IDENTITY;
                self.lookat = None;
                self.coords.insert("world".into(), DMat4::IDENTITY);
            }
            "WorldEnd" => {}
            "Include" | "Import" => {
                if self.depth >= MAX_INCLUDE_DEPTH {
                    return Err(format!(
                        "{loc}: {}: nested more than {MAX_INCLUDE_DEPTH} deep",
                        st.dir
                    ));
                }
                let path = self.resolve(arg(st, 0));
                self.depth += 1;
                self.file(&path, Some(loc))?;
                self.depth -= 1;
            }
            "Texture" => {
                let (name, class) = (arg(st, 0).to_string(), arg(st, 2));
                let value = if class == "constant" {
                    let v = match arg(st, 1) {
                        "float" => Some(TexVal::Float(self.float(st, "value", 1.0)?)),
                        _ => Some(TexVal::Colour(self.colour(st, "value", Rgb::ONE)?)),
                    };
                    self.unused(st);
                    v
                } else {
                    self.warn(
                        st,
                        &format!("texture class \"{class}\" is not supported: materials using \"{name}\" take the parameter's default"),
                    );
                    None
                };
                self.textures.insert(name, value);
            }
            "Material" => {
                let s = self.material(st, arg(st, 0))?;
                self.gs.material = MatSel::Anon(s);
                self.unused(st);
            }
            "MakeNamedMaterial" => {
                let ty = Self::string(st, "type")?.ok_or_else(|| {
                    format!("{loc}: MakeNamedMaterial: \"string type\" is missing")
                })?;
                let s = self.material(st, &ty)?;
                self.named.insert(arg(st, 0).to_string(), s);
                self.unused(st);
            }
            "NamedMaterial" => self.gs.material = MatSel::Named(arg(st, 0).to_string()),
            "AreaLightSource" => {
                if arg(st, 0) == "diffuse" {
                    let l = self.colour(st, "L", Rgb::ONE)?;
                    let scale = self.float(st, "scale", 1.0)?;
                    let two_sided = Self::boolean(st, "twosided", false)?;
                    self.gs.area = Some(Area {
                        radiance: l * scale,
                        two_sided,
                    });
                    self.unused(st);
                } else {
                    let what = format!("area light \"{}\" is not supported (left out)", arg(st, 0));
                    self.warn(st, &what);
                    self.gs.area = None;
                }
            }
            "LightSource" => self.light_source(st)?,
            "Shape" => {
                self.shape(st)?;
                self.unused(st);
            }
            "ObjectBegin" => {
                if self.object.is_some() {
                    return Err(format!("{loc}: ObjectBegin inside another ObjectBegin"));
                }
                self.stack
                    .push((self.gs.clone(), Block::Object, loc.clone()));
                self.object = Some((arg(st, 0).to_string(), Content::default()));
            }
            "ObjectInstance" => {
                let name = arg(st, 0);
                let obj = self
                    .objects
                    .get(name)
                    .ok_or_else(|| {
                        format!("{loc}: ObjectInstance: object \"{name}\" is not defined")
                    })?
                    .clone();
                let m = self.gs.ctm;
                let mut lights = Vec::with_capacity(obj.lights.len());
                for l in &obj.lights {
                    match transform_light(l, &m) {
                        Some(l) => lights.push(l),
                        None => {
                            return Err(format!(
                            "{loc}: ObjectInstance \"{name}\": a sphere or disk light under a non-uniform scale"
                        ))
                        }
                    }
                }
                let tris: Vec<Triangle> = obj
                    .triangles
                    .iter()
                    .map(|t| {
                        let v = t.v.map(|p| point32(&m, p));
                        Triangle::new(v[0], v[1], v[2], t.material)
                    })
                    .collect();
                let origins: Vec<String> = obj
                    .origins
                    .iter()
                    .map(|o| format!("{o} (instance at {loc})"))
                    .collect();
                let c = self.content();
                c.triangles.extend(tris);
                c.lights.extend(lights);
                c.origins.extend(origins);
            }
            other => {
                let what = format!("directive {other} is not supported (ignored)");
                self.warn(st, &what);
            }
        }
        Ok(())
    }

    /// The scene from what was read.
    fn finish(mut self, path: &Path) -> Result<PbrtScene, String> {
        let file = path.display();
        let (res_x, res_y) = self.film.unwrap_or(DEFAULT_FILM);
        let (ctm, fov, lookat) = self.camera.unwrap_or((DMat4::IDENTITY, 90.0, None));
        // pbrt's fov is the shorter image side's.
        let fov_y = if res_y > res_x {
            (2.0 * ((f64::from(fov).to_radians() * 0.5).tan() * res_y as f64 / res_x as f64).atan())
                .to_degrees() as f32
        } else {
            fov
        };
        let (mut camera, mirrored) = match lookat {
            Some(l) => (
                Camera {
                    eye: Vec3::from_array(l.eye),
                    target: Vec3::from_array(l.target),
                    up: Vec3::from_array(l.up),
                    fov_y,
                },
                l.mirrored,
            ),
            None => {
                let w = ctm.inverse();
                let eye = w.transform_point3(DVec3::ZERO);
                let x = w.transform_vector3(DVec3::X);
                let y = w.transform_vector3(DVec3::Y);
                let z = w.transform_vector3(DVec3::Z);
                if !(eye.is_finite() && x.is_finite() && z.length_squared() > 0.0) {
                    return Err(format!("{file}: the camera's transform is not invertible"));
                }
                (
                    Camera {
                        eye: eye.as_vec3(),
                        target: (eye + z.normalize()).as_vec3(),
                        up: y.normalize().as_vec3(),
                        fov_y,
                    },
                    x.dot(z.cross(y)) < 0.0,
                )
            }
        };
        let Content {
            mut triangles,
            mut lights,
            origins,
        } = std::mem::take(&mut self.world);
        if mirrored {
            let m = |v: Vec3| Vec3::new(-v.x, v.y, v.z);
            camera.eye = m(camera.eye);
            camera.target = m(camera.target);
            camera.up = m(camera.up);
            for t in &mut triangles {
                *t = Triangle::new(m(t.v[0]), m(t.v[1]), m(t.v[2]), t.material);
            }
            for l in &mut lights {
                *l = mirror_light(l);
            }
        }
        if triangles.is_empty() {
            return Err(format!("{file}: no reflecting triangle (of non-zero area)"));
        }
        if lights.is_empty() && self.sky.is_none() {
            return Err(format!("{file}: no light"));
        }
        if let Err(e) = LightTree::build(&lights) {
            let origin = match e {
                BuildError::InvalidLight { index, .. } => origins
                    .get(index)
                    .map_or(String::new(), |o| format!(" (from {o})")),
                _ => String::new(),
            };
            return Err(format!("{file}: {e}{origin}"));
        }
        let lights = match self.sky {
            Some(radiance) => {
                if !(radiance.is_finite() && radiance.r >= 0.0 && radiance.g >= 0.0 && radiance.b >= 0.0) {
                    return Err(format!("{file}: the infinite light's radiance {radiance:?} is not finite and non-negative"));
                }
                LightSet::build_with_environment(
                    lights,
                    UniformSky { radiance },
                    &BuildOptions::default(),
                    &Serial,
                )
            }
            None => LightSet::build(lights),
        }
        .map_err(|e| format!("{file}: {e}"))?;
        Ok(PbrtScene {
            scene: RenderScene {
                name: super::obj::scene_name(path, "pbrt"),
                geometry: Geometry::new(triangles),
                lights,
                sky: None,
                camera,
            },
            warnings: self.warnings,
            film: self.film,
            mirrored,
        })
    }
}

/// A sphere of radius `r` about the origin as triangles (object space), the zero-area
/// halves at the poles left out.
fn sphere_mesh(r: f64) -> (Points, Vec<[u32; 3]>) {
    let (nu, nv) = (SPHERE_SEGMENTS, SPHERE_RINGS);
    let mut pos = Vec::new();
    for j in 0..=nv {
        let theta = std::f64::consts::PI * j as f64 / nv as f64;
        for i in 0..nu {
            let phi = 2.0 * std::f64::consts::PI * i as f64 / nu as f64;
            let p = DVec3::new(
                r * theta.sin() * phi.cos(),
                r * theta.sin() * phi.sin(),
                -r * theta.cos(),
            );
            pos.push((p, p.as_vec3().to_array()));
        }
    }
    let id = |i: usize, j: usize| (j * nu + i % nu) as u32;
    let mut tris = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if j > 0 {
                tris.push([a, b, c]);
            }
            if j + 1 < nv {
                tris.push([a, c, d]);
            }
        }
    }
    (pos, tris)
}

/// A disk of radius `r` at height `h` on z as a triangle fan (object space).
fn disk_mesh(r: f64, h: f64) -> (Points, Vec<[u32; 3]>) {
    let n = DISK_SEGMENTS;
    let mut pos = vec![(
        DVec3::new(0.0, 0.0, h),
        DVec3::new(0.0, 0.0, h).as_vec3().to_array(),
    )];
    for i in 0..n {
        let phi = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
        let p = DVec3::new(r * phi.cos(), r * phi.sin(), h);
        pos.push((p, p.as_vec3().to_array()));
    }
    let tris = (0..n as u32)
        .map(|i| [0, 1 + i, 1 + (i + 1) % n as u32])
        .collect();
    (pos, tris)
}
