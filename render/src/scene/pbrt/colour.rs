//! The linear sRGB colour of a blackbody, normalised as pbrt-v4 normalises its lights'
//! spectra: luminance 1 (pbrt-v4 divides a light's `scale` by the spectrum's photometric
//! value; an RGB light colour is taken as it is, a blackbody is brought to luminance 1).

use manylights::Rgb;

/// A piecewise Gaussian (two widths either side of the mean).
fn g(l: f64, mu: f64, s1: f64, s2: f64) -> f64 {
    let s = if l < mu { s1 } else { s2 };
    let t = (l - mu) / s;
    (-0.5 * t * t).exp()
}

/// The CIE 1931 colour matching functions at `l` nm (the multi-lobe fit of Wyman, Sloan and
/// Shirley 2013, within a few per cent of the tables).
fn cmf(l: f64) -> [f64; 3] {
    [
        1.056 * g(l, 599.8, 37.9, 31.0) + 0.362 * g(l, 442.0, 16.0, 26.7)
            - 0.065 * g(l, 501.1, 20.4, 26.2),
        0.821 * g(l, 568.8, 46.9, 40.5) + 0.286 * g(l, 530.9, 16.3, 31.1),
        1.217 * g(l, 437.0, 11.8, 36.0) + 0.681 * g(l, 459.0, 26.0, 13.8),
    ]
}

/// Planck's law at `l` nm and `t` kelvin (up to a constant factor).
fn planck(l: f64, t: f64) -> f64 {
    const C2: f64 = 1.438_776_9e7; // h c / k in nm·K
    let l5 = l.powi(5);
    1.0 / (l5 * ((C2 / (l * t)).exp_m1()))
}

/// The colour of a blackbody at `kelvin` (> 0) in linear sRGB (D65), of luminance 1:
/// the spectrum integrated against the colour matching functions (360–830 nm), converted
/// to sRGB, negative channels clamped to 0 and the result scaled to luminance 1.
#[must_use]
pub fn blackbody(kelvin: f64) -> Rgb {
    let mut xyz = [0f64; 3];
    for l in 360..=830 {
        let l = f64::from(l);
        let b = planck(l, kelvin);
        let c = cmf(l);
        for k in 0..3 {
            xyz[k] += b * c[k];
        }
    }
    let [x, y, z] = xyz.map(|v| v / xyz[1]);
    let rgb = [
        3.2406 * x - 1.5372 * y - 0.4986 * z,
        -0.9689 * x + 1.8758 * y + 0.0415 * z,
        0.0557 * x - 0.2040 * y + 1.0570 * z,
    ]
    .map(|v| v.max(0.0));
    let c = Rgb::new(rgb[0] as f32, rgb[1] as f32, rgb[2] as f32);
    c * (1.0 / c.luminance())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d65_like_blackbody_is_near_white_and_luminance_one() {
        let c = blackbody(6504.0);
        assert!((c.luminance() - 1.0).abs() < 1e-5);
        for v in [c.r, c.g, c.b] {
            assert!((v - 1.0).abs() < 0.12, "{c:?}");
        }
        let warm = blackbody(2700.0);
        assert!(warm.r > warm.g && warm.g > warm.b, "{warm:?}");
    }
}
