//! Full-sweep SAH: every split between consecutive sorted centroids, on every axis.

use super::top_down::{BuildPrim, SplitOutcome, leaf_is_cheaper};
use crate::Aabb;
use crate::bvh::config::BuildConfig;

/// Sorts by centroid on each axis and evaluates all `n - 1` splits; the quality reference the
/// binned builder is measured against.
pub(super) fn split(
    prims: &mut [BuildPrim],
    node_bounds: &Aabb,
    config: &BuildConfig,
    may_stop: bool,
) -> SplitOutcome {
    let n = prims.len();
    let mut right_area = vec![0.0f32; n];
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        sort_on(prims, axis);
        let mut acc = Aabb::EMPTY;
        for i in (1..n).rev() {
            acc = acc.union(&prims[i].bounds());
            right_area[i] = acc.half_area();
        }
        let mut acc = Aabb::EMPTY;
        for i in 0..n - 1 {
            acc = acc.union(&prims[i].bounds());
            // Splitting between equal centroids would make the split depend on sort order,
            // not geometry; the binned builder cannot do it either.
            if prims[i].centroid()[axis] == prims[i + 1].centroid()[axis] {
                continue;
            }
            let left_n = (i + 1) as f32;
            let cost = acc.half_area() * left_n + right_area[i + 1] * (n - i - 1) as f32;
            if cost < best.0 {
                best = (cost, axis, i + 1);
            }
        }
    }
    let (cost, axis, mid) = best;
    if !cost.is_finite() {
        return SplitOutcome::NoPositionalSplit;
    }
    if may_stop && leaf_is_cheaper(config, n, cost, node_bounds) {
        return SplitOutcome::Leaf;
    }
    if axis != 2 {
        sort_on(prims, axis);
    }
    SplitOutcome::Split(mid)
}

fn sort_on(prims: &mut [BuildPrim], axis: usize) {
    prims.sort_unstable_by(|a, b| {
        a.centroid()[axis]
            .total_cmp(&b.centroid()[axis])
            .then(a.index().cmp(&b.index()))
    });
}
