//! The buffers behind the harness's pointer arguments: every output pre-filled with a
//! sentinel, so that a failing call can be checked to have written nothing; inputs copied
//! behind aligned or misaligned pointers (or NULL), with the count passed alongside.

use super::grammar::Ptr;
use core::mem::size_of;
use std::ptr;

const SENTINEL: u8 = 0xA5;

/// A misaligned pointer to bytes is a valid one.
fn aligned_if_bytes<T>(ptr: Ptr) -> Ptr {
    if ptr == Ptr::Misaligned && core::mem::align_of::<T>() == 1 {
        Ptr::Valid
    } else {
        ptr
    }
}

/// What the harness checks of a buffer after a call.
pub(super) trait Buf {
    /// No byte was written.
    fn untouched(&self) -> bool {
        true
    }
    /// A misaligned pointer with a non-zero count was passed (a success is then a finding).
    fn misaligned(&self) -> bool;
}

/// An output buffer of `len` elements of `T` (plus a byte), pre-filled with [`SENTINEL`].
pub(super) struct Out<T> {
    mem: Vec<u64>,
    len: usize,
    ptr: Ptr,
    count: usize,
    _t: core::marker::PhantomData<T>,
}

impl<T: Copy> Out<T> {
    /// An output of `len` elements passed as `ptr` with `count` (≤ `len` unless NULL).
    pub(super) fn new(len: usize, ptr: Ptr, count: usize) -> Out<T> {
        let ptr = aligned_if_bytes::<T>(ptr);
        let bytes = len * size_of::<T>() + 1;
        Out {
            mem: vec![u64::from_ne_bytes([SENTINEL; 8]); bytes.div_ceil(8) + 1],
            len,
            ptr,
            count,
            _t: core::marker::PhantomData,
        }
    }

    /// One output.
    pub(super) fn one(ptr: Ptr) -> Out<T> {
        Out::new(1, ptr, 1)
    }

    fn base(&mut self) -> *mut u8 {
        self.mem.as_mut_ptr().cast()
    }

    /// The pointer to pass.
    pub(super) fn p(&mut self) -> *mut T {
        match self.ptr {
            Ptr::Valid => self.base().cast(),
            Ptr::Null => ptr::null_mut(),
            Ptr::Misaligned => self.base().wrapping_add(1).cast(),
        }
    }

    fn bytes(&self) -> &[u8] {
        // SAFETY: the u64 buffer viewed as its bytes.
        unsafe { core::slice::from_raw_parts(self.mem.as_ptr().cast(), self.mem.len() * 8) }
    }

    /// Element `i` (written by a successful call through a valid pointer).
    pub(super) fn get(&self, i: usize) -> T {
        assert!(i < self.len);
        // SAFETY: in the buffer; every `T` here is plain integers, floats and pointers.
        unsafe { self.mem.as_ptr().cast::<T>().add(i).read() }
    }

    /// The bytes from element `i` on are untouched.
    pub(super) fn untouched_from(&self, i: usize) -> bool {
        let start = i.min(self.len) * size_of::<T>() + usize::from(self.ptr == Ptr::Misaligned);
        self.bytes()[start..].iter().all(|&b| b == SENTINEL)
    }
}

impl<T: Copy> Buf for Out<T> {
    fn untouched(&self) -> bool {
        self.bytes().iter().all(|&b| b == SENTINEL)
    }
    fn misaligned(&self) -> bool {
        self.ptr == Ptr::Misaligned && self.count > 0
    }
}

/// A read-only array copied behind an aligned or misaligned pointer (or NULL).
pub(super) struct In<T> {
    mem: Vec<u64>,
    ptr: Ptr,
    count: usize,
    _t: core::marker::PhantomData<T>,
}

impl<T: Copy> In<T> {
    /// `values` passed as `ptr` with `count` (≤ `values.len()` unless NULL).
    pub(super) fn new(values: &[T], ptr: Ptr, count: usize) -> In<T> {
        let ptr = aligned_if_bytes::<T>(ptr);
        let bytes = core::mem::size_of_val(values) + 1;
        let mut mem = vec![0u64; bytes.div_ceil(8) + 1];
        let off = usize::from(ptr == Ptr::Misaligned);
        // SAFETY: the buffer holds the values' bytes after `off`.
        unsafe {
            ptr::copy_nonoverlapping(
                values.as_ptr().cast::<u8>(),
                mem.as_mut_ptr().cast::<u8>().add(off),
                core::mem::size_of_val(values),
            );
        }
        In {
            mem,
            ptr,
            count,
            _t: core::marker::PhantomData,
        }
    }

    /// One value.
    pub(super) fn one(v: T, ptr: Ptr) -> In<T> {
        In::new(&[v], ptr, 1)
    }

    /// An optional argument (NULL when absent).
    pub(super) fn opt(v: Option<(T, Ptr)>) -> In<T> {
        match v {
            Some((v, p)) => In::one(v, p),
            None => In::new(&[], Ptr::Null, 0),
        }
    }

    /// The pointer to pass.
    pub(super) fn p(&self) -> *const T {
        match self.ptr {
            Ptr::Valid => self.mem.as_ptr().cast(),
            Ptr::Null => ptr::null(),
            Ptr::Misaligned => self.mem.as_ptr().cast::<u8>().wrapping_add(1).cast(),
        }
    }
}

impl<T> Buf for In<T> {
    fn misaligned(&self) -> bool {
        self.ptr == Ptr::Misaligned && self.count > 0
    }
}

/// A handle passed misaligned (or not).
pub(super) struct HandleArg(pub(super) bool);

impl Buf for HandleArg {
    fn misaligned(&self) -> bool {
        self.0
    }
}
