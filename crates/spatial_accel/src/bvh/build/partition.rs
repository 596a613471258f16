//! Partitioning a build's primitives around a split plane: a block partition, with a
//! branch-free Lomuto pass for the tail.

use super::top_down::BuildPrim;

/// Elements classified at a time by each end of [`partition`] (offsets fit a byte).
const PARTITION_BLOCK: usize = 64;

/// Partitions in place so that the primitives that pass `goes_left` come first; returns how
/// many did. `goes_left` may be called more than once on a primitive.
///
/// Block partitioning (Edelkamp & Weiss 2016, "BlockQuicksort"): each end classifies a block
/// of elements without branching, recording the offsets of the misplaced ones, then the two
/// lists are swapped pairwise. Why: Hoare's loop branches on every element's side, and deep in
/// a build, where boxes are scattered, that branch is a coin toss.
///
/// What is left when fewer than two blocks remain (every node of fewer than 128 primitives,
/// most of a tree's nodes) goes through Lomuto's scheme without a branch: every element is
/// swapped with the next left slot, and the slot advances when the element belongs left. Why:
/// Hoare's loop branches on every element's side here too, and those mispredictions are a
/// large share of a binned SAH build, over triangles and entity boxes alike (BENCHMARKS.md,
/// Static BVH builds).
pub(super) fn partition(
    prims: &mut [BuildPrim],
    mut goes_left: impl FnMut(&BuildPrim) -> bool,
) -> usize {
    let (mut l, mut r) = (0usize, prims.len());
    let mut misplaced_l = [0u8; PARTITION_BLOCK];
    let mut misplaced_r = [0u8; PARTITION_BLOCK];
    let (mut start_l, mut count_l, mut start_r, mut count_r) = (0, 0, 0, 0);
    // Every element left of `l` goes left, every one from `r` on goes right.
    while r - l >= 2 * PARTITION_BLOCK {
        if count_l == 0 {
            start_l = 0;
            for (i, p) in prims[l..l + PARTITION_BLOCK].iter().enumerate() {
                misplaced_l[count_l] = i as u8;
                count_l += usize::from(!goes_left(p));
            }
        }
        if count_r == 0 {
            start_r = 0;
            for (i, p) in prims[r - PARTITION_BLOCK..r].iter().rev().enumerate() {
                misplaced_r[count_r] = i as u8;
                count_r += usize::from(goes_left(p));
            }
        }
        let swaps = count_l.min(count_r);
        for k in 0..swaps {
            let i = l + misplaced_l[start_l + k] as usize;
            let j = r - 1 - misplaced_r[start_r + k] as usize;
            prims.swap(i, j);
        }
        (count_l, count_r) = (count_l - swaps, count_r - swaps);
        (start_l, start_r) = (start_l + swaps, start_r + swaps);
        if count_l == 0 {
            l += PARTITION_BLOCK;
        }
        if count_r == 0 {
            r -= PARTITION_BLOCK;
        }
    }
    // The rest, including a block whose misplaced elements are still waiting (they are
    // classified again).
    let rest = &mut prims[l..r];
    let mut next_left = 0;
    for i in 0..rest.len() {
        let left = goes_left(&rest[i]);
        rest.swap(i, next_left);
        next_left += usize::from(left);
    }
    l + next_left
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Aabb;
    use glam::Vec3A;

    /// The block partition against a plain filter: every primitive on its side, none lost or
    /// repeated, at sizes around the block length (where the block loop hands over to the
    /// Lomuto tail) and with skewed sides.
    #[test]
    fn block_partition_matches_a_filter() {
        let mut next = crate::test_floats(0x9e37_79b9_7f4a_7c15);
        let b = PARTITION_BLOCK;
        for n in [
            0,
            1,
            2,
            3,
            b - 1,
            b,
            b + 1,
            2 * b - 1,
            2 * b,
            2 * b + 1,
            5 * b + 7,
            3000,
        ] {
            for threshold in [0.0, 0.05, 0.5, 0.95, 1.0] {
                let mut prims: Vec<BuildPrim> = (0..n)
                    .map(|i| {
                        let c = Vec3A::new(next(), next(), next());
                        BuildPrim::new(Aabb::new(c, c + 0.01), i as u32)
                    })
                    .collect();
                let goes_left = |p: &BuildPrim| p.centroid().x < threshold;
                let expected_left = prims.iter().filter(|p| goes_left(p)).count();
                let mid = partition(&mut prims, goes_left);
                assert_eq!(mid, expected_left, "n {n}, threshold {threshold}");
                let mut ids: Vec<u32> = prims.iter().map(BuildPrim::index).collect();
                ids.sort_unstable();
                assert!(
                    ids.iter().copied().eq(0..n as u32),
                    "n {n}: ids lost or repeated"
                );
                for (side, range) in [(true, 0..mid), (false, mid..n)] {
                    for p in &prims[range] {
                        assert_eq!(goes_left(p), side, "n {n}");
                    }
                }
            }
        }
    }
}
