//! Status codes, the error type behind them and the thread-local last error message.

use core::fmt;
use std::cell::RefCell;
use std::ffi::{c_char, CString};

/// What every function returns: `ML_OK` or one of the `ML_ERR_*` codes. On an error,
/// `ml_last_error_message()` says what was wrong, on the thread that made the call.
pub type ml_status = i32;

/// Success: the out-params were written.
pub const ML_OK: ml_status = 0;
/// A pointer argument that must not be NULL was NULL (the message names it).
pub const ML_ERR_NULL: ml_status = 1;
/// An argument's value is invalid: NaN or infinite, negative intensity or radius, roughness out
/// of range, a uniform number outside [0, 1), a light index out of range, a count that would
/// overflow, a misaligned pointer (the message names the argument, light index and field).
pub const ML_ERR_INVALID_ARGUMENT: ml_status = 2;
/// Serialized tree bytes are corrupt, truncated or of another format version.
pub const ML_ERR_FORMAT: ml_status = 3;
/// A caller's buffer is smaller than the output (the message gives the size needed).
pub const ML_ERR_BUFFER_TOO_SMALL: ml_status = 4;
/// The call needs something the handle does not have (e.g. light descriptors in a tree loaded
/// from bytes, or a light step to weigh).
pub const ML_ERR_STATE: ml_status = 5;
/// An internal error (a caught panic): a bug in the library, never the caller's input.
pub const ML_ERR_INTERNAL: ml_status = 6;

/// An error of an exported function: its status and what to tell the caller.
#[derive(Debug)]
pub struct Error {
    status: ml_status,
    message: String,
}

impl Error {
    /// A NULL pointer argument.
    pub(crate) fn null(arg: &str) -> Error {
        Error {
            status: ML_ERR_NULL,
            message: format!("`{arg}` is NULL"),
        }
    }

    /// An invalid argument value.
    pub(crate) fn invalid(message: impl fmt::Display) -> Error {
        Error {
            status: ML_ERR_INVALID_ARGUMENT,
            message: message.to_string(),
        }
    }

    /// Corrupt bytes.
    pub(crate) fn format(message: impl fmt::Display) -> Error {
        Error {
            status: ML_ERR_FORMAT,
            message: message.to_string(),
        }
    }

    /// A buffer too small.
    pub(crate) fn too_small(message: impl fmt::Display) -> Error {
        Error {
            status: ML_ERR_BUFFER_TOO_SMALL,
            message: message.to_string(),
        }
    }

    /// A call the handle's state does not allow.
    pub(crate) fn state(message: impl fmt::Display) -> Error {
        Error {
            status: ML_ERR_STATE,
            message: message.to_string(),
        }
    }

    /// A broken invariant of the library itself.
    pub(crate) fn internal(message: impl fmt::Display) -> Error {
        Error {
            status: ML_ERR_INTERNAL,
            message: format!("internal error ({message})"),
        }
    }

    /// The same error, its message prefixed with `context: ` (the element it happened at).
    pub(crate) fn within(self, context: &str) -> Error {
        Error {
            status: self.status,
            message: format!("{context}: {}", self.message),
        }
    }

    /// A caught panic.
    #[doc(hidden)]
    pub fn from_panic(payload: Box<dyn std::any::Any + Send>) -> Error {
        let what = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".to_string());
        Error {
            status: ML_ERR_INTERNAL,
            message: format!("internal error (a panic was caught: {what})"),
        }
    }

    /// The status, after recording `function: message` as this thread's last error.
    #[doc(hidden)]
    pub fn report(self, function: &str) -> ml_status {
        let text = format!("{function}: {}", self.message).replace('\0', " ");
        let c = CString::new(text).unwrap_or_default();
        // A thread being torn down has no message slot: the status still says what happened.
        let _ = LAST_ERROR.try_with(|slot| *slot.borrow_mut() = c);
        self.status
    }

    /// The status (for tests).
    #[cfg(test)]
    pub(crate) fn status(&self) -> ml_status {
        self.status
    }
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// The message of the last call on this thread that failed (`""` if none failed): the
/// function, the argument, and where it applies the element index, light index and field, with
/// the offending value, e.g. `ml_tree_build: lights[17].sphere.radius must be positive (got -1)`.
///
/// The one function that does not return an `ml_status`. Never NULL; the string belongs to the
/// library and stays valid on this thread until its next failing call.
#[no_mangle]
pub extern "C" fn ml_last_error_message() -> *const c_char {
    static EMPTY: &[u8] = b"\0";
    crate::ffi_fn!("ml_last_error_message", EMPTY.as_ptr().cast(), {
        LAST_ERROR
            .try_with(|slot| slot.borrow().as_ptr())
            .unwrap_or(EMPTY.as_ptr().cast())
    })
}

/// The name of a status code (`"ML_OK"`, `"ML_ERR_NULL"`, …; `"unknown"` for other values),
/// written to `*out` (a static string).
///
/// Errors: `ML_ERR_NULL` if `out` is NULL.
#[no_mangle]
pub extern "C" fn ml_status_name(status: ml_status, out: *mut *const c_char) -> ml_status {
    crate::ffi_fn!("ml_status_name", {
        let out = crate::arg::out(out, "out")?;
        let name: &'static [u8] = match status {
            ML_OK => b"ML_OK\0",
            ML_ERR_NULL => b"ML_ERR_NULL\0",
            ML_ERR_INVALID_ARGUMENT => b"ML_ERR_INVALID_ARGUMENT\0",
            ML_ERR_FORMAT => b"ML_ERR_FORMAT\0",
            ML_ERR_BUFFER_TOO_SMALL => b"ML_ERR_BUFFER_TOO_SMALL\0",
            ML_ERR_STATE => b"ML_ERR_STATE\0",
            ML_ERR_INTERNAL => b"ML_ERR_INTERNAL\0",
            _ => b"unknown\0",
        };
        out.write(name.as_ptr().cast());
        Ok(())
    })
}

/// The result type of the exported functions' bodies.
pub(crate) type Result<T> = core::result::Result<T, Error>;

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::CStr;

    fn last() -> String {
        unsafe { CStr::from_ptr(ml_last_error_message()) }
            .to_string_lossy()
            .into_owned()
    }

    #[test]
    fn a_panic_becomes_internal_with_its_message() {
        let status = crate::ffi_fn!("ml_test_panic", {
            if last().len() < usize::MAX {
                panic!("boom");
            }
            Ok(())
        });
        assert_eq!(status, ML_ERR_INTERNAL);
        assert!(last().starts_with("ml_test_panic: internal error"));
        assert!(last().contains("boom"));
    }

    #[test]
    fn errors_are_recorded_per_thread() {
        assert_eq!(Error::null("tree").status(), ML_ERR_NULL);
        let s = crate::ffi_fn!("ml_test", { Err(Error::invalid("u must be in [0, 1)")) });
        assert_eq!(s, ML_ERR_INVALID_ARGUMENT);
        assert_eq!(last(), "ml_test: u must be in [0, 1)");
        std::thread::spawn(|| assert_eq!(last(), ""))
            .join()
            .unwrap();
    }
}
