//! Tiny renders (16×12) of every scene with every technique: the image average of each
//! technique (32 spp for the split-based ones, 1,024 for the one-sample ones) agrees with a
//! 256-spp `full` reference within a tolerance from the sample count (6 standard errors of
//! the difference, from the per-pixel sample variances), and a cached reference round-trips.

use manylights_render::estimator::techniques::Technique;
use manylights_render::render::{read_raw, render, write_raw, RenderConfig};
use manylights_render::scene::{self, RenderScene};

const W: usize = 16;
const H: usize = 12;

fn cfg(technique: Technique, spp: usize, seed: u64) -> RenderConfig {
    RenderConfig {
        width: W,
        height: H,
        spp,
        technique,
        seed,
        progress: false,
    }
}

fn check_scene(scene: &RenderScene) {
    let reference = render(scene, &cfg(Technique::Full, 256, 99));
    let ref_avg = reference.average();
    assert!(ref_avg > 0.0, "{}: black reference", scene.name);
    for t in Technique::ALL {
        // One-sample techniques are cheap: more estimates, so that their heavy tails (a tiny
        // light next to a wall point, picked rarely) are sampled.
        let spp = match t {
            Technique::TlSplit | Technique::MisEqual | Technique::Full => 32,
            _ => 1024,
        };
        let img = render(scene, &cfg(t, spp, 7));
        assert!(
            img.mean.iter().all(|v| v.is_finite() && *v >= 0.0),
            "{} {}: invalid pixel",
            scene.name,
            t.name()
        );
        let avg = img.average();
        let se = (img.average_se().powi(2) + reference.average_se().powi(2)).sqrt();
        let diff = (avg - ref_avg).abs();
        assert!(
            diff <= 6.0 * se + 1e-6 * ref_avg,
            "{} {}: average {avg} vs reference {ref_avg} (se {se})",
            scene.name,
            t.name()
        );
    }
}

#[test]
fn cornell_every_technique_is_unbiased() {
    check_scene(&scene::cornell(1000, 3));
}

#[test]
fn stairs_every_technique_is_unbiased() {
    check_scene(&scene::stairs());
}

#[test]
fn scenes_by_name() {
    for name in scene::SCENES {
        let s = scene::by_name(name, None).expect("known scene");
        assert_eq!(s.name, name);
        assert!(!s.lights.lights.is_empty());
    }
    assert_eq!(
        scene::by_name("cornell", None).unwrap().lights.lights.len(),
        scene::CORNELL_DEFAULT_LIGHTS
    );
    assert!(scene::by_name("nope", None).is_err());
}

#[test]
fn raw_reference_round_trips() {
    let s = scene::stairs();
    let img = render(&s, &cfg(Technique::Tl, 2, 1));
    let path = std::env::temp_dir().join(format!("mlrender-raw-{}.bin", std::process::id()));
    write_raw(&path, &img).unwrap();
    let back = read_raw(&path).unwrap();
    std::fs::remove_file(&path).ok();
    assert_eq!((back.width, back.height, back.spp), (W, H, 2));
    assert_eq!(back.mean, img.mean);
    assert_eq!(back.var, img.var);
}
