//! A cache prefetch hint for rows read a little later.

/// Asks for the cache line holding `value` ahead of its use: a hint only, with no effect off
/// x86-64. Used where a loop's reads are scattered in a way the hardware prefetcher cannot
/// predict but the loop knows its next addresses.
#[inline(always)]
pub(crate) fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: prefetching is a hint that never faults; the address is a live reference.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((value as *const T).cast::<i8>()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}
