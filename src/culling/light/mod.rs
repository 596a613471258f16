//! Shadow views of lights (point, spot, directional), culled on the trees in place of
//! bevy_light's caster tests (cargo feature `light_culling`).
//!
//! - `views`: the two systems, per light and view: walk, then decide.
//! - `walks`: the tree walks of light views and the candidates they find.
//! - `verdicts`: the trees' word on each caster test, so that only the undecided are tested.

mod verdicts;
mod views;
mod walks;

use crate::AccelSystems;
use bevy::camera::visibility::VisibilitySystems;
use bevy::ecs::schedule::{ScheduleCleanupPolicy, ScheduleConfigs};
use bevy::ecs::system::ScheduleSystem;
use bevy::prelude::*;

/// Swaps bevy_light's shadow-caster culling for the trees', if bevy_light's `LightPlugin`
/// added it (without it there are no light views to cull).
pub(super) fn replace_light_culling(app: &mut App) {
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
    // visibility), before entities no view saw are marked hidden; and after the plugin's
    // sets, whose first decides whether the trees stand aside this frame.
    let in_light_order = |systems: ScheduleConfigs<ScheduleSystem>| {
        systems
            .in_set(SimulationLightSystems::CheckLightVisibility)
            .after(VisibilitySystems::CalculateBounds)
            .after(TransformSystems::Propagate)
            .after(SimulationLightSystems::UpdateLightFrusta)
            .after(VisibilitySystems::CheckVisibility)
            .after(AccelSystems::Stats)
            .before(VisibilitySystems::MarkNewlyHiddenEntitiesInvisible)
    };
    app.add_systems(
        PostUpdate,
        in_light_order(
            (
                views::cull_directional_lights,
                views::cull_point_and_spot_lights,
            )
                .chain(),
        )
        .in_set(super::AccelCullingSystems)
        .run_if(crate::systems::trees_awake),
    );
    // bevy_light's own, for the frames in which the trees stand aside
    // (`AccelTrees::stepped_aside`), and, timed, before the trees' in the frames that time
    // both (the trees' then overwrite the same verdicts).
    let directional = super::bevy_stand_in::timed_stand_in(app, check_dir_light_mesh_visibility);
    let point = super::bevy_stand_in::timed_stand_in(app, check_point_light_mesh_visibility);
    app.add_systems(
        PostUpdate,
        in_light_order((directional, point).into_configs())
            .before(views::cull_directional_lights)
            .before(views::cull_point_and_spot_lights)
            .run_if(crate::systems::step_aside::bevy_passes_run),
    );
}
