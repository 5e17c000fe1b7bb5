//! Command-line pieces shared by `mlrender` and the instruments' `mlmeasure`: the value parsers
//! of counts and image sizes, and the palette `--grey` selects.

use crate::scene::Palette;
use clap::builder::RangedU64ValueParser;

/// The parser of counts that must be at least 1 (spp, shading points).
#[must_use]
pub fn at_least_one() -> RangedU64ValueParser<usize> {
    RangedU64ValueParser::<usize>::new().range(1..)
}

/// The parser of image sizes: 1 to 16,384 pixels.
#[must_use]
pub fn image_size() -> RangedU64ValueParser<usize> {
    RangedU64ValueParser::<usize>::new().range(1..=16_384)
}

/// The scenes' palette: grey with `--grey`, colour otherwise.
#[must_use]
pub fn palette(grey: bool) -> Palette {
    if grey {
        Palette::Grey
    } else {
        Palette::Colour
    }
}
