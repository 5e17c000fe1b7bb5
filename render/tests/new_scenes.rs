//! The built-in scenes `office`, `market` and `billboard`: each builds by name in both
//! palettes with the light count and kinds its documentation states, every light valid and
//! emitting, and a tiny render (8×6, 1 spp) gives finite non-negative pixels; `office` hides
//! most of its lights from the corridor behind walls, `market`'s powers span about three
//! decades, `billboard`'s video wall is a picture facing the camera.

use glam::Vec3;
use manylights::{Light, Occluder, Technique};
use manylights_render::render::{render, Protocol, RenderConfig};
use manylights_render::scene::{self, Palette, RenderScene};

/// Light counts by kind: spheres, disks, triangles.
fn kinds(s: &RenderScene) -> (usize, usize, usize) {
    let mut k = (0, 0, 0);
    for l in s.lights.lights() {
        match l {
            Light::Sphere { .. } => k.0 += 1,
            Light::Disk { .. } => k.1 += 1,
            Light::Triangle { .. } => k.2 += 1,
            other => panic!("{}: unexpected light {other:?}", s.name),
        }
    }
    k
}

/// A light's centre (its centroid for a triangle).
fn centre(l: &Light) -> Vec3 {
    match *l {
        Light::Sphere { center, .. } | Light::Disk { center, .. } => center,
        Light::Triangle { vertices, .. } => (vertices[0] + vertices[1] + vertices[2]) / 3.0,
        ref other => panic!("unexpected light {other:?}"),
    }
}

/// Builds `name` in both palettes and checks what every new scene promises.
fn check(name: &str, lights: usize, by_kind: (usize, usize, usize)) -> RenderScene {
    let s = scene::by_name(name, None).expect("known scene");
    assert!(scene::SCENES.contains(&name), "{name} is listed");
    assert_eq!(s.name, name);
    assert_eq!(s.lights.len(), lights, "{name}: light count");
    assert_eq!(kinds(&s), by_kind, "{name}: lights by kind");
    for (i, l) in s.lights.lights().iter().enumerate() {
        l.validate(i)
            .unwrap_or_else(|e| panic!("{name}: light {i}: {e}"));
        assert!(l.energy() > 0.0, "{name}: light {i} emits nothing");
    }
    // Grey places everything where colour does.
    let grey = scene::by_name_with(name, None, Palette::Grey).expect("grey");
    assert_eq!(grey.lights.len(), lights);
    assert_eq!(
        grey.geometry.triangles.len(),
        s.geometry.triangles.len(),
        "{name}: grey geometry"
    );
    for (a, b) in s.lights.lights().iter().zip(grey.lights.lights()) {
        assert_eq!(centre(a), centre(b), "{name}: grey light moved");
    }
    // The same scene twice is the same scene (fixed seeds).
    assert_eq!(
        s.fingerprint(),
        scene::by_name(name, None).unwrap().fingerprint(),
        "{name}: deterministic"
    );
    // A tiny render.
    let img = render(
        &s,
        &RenderConfig {
            width: 8,
            height: 6,
            spp: 1,
            technique: Technique::DEFAULT,
            seed: 1,
            progress: false,
            protocol: Protocol::Jittered,
            params: Default::default(),
            learn: None,
        },
    );
    assert_eq!(img.failed, 0, "{name}: failed estimates");
    assert!(
        img.mean
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0),
        "{name}: invalid pixel"
    );
    assert!(img.average() > 0.0, "{name}: black image");
    s
}

#[test]
fn office_builds() {
    // 12 rooms of 10 × 10 ceiling disks, 12 corridor spheres.
    assert_eq!(scene::OFFICE_LIGHTS, 1212);
    check("office", scene::OFFICE_LIGHTS, (12, 1200, 0));
}

/// From a point in the middle of the corridor, shadow rays to the lights' centres: by the
/// scene's design 97 % of them (1,176 of 1,212) are behind a wall or a closed door; the 12
/// corridor lights and the room lights seen through the open doors are not.
#[test]
fn office_hides_most_lights_from_the_corridor() {
    let s = scene::office();
    let x = Vec3::new(0.2, 1.0, -15.0);
    let lights = s.lights.lights();
    let blocked = lights
        .iter()
        .filter(|l| {
            let d = centre(l) - x;
            let t = d.length();
            s.geometry.occluded(x, d / t, t)
        })
        .count();
    let fraction = blocked as f64 / lights.len() as f64;
    assert!(fraction > 0.9, "only {blocked} of {} blocked", lights.len());
    // The corridor's own lights are all in view.
    for l in lights.iter().filter(|l| matches!(l, Light::Sphere { .. })) {
        let d = centre(l) - x;
        let t = d.length();
        assert!(!s.geometry.occluded(x, d / t, t), "corridor light hidden");
    }
}

#[test]
fn market_builds_with_powers_over_three_decades() {
    // 2,688 bulbs and 20 lamps (spheres), 24 panels (disks), 20 signs and the window
    // (40 + 64 triangles).
    assert_eq!(scene::MARKET_LIGHTS, 2836);
    let s = check("market", scene::MARKET_LIGHTS, (2708, 24, 104));
    let energies: Vec<f32> = s.lights.lights().iter().map(Light::energy).collect();
    let (lo, hi) = energies
        .iter()
        .fold((f32::INFINITY, 0f32), |(lo, hi), &e| (lo.min(e), hi.max(e)));
    assert!(hi / lo > 300.0 && hi / lo < 3000.0, "powers {lo} to {hi}");
    // The brightest sphere's radiance is over 1,000 times the dimmest disk's.
    let radiance = |l: &Light| match *l {
        Light::Sphere { radiance, .. } | Light::Disk { radiance, .. } => radiance.luminance(),
        _ => f32::NAN,
    };
    let sphere = s
        .lights
        .lights()
        .iter()
        .filter(|l| matches!(l, Light::Sphere { .. }))
        .map(radiance)
        .fold(0f32, f32::max);
    let disk = s
        .lights
        .lights()
        .iter()
        .filter(|l| matches!(l, Light::Disk { .. }))
        .map(radiance)
        .fold(f32::INFINITY, f32::min);
    assert!(sphere > 1000.0 * disk, "radiances {sphere} and {disk}");
}

#[test]
fn billboard_builds_a_picture_facing_the_camera() {
    assert_eq!(scene::BILLBOARD_SCREEN_TRIANGLES, 64 * 48 * 2);
    assert_eq!(
        scene::BILLBOARD_LIGHTS,
        scene::BILLBOARD_SCREEN_TRIANGLES + 12
    );
    let s = check(
        "billboard",
        scene::BILLBOARD_LIGHTS,
        (8, 4, scene::BILLBOARD_SCREEN_TRIANGLES),
    );
    let mut colours = Vec::new();
    for l in s.lights.lights() {
        if let Light::Triangle {
            vertices, radiance, ..
        } = *l
        {
            // Emitting towards the camera.
            let n = (vertices[1] - vertices[0]).cross(vertices[2] - vertices[0]);
            assert!(
                n.dot(s.camera.eye - vertices[0]) > 0.0,
                "a triangle faces away"
            );
            colours.push(radiance.to_array().map(f32::to_bits));
        }
    }
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 100, "{} colours", colours.len());
}
