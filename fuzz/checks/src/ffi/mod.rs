//! The C ABI (`manylights-ffi`) called from Rust as a host would call it, with arbitrary
//! arguments: a sequence of operations on handles the harness keeps (trees built from light
//! descriptors of every kind or loaded from serialized bytes, edited or not; cuts; estimators;
//! VPL acceptors), each pointer argument NULL, valid or misaligned, each value raw or in range,
//! each count at most the length of the buffer behind it (the ABI trusts a pointer and count
//! the host passes: only NULL pointers go with larger counts), light indices in or out of
//! range. Freed handles are never used again. After every call:
//!
//! - the status is one of `ML_OK` … `ML_ERR_STATE`: `ML_ERR_INTERNAL` (a caught panic or a
//!   broken invariant) and any other value are findings;
//! - on failure no output was written (every output is pre-filled with a sentinel) and
//!   `ml_last_error_message()` starts with the function's name and says something;
//! - on success no misaligned pointer was accepted, no output is NaN, a sampled light is in
//!   range with pmf in (0, 1] (`ML_NO_LIGHT` with pmf 0), pmfs are in [0, 1], estimates and
//!   MIS scales are finite and non-negative, weights in [0, 1], a batch leaves the elements
//!   past its count alone and equals the single calls bit for bit, and the unedited bytes of a
//!   serialized tree load back.
//!
//! The module's parts: `grammar` decodes the fuzzer's bytes into the operations (the
//! [`Input`] a target takes) and their values into the ABI's arguments; `buffers` holds the
//! arguments behind aligned, misaligned or NULL pointers, every output pre-filled with a
//! sentinel; `host` provides the callbacks (uniform numbers, visibility, hits); `harness` keeps
//! the handles, replays the operations, one module a family of the ABI, and makes the checks
//! above ([`check`]).

mod buffers;
mod grammar;
mod harness;
mod host;

pub use grammar::*;
pub use harness::check;

impl crate::Checked for Input {
    fn check(&self) {
        check(self)
    }
}

#[cfg(test)]
mod tests {
    /// splitmix64 bytes.
    fn bytes(seed: u64, len: usize) -> Vec<u8> {
        let mut s = seed;
        (0..len)
            .map(|_| {
                s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = s;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                (z ^ (z >> 31)) as u8
            })
            .collect()
    }

    /// Seeded inputs of every length up to 4 KiB pass the checks (the harness itself works:
    /// the committed crash inputs are replayed by `tests/fuzz_regressions.rs`).
    #[test]
    fn seeded_inputs_pass() {
        for seed in 0..300u64 {
            let b = bytes(seed, (seed as usize * 37) % 4096);
            assert!(crate::run::<super::Input>(&b), "seed {seed}: not decoded");
        }
    }
}
