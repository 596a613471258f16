//! `AccelDiagnosticsPlugin`: the trees' and the culling's figures reach Bevy's diagnostics
//! with it, and nothing is measured without it (its system is what a frame would pay).

use bevy::diagnostic::DiagnosticsStore;
use bevy::prelude::*;
use bevy_accel::prelude::*;

mod common;
mod culling_scene;
use culling_scene::*;

fn measured(app: &App, path: &bevy::diagnostic::DiagnosticPath) -> bool {
    app.world()
        .get_resource::<DiagnosticsStore>()
        .and_then(|store| store.get_measurement(path))
        .is_some()
}

/// A culled grid with `diagnostics` copies of the plugin, after 3 frames.
fn culled_grid(diagnostics: usize) -> App {
    let mut app = common::headless_app();
    app.add_plugins(AccelCullingPlugin);
    for _ in 0..diagnostics {
        app.add_plugins(AccelDiagnosticsPlugin);
    }
    app.finish();
    spawn_grid(app.world_mut(), 4, 0.5, |_, _| {});
    app.world_mut().spawn((
        Camera::default(),
        Transform::default(),
        frustum(Vec3::new(-30.0, 10.0, -30.0), Vec3::ZERO, 0.9),
    ));
    for _ in 0..3 {
        app.update();
    }
    app
}

#[test]
fn the_plugin_publishes_the_trees_and_the_culling() {
    let app = culled_grid(1);
    for path in [
        AccelStats::SYNC_TIME,
        AccelStats::MAINTAIN_TIME,
        AccelStats::ENTITIES,
        CullingStats::TIME,
        CullingStats::VISIBLE,
    ] {
        assert!(measured(&app, &path), "{path} not measured");
    }
    let store = app.world().resource::<DiagnosticsStore>();
    let entities = store.get_measurement(&AccelStats::ENTITIES).unwrap().value;
    assert_eq!(entities, 64.0);
    let visible = store.get_measurement(&CullingStats::VISIBLE).unwrap().value;
    assert_eq!(
        visible,
        app.world().resource::<CullingStats>().visible as f64
    );
}

#[test]
fn without_the_plugin_nothing_is_measured() {
    let app = culled_grid(0);
    for path in [AccelStats::SYNC_TIME, CullingStats::TIME] {
        assert!(!measured(&app, &path), "{path} measured");
    }
    // The figures are in the resources all the same.
    assert_eq!(app.world().resource::<AccelStats>().dynamic_entities, 64);
}

/// The panel adds the plugin where a game has not; added twice, it publishes once a frame.
#[test]
fn added_twice_it_publishes_once() {
    let app = culled_grid(2);
    let store = app.world().resource::<DiagnosticsStore>();
    let history = store.get(&AccelStats::SYNC_TIME).unwrap().history_len();
    assert_eq!(history, 3, "one measurement a frame");
}
