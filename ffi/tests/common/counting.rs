//! A global allocator for the test binaries that count allocations: the system allocator,
//! calling the binary's own `count` on every allocation (not on frees). A test binary
//! includes this file and installs `Counting(count)` as its `#[global_allocator]`.

use std::alloc::{GlobalAlloc, Layout, System};

/// The system allocator, `.0` called before each allocation.
pub struct Counting(pub fn());

// SAFETY: every call is forwarded to the system allocator unchanged; the hook only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        (self.0)();
        System.alloc(layout)
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        (self.0)();
        System.alloc_zeroed(layout)
    }

    unsafe fn realloc(&self, p: *mut u8, layout: Layout, size: usize) -> *mut u8 {
        (self.0)();
        System.realloc(p, layout, size)
    }

    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        System.dealloc(p, layout)
    }
}
