//! What the plugin's tests share. Each uses part of it. The plain headless Bevy app, the grid
//! and bevy_light's plugin in the app come from `accel_testkit::bevy_apps` (which the bench
//! tool uses too); what needs the plugin is here.
#![allow(dead_code, unused_imports)]

#[cfg(feature = "light_culling")]
pub use accel_testkit::bevy_apps::add_lights;
pub use accel_testkit::bevy_apps::{grid_point, plain_bevy_app};
use bevy::prelude::*;
use bevy_accel::prelude::*;

/// A headless app with the trees and what Bevy's visibility needs: no window, no renderer
/// ([`plain_bevy_app`] with `AccelPlugin`). Not finished: add the plugins under test, then
/// call `App::finish`.
pub fn headless_app() -> App {
    let mut app = plain_bevy_app();
    app.add_plugins(AccelPlugin::default());
    app
}

/// [`headless_app`] with the picking backend, finished.
#[cfg(feature = "picking")]
pub fn app() -> App {
    let mut app = headless_app();
    app.add_plugins(AccelPickingPlugin);
    app.finish();
    app
}

/// The tracked entities whose exact world box passes `keep`, sorted: the brute force that
/// every overlap query is compared with.
pub fn entities_whose_box(
    trees: &AccelTrees,
    keep: impl Fn(&bevy_accel::spatial_accel::Aabb) -> bool,
) -> Vec<Entity> {
    let mut found: Vec<Entity> = trees
        .iter()
        .filter(|&(_, slot)| keep(&trees.world_bounds(slot)))
        .map(|(entity, _)| entity)
        .collect();
    found.sort_unstable();
    found
}
