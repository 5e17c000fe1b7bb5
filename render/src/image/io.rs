//! Image files: 8-bit sRGB PNG, linear f32 OpenEXR, and the raw f32 cache of references, all
//! in RGB.

use super::{Image, Pixel};
use std::io::{BufWriter, Write};
use std::path::Path;

/// Clamp to [0, 1] and encode as 8-bit sRGB.
pub fn tone_map(v: f32) -> u8 {
    let c = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// `e` with `path` in front of its message (same kind).
fn with_path(path: &Path, e: impl std::fmt::Display, kind: std::io::ErrorKind) -> std::io::Error {
    std::io::Error::new(kind, format!("{}: {e}", path.display()))
}

/// Creates the parent folder of `path` (an error names the folder).
fn create_parent(path: &Path) -> std::io::Result<()> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => std::fs::create_dir_all(dir).map_err(|e| {
            std::io::Error::new(
                e.kind(),
                format!("cannot create folder {}: {e}", dir.display()),
            )
        }),
        _ => Ok(()),
    }
}

/// Checks that `values` holds `width × height` values.
fn check_size(path: &Path, width: usize, height: usize, values: &[Pixel]) -> std::io::Result<()> {
    if width == 0 || height == 0 || width.checked_mul(height) != Some(values.len()) {
        return Err(with_path(
            path,
            format!("{} values for a {width}x{height} image", values.len()),
            std::io::ErrorKind::InvalidInput,
        ));
    }
    Ok(())
}

/// Writes linear RGB pixels (`width × height`, row-major) as an 8-bit sRGB PNG, each channel
/// clamped to [0, 1] (creating the folder if needed; errors name the file).
pub fn write_png(
    path: &Path,
    width: usize,
    height: usize,
    values: &[Pixel],
) -> std::io::Result<()> {
    check_size(path, width, height, values)?;
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(with_path(
            path,
            "image too large for PNG",
            std::io::ErrorKind::InvalidInput,
        ));
    };
    create_parent(path)?;
    let file = std::fs::File::create(path).map_err(|e| with_path(path, &e, e.kind()))?;
    let mut enc = png::Encoder::new(BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let other = |e| with_path(path, e, std::io::ErrorKind::Other);
    let mut writer = enc.write_header().map_err(other)?;
    let data: Vec<u8> = values.iter().flat_map(|p| p.map(tone_map)).collect();
    writer.write_image_data(&data).map_err(other)?;
    writer.finish().map_err(other)?;
    Ok(())
}

/// Writes linear RGB pixels (`width × height`, row-major) as a linear OpenEXR file: 32-bit
/// float R, G and B channels (what every viewer opens; no tone mapping, no clamping), scan
/// lines with lossless ZIP compression (the most widely read layout). Creates the folder if
/// needed; errors name the file.
pub fn write_exr(
    path: &Path,
    width: usize,
    height: usize,
    values: &[Pixel],
) -> std::io::Result<()> {
    use exr::prelude::{Encoding, SpecificChannels, Vec2, WritableImage};
    check_size(path, width, height, values)?;
    create_parent(path)?;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let [r, g, b] = values[y * width + x];
        (r, g, b)
    });
    exr::prelude::Image::from_encoded_channels((width, height), Encoding::SMALL_LOSSLESS, channels)
        .write()
        .to_file(path)
        .map_err(|e| match e {
            exr::error::Error::Io(io) => with_path(path, &io, io.kind()),
            e => with_path(path, e, std::io::ErrorKind::Other),
        })
}

/// Writes `values` with [`write_exr`] if `path` ends in `.exr` (any case), with [`write_png`]
/// otherwise.
pub fn write_image(
    path: &Path,
    width: usize,
    height: usize,
    values: &[Pixel],
) -> std::io::Result<()> {
    if is_exr(path) {
        write_exr(path, width, height, values)
    } else {
        write_png(path, width, height, values)
    }
}

/// Whether `path` ends in `.exr` (any case).
pub fn is_exr(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// Writes an image's means and variances as raw little-endian f32, three channels per pixel
/// (header: width, height, spp as u64).
/// Creates the folder if needed; errors name the file.
pub fn write_raw(path: &Path, img: &Image) -> std::io::Result<()> {
    create_parent(path)?;
    let write = || -> std::io::Result<()> {
        let mut f = BufWriter::new(std::fs::File::create(path)?);
        for v in [img.width as u64, img.height as u64, img.spp as u64] {
            f.write_all(&v.to_le_bytes())?;
        }
        for p in img.mean.iter().chain(&img.var) {
            for v in p {
                f.write_all(&v.to_le_bytes())?;
            }
        }
        f.flush()
    };
    write().map_err(|e| with_path(path, &e, e.kind()))
}

/// Reads what [`write_raw`] wrote (None if missing or malformed).
pub fn read_raw(path: &Path) -> Option<Image> {
    let bytes = std::fs::read(path).ok()?;
    let u = |i: usize| -> Option<usize> {
        Some(u64::from_le_bytes(bytes.get(i * 8..i * 8 + 8)?.try_into().ok()?) as usize)
    };
    let (width, height, spp) = (u(0)?, u(1)?, u(2)?);
    let n = width * height;
    let floats: Vec<f32> = bytes
        .get(24..)?
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    if floats.len() != 6 * n {
        return None;
    }
    let pixels: Vec<Pixel> = floats.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    Some(Image {
        width,
        height,
        mean: pixels[..n].to_vec(),
        var: pixels[n..].to_vec(),
        spp,
        seconds: 0.0,
        wall_seconds: 0.0,
        failed: 0,
    })
}
