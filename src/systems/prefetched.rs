//! A loop over scattered items with two prefetch stages ahead of it: the sync's walk over
//! the moved entities.

/// The distance between the stages of [`for_each_prefetched_in_two_stages`]: a few items'
/// processing covers one memory latency, and a larger window only holds more lines in L1.
const LOOKAHEAD: usize = 8;

/// Runs `process` over `items` in order, with two prefetch stages ahead of it for data found
/// through other data (the items are scattered through Bevy's tables when only some entities
/// changed, and each one's rows lead to more scattered reads): `far` runs on each item
/// `2 * LOOKAHEAD` items before `process` reaches it (the item's own rows, the
/// record that leads to its tree slot), `near` runs [`LOOKAHEAD`] items before (what that
/// record leads to: the slot's entries and tree node). The stages share `state`, which only
/// `process` may change.
pub(crate) fn for_each_prefetched_in_two_stages<S, T>(
    items: impl Iterator<Item = T>,
    state: &mut S,
    far: impl Fn(&S, &T),
    near: impl Fn(&S, &T),
    mut process: impl FnMut(&mut S, T),
) {
    const WINDOW: usize = 2 * LOOKAHEAD;
    let mut window: [Option<T>; WINDOW] = [const { None }; WINDOW];
    let mut count = 0usize;
    // `for_each`, not a `for` loop: it runs the iterator's `fold`, which Bevy's query iterator
    // specialises into a tight loop per table. Pulled item by item through `next`, the
    // change-detection scan over every dynamic entity ran clearly slower when nothing moved
    // (the sync bench's idle row; BENCHMARKS.md, Plugin sync).
    items.for_each(|item| {
        far(state, &item);
        // The slot the new item takes holds the item `WINDOW` places before it: now due.
        if let Some(due) = window[count % WINDOW].replace(item) {
            process(state, due);
        }
        if count >= LOOKAHEAD
            && let Some(halfway) = &window[(count - LOOKAHEAD) % WINDOW]
        {
            near(state, halfway);
        }
        count += 1;
    });
    // Left: the last `min(count, WINDOW)` items; those among the last `LOOKAHEAD` have not had
    // their `near` stage yet.
    let first = count.saturating_sub(WINDOW);
    for i in count.saturating_sub(LOOKAHEAD).max(first)..count {
        if let Some(item) = &window[i % WINDOW] {
            near(state, item);
        }
    }
    for i in first..count {
        if let Some(due) = window[i % WINDOW].take() {
            process(state, due);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_stages_run_once_each_in_order_and_ahead_of_processing() {
        let l = LOOKAHEAD as u32;
        for n in 0..5 * l {
            let far = core::cell::RefCell::new(Vec::new());
            let near = core::cell::RefCell::new(Vec::new());
            let mut processed: Vec<u32> = Vec::new();
            for_each_prefetched_in_two_stages(
                0..n,
                &mut processed,
                |_, &i| far.borrow_mut().push(i),
                |processed: &Vec<u32>, &i| {
                    // `near` follows `far` by LOOKAHEAD items and leads processing by as many;
                    // the last LOOKAHEAD items get it before the tail is processed.
                    assert_eq!(
                        far.borrow().len() as u32,
                        (i + 1 + l).min(n),
                        "n {n}, item {i}"
                    );
                    let expected_done = if i + l < n {
                        (i + 1).saturating_sub(l)
                    } else {
                        n.saturating_sub(2 * l)
                    };
                    assert_eq!(processed.len() as u32, expected_done, "n {n}, item {i}");
                    near.borrow_mut().push(i);
                },
                |processed, i| {
                    assert!(near.borrow().contains(&i), "n {n}, item {i}");
                    let far_so_far = far.borrow().len() as u32;
                    assert_eq!(far_so_far, (i + 1 + 2 * l).min(n), "n {n}, item {i}");
                    processed.push(i);
                },
            );
            assert_eq!(*far.borrow(), (0..n).collect::<Vec<_>>());
            assert_eq!(*near.borrow(), (0..n).collect::<Vec<_>>());
            assert_eq!(processed, (0..n).collect::<Vec<_>>());
        }
    }
}
