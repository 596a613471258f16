//! The exact plane sweep of a node of 5 to 8 primitives: on each axis, every plane between
//! two consecutive centroids, costed from sorted prefix and suffix boxes (sweep SAH,
//! MacDonald & Booth 1990), all eight lanes at once.
//!
//! Why: nodes of 5 to 8 primitives are a large share of a binned build's splits, and their
//! bins cost more than their primitives: clearing three rows of bins, sweeping 3 x (n - 1)
//! planes one box at a time. With AVX2, a node's eight centroids sort in six compare-exchange
//! steps of one register, and every plane's left and right box comes out of three
//! shift-and-`min` steps: cheaper per split, and a whole build faster (BENCHMARKS.md, Static
//! BVH builds). The split found is also the best plane of all, where the bins see only
//! theirs, so the tree's SAH cost comes out a little lower too.
//!
//! Only where the CPU has AVX2 ([`available`]); elsewhere nodes of 5 to 8 primitives keep
//! their bins. The portable version of the same sweep (a sort, then a plane at a time)
//! makes a whole build slower than the bins do, so it is only the definition the
//! AVX2 code is tested against (`sweep_axis_portable`). Trees built on a CPU without AVX2 can
//! therefore differ from those built with it; both are valid, and the queries' results are
//! the same.

use super::top_down::{BuildPrim, SplitOutcome, leaf_is_cheaper};
use crate::Aabb;
use crate::bvh::config::BuildConfig;

/// The fewest primitives a node may have for [`split`] (smaller ones are split exhaustively).
pub(super) const MIN_PRIMS: usize = 5;

/// The most primitives a node may have for [`split`] (the lanes of a 256-bit register).
pub(super) const MAX_PRIMS: usize = 8;

/// The best plane on one axis: `area(L) n(L) + area(R) n(R)` (infinite for none), and how
/// many primitives go left, in the axis's sorted order (`order`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct AxisPlane {
    cost: f32,
    left: usize,
    order: [u8; MAX_PRIMS],
}

/// Whether [`split`] may be called: the CPU has AVX2.
#[inline]
pub(super) fn available() -> bool {
    std::is_x86_feature_detected!("avx2")
}

/// Splits `prims` ([`MIN_PRIMS`] to [`MAX_PRIMS`] of them, every corner at most half the
/// largest float, so that `lo + hi` is finite) at the cheapest plane of any axis, or makes a
/// leaf where that costs no more (`may_stop`). Ties go to the lower axis, then to fewer
/// primitives on the left. No plane separates equal centroids, so the decision does not
/// depend on the order of equal ones. Only where [`available`].
pub(super) fn split(
    prims: &mut [BuildPrim],
    node_bounds: &Aabb,
    config: &BuildConfig,
    may_stop: bool,
) -> SplitOutcome {
    let n = prims.len();
    debug_assert!((MIN_PRIMS..=MAX_PRIMS).contains(&n));
    assert!(available(), "sorted::split needs AVX2");
    // SAFETY: the CPU has AVX2.
    let best = unsafe { best_plane_avx2(prims) };
    if best.cost == f32::INFINITY {
        return SplitOutcome::NoPositionalSplit;
    }
    if may_stop && leaf_is_cheaper(config, n, best.cost, node_bounds) {
        return SplitOutcome::Leaf;
    }
    let records: [BuildPrim; MAX_PRIMS] = core::array::from_fn(|i| prims[i.min(n - 1)]);
    for (slot, &i) in prims.iter_mut().zip(&best.order[..n]) {
        *slot = records[i as usize];
    }
    SplitOutcome::Split(best.left)
}

/// The cheapest plane of the three axes' ([`sweep_axis_portable`]), the lower axis on ties:
/// the definition the AVX2 sweep must match bit for bit.
#[cfg(test)]
fn best_plane_portable(prims: &[BuildPrim]) -> AxisPlane {
    let n = prims.len();
    let records: [BuildPrim; MAX_PRIMS] = core::array::from_fn(|i| prims[i.min(n - 1)]);
    let mut best = sweep_axis_portable(&records, n, 0);
    for axis in 1..3 {
        let plane = sweep_axis_portable(&records, n, axis);
        if plane.cost < best.cost {
            best = plane;
        }
    }
    best
}

/// The best plane on `axis` among the first `n` records, one plane at a time: the definition
/// the AVX2 sweep must match bit for bit.
#[cfg(test)]
fn sweep_axis_portable(records: &[BuildPrim; MAX_PRIMS], n: usize, axis: usize) -> AxisPlane {
    let key = |i: u8| records[i as usize].corner_sum(axis);
    let mut order: [u8; MAX_PRIMS] = core::array::from_fn(|i| i as u8);
    order[..n].sort_unstable_by(|&a, &b| key(a).total_cmp(&key(b)));
    let boxes: [Aabb; MAX_PRIMS] = core::array::from_fn(|k| records[order[k] as usize].bounds());
    let mut suffix_area = [0.0f32; MAX_PRIMS];
    let mut right = Aabb::EMPTY;
    for k in (1..n).rev() {
        right = right.union(&boxes[k]);
        suffix_area[k] = right.half_area();
    }
    let mut best = AxisPlane {
        cost: f32::INFINITY,
        left: 0,
        order,
    };
    let mut left = Aabb::EMPTY;
    for k in 0..n - 1 {
        left = left.union(&boxes[k]);
        if key(order[k]) < key(order[k + 1]) {
            let cost = left.half_area() * (k + 1) as f32 + suffix_area[k + 1] * (n - k - 1) as f32;
            if cost < best.cost {
                best.cost = cost;
                best.left = k + 1;
            }
        }
    }
    best
}

use avx2::best_plane_avx2;

mod avx2 {
    use super::super::binned_avx2::{broadcast_min, transpose};
    use super::{AxisPlane, BuildPrim, MAX_PRIMS};
    use core::arch::x86_64::{
        __m256, __m256i, _CMP_EQ_OQ, _CMP_LT_OQ, _CMP_NEQ_OQ, _mm256_add_ps, _mm256_and_ps,
        _mm256_blend_ps, _mm256_blendv_ps, _mm256_cmp_ps, _mm256_cvttps_epi32, _mm256_loadu_ps,
        _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps, _mm256_mul_ps, _mm256_permutevar8x32_ps,
        _mm256_set1_ps, _mm256_setr_epi32, _mm256_setr_ps, _mm256_setzero_ps, _mm256_storeu_ps,
        _mm256_storeu_si256, _mm256_sub_ps,
    };

    /// One compare-exchange step of a bitonic network over the keys, the primitives'
    /// numbers following their keys: lane `i` meets lane `perm[i]` and keeps the larger key
    /// where bit `i` of `TAKE_MAX` is set. Equal keys keep their own numbers, so the numbers
    /// stay a permutation.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn compare_exchange<const TAKE_MAX: i32>(
        keys: __m256,
        ids: __m256,
        perm: __m256i,
    ) -> (__m256, __m256) {
        let other_keys = _mm256_permutevar8x32_ps(keys, perm);
        let other_ids = _mm256_permutevar8x32_ps(ids, perm);
        let sorted = _mm256_blend_ps::<TAKE_MAX>(
            _mm256_min_ps(keys, other_keys),
            _mm256_max_ps(keys, other_keys),
        );
        let moved = _mm256_cmp_ps::<_CMP_NEQ_OQ>(sorted, keys);
        (sorted, _mm256_blendv_ps(ids, other_ids, moved))
    }

    /// Lane `i` takes lane `perm[i]`, and the lanes of `FILL_MASK` take `fill` instead.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn shifted<const FILL_MASK: i32>(v: __m256, perm: __m256i, fill: __m256) -> __m256 {
        _mm256_blend_ps::<FILL_MASK>(_mm256_permutevar8x32_ps(v, perm), fill)
    }

    /// Inclusive scans from lane 0 up (`up`) or from lane 7 down: `min` of the lower
    /// corners, `max` of the upper ones, over the sorted boxes.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn scan(c: [__m256; 6], up: bool) -> [__m256; 6] {
        let inf = _mm256_set1_ps(f32::INFINITY);
        let neg_inf = _mm256_set1_ps(f32::NEG_INFINITY);
        let mut out = c;
        for (k, v) in out.iter_mut().enumerate() {
            let (fill, lower) = if k < 3 { (inf, true) } else { (neg_inf, false) };
            let step = |v: __m256, s: __m256| {
                if lower {
                    _mm256_min_ps(v, s)
                } else {
                    _mm256_max_ps(v, s)
                }
            };
            if up {
                *v = step(
                    *v,
                    shifted::<0b0000_0001>(*v, _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6), fill),
                );
                *v = step(
                    *v,
                    shifted::<0b0000_0011>(*v, _mm256_setr_epi32(0, 0, 0, 1, 2, 3, 4, 5), fill),
                );
                *v = step(
                    *v,
                    shifted::<0b0000_1111>(*v, _mm256_setr_epi32(0, 0, 0, 0, 0, 1, 2, 3), fill),
                );
            } else {
                *v = step(
                    *v,
                    shifted::<0x80>(*v, _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 7), fill),
                );
                *v = step(
                    *v,
                    shifted::<0xC0>(*v, _mm256_setr_epi32(2, 3, 4, 5, 6, 7, 7, 7), fill),
                );
                *v = step(
                    *v,
                    shifted::<0xF0>(*v, _mm256_setr_epi32(4, 5, 6, 7, 7, 7, 7, 7), fill),
                );
            }
        }
        out
    }

    /// Half the area of each lane's box: `Aabb::half_area`'s operations in its order.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn half_areas(b: &[__m256; 6]) -> __m256 {
        let zero = _mm256_setzero_ps();
        let ex = _mm256_max_ps(_mm256_sub_ps(b[3], b[0]), zero);
        let ey = _mm256_max_ps(_mm256_sub_ps(b[4], b[1]), zero);
        let ez = _mm256_max_ps(_mm256_sub_ps(b[5], b[2]), zero);
        _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(ex, ey), _mm256_mul_ps(ey, ez)),
            _mm256_mul_ps(ez, ex),
        )
    }

    /// The primitives' corners, component by component (primitive `i` in lane `i`):
    /// `[lo.x, lo.y, lo.z, hi.x, hi.y, hi.z]`, lanes from `n` on empty.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn corners(prims: &[BuildPrim]) -> [__m256; 6] {
        let n = prims.len();
        // Eight records of 32 bytes, `(lo, hi)` each (the last repeated to fill the lanes),
        // transposed as an 8 x 8 matrix of floats.
        let r: [__m256; MAX_PRIMS] = core::array::from_fn(|i| {
            let p: *const BuildPrim = &prims[i.min(n - 1)];
            // SAFETY: a `BuildPrim` is eight floats.
            unsafe { _mm256_loadu_ps(p.cast::<f32>()) }
        });
        let lanes = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
        let live = _mm256_cmp_ps::<_CMP_LT_OQ>(lanes, _mm256_set1_ps(n as f32));
        let raw = transpose(&r);
        let empty = [
            _mm256_set1_ps(f32::INFINITY),
            _mm256_set1_ps(f32::NEG_INFINITY),
        ];
        core::array::from_fn(|k| _mm256_blendv_ps(empty[k / 3], raw[k], live))
    }

    /// [`super::best_plane_portable`] in eight lanes: per axis, a bitonic sort of the keys
    /// (Batcher 1968), the sorted boxes' prefix and suffix boxes by scans, every plane costed
    /// at once.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn best_plane_avx2(prims: &[BuildPrim]) -> AxisPlane {
        let n = prims.len();
        let c = corners(prims);
        let mut best = AxisPlane {
            cost: f32::INFINITY,
            left: 0,
            order: [0; MAX_PRIMS],
        };
        for axis in 0..3 {
            let plane = sweep_axis(&c, n, axis);
            if plane.cost < best.cost || axis == 0 {
                best = plane;
            }
        }
        best
    }

    /// The best plane on `axis` of the corners `c` of `n` primitives.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn sweep_axis(c: &[__m256; 6], n: usize, axis: usize) -> AxisPlane {
        let inf = _mm256_set1_ps(f32::INFINITY);
        let lanes = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
        let live = _mm256_cmp_ps::<_CMP_LT_OQ>(lanes, _mm256_set1_ps(n as f32));
        let keys = _mm256_blendv_ps(inf, _mm256_add_ps(c[axis], c[axis + 3]), live);
        // Batcher's bitonic network for eight lanes: six steps, partners at distance 1, 2, 1,
        // 4, 2, 1; `TAKE_MAX` marks the lanes that keep the larger key.
        let p1 = _mm256_setr_epi32(1, 0, 3, 2, 5, 4, 7, 6);
        let p2 = _mm256_setr_epi32(2, 3, 0, 1, 6, 7, 4, 5);
        let p4 = _mm256_setr_epi32(4, 5, 6, 7, 0, 1, 2, 3);
        let ids = lanes;
        let (k, i) = compare_exchange::<0x66>(keys, ids, p1);
        let (k, i) = compare_exchange::<0x3C>(k, i, p2);
        let (k, i) = compare_exchange::<0x5A>(k, i, p1);
        let (k, i) = compare_exchange::<0xF0>(k, i, p4);
        let (k, i) = compare_exchange::<0xCC>(k, i, p2);
        let (keys, ids) = compare_exchange::<0xAA>(k, i, p1);

        // Float lane numbers to integer lane numbers: exact small integers.
        let order = _mm256_cvttps_epi32(ids);
        let sorted = c.map(|v| _mm256_permutevar8x32_ps(v, order));
        let prefix = scan(sorted, true);
        let suffix = scan(sorted, false);
        let left_area = half_areas(&prefix);
        // Plane `k` (after sorted lane `k`) has the suffix from lane `k + 1` on its right.
        let right_area = shifted::<0x80>(
            half_areas(&suffix),
            _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 7),
            _mm256_setzero_ps(),
        );
        let left_count = _mm256_add_ps(lanes, _mm256_set1_ps(1.0));
        let right_count = _mm256_sub_ps(_mm256_set1_ps(n as f32), left_count);
        let cost = _mm256_add_ps(
            _mm256_mul_ps(left_area, left_count),
            _mm256_mul_ps(right_area, right_count),
        );
        // A plane exists between unequal neighbours, before the last primitive.
        let next_keys = shifted::<0x80>(keys, _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 7), inf);
        let inside = _mm256_cmp_ps::<_CMP_LT_OQ>(lanes, _mm256_set1_ps((n - 1) as f32));
        let valid = _mm256_and_ps(inside, _mm256_cmp_ps::<_CMP_LT_OQ>(keys, next_keys));
        let cost = _mm256_blendv_ps(inf, cost, valid);
        // The least cost, broadcast, then its first lane.
        let m = broadcast_min(cost);
        let first = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(cost, m)).trailing_zeros();
        let mut order_lanes = [0i32; MAX_PRIMS];
        let mut cost_lanes = [0.0f32; MAX_PRIMS];
        // SAFETY: each array holds eight 32-bit lanes.
        unsafe {
            _mm256_storeu_si256(order_lanes.as_mut_ptr().cast(), order);
            _mm256_storeu_ps(cost_lanes.as_mut_ptr(), cost);
        }
        // No plane leaves every lane infinite, and equal to the broadcast least: no left.
        let cost = cost_lanes[first as usize];
        AxisPlane {
            cost,
            left: if cost < f32::INFINITY {
                first as usize + 1
            } else {
                0
            },
            order: order_lanes.map(|i| i as u8),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::top_down::{NodeBounds, check_small_split, leaf_wins_by_sah, records_of};
    use super::*;
    use glam::Vec3A;

    /// Nodes of 5 to 8 boxes: random, with copies (equal centroids, ties between planes),
    /// flat, far from the origin, and huge (corners near a quarter of the largest float, where
    /// every area overflows to infinity and no plane has a finite cost).
    fn nodes() -> Vec<Vec<Aabb>> {
        let mut next = crate::test_floats(0x2f1c_9a3b_77d4_e015);
        (0..4000)
            .map(|trial| {
                let n = MIN_PRIMS + trial % (MAX_PRIMS - MIN_PRIMS + 1);
                let offset = if trial % 7 == 0 { 1.0e6 } else { 0.0 };
                let scale = if trial % 13 == 0 && offset == 0.0 {
                    8.0e36
                } else {
                    1.0
                };
                let mut boxes: Vec<Aabb> = (0..n)
                    .map(|_| {
                        let c = (Vec3A::new(next(), next(), next()) * 10.0 + offset) * scale;
                        let flat = if trial % 3 == 0 { 0.0 } else { 1.0 };
                        let h = Vec3A::new(next(), next() * flat, next()) * scale;
                        Aabb::new(c - h, c + h)
                    })
                    .collect();
                if trial % 5 == 0 {
                    // Copies: equal centroids, which no plane may separate.
                    for i in (1..n).step_by(2) {
                        boxes[i] = boxes[i - 1];
                    }
                }
                if trial % 11 == 0 {
                    // Every centroid on one plane of x.
                    for b in &mut boxes {
                        b.min.x = -1.0;
                        b.max.x = 1.0;
                    }
                }
                boxes
            })
            .collect()
    }

    fn records(boxes: &[Aabb]) -> [BuildPrim; MAX_PRIMS] {
        core::array::from_fn(|i| BuildPrim::new(boxes[i.min(boxes.len() - 1)], i as u32))
    }

    /// The least `area(L) n(L) + area(R) n(R)` over every plane between two unequal sorted
    /// centroids on `axis`, each side's box by its own fold.
    fn brute_force(boxes: &[Aabb], axis: usize) -> f32 {
        let key = |b: &Aabb| b.min[axis] + b.max[axis];
        let mut best = f32::INFINITY;
        for b in boxes {
            let (left, right): (Vec<&Aabb>, Vec<&Aabb>) =
                boxes.iter().partition(|o| key(o) <= key(b));
            if right.is_empty() {
                continue;
            }
            let fold = |s: &[&Aabb]| s.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
            let cost = fold(&left).half_area() * left.len() as f32
                + fold(&right).half_area() * right.len() as f32;
            best = best.min(cost);
        }
        best
    }

    /// The portable sweep finds the cheapest plane of each axis, and its left side is every
    /// primitive whose centroid is at most the plane's.
    #[test]
    fn portable_sweep_finds_the_cheapest_plane() {
        for (trial, boxes) in nodes().iter().enumerate() {
            let n = boxes.len();
            for axis in 0..3 {
                let plane = sweep_axis_portable(&records(boxes), n, axis);
                assert_eq!(
                    plane.cost,
                    brute_force(boxes, axis),
                    "trial {trial} axis {axis}"
                );
                if plane.cost.is_finite() {
                    let key = |i: u8| boxes[i as usize].min[axis] + boxes[i as usize].max[axis];
                    let (l, r) = plane.order[..n].split_at(plane.left);
                    let l_max = l.iter().map(|&i| key(i)).fold(f32::NEG_INFINITY, f32::max);
                    let r_min = r.iter().map(|&i| key(i)).fold(f32::INFINITY, f32::min);
                    assert!(
                        l_max < r_min,
                        "trial {trial}: a plane between equal centroids"
                    );
                }
            }
        }
    }

    /// The AVX2 search gives the portable one's cost to the bit, the same left count, and the
    /// same left set (the order among equal centroids may differ).
    #[test]
    fn avx2_search_matches_the_portable_one() {
        if !available() {
            return;
        }
        for (trial, boxes) in nodes().iter().enumerate() {
            let n = boxes.len();
            let prims = &records(boxes)[..n];
            let portable = best_plane_portable(prims);
            // SAFETY: the CPU has AVX2.
            let avx2 = unsafe { best_plane_avx2(prims) };
            assert_eq!(
                avx2.cost.to_bits(),
                portable.cost.to_bits(),
                "trial {trial}"
            );
            assert_eq!(avx2.left, portable.left, "trial {trial}");
            let set = |p: &AxisPlane| {
                let mut s = p.order[..p.left].to_vec();
                s.sort_unstable();
                s
            };
            assert_eq!(set(&avx2), set(&portable), "trial {trial}");
            let mut all = avx2.order[..n].to_vec();
            all.sort_unstable();
            assert!(
                all.iter().copied().eq(0..n as u8),
                "trial {trial}: not a permutation"
            );
        }
    }

    /// The split takes the cheapest axis, keeps every primitive once, and makes a leaf exactly
    /// when the leaf costs no more (`may_stop`); where no plane has a finite cost, it finds
    /// no split by position (as the bins do), and does not panic.
    #[test]
    fn splits_at_the_cheapest_plane_of_any_axis() {
        if !available() {
            return;
        }
        let config = BuildConfig::default();
        let mut infinite = 0;
        for (trial, boxes) in nodes().iter().enumerate() {
            let n = boxes.len();
            let best = (0..3)
                .map(|a| brute_force(boxes, a))
                .fold(f32::INFINITY, f32::min);
            let node = boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
            for may_stop in [false, true] {
                let mut prims = records_of(boxes);
                let outcome = split(&mut prims, &node, &config, may_stop);
                if best == f32::INFINITY {
                    infinite += 1;
                    assert!(
                        matches!(outcome, SplitOutcome::NoPositionalSplit),
                        "trial {trial}: a split by an infinite cost"
                    );
                    continue;
                }
                let leaf_wins = leaf_wins_by_sah(&config, n, best, &node);
                let Some(mid) = check_small_split(trial, &outcome, &prims, may_stop, leaf_wins)
                else {
                    continue;
                };
                let [l, r] = [&prims[..mid], &prims[mid..]].map(NodeBounds::of);
                let cost = l.node.half_area() * mid as f32 + r.node.half_area() * (n - mid) as f32;
                assert_eq!(cost, best, "trial {trial}: not the cheapest plane");
            }
        }
        assert!(infinite > 0, "no node without a finite cost was tried");
    }
}
