//! The `tree_bytes` target: its input and checks are `manylights_fuzz_checks::tree_bytes`'s (shared with
//! the replay of `regressions/tree_bytes/`, `checks/tests/regressions.rs`).
//!
//! `ML_TREE_BYTES_MODE=as-is` or `=resealed` runs one of its two modes only (inputs of the other
//! are skipped; each input names its mode, so a crash replays the same way without it).
#![no_main]

use libfuzzer_sys::fuzz_target;
use manylights_fuzz_checks::tree_bytes::{check, Input};
use std::sync::OnceLock;

fn only() -> Option<bool> {
    static MODE: OnceLock<Option<bool>> = OnceLock::new();
    *MODE.get_or_init(|| match std::env::var("ML_TREE_BYTES_MODE").as_deref() {
        Ok("resealed") => Some(true),
        Ok("as-is") => Some(false),
        _ => None,
    })
}

fuzz_target!(|input: Input| {
    if only().is_none_or(|m| m == input.resealed) {
        check(&input)
    }
});
