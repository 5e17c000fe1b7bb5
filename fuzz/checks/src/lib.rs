//! The inputs and checks of the core's fuzz targets, in one place for the two that run them:
//! the cargo-fuzz targets in `fuzz/fuzz_targets/` (each one line: decode, then
//! [`check`](sptd::check)) and this crate's `tests/regressions.rs`, which replays every
//! committed crash input under `fuzz/regressions/<target>/` through the same checks, so that
//! `cargo test` keeps them fixed.
//!
//! Each module is one target: an `Input` that derives `Arbitrary` (decoded from the fuzzer's
//! bytes as `libfuzzer-sys` decodes it: [`decode`]) and `Debug` (what `cargo fuzz fmt` prints:
//! the reproducer), and a `check` that panics, with the input in the message, where the
//! property fails.
//!
//! | target | checks |
//! |---|---|
//! | [`build_bad_input`] | raw floats as lights: the build is an error or a tree that validates |
//! | [`tree_bytes`] | bytes to `LightTree::from_bytes`, as they are (edits of a valid tree always rejected) or resealed (the parser behind the checksum): an error or a tree that validates and samples |
//! | [`pdf_consistency`] | sampled pmfs equal queried ones, pmfs sum to 1, estimates finite |
//! | [`batch`] | the batched cut queries equal the single calls bit for bit |
//! | [`sptd`] | the BRDF-oriented cap integral: finite, ≥ 0, ≤ the albedo (with [`sptd::ALBEDO_TOLERANCE`]) |
//! | [`vpl`] | VPL acceptance: p in (0, 1], finite scaled intensity, errors naming the field |
//! | [`ffi`] | the C ABI with arbitrary arguments: a defined status, outputs only on success |

use arbitrary::{Arbitrary, Unstructured};

pub mod batch;
pub mod bounded;
pub mod build_bad_input;
pub mod ffi;
pub mod pdf_consistency;
pub mod sptd;
pub mod tree_bytes;
pub mod vpl;

/// A fuzz target: its name (as in `fuzz/Cargo.toml` and under `fuzz/regressions/`) and its
/// check on raw bytes ([`run`]).
pub struct Target {
    /// The name of the target.
    pub name: &'static str,
    /// Decodes the bytes as the target does and checks them; `false` when the target rejects
    /// them before checking (too few bytes for its input type).
    pub run: fn(&[u8]) -> bool,
}

/// Every fuzz target.
pub const TARGETS: [Target; 7] = [
    Target {
        name: "build_bad_input",
        run: run::<build_bad_input::Input>,
    },
    Target {
        name: "tree_bytes",
        run: run::<tree_bytes::Input>,
    },
    Target {
        name: "pdf_consistency",
        run: run::<pdf_consistency::Input>,
    },
    Target {
        name: "batch",
        run: run::<batch::Input>,
    },
    Target {
        name: "sptd",
        run: run::<sptd::Input>,
    },
    Target {
        name: "vpl",
        run: run::<vpl::Input>,
    },
    Target {
        name: "ffi",
        run: run::<ffi::Input>,
    },
];

/// An input a target checks.
pub trait Checked: for<'a> Arbitrary<'a> + core::fmt::Debug {
    /// Panics where a property of the target fails.
    fn check(&self);
}

/// The input `libfuzzer-sys` 0.4 (`fuzz_target!` with a typed input) hands the target for
/// `bytes`: `None` when there are fewer bytes than the type's minimum size or `Arbitrary`
/// rejects them, else `arbitrary_take_rest`.
pub fn decode<T: for<'a> Arbitrary<'a>>(bytes: &[u8]) -> Option<T> {
    if bytes.len() < T::size_hint(0).0 {
        return None;
    }
    T::arbitrary_take_rest(Unstructured::new(bytes)).ok()
}

/// [`decode`], then [`Checked::check`]; `false` when nothing was decoded.
pub fn run<T: Checked>(bytes: &[u8]) -> bool {
    match decode::<T>(bytes) {
        Some(input) => {
            input.check();
            true
        }
        None => false,
    }
}
