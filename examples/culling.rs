//! What the main camera culls, seen from above: 3,600 cubes, a third of them bobbing, culled
//! on the trees (`AccelCullingPlugin`). The main camera turns slowly at the field's edge; the
//! inset at the top right looks down on the whole field, and the overlays
//! (`AccelOverlaysPlugin`, drawn only in the inset) colour every cube's box by the main
//! camera's verdict, green seen and red culled, with the main camera's frustum in yellow.
//!
//! Keys: `Space` pauses the turn; `1` the culling boxes, `2` the frustum, `3` the dynamic
//! index's nodes.
//!
//! `ACCEL_SCREENSHOT=out.png cargo run --example culling` saves a frame and exits, with an
//! error unless the trees culled some cubes and kept others for the main camera.

use bevy::camera::Viewport;
use bevy::camera::visibility::{RenderLayers, VisibleEntities};
use bevy::prelude::*;
use bevy_accel::prelude::*;

mod support;
use support::screenshot;

const SIDE: i32 = 60;
/// The render layer only the inset sees: the overlays are drawn there.
const INSET_LAYER: usize = 1;

#[derive(Component)]
struct MainView;

#[derive(Component)]
struct Bob {
    home: Vec3,
    phase: f32,
}

#[derive(Resource, Default)]
struct Paused(bool);

fn main() -> AppExit {
    App::new()
        .add_plugins(DefaultPlugins)
        // The trees, culling and the overlays that show it.
        .add_plugins(
            AccelPlugins
                .build()
                .disable::<AccelPickingPlugin>()
                .disable::<AccelSpritePickingPlugin>()
                .disable::<AccelPreviewPlugin>()
                .disable::<AccelPanelPlugin>(),
        )
        .init_resource::<Paused>()
        .add_systems(Startup, (setup, overlays_in_the_inset_only).chain())
        .add_systems(Update, (bob, turn, keys, screenshot_and_exit))
        .run()
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let cube = meshes.add(Cuboid::new(0.8, 0.8, 0.8));
    let material = materials.add(Color::srgb(0.35, 0.45, 0.6));
    for x in -SIDE / 2..SIDE / 2 {
        for z in -SIDE / 2..SIDE / 2 {
            let home = Vec3::new(x as f32 * 2.0, 0.0, z as f32 * 2.0);
            let mut e = commands.spawn((
                Mesh3d(cube.clone()),
                MeshMaterial3d(material.clone()),
                Transform::from_translation(home),
            ));
            if (x + z) % 3 == 0 {
                e.insert(Bob {
                    home,
                    phase: (x * 5 + z * 3) as f32 * 0.2,
                });
            } else {
                e.insert(AccelStatic);
            }
        }
    }
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(3.0, 10.0, 5.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        MainView,
        Transform::from_xyz(0.0, 3.0, 70.0).looking_at(Vec3::new(0.0, 0.0, 0.0), Vec3::Y),
    ));
    // The inset: above the field, drawn after the main view into the top right corner.
    commands.spawn((
        Camera3d::default(),
        Camera {
            order: 1,
            viewport: Some(Viewport {
                physical_position: UVec2::new(800, 0),
                physical_size: UVec2::new(480, 360),
                ..default()
            }),
            ..default()
        },
        Transform::from_xyz(0.0, 150.0, 30.0).looking_at(Vec3::new(0.0, 0.0, 10.0), Vec3::NEG_Z),
        RenderLayers::from_layers(&[0, INSET_LAYER]),
    ));
}

/// The overlays answer for the main camera and are drawn only in the inset.
fn overlays_in_the_inset_only(
    mut commands: Commands,
    mut store: ResMut<GizmoConfigStore>,
    main: Query<Entity, With<MainView>>,
) {
    let (config, _) = store.config_mut::<AccelGizmos>();
    config.render_layers = RenderLayers::layer(INSET_LAYER);
    commands.insert_resource(AccelOverlaySettings {
        entity_bounds: true,
        frustum: true,
        culling_view: main.single().ok(),
        ..default()
    });
}

fn bob(time: Res<Time>, mut frame: Local<u32>, mut q: Query<(&Bob, &mut Transform)>) {
    *frame += 1;
    let t = if screenshot::screenshot_mode() {
        *frame as f32 / 30.0
    } else {
        time.elapsed_secs()
    };
    for (b, mut tf) in &mut q {
        tf.translation = b.home + Vec3::Y * (t * 2.0 + b.phase).sin();
    }
}

/// Turns the main camera about its own position, a full turn in a minute.
fn turn(time: Res<Time>, paused: Res<Paused>, mut main: Query<&mut Transform, With<MainView>>) {
    if paused.0 || screenshot::screenshot_mode() {
        return;
    }
    for mut tf in &mut main {
        tf.rotate_y(time.delta_secs() * core::f32::consts::TAU / 60.0);
    }
}

fn keys(
    keys: Res<ButtonInput<KeyCode>>,
    mut paused: ResMut<Paused>,
    mut overlays: ResMut<AccelOverlaySettings>,
) {
    if keys.just_pressed(KeyCode::Space) {
        paused.0 = !paused.0;
    }
    let overlays = &mut *overlays;
    for (key, toggle) in [
        (KeyCode::Digit1, &mut overlays.entity_bounds),
        (KeyCode::Digit2, &mut overlays.frustum),
        (KeyCode::Digit3, &mut overlays.dynamic_nodes),
    ] {
        if keys.just_pressed(key) {
            *toggle = !*toggle;
        }
    }
}

/// Screenshot mode: saves frame 30 and exits at frame 40, failing unless the main camera saw
/// some cubes and the trees culled others (as the overlay drew them).
fn screenshot_and_exit(
    mut commands: Commands,
    mut frame: Local<u32>,
    main: Query<&VisibleEntities, With<MainView>>,
    stats: Res<AccelOverlayStats>,
    mut exit: MessageWriter<AppExit>,
) {
    if !screenshot::check_due(&mut commands, &mut frame) {
        return;
    }
    let seen = main
        .single()
        .map_or(0, |v| v.get(core::any::TypeId::of::<Mesh3d>()).len());
    let culled = stats.entity_boxes - stats.visible_boxes;
    screenshot::exit_with(
        &mut exit,
        seen > 0 && stats.visible_boxes == seen.min(stats.entity_boxes) && culled > 0,
        format!(
            "main camera sees {seen} cubes; the overlay drew {} boxes, {culled} culled",
            stats.entity_boxes
        ),
    );
}
