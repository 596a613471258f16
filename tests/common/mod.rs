//! What the plugin's test files share.

use bevy::camera::visibility::VisibilityPlugin;
use bevy::prelude::*;
use bevy_accel::prelude::*;

/// A headless app with the trees and the picking backend: no window, no renderer.
pub fn app() -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin::default(),
        TransformPlugin,
        VisibilityPlugin,
        AccelPlugin::default(),
        AccelPickingPlugin,
    ))
    .init_asset::<Mesh>()
    .init_asset::<bevy::mesh::skinning::SkinnedMeshInverseBindposes>();
    app.finish();
    app
}
