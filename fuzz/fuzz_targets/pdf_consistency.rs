//! The `pdf_consistency` target: its input and checks are `manylights_fuzz_checks::pdf_consistency`'s (shared with
//! the replay of `regressions/pdf_consistency/`, `checks/tests/regressions.rs`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use manylights_fuzz_checks::pdf_consistency::{check, Input};

fuzz_target!(|input: Input| check(&input));
