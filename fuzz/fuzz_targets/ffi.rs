//! The `ffi` target: its input and checks are `manylights_fuzz_checks::ffi`'s (shared with
//! the replay of `regressions/ffi/`, `checks/tests/regressions.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use manylights_fuzz_checks::ffi::{check, Input};

fuzz_target!(|input: Input| check(&input));
