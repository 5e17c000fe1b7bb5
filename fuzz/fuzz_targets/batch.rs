//! The `batch` target: its input and checks are `manylights_fuzz_checks::batch`'s (shared with
//! the replay of `regressions/batch/`, `checks/tests/regressions.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use manylights_fuzz_checks::batch::{check, Input};

fuzz_target!(|input: Input| check(&input));
