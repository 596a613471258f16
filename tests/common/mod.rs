//! What the plugin's tests and benches share. Each uses part of it.
#![allow(dead_code)]

use bevy::camera::visibility::VisibilityPlugin;
#[cfg(feature = "light_culling")]
use bevy::camera::visibility::{VisibilitySystems, VisibleEntities};
#[cfg(feature = "light_culling")]
use bevy::light::cluster::ClusterVisibilityClass;
#[cfg(feature = "light_culling")]
use bevy::light::{LightPlugin, SimulationLightSystems};
use bevy::prelude::*;
use bevy_accel::prelude::*;
#[cfg(feature = "light_culling")]
use std::any::TypeId;

/// A headless app with the trees and what Bevy's visibility needs: no window, no renderer.
/// Bevy's visibility systems read mesh assets (to compute bounds), so the asset plugin is in
/// even where a scene sets its `Aabb`s by hand. Not finished: add the plugins under test,
/// then call `App::finish`.
pub fn headless_app() -> App {
    let mut app = plain_bevy_app();
    app.add_plugins(AccelPlugin::default());
    app
}

/// The same app without bevy_accel: the plain Bevy side of a comparison.
pub fn plain_bevy_app() -> App {
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
#[cfg(feature = "light_culling")]
type ClusteredLight = Or<(With<PointLight>, With<SpotLight>)>;

/// Stands in for light clustering (which needs the renderer's settings): every point and spot
/// light is listed in every camera's view, as a light near the cameras would be.
#[cfg(feature = "light_culling")]
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

/// Adds bevy_light's `LightPlugin` to a [`headless_app`], with what it needs there: image
/// assets (atmosphere textures) and gizmos (light gizmos), which the default plugins would
/// bring, and a stand-in for light clustering.
#[cfg(feature = "light_culling")]
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

/// [`headless_app`] with the picking backend, finished.
#[cfg(feature = "picking")]
pub fn app() -> App {
    let mut app = headless_app();
    app.add_plugins(AccelPickingPlugin);
    app.finish();
    app
}
