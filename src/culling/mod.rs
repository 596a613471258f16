//! Frustum culling on the trees, feeding Bevy's visibility.
//!
//! Bevy's `check_visibility_cpu_culling` tests every entity against every view each frame, so
//! its cost follows the size of the world (bevy issue 17133). [`AccelCullingPlugin`] replaces
//! it: per view it walks the trees, skips every subtree outside the frustum, accepts every
//! subtree fully inside without testing its entities, and runs Bevy's own per-entity tests only
//! on entities whose leaf straddles a plane, so its results are Bevy's. A view that sees most
//! of the world goes through every entity in table order instead, as Bevy's loop does (a
//! lookup per tree hit would cost more there), still taking the trees' word wherever a leaf is
//! wholly in or out of view. Both spread their per-entity work over Bevy's compute task pool
//! when it is large (the flat pass always, the tree path from 8,192 entities found), as
//! Bevy's own loop does. The tree path reads the components it decides by straight from
//! Bevy's table columns, at the row each entity was last seen in (checked against the
//! table's entity column), instead of looking each entity up.

mod bevy_rounding;
mod class_lists;
mod flat_pass;
mod found_pass;
#[cfg(feature = "light_culling")]
mod light_verdicts;
#[cfg(feature = "light_culling")]
mod light_views;
#[cfg(feature = "light_culling")]
mod light_walks;
mod slot_order;
mod system;
mod table_rows;
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
/// would; `NoCpuCulling` entities and cameras keep Bevy's behaviour. With the cargo feature
/// `light_culling` (on by default) and bevy_light's `LightPlugin` in the app, the shadow views
/// of point, spot and directional lights are culled on the trees too.
///
/// ```
/// use bevy::camera::primitives::{Aabb, Frustum};
/// use bevy::camera::visibility::VisibilityPlugin;
/// use bevy::math::primitives::ViewFrustum;
/// use bevy::prelude::*;
/// use bevy_accel::AccelCullingPlugin;
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
        CullingStats::register(app);
        // In `Last`: after the camera and light passes of `PostUpdate`, whichever ran.
        app.add_systems(Last, system::publish_culling_stats);
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
        #[cfg(feature = "light_culling")]
        replace_light_culling(app);
    }
}

/// Swaps bevy_light's shadow-caster culling for the trees', if bevy_light's `LightPlugin`
/// added it (without it there are no light views to cull).
#[cfg(feature = "light_culling")]
fn replace_light_culling(app: &mut App) {
    use bevy::light::{
        SimulationLightSystems, check_dir_light_mesh_visibility, check_point_light_mesh_visibility,
    };
    let mut removed = 0;
    for result in [
        app.remove_systems_in_set(
            PostUpdate,
            check_dir_light_mesh_visibility,
            ScheduleCleanupPolicy::RemoveSystemsOnly,
        ),
        app.remove_systems_in_set(
            PostUpdate,
            check_point_light_mesh_visibility,
            ScheduleCleanupPolicy::RemoveSystemsOnly,
        ),
    ] {
        removed += result.unwrap_or(0);
    }
    if removed == 0 {
        return;
    }
    // Bevy's ordering for these systems: after the camera views (lights may only add
    // visibility), before entities no view saw are marked hidden.
    app.add_systems(
        PostUpdate,
        (
            light_views::cull_directional_lights,
            light_views::cull_point_and_spot_lights,
        )
            .chain()
            .in_set(SimulationLightSystems::CheckLightVisibility)
            .after(VisibilitySystems::CalculateBounds)
            .after(TransformSystems::Propagate)
            .after(SimulationLightSystems::UpdateLightFrusta)
            .after(VisibilitySystems::CheckVisibility)
            .after(AccelSystems::Stats)
            .before(VisibilitySystems::MarkNewlyHiddenEntitiesInvisible),
    );
}
