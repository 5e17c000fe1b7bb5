//! The C ABI of manylights: everything a C or C++ renderer needs, behind one header
//! (`include/manylights.h`, generated from this crate by cbindgen) and one library.
//!
//! Conventions (`ffi/README.md` states them for C users): every function is prefixed `ml_`
//! and returns an [`ml_status`] (the one exception is [`ml_last_error_message`]); outputs go
//! through out-params written only on success; handles are opaque, created by `*_create` /
//! `*_build` / `*_load` and released by `*_free`, which accepts NULL; on failure the
//! thread-local [`ml_last_error_message`] names the function, the argument, the light index
//! and the field that were wrong.
//!
//! Inside: every export runs its body through [`ffi_fn!`], the one panic boundary; every
//! pointer becomes a reference through the typed helpers of the `arg` module. Besides this
//! crate, `unsafe` code is only in the core's cache prefetch hint (its feature `prefetch`) and
//! in the instruments' counting allocator.

#![allow(non_camel_case_types)]
#![allow(clippy::not_unsafe_ptr_arg_deref)]
#![deny(missing_docs)]

mod arg;
pub mod brdf;
pub mod cut;
pub mod direct;
mod error;
pub mod limits;
pub mod tree;
pub mod types;
pub mod visibility_cache;
pub mod vpl;

pub use brdf::*;
pub use cut::*;
pub use direct::*;
pub use error::*;
pub use limits::*;
pub use tree::*;
pub use types::*;
pub use visibility_cache::*;
pub use vpl::*;

/// Major version of the library (the `version` of `ffi/Cargo.toml`).
pub const ML_VERSION_MAJOR: u32 = 0;
/// Minor version of the library.
pub const ML_VERSION_MINOR: u32 = 4;
/// Patch version of the library.
pub const ML_VERSION_PATCH: u32 = 0;

/// The one panic boundary: runs the body of an exported function, converts its
/// `Result<(), Error>` into an [`ml_status`] (recording the message of an error for
/// [`ml_last_error_message`]) and turns a panic into [`ML_ERR_INTERNAL`] with its message, so
/// that no panic crosses into C. The second form has a typed fallback for functions that
/// return something else.
#[macro_export]
#[doc(hidden)]
macro_rules! ffi_fn {
    ($name:literal, $body:block) => {{
        match ::std::panic::catch_unwind(::std::panic::AssertUnwindSafe(
            || -> ::core::result::Result<(), $crate::Error> { $body },
        )) {
            Ok(Ok(())) => $crate::ML_OK,
            Ok(Err(e)) => e.report($name),
            Err(payload) => $crate::Error::from_panic(payload).report($name),
        }
    }};
    ($name:literal, $fallback:expr, $body:block) => {{
        match ::std::panic::catch_unwind(::std::panic::AssertUnwindSafe(|| $body)) {
            Ok(v) => v,
            Err(payload) => {
                $crate::Error::from_panic(payload).report($name);
                $fallback
            }
        }
    }};
}

/// Writes the library's version (`major.minor.patch`, as the `ML_VERSION_*` macros of the
/// header it was built with) to the three out-params.
///
/// Errors: `ML_ERR_NULL` if any pointer is NULL.
#[no_mangle]
pub extern "C" fn ml_version(major: *mut u32, minor: *mut u32, patch: *mut u32) -> ml_status {
    ffi_fn!("ml_version", {
        let major = arg::out(major, "major")?;
        let minor = arg::out(minor, "minor")?;
        let patch = arg::out(patch, "patch")?;
        major.write(ML_VERSION_MAJOR);
        minor.write(ML_VERSION_MINOR);
        patch.write(ML_VERSION_PATCH);
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn version_macros_match_cargo_toml() {
        let parse = |s: &str| s.parse::<u32>().unwrap();
        assert_eq!(ML_VERSION_MAJOR, parse(env!("CARGO_PKG_VERSION_MAJOR")));
        assert_eq!(ML_VERSION_MINOR, parse(env!("CARGO_PKG_VERSION_MINOR")));
        assert_eq!(ML_VERSION_PATCH, parse(env!("CARGO_PKG_VERSION_PATCH")));
    }

    #[test]
    fn every_macro_of_the_header_is_ml_and_every_limit_has_its_value() {
        let header = include_str!("../include/manylights.h");
        for line in header.lines().filter(|l| l.starts_with("#define ")) {
            let name = line.split_whitespace().nth(1).unwrap_or("");
            assert!(
                name.starts_with("ML_") || name == "MANYLIGHTS_H",
                "a macro outside ML_: {line}"
            );
        }
        for (name, value) in [
            ("ML_MAX_COORDINATE", "1e15"),
            ("ML_MAX_LIGHT_ENERGY", "1e24"),
            ("ML_MAX_TOTAL_ENERGY", "1e26"),
            ("ML_MAX_LIGHTS", "2147483646"),
            ("ML_MIN_PMF", "1.17549435e-38"),
            ("ML_MAX_DEPTH", "31"),
            ("ML_MIN_BUCKETS", "12"),
            ("ML_MAX_BUCKETS", "64"),
            ("ML_MIN_CUT_SIZE", "4"),
            ("ML_MAX_CUT_SIZE", "64"),
            ("ML_CUT_CAPACITY", "80"),
            ("ML_MAX_BUDGET", "64"),
            ("ML_MAX_LIGHT_SAMPLES", "64"),
            ("ML_MIN_ALPHA", "5e-3"),
            ("ML_MAX_VISIBILITY_CELLS", "1048576"),
            ("ML_MAX_VISIBILITY_SLOTS", "4096"),
            ("ML_MAX_VISIBILITY_COUNTERS", "16777216"),
            ("ML_SAMPLED_LIGHT_NONE", "{ ML_NO_LIGHT, 0.0f }"),
        ] {
            let line = format!("#define {name} {value}");
            assert!(header.contains(&line), "the header lacks `{line}`");
        }
    }

    #[test]
    fn no_prototype_parameter_name_ends_in_an_underscore() {
        let header = include_str!("../include/manylights.h");
        let mut in_prototype = false;
        for line in header.lines() {
            let t = line.trim_start();
            if t.starts_with("ml_status ml_") || t.starts_with("const char *ml_") {
                in_prototype = true;
            }
            if in_prototype {
                for word in t.split(|c: char| !(c.is_alphanumeric() || c == '_')) {
                    assert!(!word.ends_with('_') || word.is_empty(), "{line}");
                }
                if t.contains(");") {
                    in_prototype = false;
                }
            }
        }
    }

    #[test]
    fn header_version_macros_match_cargo_toml() {
        let header = include_str!("../include/manylights.h");
        for (name, v) in [
            ("ML_VERSION_MAJOR", env!("CARGO_PKG_VERSION_MAJOR")),
            ("ML_VERSION_MINOR", env!("CARGO_PKG_VERSION_MINOR")),
            ("ML_VERSION_PATCH", env!("CARGO_PKG_VERSION_PATCH")),
        ] {
            let line = format!("#define {name} {v}");
            assert!(header.contains(&line), "the header lacks `{line}`");
        }
    }
}
