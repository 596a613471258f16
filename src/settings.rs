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
    /// (about 3 ns each: 0.3 ms at 100k). A static entity that moves while this is off keeps
    /// its old box until the marker is removed or inserted again.
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
    /// After this many frames in a row in which no tracked entity moved, entered or left,
    /// build an 8-wide tree over the dynamic entities, as the static tree is built, that rays
    /// (picking) walk until the dynamic tree next changes: a binary tree is deep, and on the
    /// picking bench rays through the snapshot visit as few nodes as through the static tree
    /// (13.4 per ray at 100,000 entities, against 18.1 through a copy of the dynamic tree's
    /// shape and far more through the binary tree itself). It is built once per still
    /// period. `None` never builds one.
    pub ray_snapshot_after_still_frames: Option<u32>,
    /// Up to this many dynamic entities the ray snapshot is built in the frame that ends the
    /// wait (0.96 ms at 5,000 in a release build of `accel`; the picking bench measured
    /// 2.8-3.2 ms at 10,000 in the dev profile); above, on a background thread, where the
    /// frame pays only for collecting the leaves' boxes (about 1 ms at 100,000), and rays use
    /// the snapshot from the first still frame after it is done (if nothing changed
    /// meanwhile).
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
            // Half a second at 60 fps: an entity that moves now and then should not make the
            // plugin copy the tree between its moves.
            ray_snapshot_after_still_frames: Some(30),
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
