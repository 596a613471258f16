//! Many entities in the trees: `--entities N` boxes (default 100,000) on a square field, a share
//! of them (`--moving PERCENT`, default 10) wobbling every frame, culled on the trees and seen
//! by a strategy camera from above (about 2% in view). Every second the frame time, the
//! plugin's sync, maintenance and culling times and the visible count are logged and shown in
//! the window's title.
//!
//! Keys: `I` the next index choice for the movers; `3` the culling boxes overlay.
//!
//! `cargo run --example stress -- --entities 1000000 --moving 25`; with
//! `ACCEL_SCREENSHOT=out.png` it saves frame 30 and exits, failing unless the trees hold every
//! entity.

use bevy::diagnostic::{DiagnosticsStore, FrameTimeDiagnosticsPlugin};
use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy_accel::prelude::*;

mod support;
use support::screenshot;

#[derive(Component)]
struct Wobble {
    home: Vec3,
    phase: f32,
}

#[derive(Resource)]
struct Scene {
    entities: usize,
    moving_percent: usize,
}

fn arg(name: &str, default: usize) -> usize {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .map_or(default, |v| {
            v.replace('_', "")
                .parse()
                .unwrap_or_else(|_| panic!("{name} takes a count, not {v}"))
        })
}

fn main() -> AppExit {
    App::new()
        .add_plugins((
            DefaultPlugins,
            FrameTimeDiagnosticsPlugin::default(),
            // The trees, culling and the overlays: no picking, preview or panel, whose costs
            // would blur the figures this example shows.
            AccelPlugins
                .build()
                .disable::<AccelPickingPlugin>()
                .disable::<AccelSpritePickingPlugin>()
                .disable::<AccelPreviewPlugin>()
                .disable::<AccelPanelPlugin>(),
        ))
        .insert_resource(Scene {
            entities: arg("--entities", 100_000),
            moving_percent: arg("--moving", 10).min(100),
        })
        .add_systems(Startup, setup)
        .add_systems(Update, (wobble, keys, report, screenshot_and_exit))
        .run()
}

fn setup(
    mut commands: Commands,
    scene: Res<Scene>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let cube = meshes.add(Cuboid::new(1.0, 1.0, 1.0));
    let material = materials.add(Color::srgb(0.35, 0.45, 0.6));
    let per_row = (scene.entities as f32).sqrt().ceil() as usize;
    let side = per_row as f32 * 3.0;
    let stride = (100 / scene.moving_percent.max(1)).max(1);
    for i in 0..scene.entities {
        let home = Vec3::new(
            (i % per_row) as f32 * 3.0 - side / 2.0,
            0.0,
            (i / per_row) as f32 * 3.0 - side / 2.0,
        );
        let mut e = commands.spawn((
            Mesh3d(cube.clone()),
            MeshMaterial3d(material.clone()),
            Transform::from_translation(home),
        ));
        if scene.moving_percent > 0 && i % stride == 0 {
            e.insert(Wobble {
                home,
                phase: i as f32 * 0.37,
            });
        }
    }
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(3.0, 10.0, 5.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    // A strategy camera: high enough for about 2% of the field.
    let height = (0.02f32 / 1.219).sqrt() * side;
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, height, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z),
    ));
}

fn wobble(time: Res<Time>, mut movers: Query<(&Wobble, &mut Transform)>) {
    let t = time.elapsed_secs();
    movers.par_iter_mut().for_each(|(w, mut tf)| {
        let a = t + w.phase;
        tf.translation = w.home + Vec3::new(a.sin(), 0.0, a.cos());
    });
}

fn keys(
    keys: Res<ButtonInput<KeyCode>>,
    mut settings: ResMut<AccelSettings>,
    mut overlays: ResMut<AccelOverlaySettings>,
) {
    if keys.just_pressed(KeyCode::KeyI) {
        settings.index = settings.index.next();
    }
    if keys.just_pressed(KeyCode::Digit3) {
        overlays.entity_bounds = !overlays.entity_bounds;
    }
}

/// Once a second: the frame time and the plugin's own timings, in the log and the title.
fn report(
    time: Res<Time>,
    mut last: Local<f32>,
    diagnostics: Res<DiagnosticsStore>,
    stats: Res<AccelStats>,
    culling: Option<Res<CullingStats>>,
    settings: Res<AccelSettings>,
    mut window: Single<&mut Window, With<PrimaryWindow>>,
) {
    if time.elapsed_secs() - *last < 1.0 {
        return;
    }
    *last = time.elapsed_secs();
    let frame_ms = diagnostics
        .get(&FrameTimeDiagnosticsPlugin::FRAME_TIME)
        .and_then(|d| d.smoothed())
        .unwrap_or(0.0);
    let ms = |d: core::time::Duration| d.as_secs_f64() * 1e3;
    let line = format!(
        "{:.1} ms/frame | {:?} (on {:?}) | {} entities, {} moved, {} busy | sync {:.2} ms, \
         maintain {:.2} ms, culling {:.2} ms, {} visible",
        frame_ms,
        settings.index,
        stats.index,
        stats.dynamic_entities + stats.static_entities,
        stats.updated,
        stats.busy_movers,
        ms(stats.sync_time),
        ms(stats.maintain_time),
        culling.as_ref().map_or(0.0, |c| ms(c.time)),
        culling.as_ref().map_or(0, |c| c.visible),
    );
    info!("{line}");
    window.title = format!("bevy_accel stress: {line}");
}

/// Screenshot mode: saves frame 30 and exits, failing unless every entity is in the trees.
fn screenshot_and_exit(
    mut commands: Commands,
    mut frame: Local<u32>,
    scene: Res<Scene>,
    trees: Res<AccelTrees>,
    mut exit: MessageWriter<AppExit>,
) {
    if !screenshot::check_due(&mut commands, &mut frame) {
        return;
    }
    screenshot::exit_with(
        &mut exit,
        trees.len() == scene.entities,
        format!(
            "{} of {} entities in the trees",
            trees.len(),
            scene.entities
        ),
    );
}
