//! A hint that the cache line holding a value will soon be read: the one `unsafe` of the crate,
//! with the cargo feature `prefetch` (on by default). Without the feature, or on targets other
//! than x86 with SSE, x86-64 and AArch64, [`prefetch`] does nothing.
//!
//! The descents call it for the node they will read next, so that its cache line is on its
//! way while they evaluate the current one; a hint never changes a result.

/// Whether [`prefetch`] issues a hint (the feature `prefetch` on a target that has one).
pub(crate) const ENABLED: bool = cfg!(all(
    feature = "prefetch",
    any(
        target_arch = "x86_64",
        all(target_arch = "x86", target_feature = "sse"),
        target_arch = "aarch64"
    )
));

/// Asks the processor to bring the cache line holding the start of `value` into its caches
/// (all levels), without waiting for it and without any other effect. Does nothing without
/// the feature `prefetch` or on other targets.
#[inline(always)]
pub(crate) fn prefetch<T>(value: &T) {
    imp::prefetch((value as *const T).cast::<u8>());
}

#[cfg(all(
    feature = "prefetch",
    any(
        target_arch = "x86_64",
        all(target_arch = "x86", target_feature = "sse")
    )
))]
mod imp {
    #![allow(unsafe_code)]
    #[cfg(target_arch = "x86")]
    use core::arch::x86::{_mm_prefetch, _MM_HINT_T0};
    #[cfg(target_arch = "x86_64")]
    use core::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};

    #[inline(always)]
    pub(super) fn prefetch(p: *const u8) {
        // SAFETY: `_mm_prefetch` is `unsafe` for two reasons, neither of which applies.
        // 1. It needs the target feature `sse`: this module is compiled only on x86-64 (where
        //    SSE is part of the baseline) and on x86 with `sse` enabled at compile time.
        // 2. It takes a raw pointer: PREFETCHT0 is a hint, not an access. It never faults (a
        //    hint for an unmapped or protected address is dropped), never writes, and has no
        //    effect a program can observe but its timing (Intel SDM vol. 2B, PREFETCHh; AMD
        //    APM vol. 3, PREFETCHlevel). Here the pointer comes from a reference in any case,
        //    so it points into a live value.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(p.cast::<i8>()) }
    }
}

#[cfg(all(feature = "prefetch", target_arch = "aarch64"))]
mod imp {
    #![allow(unsafe_code)]

    #[inline(always)]
    pub(super) fn prefetch(p: *const u8) {
        // SAFETY: PRFM PLDL1KEEP is a hint for a later load, not an access: it never faults
        // (Arm ARM, "Prefetch memory": a PRFM to an address that would fault is treated as a
        // NOP), writes nothing (no register, no memory, no flags) and has no effect a program
        // can observe but its timing. The options say so to the compiler: `readonly` (it
        // reads no memory the compiler tracks and writes none), `nostack`,
        // `preserves_flags`. The pointer comes from a reference, so it points into a live
        // value in any case. (The `_prefetch` intrinsic of `core::arch::aarch64` is not stable;
        // `asm!` is.)
        unsafe {
            core::arch::asm!(
                "prfm pldl1keep, [{p}]",
                p = in(reg) p,
                options(nostack, readonly, preserves_flags)
            );
        }
    }
}

#[cfg(not(all(
    feature = "prefetch",
    any(
        target_arch = "x86_64",
        all(target_arch = "x86", target_feature = "sse"),
        target_arch = "aarch64"
    )
)))]
mod imp {
    #[inline(always)]
    pub(super) fn prefetch(_: *const u8) {}
}
