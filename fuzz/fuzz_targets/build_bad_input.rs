//! The `build_bad_input` target: its input and checks are `manylights_fuzz_checks::build_bad_input`'s (shared with
//! the replay of `regressions/build_bad_input/`, `checks/tests/regressions.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use manylights_fuzz_checks::build_bad_input::{check, Input};

fuzz_target!(|input: Input| check(&input));
