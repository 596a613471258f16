//! Cache prefetch hints, for reads whose next addresses the hardware prefetcher cannot guess.
//!
//! A tree walk or a loop over scattered slots is bound by the latency of each fetch that
//! misses the cache. When the code knows an address it will read a little later (a pushed
//! sibling, a child's children, the next item's slot), asking for its cache line now overlaps
//! that latency with the current work.
//!
//! Every function here is a hint only: it never faults, changes nothing a program can observe
//! but its timing, and does nothing off x86-64. They differ in which lines they ask for:
//!
//! - [`prefetch`]: the line holding the value's first byte.
//! - [`prefetch_ptr`]: the line holding an address, which need not be valid.
//! - [`prefetch_node`]: a line every 64 bytes from the value's start, for values aligned to
//!   cache lines (the tree nodes), on the hot walks.
//! - [`prefetch_all`]: every line the value spans, its last byte's included, whatever its
//!   alignment.

/// The cache line size the hints step by.
const LINE: usize = 64;

/// Asks for the cache line holding `value`'s first byte ahead of its use. Enough for a value
/// that fits in one line and does not straddle two.
#[inline(always)]
pub fn prefetch<T>(value: &T) {
    prefetch_address((value as *const T).cast::<i8>());
}

/// Asks for the cache line holding `address` ahead of its use: [`prefetch`] for a place known
/// only by its address (one past a slice's end, a slot that may not exist). The address need
/// not be valid, aligned or even mapped; it is never read.
#[inline(always)]
pub fn prefetch_ptr<T>(address: *const T) {
    prefetch_address(address.cast::<i8>());
}

/// Asks for the cache lines of `node` ahead of its use: one every 64 bytes from its start,
/// which are all the lines it spans when it is aligned to lines (the tree nodes). Tree walks
/// that miss the cache are bound by the latency of each node fetch; starting the fetches of
/// the nodes read next (a pushed sibling, a child's children) overlaps those latencies with
/// the current work. A value not aligned to lines can end on a line this leaves out: use
/// [`prefetch_all`] for it.
#[inline(always)]
pub fn prefetch_node<T>(node: &T) {
    let p = (node as *const T).cast::<i8>();
    for line in (0..core::mem::size_of::<T>()).step_by(LINE) {
        prefetch_address(p.wrapping_add(line));
    }
}

/// Asks for every cache line `value` spans, the one holding its last byte included: a value
/// that is not a whole, aligned number of lines (a 32-byte box at 16-byte alignment, a 64-byte
/// record at 16-byte alignment) can straddle one more line than its size suggests. For a type
/// of whole lines aligned to them, [`prefetch_node`] already covers its last line, and the
/// extra hint is left out at compile time.
#[inline(always)]
pub fn prefetch_all<T>(value: &T) {
    let start = (value as *const T).cast::<i8>();
    let size = core::mem::size_of::<T>();
    let whole_lines = size.is_multiple_of(LINE) && core::mem::align_of::<T>() >= LINE;
    let last = if whole_lines {
        None
    } else {
        size.checked_sub(1)
    };
    for offset in (0..size).step_by(LINE).chain(last) {
        prefetch_address(start.wrapping_add(offset));
    }
}

/// The one prefetch instruction behind every hint: into every cache level (`T0`).
#[inline(always)]
fn prefetch_address(address: *const i8) {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: `prefetch` is a hint that never faults and reads nothing the program sees,
        // whatever the address; SSE, which it needs, is part of every x86-64.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(address) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = address;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[repr(C, align(64))]
    struct Line([u8; 128]);

    #[test]
    fn hints_accept_any_value_or_address() {
        let boxes = [[0.0f32; 8]; 3];
        let lines = Line([0; 128]);
        prefetch(&boxes[1]);
        prefetch_node(&lines);
        prefetch_all(&boxes[1]);
        prefetch_all(&lines);
        prefetch_all(&());
        prefetch_ptr(boxes.as_ptr().wrapping_add(100));
        prefetch_ptr(core::ptr::null::<u64>());
    }
}
