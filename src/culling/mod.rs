//! Frustum culling on the trees, feeding Bevy's visibility.
//!
//! Bevy's `check_visibility_cpu_culling` tests every entity against every view each frame, so
//! its cost follows the size of the world (bevy issue 17133). [`AccelCullingPlugin`] replaces
//! it: per view it walks the trees, skips every subtree outside the frustum, accepts every
//! subtree fully inside without testing its entities, and runs Bevy's own per-entity tests only
//! on entities whose leaf straddles a plane, so its results are Bevy's. A view that sees most
//! of the world goes through every entity in table order instead, as Bevy's loop does (a
//! lookup per tree hit would cost more there), still taking the trees' word wherever a leaf is
//! wholly in or out of view. Both spread their per-entity work over Bevy's compute task pool,
//! as Bevy's own loop does: the flat pass always; the tree path's decisions from 2,048
//! entities found when the pool has several threads (8,192 on one), and its test of the
//! busy movers, from 4,096 of them, on the pool's other threads while it walks the trees.
//! The tree path reads the components it decides by straight from
//! Bevy's table columns, at the row each entity was last seen in (checked against the
//! table's entity column), instead of looking each entity up.
//!
//! - `camera/`: the camera views' system and its passes.
//! - `light/`: the shadow views of lights (cargo feature `light_culling`).
//! - Shared by both: `bevy_rules` (Bevy's own per-entity rules), `bevy_rounding` (tree
//!   verdicts Bevy's tests cannot contradict), `class_lists` (visible entities per class),
//!   `slot_order` (found slots in slot order), `untracked` (entities no walk finds) and
//!   `stats` ([`CullingStats`]).

mod bevy_rounding;
mod bevy_rules;
mod bevy_stand_in;
mod camera;
mod class_lists;
#[cfg(feature = "light_culling")]
mod light;
mod slot_order;
mod stats;
mod untracked;

use crate::AccelSystems;
use bevy::camera::visibility::{
    VisibilitySystems, check_visibility_cpu_culling, check_visibility_ranges,
};
use bevy::ecs::schedule::ScheduleCleanupPolicy;
use bevy::prelude::*;

pub use stats::CullingStats;
pub(crate) use stats::add_culling_measurements;

/// Runtime settings of [`AccelCullingPlugin`].
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default)]
pub struct AccelCullingSettings {
    /// Cull on the trees. Off, every view (camera and shadow) is decided by Bevy's own
    /// per-entity loop, as if the plugin were absent: to compare the two at run time.
    pub use_trees: bool,
}

impl Default for AccelCullingSettings {
    fn default() -> Self {
        Self { use_trees: true }
    }
}

/// The culling systems: the camera views' in Bevy's `VisibilitySystems::CheckVisibility`, the
/// light views' in bevy_light's `SimulationLightSystems::CheckLightVisibility`, all in
/// `PostUpdate` after [`AccelSystems::Stats`].
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AccelCullingSystems;

/// Replaces Bevy's CPU frustum culling with a traversal of the [`AccelTrees`](crate::AccelTrees).
///
/// Requires [`AccelPlugin`](crate::AccelPlugin). Add it after `DefaultPlugins`, or anywhere: the
/// built-in system is removed in [`Plugin::finish`]. Entities the trees do not hold (no `Aabb`,
/// [`AccelIgnore`](crate::AccelIgnore), a rejected transform) are tested one by one, as Bevy
/// would; `NoCpuCulling` entities and cameras keep Bevy's behaviour. With the cargo feature
/// `light_culling` (on by default) and bevy_light's `LightPlugin` in the app, the shadow views
/// of point, spot and directional lights are culled on the trees too.
///
/// ```
/// use bevy::camera::primitives::{Aabb, Frustum};
/// use bevy::camera::visibility::VisibilityPlugin;
/// use bevy::math::primitives::ViewFrustum;
/// use bevy::prelude::*;
/// use bevy_accel::prelude::*;
///
/// let mut app = App::new();
/// app.add_plugins((MinimalPlugins, AssetPlugin::default(), TransformPlugin, VisibilityPlugin))
///     .init_asset::<Mesh>()
///     .init_asset::<bevy::mesh::skinning::SkinnedMeshInverseBindposes>()
///     .add_plugins((AccelPlugin::default(), AccelCullingPlugin));
/// app.finish();
/// // A camera at the origin looking down -z (a hand-made frustum: no renderer here).
/// let view = Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
/// let projection = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1);
/// let frustum = Frustum(ViewFrustum::from_clip_from_world(&(projection * view)));
/// app.world_mut().spawn((Camera::default(), frustum));
/// let cube = Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5));
/// let ahead = app.world_mut().spawn((Transform::from_xyz(0.0, 0.0, -10.0), Visibility::Visible, cube)).id();
/// let behind = app.world_mut().spawn((Transform::from_xyz(0.0, 0.0, 10.0), Visibility::Visible, cube)).id();
/// app.update();
/// assert!(app.world().get::<ViewVisibility>(ahead).unwrap().get());
/// assert!(!app.world().get::<ViewVisibility>(behind).unwrap().get());
/// ```
#[derive(Default)]
pub struct AccelCullingPlugin;

impl Plugin for AccelCullingPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<AccelCullingSettings>()
            .register_type::<AccelCullingSettings>();
        app.init_resource::<CullingStats>().add_systems(
            PostUpdate,
            camera::cull_views_with_trees
                .in_set(VisibilitySystems::CheckVisibility)
                .in_set(AccelCullingSystems)
                .after(AccelSystems::Stats)
                .after(check_visibility_ranges)
                .run_if(crate::systems::trees_awake),
        );
    }

    fn finish(&self, app: &mut App) {
        let removed = app
            .remove_systems_in_set(
                PostUpdate,
                check_visibility_cpu_culling,
                ScheduleCleanupPolicy::RemoveSystemsOnly,
            )
            .unwrap_or(0);
        // Bevy's pass stays, for the frames in which the trees stand aside
        // (`AccelTrees::stepped_aside`), where it costs less than the trees', and for the
        // frames that time it before the trees' pass (which then overwrites the same verdicts).
        // Added back as Bevy adds it; its ordering with the range checks holds through its
        // type, which the timer keeps.
        if removed > 0 {
            let bevy_pass = bevy_stand_in::timed_stand_in(app, check_visibility_cpu_culling);
            app.add_systems(
                PostUpdate,
                bevy_pass
                    .in_set(VisibilitySystems::CheckVisibility)
                    .after(AccelSystems::Stats)
                    .before(camera::cull_views_with_trees)
                    .run_if(crate::systems::step_aside::bevy_passes_run),
            );
            if let Some(trees) = app.world().get_resource::<crate::AccelTrees>() {
                trees.step_aside.set_stand_in();
            }
        }
        #[cfg(feature = "light_culling")]
        light::replace_light_culling(app);
    }
}
