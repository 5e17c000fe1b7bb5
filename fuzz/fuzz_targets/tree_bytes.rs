//! The `tree_bytes` target: its input and checks are `manylights_fuzz_checks::tree_bytes`'s (shared with
//! the core's replay of `regressions/tree_bytes/`, `tests/fuzz_regressions.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use manylights_fuzz_checks::tree_bytes::{check, Input};

fuzz_target!(|input: Input| check(&input));
