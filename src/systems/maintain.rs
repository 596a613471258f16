//! The trees' upkeep after the sync's edits: the static tree's builds landed or started,
//! and whichever index holds the moving entities kept consistent and improved.

use super::bvh_upkeep::{RayTraffic, maintain_bvh};
use super::choose_index::{AutomaticIndex, advise_index};
use super::publish_stats::publish_tree_stats;
use crate::index::dynamic_config;
use crate::settings::AccelSettings;
use crate::stats::AccelStats;
use crate::trees::AccelTrees;
use bevy::prelude::*;
use spatial_accel::query::DynamicIndex;
use std::time::Instant;

/// The trees' upkeep in one system (each system a frame costs the executor a task and a
/// wake-up, which a small world notices): the static tree's builds, then the dynamic index's,
/// then the frame's figures published and the automatic choice of index fed with them.
pub(crate) fn maintain_trees(
    settings: Res<AccelSettings>,
    mut trees: ResMut<AccelTrees>,
    mut stats: ResMut<AccelStats>,
    mut automatic: ResMut<AutomaticIndex>,
    mut traffic: Local<RayTraffic>,
) {
    land_static_builds(&settings, &mut trees, &mut stats);
    maintain_index(&settings, &mut trees, &mut stats, &mut traffic);
    if trees.is_changed() {
        publish_tree_stats(&trees, &mut stats);
    }
    advise_index(&settings, &trees, &mut automatic, &mut stats);
    trees.step_aside.costs().add_trees(stats.maintain_time);
}

/// Makes the dynamic index consistent after the sync's edits and lets it spend
/// [`AccelSettings::upkeep_budget_micros`] improving itself; the BVH backend also rebuilds
/// when its quality has decayed and keeps its ray snapshot. Does no index work in a frame
/// without edits.
fn maintain_index(
    settings: &AccelSettings,
    trees: &mut ResMut<AccelTrees>,
    stats: &mut AccelStats,
    traffic: &mut RayTraffic,
) {
    // Compared through shared access first: a mutable access marks `AccelTrees` changed.
    if let Some(tree) = trees.index().dynamic_bvh() {
        let config = dynamic_config(settings, tree.config());
        if *tree.config() != config {
            trees.index_mut().configure_bvh(config);
        }
    }
    traffic.observe(trees, stats);
    stats.rays_per_frame = traffic.rays;
    let start = Instant::now();
    let edited = trees.bypass_change_detection().take_pending_upkeep();
    if trees.index().bvh_pair().is_some() {
        maintain_bvh(&settings.bvh, trees, stats, traffic);
    } else {
        stats.bvh = None;
        if edited && let Some(dynamic) = trees.index_mut().layered_dynamic_mut() {
            stats.last_upkeep = dynamic.maintain(settings.upkeep_budget());
        }
    }
    stats.maintain_time += start.elapsed();
}

/// Brings the static tree up to date with the static set: lands a build finished off the
/// frame, or starts one for the entities that came or went (in the frame for a first load
/// or a small set, see [`AccelSettings::static_rebuild_in_frame_up_to`]). Static newcomers
/// that no tree holds yet wait in the dynamic index, so it runs before the index's upkeep.
fn land_static_builds(
    settings: &AccelSettings,
    trees: &mut ResMut<AccelTrees>,
    stats: &mut AccelStats,
) {
    let start = Instant::now();
    // A mutable access marks `AccelTrees` changed: only a new tree does.
    let tree_state = trees.bypass_change_detection();
    let rebuilt = tree_state.advance_static(
        settings.static_rebuild_in_frame_up_to,
        settings.static_build,
    );
    if rebuilt {
        tree_state.note_index_changed();
        trees.set_changed();
    }
    stats.static_rebuilt = rebuilt;
    stats.maintain_time = start.elapsed();
}
