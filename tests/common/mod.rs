//! What the plugin's tests and benches share. Each uses part of it.
#![allow(dead_code)]

use bevy::camera::visibility::VisibilityPlugin;
use bevy::prelude::*;
use bevy_accel::prelude::*;

/// A headless app with the trees and what Bevy's visibility needs: no window, no renderer.
/// Bevy's visibility systems read mesh assets (to compute bounds), so the asset plugin is in
/// even where a scene sets its `Aabb`s by hand. Not finished: add the plugins under test,
/// then call `App::finish`.
pub fn headless_app() -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin::default(),
        TransformPlugin,
        VisibilityPlugin,
        AccelPlugin::default(),
    ))
    .init_asset::<Mesh>()
    .init_asset::<bevy::mesh::skinning::SkinnedMeshInverseBindposes>();
    app
}

/// [`headless_app`] with the picking backend, finished.
pub fn app() -> App {
    let mut app = headless_app();
    app.add_plugins(AccelPickingPlugin);
    app.finish();
    app
}
