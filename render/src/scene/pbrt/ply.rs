//! PLY meshes of `Shape "plymesh"`, read with the `ply-rs-bw` crate (ASCII, binary little and
//! big endian): vertex positions `x y z` (float or double), optional normals `nx ny nz`, and
//! faces `vertex_indices` (or `vertex_index`) of three or four vertices, quads split into
//! the triangles (0 1 2) and (0 2 3). Other properties (uv, colours, `face_indices`) are
//! ignored.

use glam::DVec3;
use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{DefaultElement, Property};
use std::path::Path;

/// A mesh read from a PLY file.
#[derive(Clone, Debug, PartialEq)]
pub struct PlyMesh {
    /// Vertex positions (double and single precision, as in the file).
    pub positions: Vec<(DVec3, [f32; 3])>,
    /// Per-vertex normals, if the file has them.
    pub normals: Option<Vec<DVec3>>,
    /// Triangles (quads split).
    pub triangles: Vec<[u32; 3]>,
}

/// A scalar property as a number.
fn scalar(p: &Property) -> Option<(f64, f32)> {
    Some(match *p {
        Property::Float(v) => (f64::from(v), v),
        Property::Double(v) => (v, v as f32),
        Property::Char(v) => (f64::from(v), f32::from(v)),
        Property::UChar(v) => (f64::from(v), f32::from(v)),
        Property::Short(v) => (f64::from(v), f32::from(v)),
        Property::UShort(v) => (f64::from(v), f32::from(v)),
        Property::Int(v) => (f64::from(v), v as f32),
        Property::UInt(v) => (f64::from(v), v as f32),
        _ => return None,
    })
}

/// An index list as `i64`s.
fn list(p: &Property) -> Option<Vec<i64>> {
    Some(match p {
        Property::ListChar(v) => v.iter().map(|&x| i64::from(x)).collect(),
        Property::ListUChar(v) => v.iter().map(|&x| i64::from(x)).collect(),
        Property::ListShort(v) => v.iter().map(|&x| i64::from(x)).collect(),
        Property::ListUShort(v) => v.iter().map(|&x| i64::from(x)).collect(),
        Property::ListInt(v) => v.iter().map(|&x| i64::from(x)).collect(),
        Property::ListUInt(v) => v.iter().map(|&x| i64::from(x)).collect(),
        _ => return None,
    })
}

/// Reads the PLY file at `path`. `Err` says what is wrong (the caller adds the file and the
/// line of the `Shape`): it cannot be read or parsed, positions are missing or not finite,
/// a face has fewer than three or more than four vertices, or an index is out of range.
pub fn read(path: &Path) -> Result<PlyMesh, String> {
    let mut f = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut f)
        .map_err(|e| format!("not a readable PLY file: {e}"))?;
    let vertices = ply.payload.get("vertex").ok_or("no \"vertex\" element")?;
    let mut positions = Vec::with_capacity(vertices.len());
    let mut normals = Some(Vec::with_capacity(vertices.len()));
    for (k, v) in vertices.iter().enumerate() {
        let c = |name: &str| -> Result<(f64, f32), String> {
            let p = v
                .get(name)
                .ok_or_else(|| format!("vertex {k} has no property {name}"))?;
            match scalar(p) {
                Some(x) if x.0.is_finite() && x.1.is_finite() => Ok(x),
                _ => Err(format!("vertex {k}: {name} is not a finite number")),
            }
        };
        let (x, y, z) = (c("x")?, c("y")?, c("z")?);
        positions.push((DVec3::new(x.0, y.0, z.0), [x.1, y.1, z.1]));
        if let Some(ns) = normals.as_mut() {
            match (v.get("nx"), v.get("ny"), v.get("nz")) {
                (Some(a), Some(b), Some(c)) => match (scalar(a), scalar(b), scalar(c)) {
                    (Some(a), Some(b), Some(c)) => ns.push(DVec3::new(a.0, b.0, c.0)),
                    _ => normals = None,
                },
                _ => normals = None,
            }
        }
    }
    let mut triangles = Vec::new();
    if let Some(faces) = ply.payload.get("face") {
        for (k, f) in faces.iter().enumerate() {
            let idx = f
                .get("vertex_indices")
                .or_else(|| f.get("vertex_index"))
                .and_then(list)
                .ok_or_else(|| format!("face {k} has no integer list vertex_indices"))?;
            let mut ix = [0u32; 4];
            for (j, &i) in idx.iter().enumerate().take(4) {
                if i < 0 || i as usize >= positions.len() {
                    return Err(format!(
                        "face {k}: vertex index {i} out of range (0..{})",
                        positions.len()
                    ));
                }
                ix[j] = i as u32;
            }
            match idx.len() {
                3 => triangles.push([ix[0], ix[1], ix[2]]),
                4 => {
                    triangles.push([ix[0], ix[1], ix[2]]);
                    triangles.push([ix[0], ix[2], ix[3]]);
                }
                n => {
                    return Err(format!(
                        "face {k} has {n} vertices (triangles and quads only)"
                    ))
                }
            }
        }
    }
    Ok(PlyMesh {
        positions,
        normals,
        triangles,
    })
}
