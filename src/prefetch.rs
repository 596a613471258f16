//! A cache prefetch hint for rows read a little later.

/// Asks for the cache line holding `value` ahead of its use: a hint only, with no effect off
/// x86-64. Used where a loop's reads are scattered in a way the hardware prefetcher cannot
/// predict but the loop knows its next addresses.
#[cfg_attr(not(feature = "culling"), allow(dead_code))]
#[inline(always)]
pub(crate) fn prefetch<T>(value: &T) {
    prefetch_address((value as *const T).cast::<i8>());
}

/// Asks for every cache line `value` spans (a 64-byte component at a 16-byte alignment
/// straddles two lines three times in four).
#[inline(always)]
pub(crate) fn prefetch_all<T>(value: &T) {
    let start = (value as *const T).cast::<i8>();
    let size = core::mem::size_of::<T>();
    // Every 64th byte, and the last: together they touch each line the value spans.
    for offset in (0..size).step_by(64).chain(size.checked_sub(1)) {
        prefetch_address(start.wrapping_add(offset));
    }
}

#[inline(always)]
fn prefetch_address(address: *const i8) {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: prefetching is a hint that never faults, whatever the address.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(address) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = address;
}

/// How many items ahead [`for_each_prefetched`] asks for an item's data: a few items'
/// processing covers one memory latency, and a larger window only holds more lines in L1.
const LOOKAHEAD: usize = 8;

/// Runs `process` over `items` in order, calling `ahead` on each item [`LOOKAHEAD`] items
/// before `process` reaches it, so the rows an item's processing reads (scattered through
/// Bevy's tables when only some entities changed) arrive while earlier items are processed.
pub(crate) fn for_each_prefetched<T>(
    items: impl Iterator<Item = T>,
    ahead: impl Fn(&T),
    mut process: impl FnMut(T),
) {
    let mut window: [Option<T>; LOOKAHEAD] = [const { None }; LOOKAHEAD];
    let mut count = 0usize;
    for item in items {
        ahead(&item);
        if let Some(due) = window[count % LOOKAHEAD].replace(item) {
            process(due);
        }
        count += 1;
    }
    // What is left is the last items, the oldest at `count % LOOKAHEAD`.
    for k in 0..LOOKAHEAD {
        if let Some(due) = window[(count + k) % LOOKAHEAD].take() {
            process(due);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn items_are_processed_once_each_in_order_whatever_the_count() {
        for n in 0..3 * LOOKAHEAD as u32 {
            let mut asked = Vec::new();
            let mut seen = Vec::new();
            let asked_cell = core::cell::RefCell::new(&mut asked);
            for_each_prefetched(
                0..n,
                |&i| asked_cell.borrow_mut().push(i),
                |i| {
                    // An item is processed only after the items LOOKAHEAD places later were
                    // asked for (or all of them, near the end).
                    let asked_so_far = asked_cell.borrow().len() as u32;
                    assert!(
                        asked_so_far >= (i + 1 + LOOKAHEAD as u32).min(n),
                        "n {n}, item {i}"
                    );
                    seen.push(i);
                },
            );
            assert_eq!(seen, (0..n).collect::<Vec<_>>());
            assert_eq!(asked, (0..n).collect::<Vec<_>>());
        }
    }
}
