//! The BVH backend's upkeep: refit, optimiser and rebuilds of the dynamic tree, and the
//! policy that keeps a 16-wide snapshot of it for rays.

use crate::StaticTreeBuild;
use crate::index::BvhIndexSettings;
use crate::stats::AccelStats;
use crate::trees::{AccelTrees, entity_tree_config};
use bevy::prelude::*;
use spatial_accel::dynamic::StaticDynamicPair;

/// What the ray snapshot policy watches, frame to frame.
#[derive(Default)]
pub(crate) struct RayTraffic {
    /// Frames in a row in which no dynamic entity entered or left.
    stable_frames: u32,
    /// Frames in a row in which, besides, no dynamic entity moved.
    still_frames: u32,
    /// Rays cast per frame, averaged over about ten frames.
    pub(crate) rays: f32,
    /// Dynamic entities moved per frame, averaged the same way.
    movers: f32,
    /// [`StaticDynamicPair::dynamic_update_count`] at the last frame.
    updates_seen: u64,
}

impl RayTraffic {
    /// Takes this frame's counts: the rays counted through [`AccelTrees::count_rays`], and
    /// the movers from the pair's update count (0 for other backends).
    pub(crate) fn observe(&mut self, trees: &AccelTrees, stats: &AccelStats) {
        let updates = trees
            .index()
            .bvh_pair()
            .map_or(self.updates_seen, StaticDynamicPair::dynamic_update_count);
        let moved = updates.saturating_sub(self.updates_seen);
        self.updates_seen = updates;
        let spawned = stats.inserted > 0 || stats.removed > 0;
        self.stable_frames = if spawned {
            0
        } else {
            self.stable_frames.saturating_add(1)
        };
        self.still_frames = if spawned || moved > 0 {
            0
        } else {
            self.still_frames.saturating_add(1)
        };
        // An exponential average: one busy frame does not make the plugin build a snapshot,
        // one quiet frame does not make it drop one.
        const WEIGHT: f32 = 0.1;
        self.rays += WEIGHT * (trees.take_rays_cast() as f32 - self.rays);
        self.movers += WEIGHT * (moved as f32 - self.movers);
    }

    /// Whether the rays cast pay for refitting the snapshot after the motion (see
    /// [`BvhIndexSettings::ray_snapshot_rays_per_mover`]).
    fn rays_pay_for_refits(&self, settings: &BvhIndexSettings) -> bool {
        self.rays > 0.0 && self.rays >= settings.ray_snapshot_rays_per_mover * self.movers
    }
}

/// The BVH backend's frame: refits what moved, lets the optimiser spend its budget, rebuilds
/// when quality has decayed, then keeps the ray snapshot (see [`keep_ray_snapshot`]). Does no
/// tree work in a frame where no dynamic leaf moved and no rebuild landed, and takes `trees`
/// mutably only for work.
pub(crate) fn maintain_bvh(
    settings: &BvhIndexSettings,
    trees: &mut ResMut<AccelTrees>,
    stats: &mut AccelStats,
    traffic: &RayTraffic,
) {
    let Some(pair) = trees.index().bvh_pair() else {
        return;
    };
    let snapshot_moved = pair.dynamic_ray_snapshot_needs_refit();
    let tree_moved = pair.dynamic().needs_refit();
    // A rebuild started by an edit lands in a later frame, which may have no edit of its
    // own: a world that holds still after a large spawn would otherwise keep its tree of
    // insertions, and every view and query would walk it.
    let rebuild_landing = pair.dynamic().rebuild_finished();
    let worth_refitting = traffic.rays_pay_for_refits(settings);
    let spawned = stats.inserted > 0 || stats.removed > 0;
    let mut report = None;
    if snapshot_moved && !worth_refitting {
        with_pair(trees, StaticDynamicPair::drop_dynamic_ray_snapshot);
    }
    if tree_moved || spawned || rebuild_landing {
        report = with_pair(trees, StaticDynamicPair::maintain_dynamic);
    } else if snapshot_moved && worth_refitting {
        // Motion inside the fat boxes: nothing for the dynamic tree, but the snapshot's
        // boxes are tight.
        with_pair(trees, StaticDynamicPair::refit_dynamic_ray_snapshot);
    }
    keep_ray_snapshot(settings, trees, traffic);
    let pair = trees.index().bvh_pair();
    let bvh = stats.bvh.get_or_insert_default();
    if report.is_some() {
        bvh.last_maintain = report;
    }
    bvh.ray_snapshot = pair.is_some_and(StaticDynamicPair::has_dynamic_ray_snapshot);
    if let Some(r) = report {
        stats.last_upkeep = spatial_accel::query::UpkeepReport {
            refit_nodes: r.refit_nodes,
            improved: r.optimize.reinserted,
            rebuilt: r.rebuilt,
        };
    }
}

/// Runs `work` on the pair (a mutable access, so it marks `AccelTrees` changed).
fn with_pair<R>(
    trees: &mut ResMut<AccelTrees>,
    work: impl FnOnce(&mut StaticDynamicPair) -> R,
) -> Option<R> {
    trees.index_mut().bvh_pair_mut().map(work)
}

/// Installs, builds or rebuilds the dynamic tree's ray snapshot as the settings ask; touches
/// `trees` mutably only when it does one of those.
///
/// Built once no dynamic entity has entered or left for
/// [`BvhIndexSettings::ray_snapshot_after_stable_frames`] frames, and either none has moved
/// for as long or rays are many next to the movers
/// ([`BvhIndexSettings::ray_snapshot_rays_per_mover`]); refit in every frame with motion
/// while that holds; rebuilt after
/// [`BvhIndexSettings::ray_snapshot_rebuild_after_moving_frames`] refits. Above
/// [`BvhIndexSettings::ray_snapshot_in_frame_max_entities`] builds run on a background
/// thread, installed by a later frame.
fn keep_ray_snapshot(
    settings: &BvhIndexSettings,
    trees: &mut ResMut<AccelTrees>,
    traffic: &RayTraffic,
) {
    let Some(pair) = trees.index().bvh_pair() else {
        return;
    };
    if pair.dynamic_ray_snapshot_pending() {
        // Polled mutably only once the build is done: a mutable access marks `AccelTrees`
        // changed, and every frame of a background build (a second or so at a million
        // movers) would otherwise cost the culling its kept walks.
        if pair.dynamic_ray_snapshot_finished() {
            with_pair(trees, StaticDynamicPair::poll_dynamic_ray_snapshot);
        }
        return;
    }
    if pair.dynamic().is_empty() {
        return;
    }
    let due = match pair.dynamic_ray_snapshot_moving_refits() {
        None => settings
            .ray_snapshot_after_stable_frames
            .is_some_and(|after| {
                traffic.stable_frames >= after
                    && (traffic.still_frames >= after || traffic.rays_pay_for_refits(settings))
            }),
        Some(moving) => settings
            .ray_snapshot_rebuild_after_moving_frames
            .is_some_and(|after| moving >= after),
    };
    if due {
        let in_background = pair.dynamic().len() > settings.ray_snapshot_in_frame_max_entities;
        with_pair(trees, |pair| {
            pair.refresh_dynamic_ray_snapshot(
                &entity_tree_config(StaticTreeBuild::Ploc),
                in_background,
            )
        });
    }
}
