//! The exact SAH split of a node of a few primitives: every way to divide them in two, costed.
//!
//! Why: a binned build spends many of its calls on nodes of three or four primitives, and
//! for those the binning's fixed cost (clearing three rows of bins, sweeping them twice)
//! outweighs the primitives. Enumerating the 3 or 7 partitions costs less per node, and finds
//! the optimal split rather than the best of the bins' planes. From five primitives on
//! (15 partitions, the unions of 31 subsets) the bins cost less again; nodes of five to
//! eight take every plane instead where the CPU has AVX2 (`sorted`).

use super::top_down::{BuildPrim, NodeBounds, SplitOutcome, leaf_is_cheaper};
use crate::Aabb;
use crate::bvh::config::BuildConfig;

/// The most primitives a node may have for [`split`].
pub(super) const MAX_PRIMS: usize = 4;

/// Splits `prims` (2 to [`MAX_PRIMS`] primitives) where the SAH cost
/// `area(L) n(L) + area(R) n(R)` is least, or makes a leaf where that split costs more than the
/// leaf (`may_stop`, as the other SAH splits decide).
pub(super) fn split(
    prims: &mut [BuildPrim],
    node_bounds: &Aabb,
    config: &BuildConfig,
    may_stop: bool,
) -> SplitOutcome {
    match prims.len() {
        2 => split_n::<2, 4>(prims, node_bounds, config, may_stop),
        3 => split_n::<3, 8>(prims, node_bounds, config, may_stop),
        4 => split_n::<4, 16>(prims, node_bounds, config, may_stop),
        0 | 1 => SplitOutcome::Leaf,
        n => unreachable!("exhaustive::split takes 2 to {MAX_PRIMS} primitives, not {n}"),
    }
}

/// [`split`] for `N` primitives, with `S = 2^N` subsets.
#[inline(always)]
fn split_n<const N: usize, const S: usize>(
    prims: &mut [BuildPrim],
    node_bounds: &Aabb,
    config: &BuildConfig,
    may_stop: bool,
) -> SplitOutcome {
    let boxes: [Aabb; N] = core::array::from_fn(|i| prims[i].bounds());
    // The union of every subset (bit `i` for primitive `i`), each from a smaller one.
    let mut unions = [Aabb::EMPTY; S];
    for m in 1..S {
        let low = m.trailing_zeros() as usize;
        unions[m] = unions[m & (m - 1)].union(&boxes[low]);
    }
    // The last primitive stays on the right, so each partition is counted once.
    let all = S - 1;
    let mut best = (f32::INFINITY, 0usize);
    for left in 1..S / 2 {
        let right = all ^ left;
        let cost = unions[left].half_area() * left.count_ones() as f32
            + unions[right].half_area() * right.count_ones() as f32;
        let better = cost < best.0;
        best.0 = if better { cost } else { best.0 };
        best.1 = if better { left } else { best.1 };
    }
    let (cost, left) = best;
    // Infinite or NaN for every partition (boxes reaching infinity): no cost to compare, so
    // the caller splits by count if the node must be split.
    if !cost.is_finite() {
        return SplitOutcome::NoPositionalSplit;
    }
    if may_stop && leaf_is_cheaper(config, N, cost, node_bounds) {
        return SplitOutcome::Leaf;
    }
    let original: [BuildPrim; N] = core::array::from_fn(|i| prims[i]);
    let mut at = 0;
    for side in [left, all ^ left] {
        for (i, p) in original.iter().enumerate() {
            if side >> i & 1 == 1 {
                prims[at] = *p;
                at += 1;
            }
        }
    }
    let mid = left.count_ones() as usize;
    SplitOutcome::SplitWithBounds(
        mid,
        [left, all ^ left].map(|side| NodeBounds {
            node: unions[side],
            tight: true,
            centroids: (0..N)
                .filter(|i| side >> i & 1 == 1)
                .fold(Aabb::EMPTY, |acc, i| acc.grow(original[i].centroid())),
        }),
    )
}

#[cfg(test)]
mod tests {
    use super::super::top_down::{check_small_split, leaf_wins_by_sah, records_of};
    use super::*;
    use glam::Vec3A;

    /// `area(L) n(L) + area(R) n(R)` of a division, each side's box found by its own fold.
    fn division_cost(side_of: impl Fn(usize) -> bool, boxes: &[Aabb]) -> f32 {
        [true, false]
            .map(|side| {
                let members: Vec<&Aabb> = (0..boxes.len())
                    .filter(|&i| side_of(i) == side)
                    .map(|i| &boxes[i])
                    .collect();
                let union = members.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
                union.half_area() * members.len() as f32
            })
            .iter()
            .sum()
    }

    /// The split is the cheapest of all divisions (found here by trying every subset as the
    /// left side), keeps every primitive once, and reports the children's exact bounds; with
    /// `may_stop`, it makes a leaf exactly when the leaf costs no more. Scenes: random boxes,
    /// coincident and flat ones, far from the origin.
    #[test]
    fn finds_the_cheapest_division() {
        let mut next = crate::test_floats(0x5851_f42d_4c95_7f2d);
        let config = BuildConfig::default();
        for trial in 0..3000 {
            let n = 2 + trial % 3;
            let offset = if trial % 7 == 0 { 1.0e6 } else { 0.0 };
            let boxes: Vec<Aabb> = (0..n)
                .map(|i| {
                    if trial % 5 == 0 && i > 0 {
                        // A copy of the first box: ties between divisions.
                        return Aabb::new(Vec3A::splat(offset), Vec3A::splat(offset + 1.0));
                    }
                    let c = Vec3A::new(next(), next(), next()) * 10.0 + offset;
                    let flat = if trial % 3 == 0 { 0.0 } else { 1.0 };
                    let h = Vec3A::new(next(), next() * flat, next());
                    Aabb::new(c - h, c + h)
                })
                .collect();
            let brute = (1..(1usize << n) - 1)
                .map(|left| division_cost(|i| left >> i & 1 == 1, &boxes))
                .fold(f32::INFINITY, f32::min);
            let node = boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
            for may_stop in [false, true] {
                let mut prims = records_of(&boxes);
                let outcome = split(&mut prims, &node, &config, may_stop);
                let leaf_wins = leaf_wins_by_sah(&config, n, brute, &node);
                let Some(mid) = check_small_split(trial, &outcome, &prims, may_stop, leaf_wins)
                else {
                    continue;
                };
                let SplitOutcome::SplitWithBounds(_, children) = outcome else {
                    panic!("trial {trial}: a split without the children's bounds");
                };
                let left_ids: Vec<usize> =
                    prims[..mid].iter().map(|p| p.index() as usize).collect();
                let cost = division_cost(|i| left_ids.contains(&i), &boxes);
                assert_eq!(cost, brute, "trial {trial}: not the cheapest division");
                for (child, side) in children.iter().zip([&prims[..mid], &prims[mid..]]) {
                    let exact = NodeBounds::of(side);
                    assert_eq!(child.node, exact.node, "trial {trial}");
                    assert_eq!(child.centroids, exact.centroids, "trial {trial}");
                }
            }
        }
    }

    /// Boxes reaching infinity have no finite cost to compare: no split by cost, and no panic.
    #[test]
    fn infinite_boxes_find_no_split_by_cost() {
        let config = BuildConfig::default();
        let infinite = Aabb::new(Vec3A::NEG_INFINITY, Vec3A::INFINITY);
        let mut prims: Vec<BuildPrim> = (0..3).map(|i| BuildPrim::new(infinite, i)).collect();
        let outcome = split(&mut prims, &infinite, &config, false);
        assert!(matches!(outcome, SplitOutcome::NoPositionalSplit));
    }
}
