//! Sorting many integer keys: the radix sort the LBVH builder sorts its Morton codes with,
//! for callers that sort ids (a query's results by entity, candidates by slot).

use crate::bvh::build::morton::radix_sort;

/// Sorts `keys` ascending, in time linear in their number: a radix sort over only the bits
/// in which the keys differ (ids drawn from a few hundred thousand differ in their low 20
/// bits or so, whatever their width). A comparison sort of tens of thousands of ids costs
/// more than the query that found them.
///
/// ```
/// let mut keys = vec![5u64 << 32 | 3, 7, 1 << 40, 3, 7];
/// spatial_accel::sort::sort_keys(&mut keys);
/// assert_eq!(keys, [3, 7, 7, 5u64 << 32 | 3, 1 << 40]);
/// ```
pub fn sort_keys(keys: &mut Vec<u64>) {
    if keys.len() < 2 {
        return;
    }
    // Below this, the comparison sort is at least as fast and allocates nothing.
    const RADIX_FROM: usize = 256;
    if keys.len() < RADIX_FROM {
        keys.sort_unstable();
        return;
    }
    // Keys often come nearly or wholly in order (slots and entities are handed out in spawn
    // order, and a walk of a still tree meets them in runs): a scan that stops at the first
    // pair out of order costs next to nothing on keys that are not, and spares the radix
    // sort's passes over keys that are.
    if keys.is_sorted() {
        return;
    }
    let (any, all) = keys
        .iter()
        .fold((0u64, u64::MAX), |(any, all), &k| (any | k, all & k));
    let differ = any & !all;
    if differ == 0 {
        return;
    }
    let low = differ.trailing_zeros();
    let high = 64 - differ.leading_zeros();
    // Bits outside `low..high` are the same in every key: sorting by the rest sorts all.
    radix_sort(keys, low..high);
}
