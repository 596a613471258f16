//! The trees' figures published in [`AccelStats`].

use crate::stats::AccelStats;
use crate::trees::AccelTrees;

/// Copies tree shape into the stats, at the end of the maintenance, in frames that changed
/// the trees; every figure is O(1) to read (the depth is the root's stored height: a walk of
/// a large tree, even once a second, would be a frame hitch).
pub(super) fn publish_tree_stats(trees: &AccelTrees, stats: &mut AccelStats) {
    let index = trees.index();
    stats.busy_movers = index.busy_movers().len();
    stats.dynamic_entities = index.dynamic_len() + stats.busy_movers;
    stats.static_entities = trees.static_len();
    stats.static_waiting = trees.static_waiting_len();
    stats.static_build_in_flight = trees.static_build_in_flight();
    stats.index = index.choice();
    stats.dynamic_index = index.dynamic_stats();
}
