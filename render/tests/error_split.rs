//! The error figures of `compare` on synthetic images with known variances: the reference's
//! variance subtracted from the MSE leaves the image's own error (within a tolerance from the
//! pixel count), the uncorrected ratio of two RMSEs is pulled towards 1 and the corrected one
//! is not, and every split of the squared error adds up to the whole.

use manylights_render::compare::error_split::{
    angle_bin, angle_name, corrected_rmse, split, Classes, ErrorSummary, ANGLE_BINS,
};
use manylights_render::image::grey;
use manylights_render::image::Image;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// A standard normal number (Box–Muller).
fn normal(rng: &mut Pcg64Mcg) -> f64 {
    let u: f64 = 1.0 - rng.random::<f64>();
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// An image of `w × h` pixels whose pixel `i` is the mean of `spp` draws of
/// `N(mu(i), sigma²)`, with their sample variance, as the renderer accumulates them.
fn noisy(
    w: usize,
    h: usize,
    spp: usize,
    mu: impl Fn(usize) -> f64,
    sigma: f64,
    rng: &mut Pcg64Mcg,
) -> Image {
    let (mut mean, mut var) = (Vec::new(), Vec::new());
    for i in 0..w * h {
        let xs: Vec<f64> = (0..spp).map(|_| mu(i) + sigma * normal(rng)).collect();
        let m = xs.iter().sum::<f64>() / spp as f64;
        let v = if spp > 1 {
            xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (spp - 1) as f64
        } else {
            0.0
        };
        mean.push(grey(m as f32));
        var.push(grey(v as f32));
    }
    Image {
        width: w,
        height: h,
        mean,
        var,
        spp,
        seconds: 0.0,
        wall_seconds: 0.0,
        failed: 0,
    }
}

#[test]
fn corrected_rmse_formula() {
    assert_eq!(corrected_rmse(0.25, 0.09), 0.4);
    assert_eq!(corrected_rmse(0.09, 0.09), 0.0);
    // More reference variance than squared error (possible by chance): 0, not NaN.
    assert_eq!(corrected_rmse(0.01, 0.09), 0.0);
    assert!(corrected_rmse(f64::NAN, 0.0).is_nan());
    // Image::mean_variances is the per-estimate variance over the spp; none below 2 spp.
    let img = Image {
        width: 2,
        height: 1,
        mean: vec![grey(1.0), grey(2.0)],
        var: vec![grey(0.5), grey(2.0)],
        spp: 4,
        seconds: 0.0,
        wall_seconds: 0.0,
        failed: 0,
    };
    assert_eq!(img.mean_variances(), vec![0.125, 0.5]);
    assert_eq!(
        Image {
            spp: 1,
            ..img.clone()
        }
        .mean_variances(),
        vec![0.0, 0.0]
    );
    let other = Image {
        mean: vec![grey(1.5), grey(0.0)],
        ..img.clone()
    };
    assert_eq!(img.squared_errors(&other), vec![0.25, 4.0]);
    assert_eq!(img.rmse(&other), (4.25f64 / 2.0).sqrt());
}

/// Images of known variance against a noisy reference of known variance: `MSE − V` estimates
/// the image's own variance, and the ratio of two images' corrected RMSEs their true ratio,
/// while the uncorrected ratio is pulled towards 1.
#[test]
fn subtracting_the_reference_variance_recovers_the_image_error() {
    let (w, h) = (128, 128);
    let p = (w * h) as f64;
    let mut rng = Pcg64Mcg::seed_from_u64(25);
    let mu = |i: usize| 0.2 + 0.6 * ((i * 7919) % 101) as f64 / 101.0;
    // Reference: 16 draws of σ 0.8 per pixel, Var(R) = 0.04.
    let (ref_spp, s) = (16, 0.8f64);
    let reference = noisy(w, h, ref_spp, mu, s, &mut rng);
    let v_true = s * s / ref_spp as f64;
    // Two images: 4 draws of σ 0.2 and of σ 0.4: Var(X) = 0.01 and 0.04.
    let a = noisy(w, h, 4, mu, 0.2, &mut rng);
    let b = noisy(w, h, 4, mu, 0.4, &mut rng);
    let ref_var = reference.mean_variances();
    let whole = |img: &Image| {
        let c = Classes {
            what: "material",
            names: vec![("all".into(), "lambert")],
            of_pixel: vec![0; w * h],
        };
        ErrorSummary::new(&img.squared_errors(&reference), &ref_var, &[c])
    };
    let (ea, eb) = (whole(&a), whole(&b));
    // V estimates Var(R): s_p² has variance 2s⁴/(n − 1), so V's is 2 v²/(n − 1)/P.
    let v_sd = (2.0 * v_true * v_true / (ref_spp - 1) as f64 / p).sqrt();
    assert!(
        (ea.ref_variance - v_true).abs() <= 5.0 * v_sd,
        "V {} against {v_true} (sd {v_sd})",
        ea.ref_variance
    );
    // Per image: the standard deviations of its MSE and of its MSE − V over the P pixels.
    let mut rel_sd = Vec::new();
    for (e, var_x) in [(&ea, 0.01f64), (&eb, 0.04)] {
        // E[(X − R)²] = Var(X) + Var(R); d² has variance 2(Var X + Var R)², and each
        // d² − V_p that plus Var V_p = 2 v²/(n − 1).
        let total = var_x + v_true;
        let sd_mse = (2.0 * total * total / p).sqrt();
        let sd = ((2.0 * total * total + 2.0 * v_true * v_true / (ref_spp - 1) as f64) / p).sqrt();
        assert!(
            (e.mse - total).abs() <= 5.0 * sd_mse,
            "MSE {} against {total}",
            e.mse
        );
        let corrected = e.mse - e.ref_variance;
        assert!(
            (corrected - var_x).abs() <= 5.0 * sd,
            "MSE − V = {corrected} against Var(X) = {var_x} (sd {sd})"
        );
        assert_eq!(e.rmse_corrected(), corrected.max(0.0).sqrt());
        rel_sd.push((sd_mse / total, sd / var_x));
    }
    // The true RMSE ratio is sqrt(0.01 / 0.04) = 0.5; with the reference's noise left in, it
    // reads sqrt(0.05 / 0.08) = 0.79. (A ratio of roots has half the quadrature sum of the
    // relative deviations as its own.)
    let raw = ea.rmse() / eb.rmse();
    let honest = ea.rmse_corrected() / eb.rmse_corrected();
    let raw_true = (0.05f64 / 0.08).sqrt();
    let raw_sd = raw_true * 0.5 * rel_sd[0].0.hypot(rel_sd[1].0);
    let honest_sd = 0.5 * 0.5 * rel_sd[0].1.hypot(rel_sd[1].1);
    assert!((raw - raw_true).abs() <= 5.0 * raw_sd, "raw ratio {raw}");
    assert!(
        (honest - 0.5).abs() <= 5.0 * honest_sd,
        "corrected ratio {honest} (sd {honest_sd})"
    );
    // The two are told apart: 0.79 against 0.5, far beyond both tolerances.
    assert!(raw_true - 0.5 > 5.0 * (raw_sd + honest_sd));
}

#[test]
fn splits_add_up_to_the_whole() {
    let (w, h) = (37, 23);
    let n = w * h;
    let mut rng = Pcg64Mcg::seed_from_u64(7);
    let reference = noisy(w, h, 8, |i| (i % 5) as f64 * 0.1, 0.3, &mut rng);
    let img = noisy(w, h, 2, |i| (i % 5) as f64 * 0.1, 0.5, &mut rng);
    let sq = img.squared_errors(&reference);
    let rv = reference.mean_variances();
    let classes: Vec<Classes> = [3usize, 7, 11]
        .iter()
        .map(|&k| Classes {
            what: "material",
            names: (0..k).map(|c| (format!("c{c}"), "plastic")).collect(),
            of_pixel: (0..n).map(|i| (i * 31 + i / 3) % k).collect(),
        })
        .collect();
    let e = ErrorSummary::new(&sq, &rv, &classes);
    assert_eq!(e.splits.len(), 3);
    for (c, parts) in classes.iter().zip(&e.splits) {
        assert_eq!(parts, &split(&sq, &rv, c));
        assert_eq!(parts.iter().map(|p| p.pixels).sum::<usize>(), n);
        assert_eq!(
            parts.iter().map(|p| p.pixels).collect::<Vec<_>>(),
            c.pixels()
        );
        let mse: f64 = parts.iter().map(|p| p.mse_part(n)).sum();
        let corrected: f64 = parts.iter().map(|p| p.mse_part_corrected(n)).sum();
        assert!((mse - e.mse).abs() <= 1e-12 * e.mse, "{mse} vs {}", e.mse);
        let whole = e.mse - e.ref_variance;
        assert!((corrected - whole).abs() <= 1e-12 * e.mse);
        // A class's RMSE is over its own pixels.
        for p in parts {
            let r = (p.squared_error / p.pixels as f64).sqrt();
            assert_eq!(p.rmse(), r);
            assert!(p.rmse_corrected() <= r);
        }
    }
}

/// The standard error of a class's part of the MSE: from the sample variance of its squared
/// errors, `sqrt(n · s²) / total`.
#[test]
fn standard_error_of_a_part() {
    let sq = [1.0, 2.0, 3.0, 4.0, 10.0];
    let rv = [0.0; 5];
    let c = Classes {
        what: "material",
        names: vec![("a".into(), "lambert"), ("b".into(), "ggx")],
        of_pixel: vec![0, 0, 0, 0, 1],
    };
    let parts = split(&sq, &rv, &c);
    // Class a: mean 2.5, s² = 5/3.
    let expect = (4.0f64 * 5.0 / 3.0).sqrt() / 5.0;
    assert!((parts[0].mse_part_se(5) - expect).abs() < 1e-12);
    assert!(parts[1].mse_part_se(5).is_nan());
    // The whole image's: over all five.
    let e = ErrorSummary::new(&sq, &rv, &[c]);
    let mean = 4.0f64;
    let s2 = [1.0f64, 2.0, 3.0, 4.0, 10.0]
        .iter()
        .map(|x| (x - mean).powi(2))
        .sum::<f64>()
        / 4.0;
    assert!((e.mse_se - (s2 / 5.0).sqrt()).abs() < 1e-12);
}

#[test]
fn angle_bins() {
    assert_eq!(angle_bin(0.0), 0);
    assert_eq!(angle_bin(0.05), 0);
    assert_eq!(angle_bin(0.1), 1);
    assert_eq!(angle_bin(0.99), ANGLE_BINS - 1);
    assert_eq!(angle_bin(1.0), ANGLE_BINS - 1);
    assert_eq!(angle_bin(-0.3), 0);
    assert_eq!(angle_name(0), "cos 0.0-0.1 (84-90°)");
    assert_eq!(angle_name(9), "cos 0.9-1.0 (0-26°)");
}
