//! `sort::sort_keys` against the standard library's sort, on keys of every width and on the
//! inputs a radix sort gets wrong: all equal, two values, only high bits differing, the full
//! 64 bits, descending, duplicates, sizes either side of the switch to the comparison sort;
//! and keys already in order but for one pair (what the scan for sorted keys must not miss).

use accel_testkit::Rng;
use spatial_accel::sort::sort_keys;

fn check(keys: Vec<u64>, what: &str) {
    let mut want = keys.clone();
    want.sort_unstable();
    let mut got = keys;
    sort_keys(&mut got);
    assert_eq!(got, want, "{what}");
}

#[test]
fn sorts_like_the_standard_sort() {
    let mut rng = Rng::new(17);
    for round in 0..400 {
        let n = [0, 1, 2, 255, 256, 257, 1000, 5000, 40_000][round % 9];
        let width = 1 + rng.below(64) as u32;
        let shift = rng.below(65 - width as usize) as u32;
        let base = rng.next_u64() & !(mask(width) << shift);
        let keys: Vec<u64> = (0..n)
            .map(|_| base | ((rng.next_u64() & mask(width)) << shift))
            .collect();
        check(
            keys,
            &format!("round {round}: {n} keys, {width} bits from bit {shift}"),
        );
    }
}

fn mask(width: u32) -> u64 {
    if width >= 64 {
        u64::MAX
    } else {
        (1 << width) - 1
    }
}

#[test]
fn sorts_the_inputs_radix_sorts_get_wrong() {
    let mut rng = Rng::new(5);
    let n = 3000;
    check(vec![42; n], "all equal");
    check(
        (0..n)
            .map(|i| if i % 3 == 0 { 7 } else { 1 << 63 })
            .collect(),
        "two values",
    );
    check(
        (0..n as u64).map(|i| (i % 7) << 57).collect(),
        "only high bits",
    );
    check((0..n as u64).rev().collect(), "descending");
    check((0..n).map(|_| rng.next_u64()).collect(), "every bit");
    check((0..n).map(|_| rng.next_u64() % 10).collect(), "duplicates");
    check(
        (0..n as u64)
            .map(|i| i | (u64::from(i % 2 == 0) << 32))
            .collect(),
        "entity-like: index and a generation of 0 or 1",
    );
    check([u64::MAX, 0, u64::MAX - 1, 1].repeat(100), "extremes");
}

#[test]
fn keys_in_order_but_for_one_pair_are_sorted() {
    let n = 3000u64;
    let ascending: Vec<u64> = (0..n).map(|i| ((i / 3) << 20) | 5).collect();
    check(ascending.clone(), "in order, with duplicates");
    for at in [0, 1, n as usize / 2, n as usize - 2] {
        let mut keys = ascending.clone();
        // Moves a larger key in front of a smaller one: two keys out of order.
        keys[at] = keys[at + 1] + (1 << 20);
        check(keys, &format!("in order but at {at}"));
        let mut keys = ascending.clone();
        keys.swap(at, n as usize - 1 - at.min(n as usize / 2 - 1));
        check(keys, &format!("one swap from {at}"));
    }
}
