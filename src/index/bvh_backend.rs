//! The BVH backend's own settings, stats and upkeep: fat leaves, the optimiser's rebuilds,
//! and the policy that keeps a 16-wide snapshot of the dynamic tree for rays.

use crate::settings::AccelSettings;
use bevy::prelude::*;
use spatial_accel::dynamic::{DynamicBvhConfig, MaintainReport};

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
    /// in larger worlds (BENCHMARKS.md, Picking). A game that casts one picking ray
    /// per frame over a moving crowd gains nothing from it; a ray-traced preview or many
    /// line-of-sight casts gain a lot.
    pub ray_snapshot_rays_per_mover: f32,
    /// Up to this many dynamic entities the ray snapshot is built in the frame that ends the
    /// wait (a build's cost grows with the entities); above, on
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
/// ([`AccelStats::dynamic_index`](crate::AccelStats::dynamic_index)).
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
