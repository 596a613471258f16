//! Partitioning a build's primitives around a split plane, returning each side's centroid
//! bounds on the way: a block partition, with Hoare's scheme for the tail.

use super::build::BuildPrim;
use crate::Aabb;
use glam::Vec3A;

/// Elements classified at a time by each end of [`partition_by_centroid`] (offsets fit a
/// byte).
const PARTITION_BLOCK: usize = 64;

/// Partitions in place so that the primitives whose point (`point`: the centroid, or a
/// multiple) passes `left` come first; returns how many did, and the bounds of the points on
/// each side: a partition reads every primitive anyway, so the children's centroid bounds
/// cost no pass of their own.
///
/// Block partitioning (Edelkamp & Weiss 2016, "BlockQuicksort"): each end classifies a block
/// of elements without branching, recording the offsets of the misplaced ones, then the two
/// lists are swapped pairwise. Why: Hoare's loop branches on every element's side, and deep in
/// a build, where boxes are scattered, that branch is a coin toss.
pub(super) fn partition_by_centroid(
    prims: &mut [BuildPrim],
    point: impl Fn(&BuildPrim) -> Vec3A,
    left: impl Fn(Vec3A) -> bool,
) -> (usize, [Aabb; 2]) {
    let mut sides = SideBounds::default();
    let (mut l, mut r) = (0usize, prims.len());
    let mut misplaced_l = [0u8; PARTITION_BLOCK];
    let mut misplaced_r = [0u8; PARTITION_BLOCK];
    let (mut start_l, mut count_l, mut start_r, mut count_r) = (0, 0, 0, 0);
    // Every element left of `l` goes left, every one from `r` on goes right.
    while r - l >= 2 * PARTITION_BLOCK {
        if count_l == 0 {
            start_l = 0;
            for (i, p) in prims[l..l + PARTITION_BLOCK].iter().enumerate() {
                let c = point(p);
                let goes_left = left(c);
                sides.add(c, goes_left);
                misplaced_l[count_l] = i as u8;
                count_l += usize::from(!goes_left);
            }
        }
        if count_r == 0 {
            start_r = 0;
            for (i, p) in prims[r - PARTITION_BLOCK..r].iter().rev().enumerate() {
                let c = point(p);
                let goes_left = left(c);
                sides.add(c, goes_left);
                misplaced_r[count_r] = i as u8;
                count_r += usize::from(goes_left);
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
    // The rest, including a block whose misplaced elements are still waiting, by Hoare's
    // loop. It classifies some elements a second time; adding a point to its side's bounds
    // twice changes nothing.
    let (mid, rest) = partition_scalar(&mut prims[l..r], &point, &left);
    let [left_bounds, right_bounds] = sides.bounds();
    (
        l + mid,
        [left_bounds.union(&rest[0]), right_bounds.union(&rest[1])],
    )
}

/// The bounds of the points sent to each side, kept without branching on the side.
struct SideBounds {
    left_min: Vec3A,
    left_max: Vec3A,
    right_min: Vec3A,
    right_max: Vec3A,
}

impl Default for SideBounds {
    fn default() -> Self {
        Self {
            left_min: Vec3A::INFINITY,
            left_max: Vec3A::NEG_INFINITY,
            right_min: Vec3A::INFINITY,
            right_max: Vec3A::NEG_INFINITY,
        }
    }
}

impl SideBounds {
    #[inline(always)]
    fn add(&mut self, c: Vec3A, goes_left: bool) {
        let to_left = glam::BVec3A::splat(goes_left);
        let inf = Vec3A::INFINITY;
        self.left_min = self.left_min.min(Vec3A::select(to_left, c, inf));
        self.left_max = self.left_max.max(Vec3A::select(to_left, c, -inf));
        self.right_min = self.right_min.min(Vec3A::select(to_left, inf, c));
        self.right_max = self.right_max.max(Vec3A::select(to_left, -inf, c));
    }

    fn bounds(&self) -> [Aabb; 2] {
        [
            Aabb {
                min: self.left_min,
                max: self.left_max,
            },
            Aabb {
                min: self.right_min,
                max: self.right_max,
            },
        ]
    }
}

/// Hoare's partition with the bounds of each side's points: the tail of
/// [`partition_by_centroid`]. Both ends scan inwards and only misplaced pairs are swapped,
/// each primitive tested once.
fn partition_scalar(
    prims: &mut [BuildPrim],
    point: impl Fn(&BuildPrim) -> Vec3A,
    left: impl Fn(Vec3A) -> bool,
) -> (usize, [Aabb; 2]) {
    let mut bounds = [Aabb::EMPTY; 2];
    let mut i = 0;
    let mut j = prims.len();
    loop {
        while i < j {
            let c = point(&prims[i]);
            if !left(c) {
                break;
            }
            bounds[0] = bounds[0].grow(c);
            i += 1;
        }
        while i < j {
            let c = point(&prims[j - 1]);
            if left(c) {
                break;
            }
            bounds[1] = bounds[1].grow(c);
            j -= 1;
        }
        if i + 1 >= j {
            return (i, bounds);
        }
        // `prims[i]` belongs right and `prims[j - 1]` left: swapped, each joins its side.
        bounds[0] = bounds[0].grow(point(&prims[j - 1]));
        bounds[1] = bounds[1].grow(point(&prims[i]));
        prims.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The block partition against a plain filter: every primitive on its side, none lost or
    /// repeated, and each side's centroid bounds those of its primitives, at sizes around the
    /// block length (where the block loop hands over to the scalar tail) and with skewed
    /// sides.
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
                let goes_left = |c: Vec3A| c.x < threshold;
                let expected_left = prims.iter().filter(|p| goes_left(p.centroid())).count();
                let (mid, bounds) =
                    partition_by_centroid(&mut prims, BuildPrim::centroid, goes_left);
                assert_eq!(mid, expected_left, "n {n}, threshold {threshold}");
                let mut ids: Vec<u32> = prims.iter().map(BuildPrim::index).collect();
                ids.sort_unstable();
                assert!(
                    ids.iter().copied().eq(0..n as u32),
                    "n {n}: ids lost or repeated"
                );
                for (side, range) in [(0, 0..mid), (1, mid..n)] {
                    let mut want = Aabb::EMPTY;
                    for p in &prims[range] {
                        assert_eq!(goes_left(p.centroid()), side == 0, "n {n}");
                        want = want.grow(p.centroid());
                    }
                    assert_eq!(bounds[side].min, want.min, "n {n}, side {side}");
                    assert_eq!(bounds[side].max, want.max, "n {n}, side {side}");
                }
            }
        }
    }
}
