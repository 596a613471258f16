//! The per-frame upkeep of whichever index holds the moving entities.

use super::bvh_backend::{RayTraffic, dynamic_config, maintain_bvh};
use crate::settings::AccelSettings;
use crate::stats::AccelStats;
use crate::trees::AccelTrees;
use bevy::prelude::*;
use spatial_accel::query::DynamicIndex;
use std::time::Instant;

/// Makes the dynamic index consistent after the sync's edits and lets it spend
/// [`AccelSettings::upkeep_budget_micros`] improving itself; the BVH backend also rebuilds
/// when its quality has decayed and keeps its ray snapshot. Does no index work in a frame
/// without edits.
pub(crate) fn maintain_index(
    settings: Res<AccelSettings>,
    mut trees: ResMut<AccelTrees>,
    mut stats: ResMut<AccelStats>,
    mut traffic: Local<RayTraffic>,
) {
    // Compared through shared access first: a mutable access marks `AccelTrees` changed.
    if let Some(tree) = trees.query().dynamic_bvh() {
        let config = dynamic_config(&settings, tree.config());
        if *tree.config() != config {
            trees.index_mut().configure_bvh(config);
        }
    }
    traffic.observe(&trees, &stats);
    stats.rays_per_frame = traffic.rays;
    let start = Instant::now();
    let edited = trees.bypass_change_detection().take_pending_upkeep();
    if trees.query().bvh_pair().is_some() {
        maintain_bvh(&settings.bvh, &mut trees, &mut stats, &traffic);
    } else {
        stats.bvh = None;
        if edited && let Some(dynamic) = trees.index_mut().layered_dynamic_mut() {
            stats.last_upkeep = dynamic.maintain(settings.upkeep_budget());
        }
    }
    stats.maintain_time = start.elapsed();
}
