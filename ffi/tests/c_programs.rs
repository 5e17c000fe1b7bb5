//! The C ABI from C and C++: compiles `tests/c/test_abi.c` (C99), `tests/c/test_abi.cpp`
//! (C++17) and `tests/c/test_hpp.cpp` (C++17, the wrapper `include/manylights.hpp`) with
//! `-Wall -Wextra -Werror -pedantic` against the static library and the committed headers,
//! runs them (under valgrind with `--error-exitcode=1 --leak-check=full
//! --errors-for-leak-kinds=definite,indirect` when `ML_FFI_VALGRIND=1`), and then
//!
//! - replays their dump with the Rust core: the same lights built into a tree, the same
//!   samples and pmfs (TL points of every `ml_receiver`), bit for bit, and the BRDF values
//!   of RGB albedos (`ml_brdf_eval`, `ml_brdf_sample`'s draw) those of `Material::eval_rgb`;
//! - checks that every function the header declares got a bad-input check with NULL and one
//!   with an invalid value (the `cover` lines they print);
//! - checks that `test_hpp.cpp` uses every class, every free function and every method of
//!   the wrapper (the throwing and the `try_` form of each fallible call).
//!
//! The compilers are `$CC` / `$CXX` (default `cc` / `c++`).

use glam::Vec3;
use manylights::importance::Receiver;
use manylights::Rgb;
use manylights::{
    BlImportance, Brdf, Frame, Light, LightTree, Material, ShadingPoint, TlImportance,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The static library cargo built for this test run (the profile directory holds it).
fn static_lib() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    let deps = exe.parent().expect("deps directory");
    let profile = deps.parent().expect("profile directory");
    // deps first: the profile directory may hold a copy from an earlier `cargo build`.
    for dir in [deps, profile] {
        let p = dir.join("libmanylights_ffi.a");
        if p.exists() {
            return p;
        }
    }
    panic!(
        "libmanylights_ffi.a not found next to {} (build the package first)",
        exe.display()
    );
}

fn compile(source: &str, cpp: bool, out: &Path) {
    let dir = manifest_dir();
    let compiler = if cpp {
        std::env::var("CXX").unwrap_or_else(|_| "c++".into())
    } else {
        std::env::var("CC").unwrap_or_else(|_| "cc".into())
    };
    let std_flag = if cpp { "-std=c++17" } else { "-std=c99" };
    let status = Command::new(&compiler)
        .args([
            std_flag,
            "-Wall",
            "-Wextra",
            "-Werror",
            "-pedantic",
            "-g",
            "-O1",
        ])
        .arg("-I")
        .arg(dir.join("include"))
        .arg(dir.join("tests/c").join(source))
        .arg(static_lib())
        .args(["-lpthread", "-ldl", "-lm", "-lrt", "-lgcc_s", "-o"])
        .arg(out)
        .status()
        .unwrap_or_else(|e| panic!("cannot run {compiler}: {e}"));
    assert!(status.success(), "{compiler} failed on {source}");
}

/// Runs a test program with the dump's path (under valgrind if asked); returns its stdout.
fn run(exe: &Path, dump: &Path) -> String {
    run_args(exe, &[dump])
}

/// Runs a test program with `args` (under valgrind if asked); returns its stdout.
fn run_args(exe: &Path, args: &[&Path]) -> String {
    let valgrind = std::env::var("ML_FFI_VALGRIND").is_ok_and(|v| v == "1");
    let mut cmd = if valgrind {
        let mut c = Command::new("valgrind");
        c.args([
            "--error-exitcode=1",
            "--leak-check=full",
            "--errors-for-leak-kinds=definite,indirect",
            "--quiet",
        ])
        .arg(exe);
        c
    } else {
        Command::new(exe)
    };
    let out = cmd.args(args).output().expect("the test program runs");
    if valgrind {
        eprintln!(
            "{}: ran under valgrind, exit status {}",
            exe.display(),
            out.status
        );
    }
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    eprintln!("{stderr}");
    assert!(
        out.status.success(),
        "{} failed ({}{}):\n{stdout}\n{stderr}",
        exe.display(),
        out.status,
        if valgrind { ", under valgrind" } else { "" }
    );
    stdout
}

fn f(tok: &str) -> f32 {
    f32::from_bits(u32::from_str_radix(tok, 16).expect("hex bits"))
}

fn v(t: &[&str]) -> Vec3 {
    Vec3::new(f(t[0]), f(t[1]), f(t[2]))
}

/// The Rust light of a dumped `ml_light` (kind, two_sided, 15 numbers: the intensity,
/// radiance or irradiance's three channels among them, `dump_light` in `scenarios.h`),
/// written out here independently of the ABI's own conversion.
fn light(t: &[&str]) -> Light {
    let kind: u32 = t[0].parse().unwrap();
    let two_sided = t[1] == "1";
    let (p, d, v2) = (v(&t[2..5]), v(&t[5..8]), v(&t[8..11]));
    let power = Rgb::new(f(t[11]), f(t[12]), f(t[13]));
    let (radius, half, falloff) = (f(t[14]), f(t[15]), f(t[16]));
    match kind {
        0 => Light::Point {
            position: p,
            intensity: power,
        },
        1 => Light::Spot {
            position: p,
            direction: d,
            intensity: power,
            half_angle: half,
            falloff_start: falloff,
        },
        2 => Light::Sphere {
            center: p,
            radius,
            radiance: power,
        },
        3 => Light::Disk {
            center: p,
            normal: d,
            radius,
            radiance: power,
            two_sided,
        },
        4 => Light::Triangle {
            vertices: [p, d, v2],
            radiance: power,
            two_sided,
        },
        _ => Light::Vpl {
            position: p,
            normal: d,
            intensity: power,
        },
    }
}

fn shading_point(t: &[&str]) -> ShadingPoint {
    let albedo = Rgb::new(f(t[10]), f(t[11]), f(t[12]));
    let (specular, alpha) = (f(t[13]), f(t[14]));
    let material = match t[9] {
        "0" => Material::Lambert { albedo },
        "1" => Material::Ggx { alpha, specular },
        _ => Material::Plastic {
            albedo,
            specular,
            alpha,
        },
    };
    ShadingPoint {
        position: v(&t[0..3]),
        normal: v(&t[3..6]),
        wo: v(&t[6..9]),
        material,
    }
}

/// Replays a dump with the core; returns the number of values compared.
fn replay(dump: &Path) -> usize {
    let text = std::fs::read_to_string(dump).expect("the dump");
    let mut lights = Vec::new();
    let mut records = Vec::new();
    for line in text.lines() {
        let t: Vec<&str> = line.split_whitespace().collect();
        match t[0] {
            "L" => lights.push(light(&t[1..])),
            _ => records.push(t),
        }
    }
    assert_eq!(lights.len(), 10_000);
    let tree = LightTree::build(&lights).expect("the dumped lights are valid");
    let none = u32::MAX;
    let mut compared = 0;
    for t in &records {
        if matches!(t[0], "F" | "G") {
            brdf_record(t);
            compared += 1;
            continue;
        }
        let (light, pmf): (u32, u32) = (
            t[t.len() - 2].parse().unwrap(),
            u32::from_str_radix(t[t.len() - 1], 16).unwrap(),
        );
        match t[0] {
            "S" | "Q" => {
                let receiver = match t[8] {
                    "0" => Receiver::Reflective,
                    "1" => Receiver::Transmissive,
                    _ => Receiver::Omnidirectional,
                };
                let imp = TlImportance::with_receiver(v(&t[1..4]), v(&t[4..7]), receiver);
                if t[0] == "S" {
                    let s = tree.sample(&imp, f(t[7]));
                    let (l, p) = s.map_or((none, 0), |s| (s.light, s.pmf.to_bits()));
                    assert_eq!((l, p), (light, pmf), "TL sample: {t:?}");
                } else {
                    assert_eq!(tree.pmf(&imp, light).to_bits(), pmf, "TL pmf: {t:?}");
                }
            }
            "B" | "P" => {
                let imp = BlImportance::new(&shading_point(&t[1..16])).expect("a valid point");
                if t[0] == "B" {
                    let s = tree.sample(&imp, f(t[16]));
                    let (l, p) = s.map_or((none, 0), |s| (s.light, s.pmf.to_bits()));
                    assert_eq!((l, p), (light, pmf), "BL sample: {t:?}");
                } else {
                    assert_eq!(tree.pmf(&imp, light).to_bits(), pmf, "BL pmf: {t:?}");
                }
            }
            other => panic!("unknown record {other}"),
        }
        compared += 1;
    }
    compared
}

/// A BRDF record: `F` (the `ml_brdf_eval` of a direction) or `G` (the `ml_brdf_sample` draw
/// of two uniform numbers: its pdf and value), checked bit for bit against the core's
/// material in the shading frame the library uses (`Material::eval_rgb` per channel).
fn brdf_record(t: &[&str]) {
    let sp = shading_point(&t[1..16]);
    let (wi, pdf) = (v(&t[16..19]), f(t[19]));
    let value = Rgb::new(f(t[20]), f(t[21]), f(t[22]));
    let frame = Frame::from_normal(sp.normal).expect("a valid normal");
    let wo = frame.to_local(sp.wo.normalize());
    let m = sp.material;
    let bits = |c: Rgb| [c.r.to_bits(), c.g.to_bits(), c.b.to_bits()];
    if t[0] == "F" {
        // A direction of unit length (to f32 rounding) is taken as it is (ml_brdf_eval's rule).
        let w = if (wi.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON {
            wi
        } else {
            wi.normalize()
        };
        let want = m.eval_rgb(wo, frame.to_local(w));
        assert_eq!(bits(value), bits(want), "ml_brdf_eval: {t:?}");
    } else {
        let (want_pdf, want) = match m.sample(wo, [wi.x, wi.y]) {
            Some((w, p)) => (p, m.eval_rgb(wo, w)),
            None => (0.0, Rgb::grey(0.0)),
        };
        assert_eq!(
            (pdf.to_bits(), bits(value)),
            (want_pdf.to_bits(), bits(want)),
            "ml_brdf_sample: {t:?}"
        );
    }
}

/// The functions the header declares.
fn header_functions() -> Vec<String> {
    let header = std::fs::read_to_string(manifest_dir().join("include/manylights.h")).unwrap();
    let mut names = Vec::new();
    for line in header.lines() {
        let line = line.trim_start();
        let rest = line
            .strip_prefix("ml_status ")
            .or_else(|| line.strip_prefix("const char *"));
        if let Some(name) = rest.and_then(|r| r.split('(').next()) {
            if name.starts_with("ml_") {
                names.push(name.to_string());
            }
        }
    }
    names
}

/// Every declared function has a NULL and an invalid-value check, except where none exists:
/// `ml_last_error_message` (no argument).
fn check_coverage(stdout: &str) -> (usize, usize) {
    let mut cover: BTreeMap<String, (u32, u32)> = BTreeMap::new();
    for line in stdout.lines() {
        let t: Vec<&str> = line.split_whitespace().collect();
        if t.first() == Some(&"cover") {
            cover.insert(t[1].into(), (t[2].parse().unwrap(), t[3].parse().unwrap()));
        }
    }
    let mut total = 0;
    let functions = header_functions();
    assert!(functions.len() > 40, "the header parse found {functions:?}");
    for name in &functions {
        if name == "ml_last_error_message" {
            continue;
        }
        let (nulls, invalids) = cover.get(name).copied().unwrap_or((0, 0));
        assert!(
            nulls >= 1 && invalids >= 1,
            "{name}: {nulls} NULL and {invalids} invalid-value checks"
        );
        total += (nulls + invalids) as usize;
    }
    (functions.len(), total)
}

fn program(source: &str, cpp: bool) {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let stem = source.replace('.', "_");
    let exe = dir.join(&stem);
    let dump = dir.join(format!("{stem}.dump"));
    compile(source, cpp, &exe);
    let stdout = run(&exe, &dump);
    let compared = replay(&dump);
    assert_eq!(compared, 3000);
    let (functions, checks) = check_coverage(&stdout);
    eprintln!("{source}: {compared} samples and pmfs equal to the core's; {checks} bad-input checks over {functions} functions");
}

#[test]
fn c99_program() {
    program("test_abi.c", false);
}

#[test]
fn cpp17_program() {
    program("test_abi.cpp", true);
}

/// What the wrapper declares in `namespace ml` (outside `detail`): its classes, its free
/// functions and the names of its `try_` calls (each also has a throwing form of the name
/// without `try_`). Read from the header's layout: namespace-scope declarations start in
/// column 0, members are indented.
fn wrapper_names() -> (Vec<String>, Vec<String>, Vec<String>) {
    let header = std::fs::read_to_string(manifest_dir().join("include/manylights.hpp")).unwrap();
    let ident = |s: &str| -> String {
        s.chars()
            .rev()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect()
    };
    let (mut classes, mut functions, mut tries) = (Vec::new(), Vec::new(), Vec::new());
    let mut in_detail = false;
    for line in header.lines() {
        if line.starts_with("namespace detail") {
            in_detail = true;
        } else if line.starts_with("}  // namespace detail") {
            in_detail = false;
        }
        let code = line.trim_start();
        if code.starts_with('*') || code.starts_with("/*") || code.starts_with("//") {
            continue;
        }
        let mut rest = line;
        while let Some(i) = rest.find("try_") {
            let name = ident(&rest[..i]);
            let tail: String = rest[i + 4..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if name.is_empty() && rest[i + 4 + tail.len()..].starts_with('(') {
                tries.push(tail.clone());
            }
            rest = &rest[i + 4..];
        }
        if in_detail || line.starts_with(' ') || line.starts_with('/') || line.starts_with('#') {
            continue;
        }
        let decl = line.replace("[[nodiscard]] ", "");
        if let Some(c) = decl
            .strip_prefix("class ")
            .or_else(|| decl.strip_prefix("struct "))
        {
            let name: String = c
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            // Not a forward declaration.
            if !name.is_empty() && (c.contains('{') || !c.trim_end().ends_with(';')) {
                classes.push(name);
            }
        } else if let Some(open) = decl.find('(') {
            if decl.starts_with("template") || decl.starts_with("namespace") {
                continue;
            }
            let name = ident(decl[..open].trim_end());
            if !name.is_empty() && !name.starts_with("try_") {
                functions.push(name);
            }
        }
    }
    for v in [&mut classes, &mut functions, &mut tries] {
        v.sort();
        v.dedup();
    }
    (classes, functions, tries)
}

#[test]
fn cpp17_wrapper() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let exe = dir.join("test_hpp");
    compile("test_hpp.cpp", true, &exe);
    let stdout = run_args(&exe, &[]);
    assert!(
        stdout.contains("test_hpp: ") && stdout.contains(" checks, 0 failures"),
        "{stdout}"
    );
    let source = std::fs::read_to_string(manifest_dir().join("tests/c/test_hpp.cpp")).unwrap();
    let (classes, functions, tries) = wrapper_names();
    assert!(
        classes.len() >= 10 && functions.len() >= 20 && tries.len() >= 40,
        "the wrapper parse found {classes:?} {functions:?} {tries:?}"
    );
    let mut missing = Vec::new();
    for c in &classes {
        if !source.contains(&format!("ml::{c}")) && !source.contains(&format!("ml::{c}<")) {
            missing.push(format!("class ml::{c}"));
        }
    }
    for f in &functions {
        if !source.contains(&format!("ml::{f}(")) {
            missing.push(format!("function ml::{f}"));
        }
    }
    for t in &tries {
        let thrown = [".", "::"]
            .iter()
            .any(|p| source.contains(&format!("{p}{t}(")));
        if !source.contains(&format!("try_{t}(")) || !thrown {
            missing.push(format!("{t} / try_{t}"));
        }
    }
    assert!(missing.is_empty(), "test_hpp.cpp does not use: {missing:?}");
    eprintln!(
        "test_hpp.cpp: {} classes, {} free functions, {} calls in both forms",
        classes.len(),
        functions.len(),
        tries.len()
    );
}
