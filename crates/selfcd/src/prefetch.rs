//! A software prefetch hint, for the loops whose next reads are known a
//! step ahead but scattered (node boxes in a descent, children in a refit):
//! a cache miss there costs more than the work around it.

/// Asks the CPU to bring the cache line holding the start of `x` closer.
/// A hint only: it reads nothing the program sees and never faults, so
/// every answer is the same with or without it; a no-op off x86-64.
#[inline(always)]
pub fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `_mm_prefetch` only needs SSE (baseline on x86-64) and does
    // not dereference: a prefetch of any address is allowed.
    unsafe {
        use core::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>((x as *const T).cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}
