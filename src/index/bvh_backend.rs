//! The BVH backend's own settings, stats and upkeep: fat leaves, the optimiser's rebuilds,
//! and the policy that keeps a 16-wide snapshot of the dynamic tree for rays.

use crate::settings::AccelSettings;
use crate::stats::AccelStats;
use crate::trees::AccelTrees;
use bevy::prelude::*;
use spatial_accel::dynamic::{DynamicBvhConfig, MaintainReport, StaticDynamicPair};

/// Settings of the BVH backend ([`IndexChoice::Bvh`](super::IndexChoice::Bvh)); the other
/// backends ignore them.
#[derive(Reflect, Clone, Debug, PartialEq)]
#[reflect(Default)]
pub struct BvhIndexSettings {
    /// Absolute growth of each side of a dynamic leaf, in world units: motion within it costs
    /// nothing.
    pub fat_margin: f32,
    /// Growth of each side of a dynamic leaf as a fraction of its size.
    pub relative_fat_margin: f32,
    /// When a moving entity outgrows its leaf, the new leaf also reaches this many times its
    /// last step ahead along its motion, so an entity moving steadily costs tree work every
    /// few frames instead of every frame. 0 turns it off.
    pub motion_prediction: f32,
    /// Rebuild the dynamic tree when its SAH cost passes this multiple of a fresh build's.
    pub rebuild_threshold: f32,
    /// Run those rebuilds on a background thread and swap the result in when done.
    pub background_rebuild: bool,
    /// After this many frames in a row in which no dynamic entity entered or left the trees,
    /// build a 16-wide tree over the dynamic entities, as the static tree is built, that rays
    /// (picking) walk instead of the binary dynamic tree: a binary tree is deep, and rays
    /// through the snapshot visit about as few nodes as through the static tree
    /// (BENCHMARKS.md, Picking). Motion keeps it: each frame it is refit along the paths of
    /// the entities that moved. An entity entering or leaving drops it. `None` never builds
    /// one.
    pub ray_snapshot_after_stable_frames: Option<u32>,
    /// Rebuild the ray snapshot after it has been refit for motion in this many frames: a
    /// refit keeps the tree's shape, which fits the positions it was built for less and less
    /// as entities wander. The rebuild runs as the first build does (see
    /// [`ray_snapshot_in_frame_max_entities`](Self::ray_snapshot_in_frame_max_entities)), the
    /// old snapshot serving rays until the new one is in. `None` never rebuilds it.
    pub ray_snapshot_rebuild_after_moving_frames: Option<u32>,
    /// Keep the ray snapshot through motion only while the rays cast per frame are at least
    /// this many times the dynamic entities that move per frame (both averaged over about ten
    /// frames); otherwise it is dropped at the first motion, and rebuilt once the world has
    /// held still for [`ray_snapshot_after_stable_frames`](Self::ray_snapshot_after_stable_frames).
    ///
    /// Why: refitting it costs each moving entity its path in the snapshot, while each ray
    /// walking it instead of the binary tree saves more than a mover's refit costs, and more
    /// in larger worlds (docs/experiments.md, Picking). A game that casts one picking ray
    /// per frame over a moving crowd gains nothing from it; a ray-traced preview or many
    /// line-of-sight casts gain a lot.
    pub ray_snapshot_rays_per_mover: f32,
    /// Up to this many dynamic entities the ray snapshot is built in the frame that ends the
    /// wait (a build's cost grows with the entities: docs/experiments.md, Picking); above, on
    /// a background thread, where the frame pays only for collecting the leaves' boxes, and
    /// rays use the snapshot from the frame after it is done (if no dynamic entity entered or
    /// left meanwhile; motion meanwhile is refit when it is installed).
    pub ray_snapshot_in_frame_max_entities: usize,
}

impl Default for BvhIndexSettings {
    fn default() -> Self {
        Self {
            fat_margin: 0.1,
            relative_fat_margin: 0.05,
            motion_prediction: 2.0,
            rebuild_threshold: 1.3,
            background_rebuild: true,
            // Half a second at 60 fps: a scene that spawns now and then should not make the
            // plugin build the snapshot between its spawns.
            ray_snapshot_after_stable_frames: Some(30),
            // Two seconds at 60 fps; a rebuild costs the frame only the collection of the
            // boxes for the background thread.
            ray_snapshot_rebuild_after_moving_frames: Some(120),
            // Break-even, from the costs above, is about 0.25-0.75 rays per mover: 1 leaves a
            // margin.
            ray_snapshot_rays_per_mover: 1.0,
            ray_snapshot_in_frame_max_entities: 5_000,
        }
    }
}

/// What the BVH backend did in the last frame, beside the figures every index reports
/// ([`AccelStats::dynamic_index`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct BvhIndexStats {
    /// The dynamic tree's last maintenance report (refit size, optimiser work, quality,
    /// rebuilds). Kept as the report itself, not text: formatting it every frame would put
    /// an allocation in the sync path.
    pub last_maintain: Option<MaintainReport>,
    /// Whether rays walk a 16-wide snapshot of the dynamic tree (see
    /// [`BvhIndexSettings::ray_snapshot_after_stable_frames`]).
    pub ray_snapshot: bool,
}

/// The dynamic tree's configuration the settings ask for, over what it has.
pub(crate) fn dynamic_config(
    settings: &AccelSettings,
    current: &DynamicBvhConfig,
) -> DynamicBvhConfig {
    let bvh = &settings.bvh;
    DynamicBvhConfig {
        margin: bvh.fat_margin,
        relative_margin: bvh.relative_fat_margin,
        motion_prediction: bvh.motion_prediction,
        optimize_budget: settings.upkeep_budget(),
        rebuild_threshold: bvh.rebuild_threshold,
        background_rebuild: bvh.background_rebuild,
        ..*current
    }
}

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
            .query()
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
/// tree work in a frame where no dynamic leaf moved, and takes `trees` mutably only for work.
pub(crate) fn maintain_bvh(
    settings: &BvhIndexSettings,
    trees: &mut ResMut<AccelTrees>,
    stats: &mut AccelStats,
    traffic: &RayTraffic,
) {
    let Some(pair) = trees.query().bvh_pair() else {
        return;
    };
    let snapshot_moved = pair.dynamic_ray_snapshot_needs_refit();
    let tree_moved = pair.dynamic().needs_refit();
    let worth_refitting = traffic.rays_pay_for_refits(settings);
    let spawned = stats.inserted > 0 || stats.removed > 0;
    let mut report = None;
    if snapshot_moved && !worth_refitting {
        with_pair(trees, StaticDynamicPair::drop_dynamic_ray_snapshot);
    }
    if tree_moved || spawned {
        report = with_pair(trees, StaticDynamicPair::maintain_dynamic);
    } else if snapshot_moved && worth_refitting {
        // Motion inside the fat boxes: nothing for the dynamic tree, but the snapshot's
        // boxes are tight.
        with_pair(trees, StaticDynamicPair::refit_dynamic_ray_snapshot);
    }
    keep_ray_snapshot(settings, trees, traffic);
    let pair = trees.query().bvh_pair();
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
    let Some(pair) = trees.query().bvh_pair() else {
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
                &crate::scenery::entity_tree_config(crate::StaticTreeBuild::Ploc),
                in_background,
            )
        });
    }
}
