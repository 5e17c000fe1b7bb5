//! Images: the linear RGB [`Image`] a render produces, its files ([`io`]: PNG, linear
//! OpenEXR, a raw cache format), side-by-side comparisons with captions and magnified crops
//! ([`compose`], in the built-in bitmap [`font`]) and convergence plots ([`plot`]).

pub mod compose;
pub mod font;
pub mod io;
pub mod plot;

pub use compose::{
    caption_height, caption_scale, crop_region, side_by_side, side_by_side_labelled,
    side_by_side_with_crops,
};
pub use io::{is_exr, read_raw, tone_map, write_exr, write_image, write_png, write_raw};
pub use plot::convergence_svg;

/// One pixel: linear red, green and blue.
pub type Pixel = [f32; 3];

/// The grey pixel of `v`.
#[inline]
pub fn grey(v: f32) -> Pixel {
    [v; 3]
}

/// The mean of a pixel's three channels, in f64 (exactly `v` for a grey `v`).
#[inline]
pub fn channel_mean(p: Pixel) -> f64 {
    (f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2])) / 3.0
}

/// A rendered image in linear RGB: per-pixel mean and per-estimate variance, per channel.
#[derive(Clone, Debug)]
pub struct Image {
    /// Width.
    pub width: usize,
    /// Height.
    pub height: usize,
    /// Mean of the estimates, row-major.
    pub mean: Vec<Pixel>,
    /// Per-estimate sample variance of each pixel and channel (0 with one estimate).
    pub var: Vec<Pixel>,
    /// Estimates per pixel.
    pub spp: usize,
    /// Busy seconds of the render: the CPU time spent on its rows, summed over the threads
    /// that rendered them (see the module documentation). 0 for an image read from disk.
    pub seconds: f64,
    /// Wall-clock seconds of the render. 0 for an image read from disk.
    pub wall_seconds: f64,
    /// Estimates (and shading points' set-ups) the core refused with an error, each counted
    /// as black: 0 unless the renderer hands the core something it rejects. 0 for an image
    /// read from disk.
    pub failed: u64,
}

/// A warning on stderr when `failed` estimates of `what` were refused by the core (each
/// counted as black: [`Image::failed`]); nothing when there were none.
pub fn warn_failed(what: &str, failed: u64) {
    if failed > 0 {
        eprintln!("warning: {failed} estimates of {what} failed (counted as black)");
    }
}

impl Image {
    /// The average over pixels of the pixel means' channel mean ([`channel_mean`]).
    pub fn average(&self) -> f64 {
        self.mean.iter().map(|&v| channel_mean(v)).sum::<f64>() / self.mean.len() as f64
    }

    /// Standard error of [`Image::average`] from the per-pixel variances (each pixel's
    /// channel-mean variance taken as the mean of its channels' variances: exact for grey
    /// images, an upper bound for colour ones).
    pub fn average_se(&self) -> f64 {
        let n = self.mean.len() as f64;
        let s: f64 = self.var.iter().map(|&v| channel_mean(v)).sum();
        (s / self.spp.max(1) as f64).sqrt() / n
    }

    /// The squared difference to `other` (same size) at every pixel, row-major, averaged over
    /// the three channels: the per-pixel error every RMSE and error split of the renderer sums.
    pub fn squared_errors(&self, other: &Image) -> Vec<f64> {
        self.mean
            .iter()
            .zip(&other.mean)
            .map(|(a, b)| {
                (0..3)
                    .map(|c| (f64::from(a[c]) - f64::from(b[c])).powi(2))
                    .sum::<f64>()
                    / 3.0
            })
            .collect()
    }

    /// The variance of each pixel's mean estimated from the image's own estimates, averaged
    /// over the three channels: the per-estimate sample variance over the number of
    /// estimates, row-major (0 everywhere below 2 estimates, where there is no estimate of it).
    pub fn mean_variances(&self) -> Vec<f64> {
        let spp = self.spp;
        self.var
            .iter()
            .map(|&v| {
                if spp >= 2 {
                    channel_mean(v) / spp as f64
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// Root mean square difference to `other` (same size), over the three channels of every
    /// pixel: the root of the mean of [`Image::squared_errors`].
    pub fn rmse(&self, other: &Image) -> f64 {
        let s: f64 = self.squared_errors(other).iter().sum();
        (s / self.mean.len() as f64).sqrt()
    }
}
