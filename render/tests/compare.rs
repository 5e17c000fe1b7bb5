//! `compare::run` on a tiny configuration (stairs, 12×8, 2 spp, a 16-spp reference, the
//! convergence plot up to 8 spp): every output file is written and readable (EXR values equal
//! to the rendered means), the JSON lists every technique in order with finite numbers;
//! the equal-time arithmetic; bad input is an error, not a panic; the `mlrender` binary's
//! `--time` checks and EXR output; the short summary `mlrender compare` prints (the full
//! tables with `--full`) and no progress bar when stderr is not a terminal.

use manylights::Technique;
use manylights_render::compare::{self, check_time, equal_time_spp, CompareConfig, Cost};
use manylights_render::image::font;
use manylights_render::image::{self, read_raw, Image};
use manylights_render::render::{render, Protocol, RenderConfig};
use manylights_render::scene;
use std::path::{Path, PathBuf};
use std::process::Command;

const W: usize = 12;
const H: usize = 8;
const NAMES: [&str; 10] = [
    "uniform",
    "energy",
    "tl",
    "tl-split",
    "bl",
    "mis-equal",
    "full",
    "tl-mis",
    "bl-mis",
    "tl-mis-pinf",
];

/// A fresh, empty temporary folder for one test.
fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mlrender-test-{}-{name}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn config(out: &Path, plot: bool, time: Option<f64>) -> CompareConfig {
    CompareConfig {
        width: W,
        height: H,
        spp: 2,
        ref_spp: 16,
        seed: 3,
        out: out.to_path_buf(),
        progress: false,
        plot,
        time,
        protocol: Protocol::Jittered,
        params: Default::default(),
        learn: None,
        techniques: Vec::new(),
    }
}

/// The R channel of an EXR file (checking R = G = B), with its size.
fn read_exr(path: &Path) -> (usize, usize, Vec<f32>) {
    let img = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _| (size.width(), vec![0f32; size.width() * size.height()]),
        |(w, px): &mut (usize, Vec<f32>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            assert!(r.to_bits() == g.to_bits() && g.to_bits() == b.to_bits());
            px[pos.y() * *w + pos.x()] = r;
        },
    )
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let size = img.layer_data.size;
    (
        size.width(),
        size.height(),
        img.layer_data.channel_data.pixels.1,
    )
}

/// An 8-bit RGB PNG file of a grey image: its size and pixels (one channel; the three are
/// checked equal).
fn read_png(path: &Path) -> (usize, usize, Vec<u8>) {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    buf.truncate(info.buffer_size());
    let grey: Vec<u8> = buf
        .chunks_exact(3)
        .map(|p| {
            assert!(p[0] == p[1] && p[1] == p[2], "{}: not grey", path.display());
            p[0]
        })
        .collect();
    (info.width as usize, info.height as usize, grey)
}

fn assert_same(path: &Path, values: &[[f32; 3]]) {
    let (w, h, px) = read_exr(path);
    assert_eq!((w, h), (W, H), "{}", path.display());
    assert_eq!(px.len(), values.len());
    for (a, b) in px.iter().zip(values) {
        // The scene is grey: every channel of the image is the same.
        assert!(b[0].to_bits() == b[1].to_bits() && b[1].to_bits() == b[2].to_bits());
        assert_eq!(
            a.to_bits(),
            b[0].to_bits(),
            "{}: {a} vs {b:?}",
            path.display()
        );
    }
}

#[test]
fn compare_writes_every_output() {
    let out = temp_dir("run");
    let s = scene::stairs();
    let cfg = config(&out, true, None);
    let report = compare::run(&s, &cfg).expect("compare runs");
    let dir = compare::output_dir(&s, &cfg);
    assert_eq!(report.dir, dir);

    // Images: PNG and EXR per technique (equal spp and equal time), the reference, the
    // side-by-side images, the plot and the table.
    let mut files = vec![
        "reference.png".to_string(),
        "reference.exr".to_string(),
        "reference-error.png".to_string(),
        "reference-error.exr".to_string(),
        "side_by_side.png".to_string(),
        "side_by_side_equal_time.png".to_string(),
        "side_by_side_error.png".to_string(),
        "side_by_side_equal_time_error.png".to_string(),
        "convergence.svg".to_string(),
        "table.md".to_string(),
    ];
    for n in NAMES {
        for suffix in ["", "-equal-time", "-error", "-equal-time-error"] {
            files.push(format!("{n}{suffix}.png"));
            files.push(format!("{n}{suffix}.exr"));
        }
    }
    for f in &files {
        let p = dir.join(f);
        let len = std::fs::metadata(&p)
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
            .len();
        assert!(len > 0, "{} is empty", p.display());
    }
    for name in [
        "side_by_side.png",
        "side_by_side_equal_time.png",
        "side_by_side_error.png",
        "side_by_side_equal_time_error.png",
    ] {
        let (w, h, px) = read_png(&dir.join(name));
        // The techniques' images and the reference, and their crops, 4-pixel gaps, under a
        // caption strip: 12-pixel panels are too narrow for ×2 text, so ×1, 1 + 7 + 1 rows.
        let strip = 9;
        let panels = NAMES.len() + 1;
        assert_eq!(
            (w, h),
            (panels * W + (panels - 1) * 4, strip + 2 * H + 4),
            "{name}"
        );
        assert_eq!(image::caption_height(1), strip);
        for i in 0..panels {
            let x0 = i * (W + 4);
            let caption = (0..strip).flat_map(|y| px[y * w + x0..y * w + x0 + W].to_vec());
            assert!(
                caption.filter(|&v| v > 0).count() >= 5,
                "{name}: no caption above panel {i}"
            );
            // The margins above and below the text and the gaps beside it stay black.
            assert!(px[x0..x0 + W].iter().all(|&v| v == 0), "{name}: panel {i}");
            let last = (strip - 1) * w;
            assert!(px[last + x0..last + x0 + W].iter().all(|&v| v == 0));
            if i + 1 < panels {
                for y in 0..strip {
                    let gap = y * w + x0 + W;
                    assert!(px[gap..gap + 4].iter().all(|&v| v == 0), "{name}: gap {i}");
                }
            }
        }
        // Below the strip: the reference panel as written on its own (but for the outline of
        // the crop region), and its crop.
        let own = if name.ends_with("_error.png") {
            "reference-error.png"
        } else {
            "reference.png"
        };
        let (rw, rh, rpx) = read_png(&dir.join(own));
        assert_eq!((rw, rh), (W, H));
        let (cx0, cy0, cx1, cy1) = image::crop_region(W, H);
        let x0 = NAMES.len() * (W + 4);
        for y in 0..H {
            for x in 0..W {
                let on_outline = (x == cx0 || x == cx1 || y == cy0 || y == cy1)
                    && (cx0..=cx1).contains(&x)
                    && (cy0..=cy1).contains(&y);
                let v = px[(strip + y) * w + x0 + x];
                if on_outline {
                    assert!(v == 0 || v == 255, "{name}: outline ({x}, {y}) = {v}");
                } else {
                    assert_eq!(v, rpx[y * W + x], "{name}: reference ({x}, {y})");
                }
                let crop = px[(strip + H + 4 + y) * w + x0 + x];
                assert_eq!(
                    crop,
                    rpx[(cy0 + y / 2).min(H - 1) * W + (cx0 + x / 2).min(W - 1)]
                );
            }
        }
    }
    let svg = std::fs::read_to_string(dir.join("convergence.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert_eq!(svg.matches("<polyline").count(), NAMES.len());
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    for n in NAMES {
        assert!(table.contains(&format!("| {n} |")), "{table}");
    }
    assert_eq!(report.table_path(), dir.join("table.md"));
    assert_eq!(table, report.table());
    check_summary(&report.summary(), &dir);

    // EXR: the rendered means exactly (renders are deterministic for a seed).
    for t in Technique::ALL {
        let img = render(
            &s,
            &RenderConfig {
                width: W,
                height: H,
                spp: cfg.spp,
                technique: t,
                seed: cfg.seed,
                progress: false,
                protocol: cfg.protocol,
                params: cfg.params,
                learn: None,
            },
        );
        assert_same(&dir.join(format!("{}.exr", t.name())), &img.mean);
    }
    let reference = read_raw(&compare::reference_path(&s, &cfg)).expect("cached reference");
    assert_same(&dir.join("reference.exr"), &reference.mean);
    // The error maps' EXR: the squared errors against the reference (the reference's own: the
    // variance of its pixel means); their PNG: the absolute error over the report's scale.
    let ref_var: Vec<[f32; 3]> = reference
        .mean_variances()
        .iter()
        .map(|&v| image::grey(v as f32))
        .collect();
    assert_same(&dir.join("reference-error.exr"), &ref_var);
    let tl_mis = render(
        &s,
        &RenderConfig {
            width: W,
            height: H,
            spp: cfg.spp,
            technique: Technique::TlMis,
            seed: cfg.seed,
            progress: false,
            protocol: cfg.protocol,
            params: cfg.params,
            learn: None,
        },
    );
    let sq = tl_mis.squared_errors(&reference);
    let sq32: Vec<[f32; 3]> = sq.iter().map(|&e| image::grey(e as f32)).collect();
    assert_same(&dir.join("tl-mis-error.exr"), &sq32);
    let (_, _, png) = read_png(&dir.join("tl-mis-error.png"));
    let expect: Vec<u8> = sq
        .iter()
        .map(|&e| image::tone_map((e.sqrt() / report.error_map_scale) as f32))
        .collect();
    assert_eq!(png, expect);
    let mse = sq.iter().sum::<f64>() / sq.len() as f64;
    assert!((report.error_map_scale - compare::ERROR_MAP_SCALE * mse.sqrt()).abs() < 1e-12);

    // JSON.
    let j = report.json();
    assert_eq!(j["scene"], "stairs");
    assert_eq!(j["lights"], s.lights.len());
    assert_eq!(j["resolution"], serde_json::json!([W, H]));
    assert_eq!(j["time_budget_from"], "full");
    let techs = j["techniques"].as_array().unwrap();
    let names: Vec<&str> = techs.iter().map(|t| t["name"].as_str().unwrap()).collect();
    assert_eq!(names, NAMES);
    let md = report.table();
    for t in techs {
        for key in [
            "rmse_equal_spp",
            "rmse_equal_time",
            "ms_per_spp",
            "ms_fixed",
            "seconds_equal_time",
            "mean_rel_diff",
            "mean_rel_diff_se",
        ] {
            let v = t[key].as_f64();
            assert!(
                v.is_some_and(|v| v.is_finite() && v >= 0.0),
                "{}: {key} = {}",
                t["name"],
                t[key]
            );
        }
        // The highest spp rendered: the plot goes to 4 × 2 spp, the equal-time render may
        // go further.
        let spp_t = t["spp_equal_time"].as_u64().unwrap();
        assert!(spp_t >= 1);
        assert_eq!(t["mean_rel_diff_spp"].as_u64().unwrap(), spp_t.max(8));
        // The signed difference is the absolute one with its sign, and the table shows it.
        let signed = t["mean_rel_diff_signed"].as_f64().unwrap();
        assert_eq!(signed.abs(), t["mean_rel_diff"].as_f64().unwrap());
        let shown = format!("| {:+.2} % |", 100.0 * signed);
        let row = md
            .lines()
            .find(|l| l.starts_with(&format!("| {} | ", t["name"].as_str().unwrap())))
            .unwrap();
        assert!(row.contains(&shown), "{row} lacks {shown}");
    }
    // `full` gets its own spp back when the budget is its own time.
    assert_eq!(techs[6]["spp_equal_time"], 2);

    // The reference's variance and the corrected RMSEs: RMSE' = sqrt(max(0, MSE − V)) and
    // the ratios to tl-mis.
    let v = j["reference_mean_variance"].as_f64().unwrap();
    let expect_v = reference.mean_variances().iter().sum::<f64>() / (W * H) as f64;
    assert!((v - expect_v).abs() <= 1e-12 * expect_v && v > 0.0);
    assert!((j["reference_rmse_floor"].as_f64().unwrap() - v.sqrt()).abs() < 1e-12);
    let mis = &techs[7];
    assert_eq!(mis["name"], "tl-mis");
    for t in techs {
        for at in ["equal_spp", "equal_time"] {
            let rmse = t[format!("rmse_{at}")].as_f64().unwrap();
            let corrected = t[format!("rmse_{at}_corrected")].as_f64().unwrap();
            assert!(
                (corrected - (rmse * rmse - v).max(0.0).sqrt()).abs() <= 1e-9 * rmse,
                "{}: {at}",
                t["name"]
            );
            // At equal time the ratios are of the RMSEs scaled to the budget,
            // RMSE × √(t / budget), so that a render that overshot its budget gains nothing.
            let scale = |x: &serde_json::Value| {
                if at == "equal_time" {
                    let t = x["seconds_equal_time"].as_f64().unwrap();
                    (t / j["time_budget_s"].as_f64().unwrap()).sqrt()
                } else {
                    1.0
                }
            };
            if at == "equal_time" {
                let b = t["rmse_equal_time_at_budget"].as_f64().unwrap();
                assert!(
                    (b - rmse * scale(t)).abs() <= 1e-12 * b.max(1e-300),
                    "{}",
                    t["name"]
                );
                assert!((t["budget_scale"].as_f64().unwrap() - scale(t)).abs() <= 1e-12);
            }
            let ratio = t[format!("rmse_{at}_vs_tl_mis")].as_f64().unwrap();
            let mis_rmse = mis[format!("rmse_{at}")].as_f64().unwrap();
            let want = (rmse * scale(t)) / (mis_rmse * scale(mis));
            assert!((ratio - want).abs() <= 1e-12 * ratio, "{}: {at}", t["name"]);
            let key = format!("rmse_{at}_corrected_vs_tl_mis");
            let mis_c = mis[format!("rmse_{at}_corrected")].as_f64().unwrap();
            if mis_c > 0.0 {
                let r = t[key.as_str()].as_f64().unwrap();
                let want = (corrected * scale(t)) / (mis_c * scale(mis));
                assert!((r - want).abs() <= 1e-12 * r.max(1e-300));
            }
            assert!(t["mean_rel_diff_sigma"].as_f64().is_some());
            assert!(t[format!("mse_{at}_se")].as_f64().is_some_and(|x| x >= 0.0));
        }
    }

    // The splits: every pixel in one class of each; per technique the parts add up to its
    // MSE (and, with the reference's variance removed, to MSE − V).
    let classes = &j["error_classes"];
    for what in ["material", "angle", "material_angle"] {
        let list = classes[what].as_array().unwrap();
        let pixels: u64 = list.iter().map(|c| c["pixels"].as_u64().unwrap()).sum();
        assert_eq!(pixels, (W * H) as u64, "{what}");
        for c in list {
            assert!(c["pixels"].as_u64().unwrap() > 0);
            assert!(c["reference_mean"].as_f64().is_some_and(|m| m >= 0.0));
            assert_eq!(c.get("kind").is_some(), what != "angle", "{what}: {c}");
        }
        for t in techs {
            for at in ["equal_spp", "equal_time"] {
                let parts = t["errors"][what][at].as_array().unwrap();
                assert_eq!(parts.len(), list.len());
                let rmse = t[format!("rmse_{at}")].as_f64().unwrap();
                let sum: f64 = parts.iter().map(|p| p["mse"].as_f64().unwrap()).sum();
                assert!(
                    (sum - rmse * rmse).abs() <= 1e-9 * rmse * rmse,
                    "{} {what} {at}: {sum} vs {}",
                    t["name"],
                    rmse * rmse
                );
                let sum_c: f64 = parts
                    .iter()
                    .map(|p| p["mse_corrected"].as_f64().unwrap())
                    .sum();
                assert!((sum_c - (rmse * rmse - v)).abs() <= 1e-9 * rmse * rmse);
                for (p, c) in parts.iter().zip(list) {
                    assert_eq!(p["class"], c["name"]);
                    assert!(p["rmse"].as_f64().is_some_and(|r| r >= 0.0));
                    let px = list.iter().find(|c| c["name"] == p["class"]).unwrap()["pixels"]
                        .as_u64()
                        .unwrap();
                    assert_eq!(p["mse_se"].as_f64().is_some(), px >= 2, "{p}");
                    assert!(p["rmse_corrected"].as_f64().is_some_and(|r| r >= 0.0));
                }
            }
        }
    }
    // Stairs: Lambert walls, plastic steps, a GGX rail; view-angle bins grazing first.
    let materials: Vec<&str> = classes["material"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["kind"].as_str().unwrap())
        .collect();
    assert!(materials.contains(&"lambert") && materials.contains(&"plastic"));
    let angles: Vec<&str> = classes["angle"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    let mut sorted = angles.clone();
    sorted.sort();
    if let Some(i) = sorted.iter().position(|&a| a == "no hit") {
        let nh = sorted.remove(i);
        sorted.push(nh);
    }
    assert_eq!(angles, sorted);
    for name in [
        "reference variance removed",
        "error by material",
        "error by view angle",
    ] {
        assert!(table.contains(name), "{name} missing from the table");
    }

    // A given budget, no plot: the cached reference is reused.
    let report = compare::run(&s, &config(&out, false, Some(0.002))).expect("compare runs");
    assert!(report.time_given);
    assert_eq!(report.json()["time_budget_s"], 0.002);
    assert_eq!(report.json()["time_budget_from"], "--time");

    // A subset of the techniques (given out of order): only those, in Technique::ALL order.
    let mut cfg = config(&out, false, Some(0.002));
    cfg.techniques = vec![Technique::BlMis, Technique::TlMis, Technique::Bl];
    let report = compare::run(&s, &cfg).expect("compare runs");
    let names: Vec<&str> = report
        .techniques
        .iter()
        .map(|t| t.technique.name())
        .collect();
    assert_eq!(names, ["bl", "tl-mis", "bl-mis"]);
    assert!(report.table().contains("| bl-mis |"));
    // tl-mis, bl and the default are needed, and full without a budget.
    for (ts, time) in [
        (
            vec![Technique::Bl, Technique::BlMis, Technique::Full],
            Some(0.002),
        ),
        (
            vec![Technique::TlMis, Technique::Bl, Technique::BlMis],
            None,
        ),
    ] {
        let mut cfg = config(&out, false, time);
        cfg.techniques = ts;
        let e = compare::run(&s, &cfg).expect_err("refused");
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput, "{e}");
    }
    std::fs::remove_dir_all(&out).ok();
}

/// The first channel of grey pixels (the three checked equal).
fn red(px: &[[f32; 3]]) -> Vec<f32> {
    px.iter()
        .map(|p| {
            assert!(p[0] == p[1] && p[1] == p[2]);
            p[0]
        })
        .collect()
}

/// A flat `width × height` image of `value`.
fn flat(width: usize, height: usize, value: f32) -> Image {
    Image {
        width,
        height,
        mean: vec![[value; 3]; width * height],
        var: vec![[0.0; 3]; width * height],
        spp: 1,
        seconds: 0.0,
        wall_seconds: 0.0,
        failed: 0,
    }
}

#[test]
fn captions() {
    // Every character of the captions has a glyph, all but the space with ink, and the
    // glyphs are distinct.
    let chars = "abcdefghijklmnopqrstuvwxyz0123456789-. ×";
    let mut seen = Vec::new();
    for c in chars.chars() {
        let g = font::glyph(c).unwrap_or_else(|| panic!("no glyph for {c:?}"));
        assert!(g.iter().all(|&row| row < 1 << font::GLYPH_W), "{c:?}");
        assert_eq!(g.iter().all(|&row| row == 0), c == ' ', "{c:?}");
        assert!(!seen.contains(&g), "{c:?} looks like another character");
        seen.push(g);
    }
    assert_eq!(font::glyph('Q'), font::glyph('q'));
    assert_eq!(font::glyph('é'), None);
    assert_eq!(font::text_width("", 2), 0);
    assert_eq!(font::text_width("full 0.1003", 1), 11 * 6 - 1);
    assert_eq!(font::text_width("full 0.1003", 2), 2 * (11 * 6 - 1));
    assert_eq!(font::truncate("uniform", 1, 12), "un");
    assert_eq!(font::truncate("uniform", 1, 41), "uniform");
    assert_eq!(font::truncate("uniform", 1, 40), "unifor");

    // A black panel: the caption is the only ink, and drawn in white.
    let dark = flat(96, 96, 0.0);
    let long = "mis-equal 0.1003";
    // The longest caption fits a 96-pixel panel at ×1, not at ×2; 256 pixels take ×2.
    assert_eq!(image::caption_scale(&[(long, &dark)]), 1);
    let wide = flat(256, 40, 0.0);
    assert_eq!(image::caption_scale(&[(long, &wide)]), 2);
    assert_eq!(image::caption_height(2), 18);
    let (w, h, px) = image::side_by_side_labelled(&[(long, &dark), ("reference", &dark)], 4);
    let px = red(&px);
    assert_eq!((w, h), (196, 9 + 2 * 96 + 4));
    let ink = |x0: usize, x1: usize| -> Vec<usize> {
        (0..9)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .filter(|&(x, y)| px[y * w + x] > 0.0)
            .map(|(x, _)| x)
            .collect()
    };
    // The whole caption, from the left margin to the panel's edge.
    let first = ink(0, 96);
    assert_eq!(first.iter().min(), Some(&1));
    assert!(first.iter().max().is_some_and(|&x| x <= 95));
    assert!(ink(96, 100).is_empty());
    // "reference" is centred: as much black on either side, give or take a pixel.
    let second = ink(100, 196);
    let (lo, hi) = (second.iter().min().unwrap(), second.iter().max().unwrap());
    assert!((lo - 100).abs_diff(195 - hi) <= 1, "{lo}..{hi}");
    assert!(px[..w * 9].iter().all(|&v| v == 0.0 || v == 1.0));
    // The crop region's outline, on the top row only.
    let (cx0, cy0, cx1, cy1) = image::crop_region(96, 96);
    assert_eq!((cx0, cy0, cx1, cy1), (24, 48, 71, 95));
    let top = |x: usize, y: usize| px[(9 + y) * w + x];
    assert!((cx0..=cx1).any(|x| top(x, cy0) == 1.0));
    assert!((cy0..=cy1).any(|y| top(cx1, y) == 1.0));
    assert_eq!(top(cx0 + 1, cy0 + 1), 0.0);
    assert!(px[(9 + 96) * w..].iter().all(|&v| v == 0.0));

    // ×2 on wide panels; too narrow a panel cuts the caption short.
    let (w, h, px) = image::side_by_side_labelled(&[(long, &wide)], 4);
    let px = red(&px);
    assert_eq!((w, h), (256, 18 + 2 * 40 + 4));
    assert!(px[..w * 18].contains(&1.0));
    let narrow = flat(5, 4, 0.5);
    let (w, h, px) = image::side_by_side_labelled(&[("uniform", &narrow)], 0);
    let px = red(&px);
    assert_eq!((w, h), (5, 9 + 8));
    assert!(px[..5 * 9].iter().all(|&v| v == 0.0));
    assert_eq!(image::side_by_side_labelled(&[], 4), (0, 0, Vec::new()));
}

#[test]
fn equal_time_arithmetic() {
    let c = Cost {
        fixed: 0.5,
        per_spp: 0.25,
    };
    assert_eq!(equal_time_spp(10.5, c), 40);
    assert_eq!(equal_time_spp(10.6, c), 40);
    assert_eq!(equal_time_spp(10.65, c), 41);
    // Never below 1, even when the fixed part eats the budget.
    assert_eq!(equal_time_spp(0.6, c), 1);
    assert_eq!(equal_time_spp(0.1, c), 1);
    let free = Cost {
        fixed: 0.0,
        per_spp: 0.0,
    };
    assert_eq!(equal_time_spp(1.0, free), 1);
    let nan = Cost {
        fixed: 0.0,
        per_spp: f64::NAN,
    };
    assert_eq!(equal_time_spp(1.0, nan), 1);

    // The cost model from a 0-spp and a 4-spp render.
    let c = Cost::from_times(1.0, 3.0, 4);
    assert_eq!(
        c,
        Cost {
            fixed: 1.0,
            per_spp: 0.5
        }
    );
    // A budget equal to the calibration render's time gives its spp back.
    assert_eq!(equal_time_spp(3.0, c), 4);
    // Inconsistent timings: the whole time per spp.
    assert_eq!(
        Cost::from_times(3.0, 2.0, 4),
        Cost {
            fixed: 0.0,
            per_spp: 0.5
        }
    );
    assert_eq!(Cost::from_times(f64::NAN, 2.0, 4).fixed, 0.0);

    assert_eq!(check_time(1.5), Ok(1.5));
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(check_time(bad).is_err(), "{bad}");
    }
}

#[test]
fn bad_input_is_an_error() {
    let out = temp_dir("bad");
    let s = scene::stairs();
    // An output root below a regular file cannot be created.
    let file = out.join("file");
    std::fs::write(&file, b"x").unwrap();
    let e = compare::run(&s, &config(&file.join("sub"), false, None)).unwrap_err();
    assert!(e.to_string().contains("file"), "{e}");
    let mut cfg = config(&out, false, None);
    cfg.spp = 0;
    assert!(compare::run(&s, &cfg).is_err());
    let mut cfg = config(&out, false, Some(-1.0));
    assert!(compare::run(&s, &cfg).is_err());
    cfg.time = None;
    cfg.width = 0;
    assert!(compare::run(&s, &cfg).is_err());
    std::fs::remove_dir_all(&out).ok();
}

/// The short summary: a title line, a header, one line per technique in order (its name,
/// two RMSEs, the ratio to tl-mis, the signed mean difference in %), and a last line naming
/// the full tables' file and the folder of the images; 13 lines, none longer than 100
/// characters but for the paths, no Markdown table.
fn check_summary(summary: &str, dir: &Path) {
    let lines: Vec<&str> = summary.lines().collect();
    assert_eq!(lines.len(), 2 + NAMES.len() + 1, "{summary}");
    assert!(lines[0].starts_with("stairs, 20 lights, "), "{summary}");
    assert!(lines[1].starts_with("technique"), "{summary}");
    for (line, n) in lines[2..2 + NAMES.len()].iter().zip(NAMES) {
        let f: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(f[0], n, "{summary}");
        for x in &f[1..3] {
            assert!(x.parse::<f64>().is_ok_and(|v| v >= 0.0), "{line}");
        }
        assert!(f[3].parse::<f64>().is_ok_and(|v| v > 0.0), "{line}");
        if n == "tl-mis" {
            assert_eq!(f[3], "1.000", "{line}");
        }
        assert!(f[4].parse::<f64>().is_ok() && f[5] == "%", "{line}");
    }
    let last = lines.last().unwrap();
    assert!(
        last.contains(&dir.join("table.md").display().to_string())
            && last.contains(&format!("{}/*.png", dir.display())),
        "{last}"
    );
    let paths = 2 * dir.display().to_string().chars().count();
    assert!(last.chars().count() <= 100 + paths, "{last}");
    assert!(
        lines[..lines.len() - 1]
            .iter()
            .all(|l| l.chars().count() <= 100),
        "{summary}"
    );
    assert!(!summary.contains("|---"), "{summary}");
}

#[test]
fn cli_compare_prints_a_summary() {
    let out = temp_dir("cli-summary");
    let (w, h) = (W.to_string(), H.to_string());
    let args = [
        "compare",
        "--scene",
        "stairs",
        "--width",
        &w,
        "--height",
        &h,
        "--spp",
        "2",
        "--ref-spp",
        "16",
        "--seed",
        "3",
        "--no-plot",
        "--out",
        out.to_str().unwrap(),
    ];
    let dir = out.join("compare").join("stairs-20");
    let o = mlrender(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    check_summary(&stdout, &dir);
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    assert!(table.contains("| bl-mis |"), "{table}");
    // stderr is not a terminal here: no progress bar, a few plain lines.
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("left") && !err.contains("rows"), "{err}");
    assert!(err.lines().count() <= 3, "{err}");
    // --full prints the tables of table.md (rewritten: the equal-time renders follow the
    // timings), then the summary; --json keeps its last line.
    let o = mlrender(&[&args[..], &["--full", "--json"]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    let table = std::fs::read_to_string(dir.join("table.md")).unwrap();
    let (before, json) = stdout.trim_end().rsplit_once('\n').unwrap();
    assert!(before.starts_with(table.trim_end()), "{before}");
    let summary = &before[table.trim_end().len()..].trim_start();
    check_summary(summary, &dir);
    let j: serde_json::Value = serde_json::from_str(json).unwrap();
    assert_eq!(j["techniques"].as_array().unwrap().len(), NAMES.len());
    std::fs::remove_dir_all(&out).ok();
}

fn mlrender(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_mlrender"))
        .args(args)
        .output()
        .expect("mlrender runs")
}

#[test]
fn cli_time_checks_and_exr_output() {
    for args in [
        &["compare", "--time", "0"][..],
        &["compare", "--time", "-2"],
        &["compare", "--time", "nan"],
        &["compare", "--time", "inf"],
        &["compare", "--time", "abc"],
        &["compare", "--time", "1", "--spp", "4"],
        &["compare", "--spp", "0"],
        &["render", "--width", "0"],
    ] {
        let o = mlrender(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        assert!(!o.stderr.is_empty(), "{args:?}");
    }
    let o = mlrender(&["compare", "--time", "-2"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("positive"), "{err}");

    // `render --technique` takes every technique by its core name; the default is the core's.
    let o = mlrender(&["render", "--help"]);
    let help = String::from_utf8_lossy(&o.stdout);
    for t in Technique::ALL {
        assert!(help.contains(t.name()), "{t} missing from:\n{help}");
    }
    let default = format!("[default: {}]", Technique::DEFAULT.name());
    assert!(help.contains(&default), "{default} missing from:\n{help}");
    let o = mlrender(&["render", "--technique", "no-such"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("bl-mis"));

    let out = temp_dir("cli");
    let exr = out.join("img.exr");
    let (w, h) = (W.to_string(), H.to_string());
    let base = [
        "render",
        "--scene",
        "stairs",
        "--technique",
        "tl",
        "--spp",
        "2",
        "--width",
        &w,
        "--height",
        &h,
    ];
    let o = mlrender(&[&base[..], &["-o", exr.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (ew, eh, px) = read_exr(&exr);
    assert_eq!((ew, eh), (W, H));
    assert!(px.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert!(px.iter().any(|&v| v > 0.0));
    // An output below a regular file: a message and status 1.
    let bad = exr.join("x.png");
    let o = mlrender(&[&base[..], &["-o", bad.to_str().unwrap()]].concat());
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("img.exr"));
    std::fs::remove_dir_all(&out).ok();
}
