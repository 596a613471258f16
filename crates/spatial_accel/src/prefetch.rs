//! Cache prefetch hints, for traversals whose next nodes lie at scattered places in memory.

/// Asks for the cache lines of `node` ahead of its use. Tree walks that miss the cache are
/// bound by the latency of each node fetch; starting the fetches of the nodes read next (a
/// pushed sibling, a child's children) overlaps those latencies with the current work. A hint
/// only: no effect off x86-64.
#[inline(always)]
pub(crate) fn prefetch_node<T>(node: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let p = (node as *const T).cast::<i8>();
        for line in (0..core::mem::size_of::<T>()).step_by(64) {
            // SAFETY: prefetching is a hint that never faults; the address is inside `node`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.add(line)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = node;
}

/// Like [`prefetch_node`], and also asks for the line holding the value's last byte: a value
/// that is not a whole, aligned number of lines (a 32-byte box at 16-byte alignment) can end
/// on a line `prefetch_node` leaves out. For values read once, off the hot traversal loops,
/// where the extra hint costs nothing that matters.
#[inline(always)]
pub(crate) fn prefetch_value<T>(value: &T) {
    prefetch_node(value);
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let size = core::mem::size_of::<T>();
        if size > 0 {
            // SAFETY: prefetching is a hint that never faults; the address is inside `value`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>((value as *const T).cast::<i8>().add(size - 1)) };
        }
    }
}
