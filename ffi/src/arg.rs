//! The one place where C pointers become Rust references: NULL and alignment checked, sizes
//! checked against overflow, outputs written through [`Out`] (so that nothing is read from
//! them, and they are written only once the call has succeeded).
//!
//! Safety contract (stated to C users in `ffi/README.md` and the header): a non-NULL pointer
//! points to valid, initialised memory of its type (for `count` elements where a count goes
//! with it), not written by another thread during the call; an out-param's memory may be
//! uninitialised; handle pointers were returned by this library and not freed.

use crate::error::{Error, Result};
use core::mem::size_of;

/// A read-only argument: `&*p` after the NULL and alignment checks.
#[inline]
pub(crate) fn get<'a, T>(p: *const T, name: &str) -> Result<&'a T> {
    if p.is_null() {
        return Err(Error::null(name));
    }
    if !p.is_aligned() {
        return Err(Error::invalid(format_args!("`{name}` is misaligned")));
    }
    // SAFETY: non-NULL and aligned; validity for reads is the caller's contract (module docs).
    Ok(unsafe { &*p })
}

/// An optional read-only argument (NULL allowed: `None`).
#[inline]
pub(crate) fn opt<'a, T>(p: *const T, name: &str) -> Result<Option<&'a T>> {
    if p.is_null() {
        Ok(None)
    } else {
        get(p, name).map(Some)
    }
}

/// A handle the caller mutates: `&mut *p` after the NULL and alignment checks.
#[inline]
pub(crate) fn get_mut<'a, T>(p: *mut T, name: &str) -> Result<&'a mut T> {
    if p.is_null() {
        return Err(Error::null(name));
    }
    if !p.is_aligned() {
        return Err(Error::invalid(format_args!("`{name}` is misaligned")));
    }
    // SAFETY: non-NULL and aligned; exclusive access for the call is the caller's contract
    // (per-thread handles).
    Ok(unsafe { &mut *p })
}

/// Checks that `count` elements of `T` fit in the address space (`count · size_of::<T>()` at
/// most `isize::MAX`).
#[inline]
pub(crate) fn check_count<T>(count: usize, name: &str) -> Result<()> {
    let size = size_of::<T>().max(1);
    if count > isize::MAX as usize / size {
        return Err(Error::invalid(format_args!(
            "`{name}`: {count} elements of {size} bytes overflow the address space"
        )));
    }
    Ok(())
}

/// A read-only array of `count` elements (NULL allowed when `count` is 0).
#[inline]
pub(crate) fn slice<'a, T>(p: *const T, count: usize, name: &str) -> Result<&'a [T]> {
    check_count::<T>(count, name)?;
    if count == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(Error::null(name));
    }
    if !p.is_aligned() {
        return Err(Error::invalid(format_args!("`{name}` is misaligned")));
    }
    // SAFETY: non-NULL, aligned, size checked against isize::MAX; validity of `count`
    // elements is the caller's contract.
    Ok(unsafe { core::slice::from_raw_parts(p, count) })
}

/// An output array of `count` elements (NULL allowed when `count` is 0), to be written only.
#[inline]
pub(crate) fn out_slice<'a, T: Copy>(
    p: *mut T,
    count: usize,
    name: &str,
) -> Result<OutSlice<'a, T>> {
    check_count::<T>(count, name)?;
    if count == 0 {
        return Ok(OutSlice {
            p: core::ptr::NonNull::dangling().as_ptr(),
            len: 0,
            _life: core::marker::PhantomData,
        });
    }
    if p.is_null() {
        return Err(Error::null(name));
    }
    if !p.is_aligned() {
        return Err(Error::invalid(format_args!("`{name}` is misaligned")));
    }
    Ok(OutSlice {
        p,
        len: count,
        _life: core::marker::PhantomData,
    })
}

/// An out-param: written once the call has succeeded, never read.
pub(crate) struct Out<'a, T> {
    p: *mut T,
    _life: core::marker::PhantomData<&'a mut T>,
}

impl<T> Out<'_, T> {
    /// Writes the output.
    #[inline]
    pub(crate) fn write(self, v: T) {
        // SAFETY: checked non-NULL and aligned in `out`; writable memory for one `T` is the
        // caller's contract; `write` neither reads nor drops the old (maybe uninitialised)
        // value.
        unsafe { self.p.write(v) }
    }
}

/// An out-param of type `T` (not NULL, aligned).
#[inline]
pub(crate) fn out<'a, T>(p: *mut T, name: &str) -> Result<Out<'a, T>> {
    if p.is_null() {
        return Err(Error::null(name));
    }
    if !p.is_aligned() {
        return Err(Error::invalid(format_args!("`{name}` is misaligned")));
    }
    Ok(Out {
        p,
        _life: core::marker::PhantomData,
    })
}

/// An output array: elements written one by one, never read.
pub(crate) struct OutSlice<'a, T> {
    p: *mut T,
    len: usize,
    _life: core::marker::PhantomData<&'a mut [T]>,
}

impl<T: Copy> OutSlice<'_, T> {
    /// Number of elements.
    #[inline]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Writes element `i` (`i < len`, checked).
    #[inline]
    pub(crate) fn set(&mut self, i: usize, v: T) {
        assert!(i < self.len, "output index out of range");
        // SAFETY: `i < len` and the array of `len` writable elements is the caller's contract.
        unsafe { self.p.add(i).write(v) }
    }
}

/// Moves a Rust value to the heap and returns the handle C keeps.
#[inline]
pub(crate) fn into_handle<T>(v: T) -> *mut T {
    Box::into_raw(Box::new(v))
}

/// Releases a handle made by [`into_handle`] (NULL: nothing).
#[inline]
pub(crate) fn free_handle<T>(p: *mut T, name: &str) -> Result<()> {
    if p.is_null() {
        return Ok(());
    }
    if !p.is_aligned() {
        return Err(Error::invalid(format_args!("`{name}` is misaligned")));
    }
    // SAFETY: `p` came from `into_handle::<T>` and is freed once (the caller's contract).
    drop(unsafe { Box::from_raw(p) });
    Ok(())
}
