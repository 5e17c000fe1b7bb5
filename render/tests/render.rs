//! Tiny renders (16×12) of every scene (the built-in ones and a small OBJ + MTL file,
//! `tests/data/box.obj`) with every technique: the image average of each technique (32 spp
//! for the split-based ones, 1,024 for the one-sample ones; 4× that on `exhibition` and
//! `city`) agrees with a 256-spp `full` reference within a tolerance from the sample count
//! (6 standard errors of the difference, from the per-pixel sample variances), and a cached
//! reference round-trips; no estimate fails. The OBJ loader's
//! materials, lights and errors are checked on that file and on small broken ones.

use manylights::Material;
use manylights::Rgb;
use manylights::Technique;
use manylights_render::image::{read_raw, write_raw};
use manylights_render::render::{render, Protocol, RenderConfig};
use manylights_render::scene::{self, RenderScene};
use std::path::{Path, PathBuf};

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
        protocol: Protocol::Jittered,
        params: Default::default(),
        learn: None,
    }
}

/// Estimates per pixel of the split-based techniques and of the one-sample ones.
#[derive(Clone, Copy)]
struct Spp {
    split: usize,
    one: usize,
}

/// The default: one-sample techniques are cheap, so more estimates, so that their heavy tails
/// (a tiny light next to a wall point, picked rarely) are sampled.
const SPP: Spp = Spp {
    split: 32,
    one: 1024,
};

/// For the scenes made to defeat the techniques that ignore the BRDF (`exhibition`, `city`):
/// a glossy highlight comes from one of hundreds or thousands of lights, which `uniform`,
/// `power`, `tl` and `tl-split` pick rarely, so 4× the estimates (about 3 s a scene in
/// release mode).
const GLOSSY_SPP: Spp = Spp {
    split: 128,
    one: 4096,
};

fn check_scene(scene: &RenderScene, spp: Spp) {
    let reference = render(scene, &cfg(Technique::Full, 256, 99));
    let ref_avg = reference.average();
    assert!(ref_avg > 0.0, "{}: black reference", scene.name);
    assert_eq!(
        reference.failed, 0,
        "{}: failed reference estimates",
        scene.name
    );
    for t in Technique::ALL {
        let spp = match t {
            Technique::TlSplit | Technique::MisEqual | Technique::Full => spp.split,
            _ => spp.one,
        };
        let img = render(scene, &cfg(t, spp, 7));
        // The core refuses nothing the renderer hands it (a refusal would be counted black).
        assert_eq!(
            img.failed,
            0,
            "{} {}: failed estimates",
            scene.name,
            t.name()
        );
        assert!(
            img.mean
                .iter()
                .flatten()
                .all(|v| v.is_finite() && *v >= 0.0),
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
    check_scene(&scene::cornell(1000, 3), SPP);
}

#[test]
fn stairs_every_technique_is_unbiased() {
    check_scene(&scene::stairs(), SPP);
}

#[test]
fn exhibition_every_technique_is_unbiased() {
    check_scene(&scene::exhibition(), GLOSSY_SPP);
}

#[test]
fn city_every_technique_is_unbiased() {
    check_scene(&scene::city(), GLOSSY_SPP);
}

#[test]
fn city_sun_every_technique_is_unbiased() {
    check_scene(&scene::city_sun(scene::Palette::Colour), GLOSSY_SPP);
}

fn box_obj() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/box.obj")
}

#[test]
fn obj_every_technique_is_unbiased() {
    check_scene(&scene::obj::load(&box_obj()).expect("box.obj loads"), SPP);
}

#[test]
fn obj_materials_and_lights() {
    let s = scene::obj::load(&box_obj()).expect("box.obj loads");
    assert_eq!(s.name, "box");
    // Floor and wall quads, two cubes; the two emissive quads are lights only.
    assert_eq!(s.geometry.triangles.len(), 2 + 2 + 12 + 12);
    assert_eq!(s.lights.len(), 4);
    let mut radiances: Vec<f32> = s
        .lights
        .lights()
        .iter()
        .map(|l| match *l {
            manylights::Light::Triangle {
                radiance,
                two_sided,
                ..
            } => {
                assert!(!two_sided);
                assert_eq!(radiance, manylights::Rgb::grey(radiance.r), "Ke is grey");
                radiance.r
            }
            other => panic!("not a triangle light: {other:?}"),
        })
        .collect();
    radiances.sort_by(f32::total_cmp);
    for (r, want) in radiances.iter().zip([6.0, 6.0, 25.0, 25.0]) {
        assert!((r - want).abs() < 1e-5, "radiance {r}, want {want}");
    }
    let has = |want: Material| s.geometry.triangles.iter().any(|t| t.material == want);
    let lum = |r: f32, g: f32, b: f32| 0.2126 * r + 0.7152 * g + 0.0722 * b;
    assert!(has(Material::Lambert {
        albedo: Rgb::new(0.5, 0.5, 0.5)
    }));
    assert!(has(Material::Lambert {
        albedo: Rgb::new(0.7, 0.6, 0.5)
    }));
    assert!(has(Material::Plastic {
        albedo: Rgb::new(0.4, 0.4, 0.4),
        specular: lum(0.5, 0.5, 0.5),
        alpha: (2.0f32 / 202.0).sqrt(),
    }));
    assert!(has(Material::Ggx {
        alpha: 0.3 * 0.3,
        specular: lum(0.9, 0.9, 0.9),
    }));
    // The automatic camera looks at the bounding box's centre from +z.
    let c = s.camera;
    assert!((c.target - glam::Vec3::new(0.0, 0.6, 0.0)).length() < 1e-5);
    assert!(c.eye.z > 1.0 && (c.eye.x, c.eye.y) == (c.target.x, c.target.y));
    // by_name takes the path.
    let by_path = scene::by_name(box_obj().to_str().unwrap(), None).expect("by path");
    assert_eq!(by_path.lights.len(), 4);
}

/// Writes `obj` (and `mtl`, as `<stem>.mtl`, if given) to a fresh temporary folder and
/// returns the OBJ's path.
fn write_obj(stem: &str, obj: &str, mtl: Option<&str>) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mlrender-obj-{}-{stem}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    if let Some(mtl) = mtl {
        std::fs::write(dir.join(format!("{stem}.mtl")), mtl).unwrap();
    }
    let path = dir.join(format!("{stem}.obj"));
    std::fs::write(&path, format!("mtllib {stem}.mtl\n{obj}")).unwrap();
    path
}

fn load_err(path: &Path) -> String {
    let e = scene::obj::load(path).expect_err("must not load");
    assert!(
        e.contains(&path.display().to_string()),
        "{e:?} names no file"
    );
    e
}

const EMITTER_MTL: &str = "newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKe 4 4 4\n";
const FLOOR: &str = "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nusemtl grey\nf 1 4 3 2\n";

#[test]
fn obj_errors_name_the_file() {
    let missing = Path::new("/nonexistent/mlrender/missing.obj");
    load_err(missing);
    assert!(scene::by_name(missing.to_str().unwrap(), None).is_err());

    let no_light = write_obj("nolight", FLOOR, Some(EMITTER_MTL));
    assert!(load_err(&no_light).contains("no light"));

    let lamp = "v 0 1 0\nv 0 1 1\nv 1 1 0\nusemtl lamp\nf 5 6 7\n";
    let no_tri = write_obj(
        "notri",
        &lamp.replace("f 5 6 7", "f 1 2 3"),
        Some(EMITTER_MTL),
    );
    assert!(load_err(&no_tri).contains("no reflecting triangle"));

    // Zero-area emitters only: a light list with no energy.
    let flat = "v 0 1 0\nv 0 1 0\nv 1 1 0\nusemtl lamp\nf 5 6 7\n";
    let zero = write_obj("zeroarea", &format!("{FLOOR}{flat}"), Some(EMITTER_MTL));
    assert!(load_err(&zero).contains("no light"));

    // A light the tree rejects: the message names the light, its field, object and material.
    let far = "o far_lamp\nv 0 1 0\nv 2e15 1 1\nv 1 1 0\nusemtl lamp\nf 5 6 7\n";
    let bad = write_obj("badlight", &format!("{FLOOR}{far}"), Some(EMITTER_MTL));
    let e = load_err(&bad);
    assert!(
        e.contains("light 0")
            && e.contains("vertices[1]")
            && e.contains("far_lamp")
            && e.contains("lamp"),
        "{e}"
    );

    let blinding = write_obj(
        "blinding",
        &format!("{FLOOR}{lamp}"),
        Some("newmtl grey\nKd 0.5 0.5 0.5\nnewmtl lamp\nKe 1e30 1e30 1e30\n"),
    );
    let e = load_err(&blinding);
    assert!(e.contains("light 0") && e.contains("radiance"), "{e}");

    let nan = write_obj(
        "nan",
        &format!("{FLOOR}v nan 0 0\nf 1 2 5\n"),
        Some(EMITTER_MTL),
    );
    assert!(load_err(&nan).contains("not finite"));

    let bad_kd = write_obj(
        "badkd",
        &format!("{FLOOR}{lamp}"),
        Some("newmtl grey\nKd inf 0 0\nnewmtl lamp\nKe 4 4 4\n"),
    );
    assert!(load_err(&bad_kd).contains("Kd"));

    let no_mtl = write_obj("nomtl", &format!("{FLOOR}{lamp}"), None);
    load_err(&no_mtl);

    let good = write_obj("good", &format!("{FLOOR}{lamp}"), Some(EMITTER_MTL));
    let s = scene::obj::load(&good).expect("a floor and a lamp load");
    assert_eq!((s.geometry.triangles.len(), s.lights.len()), (2, 1));
    for p in [
        no_light, no_tri, zero, bad, blinding, nan, bad_kd, no_mtl, good,
    ] {
        std::fs::remove_dir_all(p.parent().unwrap()).ok();
    }
}

#[test]
fn scenes_by_name() {
    for name in scene::SCENES {
        let s = scene::by_name(name, None).expect("known scene");
        assert_eq!(s.name, name);
        assert!(!s.lights.is_empty());
    }
    assert_eq!(
        scene::by_name("cornell", None).unwrap().lights.len(),
        scene::CORNELL_DEFAULT_LIGHTS
    );
    assert_eq!(
        scene::by_name("exhibition", None).unwrap().lights.len(),
        scene::EXHIBITION_DISKS + scene::EXHIBITION_PANEL_TRIANGLES
    );
    assert_eq!(
        scene::by_name("city", Some(5)).unwrap().lights.len(),
        scene::CITY_LIGHTS
    );
    assert!(scene::by_name("nope", None).is_err());
}

/// `cornell --lights N`: 4 mm lights up to the default count, then radii shrinking as 1/√N so
/// that the covered fraction of the walls stays that of the default scene, and lights far
/// apart against their size; total power independent of N.
#[test]
fn cornell_lights_keep_their_coverage() {
    use manylights::Light;
    let stats = |n: usize| {
        let s = scene::by_name("cornell", Some(n)).unwrap();
        let mut area = 0.0f64;
        let mut power = 0.0f64;
        for l in s.lights.lights() {
            let Light::Sphere {
                radius, radiance, ..
            } = *l
            else {
                panic!("cornell has sphere lights only");
            };
            assert_eq!(radius, scene::cornell_light_radius(n));
            let a = std::f64::consts::PI * f64::from(radius).powi(2);
            area += a;
            power += 4.0 * std::f64::consts::PI * a * f64::from(radiance.luminance());
        }
        (area, power, s.lights.len())
    };
    assert_eq!(
        scene::cornell_light_radius(1000),
        scene::CORNELL_LIGHT_RADIUS
    );
    assert_eq!(
        scene::cornell_light_radius(scene::CORNELL_DEFAULT_LIGHTS),
        scene::CORNELL_LIGHT_RADIUS
    );
    let (a0, p0, n0) = stats(scene::CORNELL_DEFAULT_LIGHTS);
    let (a1, p1, n1) = stats(100_000);
    assert_eq!((n0, n1), (scene::CORNELL_DEFAULT_LIGHTS, 100_000));
    assert!((a1 / a0 - 1.0).abs() < 1e-3, "covered area {a0} → {a1}");
    // Lights on 2 × 0.81 m² of wall: cross-sections cover under 5 % of it.
    assert!(a1 < 0.05 * 1.62, "{a1}");
    // Powers are 12/N × a log-uniform factor of mean 1.35: the totals agree to a few %.
    assert!((p1 / p0 - 1.0).abs() < 0.05, "total power {p0} → {p1}");
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

/// The reference cache key: the same scene gives the same fingerprint, any change of lights,
/// geometry or camera another.
#[test]
fn fingerprint_tells_scenes_apart() {
    let a = scene::cornell(1000, 3);
    assert_eq!(a.fingerprint(), scene::cornell(1000, 3).fingerprint());
    assert_ne!(a.fingerprint(), scene::cornell(1000, 4).fingerprint());
    assert_ne!(a.fingerprint(), scene::cornell(1001, 3).fingerprint());
    let mut moved = scene::cornell(1000, 3);
    moved.camera.fov_y += 1e-3;
    assert_ne!(a.fingerprint(), moved.fingerprint());
    assert_ne!(scene::stairs().fingerprint(), a.fingerprint());
}

/// `compare`'s material classes: every material of `city` is one of its five named classes;
/// the other scenes' classes are their kind and glossy lobe.
#[test]
fn material_classes() {
    let city = scene::city();
    let mut names: Vec<String> = city
        .geometry
        .triangles
        .iter()
        .map(|t| city.material_class(&t.material).name)
        .collect();
    names.sort();
    names.dedup();
    assert_eq!(
        names,
        [
            "cars (plastic α 0.07 ks 0.6)",
            "glass façades (plastic α 0.1 ks 0.7)",
            "lamp poles (ggx α 0.2 ks 0.6)",
            "sidewalks and stone façades (lambert)",
            "wet street (plastic α 0.15 ks 0.5)",
        ]
    );
    let stairs = scene::stairs();
    for t in &stairs.geometry.triangles {
        let c = stairs.material_class(&t.material);
        let kind = match t.material {
            Material::Lambert { .. } => "lambert",
            Material::Ggx { .. } => "ggx",
            Material::Plastic { .. } => "plastic",
            _ => "material",
        };
        assert_eq!(c.kind, kind);
        assert!(c.name.starts_with(kind) && !c.name.contains('('), "{c:?}");
    }
    // The albedo does not change the class.
    let a = Material::Plastic {
        albedo: Rgb::grey(0.1),
        specular: 0.5,
        alpha: 0.15,
    };
    let b = Material::Plastic {
        albedo: Rgb::grey(0.9),
        specular: 0.5,
        alpha: 0.15,
    };
    assert_eq!(city.material_class(&a), city.material_class(&b));
}

/// `--camera eye,target,up,fov`: the default framing given explicitly (its numbers printed
/// exactly) renders the same bits as the scene's own camera; another view renders another,
/// lit image; malformed texts are errors naming what is wrong.
#[test]
fn a_camera_from_the_command_line() {
    let mut s = scene::obj::load(&box_obj()).expect("box.obj loads");
    let c = s.camera;
    let text = format!(
        "{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?}",
        c.eye.x,
        c.eye.y,
        c.eye.z,
        c.target.x,
        c.target.y,
        c.target.z,
        c.up.x,
        c.up.y,
        c.up.z,
        c.fov_y
    );
    let parsed = scene::Camera::parse(&text).expect("the default camera parses");
    assert_eq!(
        (parsed.eye, parsed.target, parsed.up, parsed.fov_y),
        (c.eye, c.target, c.up, c.fov_y)
    );
    let own = render(&s, &cfg(Technique::TlMis, 4, 5));
    s.camera = parsed;
    let given = render(&s, &cfg(Technique::TlMis, 4, 5));
    let bits = |m: &[[f32; 3]]| m.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(
        bits(&own.mean),
        bits(&given.mean),
        "the same camera, the same bits"
    );
    // From the side, looking at the box's centre from +x, with a narrower field of view.
    let side = format!(
        "{},{},{},{},{},{},0,1,0,30",
        c.target.x + (c.eye - c.target).length(),
        c.target.y,
        c.target.z,
        c.target.x,
        c.target.y,
        c.target.z
    );
    s.camera = scene::Camera::parse(&side).expect("a side view parses");
    let moved = render(&s, &cfg(Technique::TlMis, 4, 5));
    assert_ne!(
        bits(&own.mean),
        bits(&moved.mean),
        "another view, another image"
    );
    assert!(moved.average() > 0.0, "the side view is lit");
    for (bad, says) in [
        ("0,0,1,0,0,0,0,1,0", "ten numbers"),
        ("0,0,1,0,0,0,0,1,0,45,1", "ten numbers"),
        ("0,0,x,0,0,0,0,1,0,45", "eye z"),
        ("0,0,1,0,0,0,0,1,NaN,45", "up z"),
        ("0,0,1,0,0,1,0,1,0,45", "eye is on the target"),
        ("3e38,0,0,-3e38,0,0,0,1,0,45", "too large"),
        ("0,0,1,0,0,0,0,0,2,45", "up direction"),
        ("0,0,1,0,0,0,0,0,0,45", "up direction"),
        ("0,0,1,0,0,0,0,1,0,0", "fov"),
        ("0,0,1,0,0,0,0,1,0,180", "fov"),
    ] {
        let e = scene::Camera::parse(bad).expect_err(bad);
        assert!(e.contains(says) && e.starts_with("--camera"), "{bad}: {e}");
    }
}
