//! Every committed crash input of the fuzz targets (`fuzz/regressions/<target>/`) replayed
//! through the checks its target makes, which live once in this crate for both the targets
//! and this test: `cargo test` keeps every crash fixed. A `tree_bytes` input written in an
//! older byte format is just rejected by `from_bytes` (an error, which that check accepts).

use manylights_fuzz_checks::TARGETS;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// The fuzz workspace, `fuzz/`: this crate's parent directory.
fn fuzz_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the crate lies in fuzz/")
}

fn regressions() -> PathBuf {
    fuzz_dir().join("regressions")
}

/// The files of `dir`, sorted (none when it does not exist).
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(entries) => entries
            .map(|e| e.expect("a readable directory").path())
            .filter(|p| p.is_file())
            .collect(),
        Err(_) => Vec::new(),
    };
    v.sort();
    v
}

#[test]
fn every_fuzz_regression_passes_its_targets_checks() {
    let mut replayed = 0;
    let mut failures = Vec::new();
    for target in &TARGETS {
        for file in files(&regressions().join(target.name)) {
            let bytes = std::fs::read(&file).expect("a readable file");
            match catch_unwind(AssertUnwindSafe(|| (target.run)(&bytes))) {
                Ok(true) => replayed += 1,
                Ok(false) => failures.push(format!("{}: not decoded", file.display())),
                Err(e) => {
                    let msg = e
                        .downcast_ref::<String>()
                        .map(String::as_str)
                        .or_else(|| e.downcast_ref::<&str>().copied())
                        .unwrap_or("(no message)");
                    failures.push(format!("{}: {msg}", file.display()));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    eprintln!("replayed {replayed} fuzz regression inputs");
    assert!(
        replayed > 0,
        "no regression input under {}",
        regressions().display()
    );
}

/// Every target of `fuzz/Cargo.toml` has its checks here, and every directory under
/// `fuzz/regressions/` is a target's: no crash input goes unreplayed.
#[test]
fn every_fuzz_target_and_regression_directory_is_replayed() {
    let known: Vec<&str> = TARGETS.iter().map(|t| t.name).collect();
    let manifest = std::fs::read_to_string(fuzz_dir().join("Cargo.toml")).expect("fuzz/Cargo.toml");
    let mut bins = Vec::new();
    let mut in_bin = false;
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            in_bin = line == "[[bin]]";
        } else if let Some(name) = line.strip_prefix("name = ").filter(|_| in_bin) {
            bins.push(name.trim_matches('"').to_string());
        }
    }
    bins.sort();
    let mut want: Vec<String> = known.iter().map(|s| s.to_string()).collect();
    want.sort();
    assert_eq!(bins, want, "fuzz targets against replayed targets");
    for entry in std::fs::read_dir(regressions()).expect("fuzz/regressions") {
        let path = entry.expect("a readable directory").path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        assert!(
            known.contains(&name),
            "{} is no fuzz target's",
            path.display()
        );
    }
}
