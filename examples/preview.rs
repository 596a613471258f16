//! The ray-traced preview (`AccelPreviewPlugin`): a still scene of Stanford bunnies
//! (`assets/bunny.glb`, through Bevy's glTF loader), boxes and spheres on a floor, under a sun
//! and a point light, traced on the CPU through the same trees and mesh BVHs that picking
//! uses. The image refines while nothing moves and starts over when the camera or the scene
//! changes.
//!
//! Keys: `F2` the preview on and off, `M` the next view (shaded, ambient occlusion, path
//! traced, normals, depth, traversal cost, entity ids, leaf depth), `C` over the view or in
//! a corner, arrows orbit the camera, `F1` the panel.
//!
//! `ACCEL_SCREENSHOT=out.png cargo run --example preview` traces whole samples each frame,
//! saves a frame once every pixel has two, and exits, failing unless the image restarted
//! when the camera moved. `ACCEL_PREVIEW=off` saves the raster view instead,
//! `ACCEL_PREVIEW_MODE=ids` the entity-id view: `.ci/real-window` checks that the two cover
//! the same pixels.

use bevy::diagnostic::FrameTimeDiagnosticsPlugin;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use bevy_accel::prelude::*;

mod support;
use support::screenshot;

#[derive(Component)]
struct Orbit {
    yaw: f32,
    pitch: f32,
    distance: f32,
}

fn main() -> AppExit {
    let shot = screenshot::screenshot_mode();
    let preview_on = std::env::var("ACCEL_PREVIEW").map_or(true, |v| v != "off");
    let mode = match std::env::var("ACCEL_PREVIEW_MODE").as_deref() {
        Ok("ids") => AccelPreviewMode::EntityIds,
        _ => AccelPreviewMode::Shaded,
    };
    App::new()
        .add_plugins((
            DefaultPlugins,
            FrameTimeDiagnosticsPlugin::default(),
            AccelPlugins
                .build()
                .disable::<AccelCullingPlugin>()
                .disable::<AccelSpritePickingPlugin>()
                .disable::<AccelOverlaysPlugin>(),
        ))
        .insert_resource(ClearColor(Color::BLACK))
        .insert_resource(AccelPreviewSettings {
            enabled: preview_on,
            mode,
            // Screenshot mode traces a whole sample per frame, so that its frames compare.
            frame_budget_ms: if shot { 10_000.0 } else { 12.0 },
            ..default()
        })
        .insert_resource(AccelPanelSettings {
            // The shots compare images; the panel would cover part of them.
            open: !shot,
            ..default()
        })
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, orbit, screenshot_when_sampled))
        .run()
}

fn setup(
    mut commands: Commands,
    assets: Res<AssetServer>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let bunny: Handle<Mesh> = assets.load(
        GltfAssetLabel::Primitive {
            mesh: 0,
            primitive: 0,
        }
        .from_asset("bunny.glb"),
    );
    let colours = [
        Color::srgb(0.8, 0.3, 0.25),
        Color::srgb(0.3, 0.7, 0.35),
        Color::srgb(0.3, 0.45, 0.85),
    ];
    for (i, colour) in colours.iter().enumerate() {
        commands.spawn((
            Mesh3d(bunny.clone()),
            MeshMaterial3d(materials.add(*colour)),
            Transform::from_xyz(i as f32 * 3.5 - 3.5, 0.0, 0.0)
                .with_rotation(Quat::from_rotation_y(0.6 * i as f32))
                .with_scale(Vec3::splat(0.3)),
            AccelStatic,
        ));
    }
    let cube = meshes.add(Cuboid::new(1.0, 1.0, 1.0));
    let sphere = meshes.add(Sphere::new(0.6).mesh().uv(32, 18));
    let grey = materials.add(Color::srgb(0.7, 0.7, 0.7));
    let glow = materials.add(StandardMaterial {
        base_color: Color::srgb(0.9, 0.8, 0.3),
        emissive: LinearRgba::rgb(400.0, 300.0, 80.0),
        ..default()
    });
    for k in 0..6 {
        let x = k as f32 * 1.6 - 4.0;
        commands.spawn((
            Mesh3d(if k % 2 == 0 {
                cube.clone()
            } else {
                sphere.clone()
            }),
            MeshMaterial3d(if k == 3 { glow.clone() } else { grey.clone() }),
            Transform::from_xyz(x, 0.6, 3.0).with_rotation(Quat::from_rotation_y(k as f32)),
            AccelStatic,
        ));
    }
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(30.0, 30.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.5, 0.5, 0.5))),
        AccelStatic,
    ));
    commands.spawn((
        DirectionalLight {
            shadow_maps_enabled: true,
            illuminance: 6_000.0,
            ..default()
        },
        Transform::from_xyz(4.0, 10.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        PointLight {
            shadow_maps_enabled: true,
            intensity: 2_000_000.0,
            range: 20.0,
            color: Color::srgb(1.0, 0.85, 0.7),
            ..default()
        },
        Transform::from_xyz(-4.0, 5.0, 4.0),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::default(),
        Orbit {
            yaw: 0.3,
            pitch: 0.45,
            distance: 12.0,
        },
    ));
}

fn keys(keys: Res<ButtonInput<KeyCode>>, mut settings: ResMut<AccelPreviewSettings>) {
    if keys.just_pressed(KeyCode::KeyM) {
        let i = AccelPreviewMode::ALL
            .iter()
            .position(|m| *m == settings.mode)
            .unwrap_or(0);
        settings.mode = AccelPreviewMode::ALL[(i + 1) % AccelPreviewMode::ALL.len()];
        info!("preview: {}", settings.mode.name());
    }
    if keys.just_pressed(KeyCode::KeyC) {
        settings.placement = match settings.placement {
            PreviewPlacement::Overlay => PreviewPlacement::Corner,
            PreviewPlacement::Corner => PreviewPlacement::Overlay,
        };
    }
}

fn orbit(
    keys: Res<ButtonInput<KeyCode>>,
    time: Res<Time>,
    mut camera: Single<(&mut Orbit, &mut Transform)>,
) {
    let (orbit, tf) = &mut *camera;
    let step = time.delta_secs();
    for (key, yaw, pitch) in [
        (KeyCode::ArrowLeft, -1.0, 0.0),
        (KeyCode::ArrowRight, 1.0, 0.0),
        (KeyCode::ArrowUp, 0.0, 1.0),
        (KeyCode::ArrowDown, 0.0, -1.0),
    ] {
        if keys.pressed(key) {
            orbit.yaw += yaw * step;
            orbit.pitch = (orbit.pitch + pitch * step).clamp(0.05, 1.4);
        }
    }
    let at = Vec3::new(0.0, 1.0, 0.0);
    let offset = Quat::from_euler(EulerRot::YXZ, orbit.yaw, -orbit.pitch, 0.0) * Vec3::Z;
    let wanted = Transform::from_translation(at + offset * orbit.distance).looking_at(at, Vec3::Y);
    if **tf != wanted {
        **tf = wanted;
    }
}

/// Screenshot mode: waits for the meshes, nudges the camera once (the image must restart),
/// then saves a frame once every pixel has two samples (or, with the preview off, after the
/// same frames) and exits.
// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
fn screenshot_when_sampled(
    mut commands: Commands,
    mut frame: Local<u32>,
    mut saved_at: Local<Option<u32>>,
    mut restarted_after_nudge: Local<bool>,
    settings: Res<AccelPreviewSettings>,
    stats: Res<AccelPreviewStats>,
    mut camera: Single<&mut Orbit>,
    meshes: Res<Assets<Mesh>>,
    handles: Query<&Mesh3d>,
    mut exit: MessageWriter<AppExit>,
) {
    let Ok(path) = std::env::var("ACCEL_SCREENSHOT") else {
        return;
    };
    *frame += 1;
    let loaded = handles.iter().all(|m| meshes.contains(&m.0));
    if *frame == 20 {
        camera.yaw += 0.05;
    } else if *frame > 20 && stats.restarted {
        *restarted_after_nudge = true;
    }
    let ready = *frame > 30
        && loaded
        && (!settings.enabled || (*restarted_after_nudge && stats.samples >= 2));
    if ready && saved_at.is_none() {
        commands
            .spawn(Screenshot::primary_window())
            .observe(save_to_disk(path));
        *saved_at = Some(*frame);
    }
    if saved_at.is_some_and(|at| *frame == at + 10) {
        screenshot::exit_with(
            &mut exit,
            !settings.enabled || *restarted_after_nudge,
            format!(
                "preview {}: {} samples, restarted after the camera moved: {}",
                if settings.enabled { "on" } else { "off" },
                stats.samples,
                *restarted_after_nudge
            ),
        );
    }
    if *frame > 2_000 {
        screenshot::exit_with(
            &mut exit,
            false,
            "the preview never reached two samples".into(),
        );
    }
}
