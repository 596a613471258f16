//! Plain headless Bevy apps for the plugin's tests and benches (feature `bevy`), and bevy_light
//! in them (feature `lights`).
//!
//! This crate does not depend on `bevy_accel` (the plugin's dev-dependency on it would make a
//! cycle): the apps here are plain Bevy, and the callers add `AccelPlugin` and the plugins
//! under test themselves.

use bevy::camera::visibility::VisibilityPlugin;
#[cfg(feature = "lights")]
use bevy::camera::visibility::{VisibilitySystems, VisibleEntities};
#[cfg(feature = "lights")]
use bevy::light::cluster::ClusterVisibilityClass;
#[cfg(feature = "lights")]
use bevy::light::{LightPlugin, SimulationLightSystems};
use bevy::prelude::*;
#[cfg(feature = "lights")]
use std::any::TypeId;

/// The variable that sets the compute pool of every [`plain_bevy_app`] of a process: the
/// plugin's equivalence tests run at 1, 2 and 4 compute threads in CI (`.ci/run`), so that
/// the parts split across the pool are held to Bevy's results as much as the serial ones.
pub const COMPUTE_THREADS_VAR: &str = "ACCEL_TEST_COMPUTE_THREADS";

/// Makes Bevy's task pools with the compute pool [`COMPUTE_THREADS_VAR`] asks for, if it is
/// set and the pools are not made yet (they are made once per process, by the first app).
/// A value that is not a positive number is refused loudly: a test run meant for 4 threads
/// must not pass quietly on the default.
fn make_pools_from_env() {
    let Ok(text) = std::env::var(COMPUTE_THREADS_VAR) else {
        return;
    };
    let threads: usize = match text.trim().parse() {
        Ok(n) if n > 0 => n,
        _ => panic!("{COMPUTE_THREADS_VAR}={text:?}: want a positive number of threads"),
    };
    let mut pools = bevy::app::TaskPoolOptions::default();
    pools.compute.min_threads = threads;
    pools.compute.max_threads = threads;
    pools.create_default_pools();
}

/// A headless app with what Bevy's visibility needs: no window, no renderer. Bevy's visibility
/// systems read mesh assets (to compute bounds), so the asset plugin is in even where a scene
/// sets its `Aabb`s by hand. Its compute pool has the size [`COMPUTE_THREADS_VAR`] gives, or
/// Bevy's default. Not finished: add the plugins under test, then call `App::finish`.
pub fn plain_bevy_app() -> App {
    make_pools_from_env();
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin::default(),
        TransformPlugin,
        VisibilityPlugin,
    ))
    .init_asset::<Mesh>()
    .init_asset::<bevy::mesh::skinning::SkinnedMeshInverseBindposes>();
    app
}

/// The lights clustering assigns to views.
#[cfg(feature = "lights")]
type ClusteredLight = Or<(With<PointLight>, With<SpotLight>)>;

/// Stands in for light clustering (which needs the renderer's settings): every point and spot
/// light is listed in every camera's view, as a light near the cameras would be.
#[cfg(feature = "lights")]
fn list_lights_in_views(
    mut views: Query<&mut VisibleEntities, With<Camera>>,
    lights: Query<Entity, ClusteredLight>,
) {
    for mut visible in &mut views {
        let list = visible.get_mut(TypeId::of::<ClusterVisibilityClass>());
        list.clear();
        list.extend(lights.iter());
        list.sort_unstable();
    }
}

/// Adds bevy_light's `LightPlugin` to a [`plain_bevy_app`] (with or without the plugin), with
/// what it needs there: image assets (atmosphere textures) and gizmos (light gizmos), which
/// the default plugins would bring, and a stand-in for light clustering.
#[cfg(feature = "lights")]
pub fn add_lights(app: &mut App) {
    app.init_asset::<Image>()
        .add_plugins((bevy::gizmos::GizmoPlugin, LightPlugin))
        .add_systems(
            PostUpdate,
            list_lights_in_views
                .after(VisibilitySystems::CheckVisibility)
                .before(SimulationLightSystems::UpdateLightFrusta)
                .before(SimulationLightSystems::CheckLightVisibility),
        );
}

/// The `i`th point of a cube grid `side` points wide, 4 units apart (the culling benches'
/// scenes: unit boxes with gaps between them).
pub fn grid_point(i: usize, side: usize) -> Vec3 {
    Vec3::new(
        (i % side) as f32,
        (i / side % side) as f32,
        (i / side / side) as f32,
    ) * 4.0
}
