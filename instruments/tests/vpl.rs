//! `mlmeasure vpl` in miniature: on tiny versions of both scenes, instant radiosity with VPL
//! acceptance has the image mean of plain instant radiosity (acceptance is unbiased), and so
//! does the tree gather of the accepted VPLs; the tolerance is 5 standard errors of the
//! difference, from the spread of the frames' image means.

use manylights_instruments::vpl::gather::TreeSampling;
use manylights_instruments::vpl::{
    run_variant, scenes, Budget, Gather, Setup, Variant, VariantConfig,
};

fn mean_and_se(v: &Variant) -> (f64, f64) {
    let n = v.frame_means.len() as f64;
    let m = v.frame_means.iter().sum::<f64>() / n;
    let var = v.frame_means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

fn check(scene: scenes::VplScene, vpls: usize, frames: usize) {
    let name = scene.scene.name.clone();
    let setup = Setup::new(scene, 16, 12);
    let base = VariantConfig {
        accept: false,
        gather: Gather::All,
        budget: Budget::Frames(frames),
        vpls,
        importons: 32,
        epsilon: 0.05,
        seed: 11,
        progress: false,
    };
    let plain = run_variant(&setup, "plain", &base);
    let accept = run_variant(
        &setup,
        "accept",
        &VariantConfig {
            accept: true,
            seed: 12,
            ..base
        },
    );
    let tree = run_variant(
        &setup,
        "tree",
        &VariantConfig {
            accept: true,
            gather: Gather::Tree {
                spp: 8,
                sampling: TreeSampling::Split,
            },
            seed: 13,
            ..base
        },
    );
    let (mp, sp) = mean_and_se(&plain);
    assert!(mp > 0.0, "{name}: the plain image is black");
    for v in [&accept, &tree] {
        let (m, s) = mean_and_se(v);
        let tol = 5.0 * (sp * sp + s * s).sqrt();
        eprintln!(
            "{name}: {} {m:.5e} ± {s:.1e}, plain {mp:.5e} ± {sp:.1e}",
            v.name
        );
        assert!(
            (m - mp).abs() <= tol,
            "{name}: {} mean {m:.5e} ± {s:.1e} vs plain {mp:.5e} ± {sp:.1e} (tolerance {tol:.1e})",
            v.name
        );
        // Not a vacuous test: the standard error is a small part of the mean.
        assert!(
            s < 0.2 * m,
            "{name}: {} too noisy to test ({s} of {m})",
            v.name
        );
    }
    // Acceptance did discard candidates after the first frame and kept about N per frame.
    assert!(accept.stats.candidates > accept.stats.accepted, "{name}");
    let per_frame = accept.vpls as f64 / frames as f64;
    assert!(
        per_frame > 0.5 * vpls as f64 && per_frame < 2.0 * vpls as f64,
        "{name}: {per_frame} VPLs per frame for {vpls} wanted"
    );
}

#[test]
fn acceptance_is_unbiased_on_corner() {
    check(scenes::corner(), 400, 48);
}

#[test]
fn acceptance_is_unbiased_on_room() {
    check(scenes::room(), 100, 32);
}
