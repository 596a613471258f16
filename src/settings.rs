//! Runtime settings of the plugin.

use bevy::prelude::*;
use core::time::Duration;

/// What the trees keep and how hard they work to stay good. Change it at runtime as a
/// resource; the plugin reads it every frame.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default)]
pub struct AccelSettings {
    /// Master switch: when off, no system touches the trees (they keep their last state, and
    /// catch up when it is turned back on).
    pub enabled: bool,
    /// Track only entities with [`AccelTracked`](crate::AccelTracked) instead of every entity
    /// with an `Aabb` and a `GlobalTransform`.
    pub require_marker: bool,
    /// Watch [`AccelStatic`](crate::AccelStatic) entities for motion too, rebuilding the
    /// static tree when one moves. Off by default: the marker promises the entity does not
    /// move, and watching costs a change-detection scan over every static entity each frame
    /// (see docs/experiments.md, Plugin sync). A static entity that moves while this is off
    /// keeps its old box until the marker is removed or inserted again.
    pub watch_static_motion: bool,
    /// Absolute growth of each side of a dynamic leaf, in world units: motion within it costs
    /// nothing.
    pub fat_margin: f32,
    /// Growth of each side of a dynamic leaf as a fraction of its size.
    pub relative_fat_margin: f32,
    /// When a moving entity outgrows its leaf, the new leaf also reaches this many times its
    /// last step ahead along its motion, so an entity moving steadily costs tree work every
    /// few frames instead of every frame. 0 turns it off.
    pub motion_prediction: f32,
    /// Time the dynamic tree's optimiser may spend per frame, in microseconds.
    pub optimize_budget_micros: u32,
    /// Rebuild the dynamic tree when its SAH cost passes this multiple of a fresh build's.
    pub rebuild_threshold: f32,
    /// Run those rebuilds on a background thread and swap the result in when done.
    pub background_rebuild: bool,
    /// After this many frames in a row in which no dynamic entity entered or left the trees,
    /// build a 16-wide tree over the dynamic entities, as the static tree is built, that rays
    /// (picking) walk instead of the binary dynamic tree: a binary tree is deep, and on the
    /// picking bench rays through the snapshot visit as few nodes as through the static tree
    /// (13.4 per ray at 100,000 entities, against 18.1 through a copy of the dynamic tree's
    /// shape and far more through the binary tree itself). Motion keeps it: each frame it is
    /// refit along the paths of the entities that moved. An entity entering or leaving drops
    /// it. `None` never builds one.
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
    /// in larger worlds (measured on the picking bench: docs/experiments.md, Picking). A
    /// game that casts one picking ray per frame over a moving crowd gains nothing from it;
    /// a ray-traced preview or many line-of-sight casts gain a lot.
    pub ray_snapshot_rays_per_mover: f32,
    /// Up to this many dynamic entities the ray snapshot is built in the frame that ends the
    /// wait (a build's cost grows with the entities: docs/experiments.md, Picking); above, on
    /// a background thread, where the frame pays only for collecting the leaves' boxes, and
    /// rays use the snapshot from the frame after it is done (if no dynamic entity entered or
    /// left meanwhile; motion meanwhile is refit when it is installed).
    pub ray_snapshot_in_frame_max_entities: usize,
}

impl Default for AccelSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            require_marker: false,
            watch_static_motion: false,
            fat_margin: 0.1,
            relative_fat_margin: 0.05,
            motion_prediction: 2.0,
            optimize_budget_micros: 500,
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

impl AccelSettings {
    /// The optimiser's per-frame budget as a duration.
    pub fn optimize_budget(&self) -> Duration {
        Duration::from_micros(self.optimize_budget_micros as u64)
    }
}
