//! `mlmeasure bench --json` at a tiny size: the last line of stdout is one flat JSON object with
//! exactly the keys scripts read, each of its pinned kind (integer, float or string), and the
//! run's settings echoed; `--build-only` gives the build's keys only.

use serde_json::{Map, Value};
use std::process::Command;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Int,
    Float,
    Str,
}
use Kind::{Float, Int, Str};

/// The keys of a build-only report, and the first keys of a full one.
const BUILD_KEYS: [(&str, Kind); 18] = [
    ("baseline_build_cpu_ms", Float),
    ("baseline_build_ms", Float),
    ("baseline_build_peak_bytes_per_light", Float),
    ("baseline_bytes_per_light", Float),
    ("build_cpu_ms", Float),
    ("build_ms", Float),
    ("build_parallel_cpu_ms", Float),
    ("build_parallel_ms", Float),
    ("build_peak_bytes_per_light", Float),
    ("build_threads", Int),
    ("bytes_per_light", Float),
    ("depth", Int),
    ("kinds", Str),
    ("lights", Int),
    ("mean_fill", Float),
    ("nodes", Int),
    ("repeats", Int),
    ("seed", Int),
];

/// The keys a full report has besides [`BUILD_KEYS`].
const SAMPLING_KEYS: [(&str, Kind); 29] = [
    ("avg_bl_budget", Float),
    ("avg_cut_size", Float),
    ("avg_split_cut_size", Float),
    ("baseline_msamples_per_s", Float),
    ("batch_lanes", Int),
    ("batch_size", Int),
    ("batch_speedup", Float),
    ("bl_msamples_per_s", Float),
    ("bl_single_msamples_per_s", Float),
    ("bl_vs_tl", Float),
    ("cut_builds_per_s", Float),
    ("ffi_batch_msamples_per_s", Float),
    ("ffi_batch_vs_tl_batch", Float),
    ("memo_speedup", Float),
    ("pmf_batch_mqueries_per_s", Float),
    ("pmf_max_rel_err", Float),
    ("pmf_mqueries_per_s", Float),
    ("pmf_sum_max_err", Float),
    ("points", Int),
    ("returned_fraction", Float),
    ("speedup", Float),
    ("split_cut_builds_per_s", Float),
    ("split_each_msamples_per_s", Float),
    ("split_each_speedup", Float),
    ("split_msamples_per_s", Float),
    ("tl_8_per_point_memo_msamples_per_s", Float),
    ("tl_8_per_point_msamples_per_s", Float),
    ("tl_batch_msamples_per_s", Float),
    ("tl_msamples_per_s", Float),
];

/// Runs `mlmeasure bench` at 50 lights, 64 points, seed 7, one repeat, with `extra` arguments;
/// returns stdout's last line as a JSON object, and stdout.
fn bench_json(extra: &[&str]) -> (Map<String, Value>, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_mlmeasure"))
        .args([
            "bench",
            "--lights",
            "50",
            "--points",
            "64",
            "--seed",
            "7",
            "--repeats",
            "1",
            "--json",
        ])
        .args(extra)
        .output()
        .expect("mlmeasure runs");
    let stdout = String::from_utf8(o.stdout).expect("stdout is UTF-8");
    assert!(
        o.status.success(),
        "{extra:?}: {}\n{stdout}",
        String::from_utf8_lossy(&o.stderr)
    );
    let last = stdout.lines().last().expect("stdout has a line");
    match serde_json::from_str(last) {
        Ok(Value::Object(m)) => (m, stdout),
        other => panic!("{extra:?}: the last line is not a JSON object: {other:?}\n{last}"),
    }
}

fn kind(v: &Value) -> Option<Kind> {
    match v {
        Value::Number(n) if n.is_u64() => Some(Int),
        Value::Number(n) if n.is_f64() => Some(Float),
        Value::String(_) => Some(Str),
        _ => None,
    }
}

/// `report` has exactly the keys of `expected`, each of its kind.
fn assert_keys(report: &Map<String, Value>, expected: &[(&str, Kind)], what: &str) {
    for &(key, k) in expected {
        let v = report
            .get(key)
            .unwrap_or_else(|| panic!("{what}: no key {key}"));
        assert_eq!(kind(v), Some(k), "{what}: {key} = {v}");
    }
    let extra: Vec<&String> = report
        .keys()
        .filter(|key| !expected.iter().any(|(e, _)| e == key))
        .collect();
    assert!(extra.is_empty(), "{what}: unpinned keys {extra:?}");
}

/// The settings of [`bench_json`], echoed.
fn assert_settings(report: &Map<String, Value>) {
    assert_eq!(report["lights"], 50);
    assert_eq!(report["seed"], 7);
    assert_eq!(report["repeats"], 1);
    assert_eq!(report["kinds"], "mixed");
}

#[test]
fn full_json_has_every_key() {
    let (r, stdout) = bench_json(&[]);
    let all: Vec<(&str, Kind)> = BUILD_KEYS.iter().chain(&SAMPLING_KEYS).copied().collect();
    assert_keys(&r, &all, "full");
    assert_settings(&r);
    assert_eq!(r["points"], 64);
    assert_eq!(r["batch_size"], 256);
    assert_eq!(r["batch_lanes"], manylights::internals::sample::BATCH_LANES);
    assert!(r["pmf_max_rel_err"].as_f64().unwrap() < 1e-3);
    assert!(r["pmf_sum_max_err"].as_f64().unwrap() < 1e-3);
    assert!(r["tl_msamples_per_s"].as_f64().unwrap() > 0.0);
    // The human table comes first, with its sampling rows.
    assert!(stdout.starts_with("| measure | value |"), "{stdout}");
    assert!(stdout.contains("| shading points | 64.0000 |"), "{stdout}");
    assert!(stdout.contains("| mean split cut size |"), "{stdout}");
}

#[test]
fn build_only_json_has_the_build_keys() {
    let (r, stdout) = bench_json(&["--build-only"]);
    assert_keys(&r, &BUILD_KEYS, "build-only");
    assert_settings(&r);
    assert!(r["build_ms"].as_f64().unwrap() > 0.0);
    assert!(!stdout.contains("shading points"), "{stdout}");
}
