//! The `sptd` target: its input and checks are `manylights_fuzz_checks::sptd`'s (shared with
//! the replay of `regressions/sptd/`, `checks/tests/regressions.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use manylights_fuzz_checks::sptd::{check, Input};

fuzz_target!(|input: Input| check(&input));
