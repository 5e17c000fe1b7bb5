//! A tiny built-in bitmap font for captions on grey-level images (no font files, no font
//! crate).
//!
//! Each glyph is 5 × 7 pixels, one `u8` per row, top row first, bit 4 the leftmost pixel.
//! Covered: `a`–`z` (lower case; upper-case ASCII is drawn with the lower-case glyph), `0`–`9`,
//! `-`, `.`, `:`, `+`, `%`, `×` and space; any other character is drawn as a hollow box.
//! Lower case has no descender row: `g`, `j`, `p`, `q` and `y` sit on the baseline with a
//! shortened tail. Glyphs are set [`ADVANCE`] pixels apart (one blank column between them)
//! and magnified by an integer scale (nearest neighbour).

/// Glyph width in pixels (at scale 1).
pub const GLYPH_W: usize = 5;
/// Glyph height in pixels (at scale 1).
pub const GLYPH_H: usize = 7;
/// Horizontal distance between the left edges of two consecutive glyphs (at scale 1).
pub const ADVANCE: usize = GLYPH_W + 1;

/// The glyph drawn for a character the font does not cover: a hollow box.
const UNKNOWN: [u8; GLYPH_H] = [
    0b11111, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b11111,
];

/// The glyph table: a character and its rows, top first, bit 4 leftmost.
#[rustfmt::skip]
const GLYPHS: [(char, [u8; GLYPH_H]); 48] = [
    ('a', [0b00000, 0b00000, 0b01110, 0b00001, 0b01111, 0b10001, 0b01111]),
    ('b', [0b10000, 0b10000, 0b10110, 0b11001, 0b10001, 0b10001, 0b11110]),
    ('c', [0b00000, 0b00000, 0b01110, 0b10000, 0b10000, 0b10001, 0b01110]),
    ('d', [0b00001, 0b00001, 0b01101, 0b10011, 0b10001, 0b10001, 0b01111]),
    ('e', [0b00000, 0b00000, 0b01110, 0b10001, 0b11111, 0b10000, 0b01110]),
    ('f', [0b00110, 0b01001, 0b01000, 0b11100, 0b01000, 0b01000, 0b01000]),
    ('g', [0b00000, 0b00000, 0b01111, 0b10001, 0b01111, 0b00001, 0b01110]),
    ('h', [0b10000, 0b10000, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001]),
    ('i', [0b00100, 0b00000, 0b01100, 0b00100, 0b00100, 0b00100, 0b01110]),
    ('j', [0b00010, 0b00000, 0b00110, 0b00010, 0b00010, 0b10010, 0b01100]),
    ('k', [0b10000, 0b10000, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010]),
    ('l', [0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110]),
    ('m', [0b00000, 0b00000, 0b11010, 0b10101, 0b10101, 0b10101, 0b10101]),
    ('n', [0b00000, 0b00000, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001]),
    ('o', [0b00000, 0b00000, 0b01110, 0b10001, 0b10001, 0b10001, 0b01110]),
    ('p', [0b00000, 0b00000, 0b11110, 0b10001, 0b11110, 0b10000, 0b10000]),
    ('q', [0b00000, 0b00000, 0b01111, 0b10001, 0b01111, 0b00001, 0b00001]),
    ('r', [0b00000, 0b00000, 0b10110, 0b11001, 0b10000, 0b10000, 0b10000]),
    ('s', [0b00000, 0b00000, 0b01111, 0b10000, 0b01110, 0b00001, 0b11110]),
    ('t', [0b01000, 0b01000, 0b11100, 0b01000, 0b01000, 0b01001, 0b00110]),
    ('u', [0b00000, 0b00000, 0b10001, 0b10001, 0b10001, 0b10011, 0b01101]),
    ('v', [0b00000, 0b00000, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100]),
    ('w', [0b00000, 0b00000, 0b10001, 0b10001, 0b10101, 0b10101, 0b01010]),
    ('x', [0b00000, 0b00000, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001]),
    ('y', [0b00000, 0b00000, 0b10001, 0b10001, 0b01111, 0b00001, 0b01110]),
    ('z', [0b00000, 0b00000, 0b11111, 0b00010, 0b00100, 0b01000, 0b11111]),
    ('0', [0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110]),
    ('1', [0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110]),
    ('2', [0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111]),
    ('3', [0b11111, 0b00010, 0b00100, 0b00010, 0b00001, 0b10001, 0b01110]),
    ('4', [0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010]),
    ('5', [0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110]),
    ('6', [0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110]),
    ('7', [0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000]),
    ('8', [0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110]),
    ('9', [0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100]),
    ('-', [0b00000, 0b00000, 0b00000, 0b00000, 0b01110, 0b00000, 0b00000]),
    ('.', [0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b01100]),
    (':', [0b00000, 0b01100, 0b01100, 0b00000, 0b01100, 0b01100, 0b00000]),
    ('+', [0b00000, 0b00000, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100]),
    ('%', [0b11000, 0b11001, 0b00010, 0b00100, 0b01000, 0b10011, 0b00011]),
    ('×', [0b00000, 0b00000, 0b00000, 0b01010, 0b00100, 0b01010, 0b00000]),
    (' ', [0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b00000]),
    ('(', [0b00010, 0b00100, 0b01000, 0b01000, 0b01000, 0b00100, 0b00010]),
    (')', [0b01000, 0b00100, 0b00010, 0b00010, 0b00010, 0b00100, 0b01000]),
    ('/', [0b00000, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b00000]),
    ('=', [0b00000, 0b00000, 0b11111, 0b00000, 0b11111, 0b00000, 0b00000]),
    ('_', [0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b11111]),
];

/// The rows of `c`'s glyph (top first, bit 4 leftmost), `None` if the font does not cover it.
/// Upper-case ASCII letters give their lower-case glyph.
pub fn glyph(c: char) -> Option<[u8; GLYPH_H]> {
    let c = c.to_ascii_lowercase();
    GLYPHS.iter().find(|(g, _)| *g == c).map(|&(_, rows)| rows)
}

/// Width in pixels of `text` drawn at `scale` by [`draw_text`]: from the left edge of the first
/// glyph to the right edge of the last (0 for an empty text).
pub fn text_width(text: &str, scale: usize) -> usize {
    match text.chars().count() {
        0 => 0,
        n => (n * ADVANCE - 1) * scale,
    }
}

/// The longest prefix of `text` (whole characters) whose [`text_width`] at `scale` is at most
/// `max_width`.
pub fn truncate(text: &str, scale: usize, max_width: usize) -> &str {
    let fit = (max_width + scale) / (ADVANCE * scale).max(1);
    match text.char_indices().nth(fit) {
        Some((end, _)) => &text[..end],
        None => text,
    }
}

/// Draws `text` into the row-major grey-level buffer `buf` (`width` pixels per row), its top
/// left corner at (`x`, `y`), each glyph pixel a `scale × scale` block set to `value`. Only
/// glyph pixels are written (the background is left as it is); what falls outside the buffer
/// is clipped.
pub fn draw_text(
    buf: &mut [f32],
    width: usize,
    x: usize,
    y: usize,
    text: &str,
    scale: usize,
    value: f32,
) {
    if width == 0 {
        return;
    }
    let height = buf.len() / width;
    for (i, c) in text.chars().enumerate() {
        let rows = glyph(c).unwrap_or(UNKNOWN);
        let gx = x + i * ADVANCE * scale;
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..GLYPH_W {
                if (bits >> (GLYPH_W - 1 - col)) & 1 == 0 {
                    continue;
                }
                for py in y + r * scale..(y + (r + 1) * scale).min(height) {
                    let row = &mut buf[py * width..(py + 1) * width];
                    let px0 = (gx + col * scale).min(width);
                    let px1 = (px0 + scale).min(width);
                    row[px0..px1].fill(value);
                }
            }
        }
    }
}
