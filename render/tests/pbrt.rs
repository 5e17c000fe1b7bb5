//! The pbrt-v4 reader of mlrender on small files under `tests/pbrt/`: every mapped directive
//! is read and every unmapped one warns with its `file:line`; malformed files fail with their
//! line; a sphere light over a plane matches its closed form; a scene written as OBJ and as
//! pbrt renders the same bits; instanced emissive objects are flattened; the three PLY
//! encodings of a mesh load the same triangles; the camera's handedness is pbrt's.

use manylights::{Light, Material, Rgb, Technique};
use manylights_render::render::{primary, render, Protocol, RenderConfig};
use manylights_render::scene::pbrt::{self, ply};
use manylights_render::scene::{self, Camera};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/pbrt")
        .join(name)
}

/// The 1-based line of `file` holding `needle` (the first).
fn line_of(file: &Path, needle: &str) -> usize {
    let text = std::fs::read_to_string(file).unwrap();
    text.lines()
        .position(|l| l.contains(needle))
        .unwrap_or_else(|| panic!("{needle:?} not in {}", file.display()))
        + 1
}

fn cfg(w: usize, h: usize, spp: usize, protocol: Protocol) -> RenderConfig {
    RenderConfig {
        width: w,
        height: h,
        spp,
        technique: Technique::DEFAULT,
        seed: 7,
        progress: false,
        protocol,
        params: Default::default(),
        learn: None,
    }
}

#[test]
fn every_directive_is_read_and_every_unsupported_one_warns_with_its_line() {
    let path = data("every.pbrt");
    let p = pbrt::load(&path).expect("every.pbrt loads");
    let file = path.display().to_string();
    // Each unsupported directive, type or parameter: its warning names the directive and
    // the line.
    for (needle, directive, what) in [
        ("Sampler \"halton\"", "Sampler", "ignored"),
        ("Integrator", "Integrator", "ignored"),
        ("PixelFilter", "PixelFilter", "ignored"),
        ("Option", "Option", "ignored"),
        ("\"string filename\" \"every.exr\"", "Film", "filename"),
        ("lensradius", "Camera", "lensradius"),
        ("\"checkerboard\"", "Texture", "checkerboard"),
        (
            "\"texture reflectance\" \"checks\"",
            "Material",
            "not constant",
        ),
        ("Material \"hair\"", "Material", "hair"),
        ("Shape \"curve\"", "Shape", "curve"),
        ("\"goniometric\"", "LightSource", "goniometric"),
        ("MakeNamedMedium", "MakeNamedMedium", "ignored"),
    ] {
        let at = format!("{file}:{}: {directive}", line_of(&path, needle));
        assert!(
            p.warnings
                .iter()
                .any(|w| w.starts_with(&at) && w.contains(what)),
            "no warning {at} … {what} in {:#?}",
            p.warnings
        );
    }
    assert_eq!(p.film, Some((20, 10)));
    assert!(
        !p.mirrored,
        "Scale -1 1 1 before LookAt keeps the coordinates"
    );
    let s = &p.scene;
    // Materials: every mapped kind is there.
    let mats: Vec<Material> = s.geometry.triangles.iter().map(|t| t.material).collect();
    let has = |f: &dyn Fn(&Material) -> bool| mats.iter().any(f);
    assert!(has(
        &|m| matches!(m, Material::Lambert { albedo } if *albedo == Rgb::grey(0.5))
    ));
    assert!(has(
        &|m| matches!(m, Material::Plastic { albedo, specular, alpha }
        if *albedo == Rgb::grey(0.4) && (*specular - 0.04).abs() < 1e-6 && (*alpha - 0.3).abs() < 1e-6)
    ));
    assert!(has(&|m| matches!(m, Material::Ggx { alpha, specular }
        if (*alpha - 0.2).abs() < 1e-6 && *specular > 0.0 && *specular < 1.0)));
    assert!(has(
        &|m| matches!(m, Material::Ggx { specular, .. } if *specular == 1.0)
    ));
    assert!(has(
        &|m| matches!(m, Material::Lambert { albedo } if *albedo == Rgb::new(0.5, 0.6, 0.7))
    ));
    // Lights: disk (two-sided blackbody, facing down after ReverseOrientation), sphere,
    // two instances of the lamp triangle, point, spot, distant; the sky is the environment.
    let lights = s.lights.lights();
    let count = |f: &dyn Fn(&Light) -> bool| lights.iter().filter(|l| f(l)).count();
    assert_eq!(
        count(&|l| matches!(
            l,
            Light::Disk {
                two_sided: true,
                ..
            }
        )),
        1
    );
    for l in lights {
        if let Light::Disk {
            center,
            normal,
            radiance,
            ..
        } = *l
        {
            assert!((center - glam::Vec3::new(0.0, 3.0, 0.0)).length() < 1e-5);
            // Rotate 90 about x turns +z to −y; ReverseOrientation turns it up.
            assert!(normal.y > 0.99, "{normal}");
            let expected = pbrt::blackbody(3000.0) * 5.0;
            assert!((radiance.luminance() - 5.0).abs() < 1e-4);
            assert_eq!(radiance, expected);
        }
    }
    assert_eq!(
        count(&|l| matches!(l, Light::Sphere { radius, .. } if *radius == 0.1)),
        1
    );
    let lamps: Vec<[glam::Vec3; 3]> = lights
        .iter()
        .filter_map(|l| match *l {
            Light::Triangle { vertices, .. } => Some(vertices),
            _ => None,
        })
        .collect();
    assert_eq!(lamps.len(), 2, "the instanced lamp, twice");
    assert!(lamps
        .iter()
        .any(|v| v[0] == glam::Vec3::new(-1.0, 2.0, 0.0)));
    assert!(lamps.iter().any(|v| v[0] == glam::Vec3::new(0.0, 2.0, 0.0)));
    assert_eq!(
        count(&|l| matches!(l, Light::Point { intensity, .. } if *intensity == Rgb::grey(2.0))),
        1
    );
    assert_eq!(count(&|l| matches!(l, Light::Spot { .. })), 1);
    assert_eq!(count(&|l| matches!(l, Light::Distant { .. })), 1);
    assert_eq!(count(&|l| matches!(l, Light::Environment { .. })), 1);
    // Geometry: the two floors (bilinear patches), the sphere, the disk, three PLY meshes
    // (3 triangles each) and the "hair" triangle.
    let ply_tris = 3;
    assert!(s.geometry.triangles.len() > 2 + 2 + 48 + 3 * ply_tris + 1);
    // The transformed PLY copies: Transform then ConcatTransform move the second by (2, 0, 1).
    assert!(s
        .geometry
        .triangles
        .iter()
        .any(|t| t.v.contains(&glam::Vec3::new(2.5, 1.0, 1.5))));
    // It renders.
    let img = render(s, &cfg(20, 10, 4, Protocol::Jittered));
    assert_eq!(img.failed, 0);
    assert!(img.average() > 0.0);
    // And by name, as mlrender takes it.
    let by_name = scene::by_name(path.to_str().unwrap(), None).expect("by_name reads .pbrt");
    assert_eq!(by_name.fingerprint(), s.fingerprint());
}

#[test]
fn malformed_files_fail_with_their_line() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("pbrt-malformed");
    std::fs::create_dir_all(&dir).unwrap();
    let head = "LookAt 0 1 5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin\n";
    for (k, (body, what)) in [
        ("Shape \"trianglemesh\" \"point3 P [ 0 0 0 ]\"\n", "not \"type name\""),
        ("Translate 1 2\n", "takes 3 numbers"),
        ("Shape \"trianglemesh\" \"point3 P\" [ 0 0 0  1 0 0\n", "missing ']'"),
        ("AttributeEnd\n", "without a block"),
        ("NamedMaterial \"nope\" Shape \"sphere\"\n", "not defined"),
        ("Material \"diffuse\" \"rgb reflectance\" [ 1 2 ]\n", "wrong number"),
        ("Shape \"trianglemesh\" \"point3 P\" [ 0 0 0 1 0 0 0 1 0 ] \"integer indices\" [ 0 1 7 ]\n", "not a vertex"),
        ("Texture \"unterminated\n", "unterminated string"),
        ("ObjectInstance \"ghost\"\n", "not defined"),
        ("Shape \"plymesh\" \"string filename\" \"missing.ply\"\n", "cannot open"),
        ("AttributeBegin 1 AttributeEnd\n", "takes no arguments"),
    ]
    .into_iter()
    .enumerate()
    {
        let path = dir.join(format!("bad{k}.pbrt"));
        std::fs::write(&path, format!("{head}{body}")).unwrap();
        let e = pbrt::load(&path).expect_err(body);
        let at = format!("{}:4", path.display());
        assert!(e.contains(&at) && e.contains(what), "{body:?}: {e}");
    }
    // A file that does not start with a directive.
    let path = dir.join("number.pbrt");
    std::fs::write(&path, "\n1 2 3\n").unwrap();
    let e = pbrt::load(&path).unwrap_err();
    assert!(
        e.contains(&format!("{}:2", path.display())) && e.contains("expected a directive"),
        "{e}"
    );
    // An unclosed block names where it was opened.
    let path = dir.join("open.pbrt");
    std::fs::write(&path, format!("{head}AttributeBegin\n")).unwrap();
    let e = pbrt::load(&path).unwrap_err();
    assert!(e.contains(&format!("{}:4", path.display())), "{e}");
}

#[test]
fn sphere_light_over_a_plane_matches_the_closed_form() {
    let p = pbrt::load(&data("sphere_over_plane.pbrt")).expect("loads");
    let s = &p.scene;
    let (l, r, d, rho) = (4.0f64, 0.5f64, 5.0f64, 0.6f64);
    let (w, h, spp) = (4, 4, 4096);
    for technique in [Technique::DEFAULT, Technique::TlMis] {
        let img = render(
            s,
            &RenderConfig {
                technique,
                ..cfg(w, h, spp, Protocol::FixedPoint)
            },
        );
        assert_eq!(img.failed, 0);
        for py in 0..h {
            for px in 0..w {
                let sp = primary(s, px, py, w, h).expect("the plane is seen");
                let x = sp.position.as_dvec3();
                let dist = (x - glam::DVec3::new(0.0, d, 0.0)).length();
                // Radiance ρ/π · E with E = π L r² d / D³ (ρ L (r/d)² right below).
                let expected = rho * l * r * r * d / dist.powi(3);
                let i = py * w + px;
                for c in 0..3 {
                    let mean = f64::from(img.mean[i][c]);
                    let se = (f64::from(img.var[i][c]) / spp as f64).sqrt();
                    assert!(
                        (mean - expected).abs() <= 5.0 * se + 1e-6,
                        "{technique:?} pixel ({px}, {py}): {mean} vs {expected} (se {se})"
                    );
                }
            }
        }
    }
    // ρ L (r/d)² is what the closed form gives right below the light.
    assert!((rho * l * (r / d).powi(2) - 0.024).abs() < 1e-12);
}

#[test]
fn the_same_scene_as_obj_and_as_pbrt_renders_the_same_bits() {
    let mut obj = scene::obj::load(&data("quads.obj")).expect("quads.obj loads");
    let p = pbrt::load(&data("quads.pbrt")).expect("quads.pbrt loads");
    assert!(p.warnings.is_empty(), "{:#?}", p.warnings);
    // The pbrt LookAt (under Scale -1 1 1) is the camera `--camera` gives the OBJ scene.
    obj.camera = Camera::parse("0,1,3.5,0,0.5,0,0,1,0,40").unwrap();
    let pb = p.scene;
    assert_eq!(format!("{:?}", pb.camera), format!("{:?}", obj.camera));
    assert_eq!(pb.fingerprint(), obj.fingerprint());
    for protocol in [Protocol::Jittered, Protocol::FixedPoint] {
        let a = render(&obj, &cfg(16, 12, 8, protocol));
        let b = render(&pb, &cfg(16, 12, 8, protocol));
        assert!(a.average() > 0.0);
        let bits = |img: &manylights_render::image::Image| -> Vec<u32> {
            img.mean.iter().flatten().map(|v| v.to_bits()).collect()
        };
        assert_eq!(bits(&a), bits(&b), "{protocol:?}");
    }
}

#[test]
fn the_camera_is_pbrts_left_handed_one() {
    // A point light at world +x over a plane, seen from +z: pbrt's plain LookAt shows +x on
    // the image's left; under Scale -1 1 1 on its right.
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("pbrt-hand");
    std::fs::create_dir_all(&dir).unwrap();
    let scene_text = |pre: &str| {
        format!(
            "{pre}LookAt 0 3 6  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 60\nWorldBegin\n\
             Shape \"trianglemesh\" \"point3 P\" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5 ] \"integer indices\" [ 0 1 2 0 2 3 ]\n\
             LightSource \"point\" \"rgb I\" [ 5 5 5 ] \"point3 from\" [ 3 0.5 0 ]\n"
        )
    };
    let (w, h) = (8, 4);
    let halves = |name: &str, pre: &str| -> (f32, f32, bool) {
        let path = dir.join(name);
        std::fs::write(&path, scene_text(pre)).unwrap();
        let p = pbrt::load(&path).unwrap();
        let img = render(&p.scene, &cfg(w, h, 4, Protocol::FixedPoint));
        let (mut left, mut right) = (0.0, 0.0);
        for (i, px) in img.mean.iter().enumerate() {
            if i % w < w / 2 {
                left += px[0];
            } else {
                right += px[0];
            }
        }
        (left, right, p.mirrored)
    };
    let (left, right, mirrored) = halves("plain.pbrt", "");
    assert!(mirrored);
    assert!(
        left > 2.0 * right,
        "plain LookAt: +x on the left ({left} vs {right})"
    );
    let (left, right, mirrored) = halves("flipped.pbrt", "Scale -1 1 1\n");
    assert!(!mirrored);
    assert!(
        right > 2.0 * left,
        "Scale -1 1 1: +x on the right ({left} vs {right})"
    );

    // A camera from Rotate and Translate: at (0, 0, 5) looking along −x, y up.
    let path = dir.join("rotate.pbrt");
    std::fs::write(
        &path,
        format!(
            "Scale -1 1 1\nRotate 90 0 1 0\nTranslate 0 0 -5\nCamera \"perspective\"\nWorldBegin\n{}",
            scene_text("").split_once("WorldBegin\n").unwrap().1
        ),
    )
    .unwrap();
    let p = pbrt::load(&path).unwrap();
    let c = p.scene.camera;
    assert!(!p.mirrored);
    assert!(
        (c.eye - glam::Vec3::new(0.0, 0.0, 5.0)).length() < 1e-5,
        "{c:?}"
    );
    assert!(
        ((c.target - c.eye).normalize() - glam::Vec3::NEG_X).length() < 1e-5,
        "{c:?}"
    );
    assert!((c.up - glam::Vec3::Y).length() < 1e-5, "{c:?}");
    // No Film: pbrt's 1280 x 720, landscape, so the fov is the vertical one.
    assert_eq!(c.fov_y, 90.0);
}

#[test]
fn instanced_emissive_objects_are_flattened_and_render() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("pbrt-instance");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("instances.pbrt");
    std::fs::write(
        &path,
        "Scale -1 1 1\nLookAt 0 4 6  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 60\nWorldBegin\n\
         Shape \"trianglemesh\" \"point3 P\" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5 ] \"integer indices\" [ 0 1 2 0 2 3 ]\n\
         ObjectBegin \"bulb\"\n\
           AreaLightSource \"diffuse\" \"rgb L\" [ 10 10 10 ]\n\
           Shape \"sphere\" \"float radius\" 0.1\n\
           Shape \"trianglemesh\" \"point3 P\" [ 0 0.5 0  0.2 0.5 0  0 0.5 0.2 ]\n\
         ObjectEnd\n\
         AttributeBegin\n  Translate 1 1 0\n  Scale 2 2 2\n  ObjectInstance \"bulb\"\nAttributeEnd\n\
         AttributeBegin\n  Translate -1 1 0\n  ObjectInstance \"bulb\"\nAttributeEnd\n",
    )
    .unwrap();
    let p = pbrt::load(&path).unwrap();
    let lights = p.scene.lights.lights();
    assert_eq!(lights.len(), 4);
    let spheres: Vec<(glam::Vec3, f32)> = lights
        .iter()
        .filter_map(|l| match *l {
            Light::Sphere { center, radius, .. } => Some((center, radius)),
            _ => None,
        })
        .collect();
    assert_eq!(spheres.len(), 2);
    assert!(spheres.iter().any(
        |&(c, r)| (c - glam::Vec3::new(1.0, 1.0, 0.0)).length() < 1e-6 && (r - 0.2).abs() < 1e-6
    ));
    assert!(spheres.iter().any(
        |&(c, r)| (c - glam::Vec3::new(-1.0, 1.0, 0.0)).length() < 1e-6 && (r - 0.1).abs() < 1e-6
    ));
    // The triangles face down in both copies (emitting towards the floor).
    for l in lights {
        if let Light::Triangle { vertices: v, .. } = l {
            assert!((v[1] - v[0]).cross(v[2] - v[0]).y < 0.0);
        }
    }
    let img = render(&p.scene, &cfg(12, 8, 4, Protocol::Jittered));
    assert_eq!(img.failed, 0);
    assert!(img.average() > 0.0);
}

#[test]
fn binary_and_ascii_ply_load_the_same_triangles() {
    let a = ply::read(&data("mesh_ascii.ply")).unwrap();
    let le = ply::read(&data("mesh_binary_le.ply")).unwrap();
    let be = ply::read(&data("mesh_binary_be.ply")).unwrap();
    // The quad is split into (0 3 2) and (0 2 1); the triangle stays.
    assert_eq!(a.triangles, vec![[0, 3, 2], [0, 2, 1], [0, 1, 4]]);
    assert_eq!(le.triangles, a.triangles);
    assert_eq!(be.triangles, a.triangles);
    let pos = |m: &ply::PlyMesh| m.positions.iter().map(|p| p.1).collect::<Vec<_>>();
    assert_eq!(pos(&le), pos(&a));
    assert_eq!(pos(&be), pos(&a));
    assert!(a.normals.is_some() && le.normals.is_none());
}

/// Without `--width`/`--height`, `mlrender render` renders a pbrt file at its `Film`
/// resolution (`every.pbrt`: 20 × 10); given, the command line wins.
#[test]
fn the_film_resolution_is_the_default_image_size() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let size = |extra: &[&str], name: &str| {
        let out = dir.join(name);
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_mlrender"))
            .args(["render", "--scene"])
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/pbrt/every.pbrt"))
            .args(["--spp", "1", "-o"])
            .arg(&out)
            .args(extra)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .unwrap();
        assert!(status.success());
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&out).unwrap()));
        let info = decoder.read_info().unwrap();
        (info.info().width, info.info().height)
    };
    assert_eq!(size(&[], "film.png"), (20, 10));
    assert_eq!(size(&["--width", "8", "--height", "6"], "cli.png"), (8, 6));
}
