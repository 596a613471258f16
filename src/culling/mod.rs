//! Frustum culling on the trees, feeding Bevy's visibility.
//!
//! Bevy's `check_visibility_cpu_culling` tests every entity against every view each frame, so
//! its cost follows the size of the world (bevy issue 17133). [`AccelCullingPlugin`] replaces
//! it: per view it walks the trees, skips every subtree outside the frustum, accepts every
//! subtree fully inside without testing its entities, and runs Bevy's own per-entity tests only
//! on entities whose leaf straddles a plane, so its results are Bevy's.

mod class_lists;
mod slot_order;
mod system;
mod tree_pass;
mod untracked;
mod view_walk;

use crate::AccelSystems;
use bevy::camera::visibility::{
    VisibilitySystems, check_visibility_cpu_culling, check_visibility_ranges,
};
use bevy::ecs::schedule::ScheduleCleanupPolicy;
use bevy::prelude::*;

pub use system::CullingStats;

/// Replaces Bevy's CPU frustum culling with a traversal of the [`AccelTrees`](crate::AccelTrees).
///
/// Requires [`AccelPlugin`](crate::AccelPlugin). Add it after `DefaultPlugins`, or anywhere: the
/// built-in system is removed in [`Plugin::finish`]. Entities the trees do not hold (no `Aabb`,
/// [`AccelIgnore`](crate::AccelIgnore), a rejected transform) are tested one by one, as Bevy
/// would; `NoCpuCulling` entities and cameras keep Bevy's behaviour.
#[derive(Default)]
pub struct AccelCullingPlugin;

impl Plugin for AccelCullingPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<CullingStats>().add_systems(
            PostUpdate,
            system::cull_views_with_trees
                .in_set(VisibilitySystems::CheckVisibility)
                .after(AccelSystems::Stats)
                .after(check_visibility_ranges),
        );
    }

    fn finish(&self, app: &mut App) {
        app.remove_systems_in_set(
            PostUpdate,
            check_visibility_cpu_culling,
            ScheduleCleanupPolicy::RemoveSystemsOnly,
        )
        .ok();
    }
}
