//! Comparison images: panels side by side, a row of magnified crops, caption strips.

use super::{font, Image, Pixel};

/// Images side by side (same height), separated by `gap` black columns.
pub fn side_by_side(images: &[&Image], gap: usize) -> (usize, usize, Vec<Pixel>) {
    let h = images.first().map_or(0, |i| i.height);
    let w: usize =
        images.iter().map(|i| i.width).sum::<usize>() + gap * images.len().saturating_sub(1);
    let mut out = vec![[0f32; 3]; w * h];
    let mut x0 = 0;
    for img in images {
        for y in 0..h.min(img.height) {
            out[y * w + x0..y * w + x0 + img.width]
                .copy_from_slice(&img.mean[y * img.width..(y + 1) * img.width]);
        }
        x0 += img.width + gap;
    }
    (w, h, out)
}

/// The part of a `width × height` image that the crops row of [`side_by_side_with_crops`]
/// magnifies 2×: its lower middle quarter, as inclusive pixel bounds `(x0, y0, x1, y1)`
/// (columns w/4 to w/4 + (w − 1)/2, rows h/2 to the last).
pub fn crop_region(width: usize, height: usize) -> (usize, usize, usize, usize) {
    let (x0, y0) = (width / 4, height / 2);
    let x1 = (x0 + width.saturating_sub(1) / 2).min(width.saturating_sub(1));
    let y1 = (y0 + height.saturating_sub(1) / 2).min(height.saturating_sub(1));
    (x0, y0, x1, y1)
}

/// The crops row: each image's [`crop_region`] magnified 2× (nearest neighbour), `w` wide
/// and `h` high, placed as in [`side_by_side`].
fn crops_row(images: &[&Image], gap: usize, w: usize, h: usize) -> Vec<Pixel> {
    let mut row = vec![[0f32; 3]; w * h];
    let mut x0 = 0;
    for img in images {
        let (iw, ih) = (img.width, img.height);
        let (cx, cy, _, _) = crop_region(iw, ih);
        for y in 0..h.min(ih) {
            for x in 0..iw {
                let sx = (cx + x / 2).min(iw - 1);
                let sy = (cy + y / 2).min(ih - 1);
                row[y * w + x0 + x] = img.mean[sy * iw + sx];
            }
        }
        x0 += iw + gap;
    }
    row
}

/// [`side_by_side`] with a second row: each image's crop of its lower middle quarter
/// ([`crop_region`]), magnified 2× (nearest neighbour), below it, `gap` black rows between.
pub fn side_by_side_with_crops(images: &[&Image], gap: usize) -> (usize, usize, Vec<Pixel>) {
    let (w, h, top) = side_by_side(images, gap);
    let mut out = top;
    out.extend(std::iter::repeat_n([0.0; 3], w * gap));
    out.extend(crops_row(images, gap, w, h));
    (w, 2 * h + gap, out)
}

/// Outlines each image's [`crop_region`] on the side-by-side row `top` (`w` wide): a 1-pixel
/// line inside the region's border, in dashes of two white (1.0) and two black pixels so that
/// it shows on bright and dark areas alike.
fn outline_crop_regions(top: &mut [Pixel], w: usize, images: &[&Image], gap: usize) {
    let h = top.len().checked_div(w).unwrap_or(0);
    let mut x0 = 0;
    for img in images {
        let (ax, ay, bx, by) = crop_region(img.width, img.height);
        let mut set = |x: usize, y: usize| {
            if y < h {
                top[y * w + x0 + x] = if (x + y) / 2 % 2 == 0 {
                    [1.0; 3]
                } else {
                    [0.0; 3]
                };
            }
        };
        if img.width > 0 && img.height > 0 {
            for x in ax..=bx {
                set(x, ay);
                set(x, by);
            }
            for y in ay..=by {
                set(ax, y);
                set(bx, y);
            }
        }
        x0 += img.width + gap;
    }
}

/// Height in pixels of the caption strip of [`side_by_side_labelled`] at font scale `scale`:
/// the glyph height and a black margin of `scale` pixels above and below.
pub fn caption_height(scale: usize) -> usize {
    (font::GLYPH_H + 2) * scale
}

/// The font scale of the captions of [`side_by_side_labelled`]: 2 if every label fits above
/// its image at ×2 (with a margin of 2 pixels on the left), 1 otherwise.
pub fn caption_scale(panels: &[(&str, &Image)]) -> usize {
    let fits = |label: &str, img: &Image| 2 + font::text_width(label, 2) <= img.width;
    if panels.iter().all(|&(label, img)| fits(label, img)) {
        2
    } else {
        1
    }
}

/// The labelled comparison image: [`side_by_side_with_crops`] of the images, with a caption
/// strip on top — each panel's label in white (1.0) on black, centred above it, in the
/// built-in [`font`] at [`caption_scale`] (a label too long for its panel even at ×1 is cut
/// short) — and each image's [`crop_region`] outlined on the top row (1 pixel, dashed white
/// and black), so that the crops row needs no labels of its own. Returns width, height
/// ([`caption_height`] + 2 × image height + `gap`) and the values.
pub fn side_by_side_labelled(panels: &[(&str, &Image)], gap: usize) -> (usize, usize, Vec<Pixel>) {
    if panels.is_empty() {
        return (0, 0, Vec::new());
    }
    let images: Vec<&Image> = panels.iter().map(|&(_, img)| img).collect();
    let (w, h, mut top) = side_by_side(&images, gap);
    outline_crop_regions(&mut top, w, &images, gap);
    let scale = caption_scale(panels);
    let strip = caption_height(scale);
    let mut strip_values = vec![0f32; w * strip];
    let mut x0 = 0;
    for &(label, img) in panels {
        let text = font::truncate(label, scale, img.width.saturating_sub(scale));
        let dx = (img.width.saturating_sub(font::text_width(text, scale)) / 2).max(scale);
        font::draw_text(&mut strip_values, w, x0 + dx, scale, text, scale, 1.0);
        x0 += img.width + gap;
    }
    let mut out: Vec<Pixel> = strip_values.into_iter().map(|v| [v; 3]).collect();
    out.extend(top);
    out.extend(std::iter::repeat_n([0.0; 3], w * gap));
    out.extend(crops_row(&images, gap, w, h));
    (w, strip + 2 * h + gap, out)
}
