//! Splits that look only at centroid positions: spatial midpoint and object median.

use super::partition::partition;
use super::top_down::{BuildPrim, SplitOutcome};
use crate::Aabb;

/// Midpoint of the centroid bounds on their longest axis; the object median when rounding
/// leaves one side empty.
pub(super) fn midpoint(prims: &mut [BuildPrim], centroid_bounds: &Aabb) -> SplitOutcome {
    let axis = centroid_bounds.longest_axis();
    let plane = centroid_bounds.center()[axis];
    let mid = partition(prims, |p| p.centroid()[axis] < plane);
    if mid == 0 || mid == prims.len() {
        return median(prims, centroid_bounds);
    }
    SplitOutcome::Split(mid)
}

/// Median centroid on the longest axis of the centroid bounds: a balanced split.
pub(super) fn median(prims: &mut [BuildPrim], centroid_bounds: &Aabb) -> SplitOutcome {
    let axis = centroid_bounds.longest_axis();
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| {
        a.centroid()[axis].total_cmp(&b.centroid()[axis])
    });
    SplitOutcome::Split(mid)
}
