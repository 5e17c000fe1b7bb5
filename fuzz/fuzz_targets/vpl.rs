//! The `vpl` target: its input and checks are `manylights_fuzz_checks::vpl`'s (shared with
//! the replay of `regressions/vpl/`, `checks/tests/regressions.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use manylights_fuzz_checks::vpl::{check, Input};

fuzz_target!(|input: Input| check(&input));
