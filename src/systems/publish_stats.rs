//! The trees' figures published: [`AccelStats`], and every plugin's Bevy diagnostics.

use crate::stats::AccelStats;
use crate::trees::AccelTrees;
use bevy::diagnostic::Diagnostics;
use bevy::prelude::*;

/// Copies tree shape into the stats, at the end of the maintenance, in frames that changed
/// the trees; every figure is O(1) to read (the depth is the root's stored height: a walk of
/// a large tree, even once a second, would be a frame hitch).
pub(super) fn publish_tree_stats(trees: &AccelTrees, stats: &mut AccelStats) {
    let index = trees.query();
    stats.busy_movers = index.busy_movers().len();
    stats.dynamic_entities = index.dynamic_len() + stats.busy_movers;
    stats.static_entities = trees.static_len();
    stats.static_waiting = trees.static_waiting_len();
    stats.static_build_in_flight = trees.static_build_in_flight();
    stats.index = index.choice();
    stats.dynamic_index = index.dynamic_stats();
}

/// Adds the frame's figures of the trees, the culling and the picking to Bevy's diagnostics,
/// in `Last` (after the culling's passes, whichever ran). One system for every plugin: each
/// system a frame costs Bevy's executor a task and a thread wake-up, which a small world
/// notices.
pub(crate) fn publish_diagnostics(
    stats: Res<AccelStats>,
    #[cfg(feature = "culling")] culling: Option<Res<crate::culling::CullingStats>>,
    #[cfg(feature = "picking")] picking: Option<Res<crate::picking::AccelPickingStats>>,
    mut diagnostics: Diagnostics,
) {
    let s = &*stats;
    diagnostics.add_measurement(&AccelStats::SYNC_TIME, || s.sync_time.as_secs_f64() * 1e3);
    diagnostics.add_measurement(&AccelStats::MAINTAIN_TIME, || {
        s.maintain_time.as_secs_f64() * 1e3
    });
    diagnostics.add_measurement(&AccelStats::ENTITIES, || {
        (s.dynamic_entities + s.static_entities) as f64
    });
    diagnostics.add_measurement(&AccelStats::DEPTH, || s.dynamic_index.depth as f64);
    if let Some(ratio) = s.dynamic_index.quality_ratio {
        diagnostics.add_measurement(&AccelStats::QUALITY_RATIO, || ratio as f64);
    }
    #[cfg(feature = "culling")]
    if let Some(culling) = culling {
        crate::culling::add_culling_measurements(&culling, &mut diagnostics);
    }
    #[cfg(feature = "picking")]
    if let Some(picking) = picking {
        crate::picking::add_picking_measurements(&picking, &mut diagnostics);
    }
}
