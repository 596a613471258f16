//! Click to select, through `AccelPickingPlugin`: a few hundred meshes of several kinds, and a
//! row of Stanford bunnies (`assets/bunny.glb`, through Bevy's glTF loader) behind them; a
//! click highlights the mesh under the pointer and logs the entity, the triangle and the hit
//! point, all found through the trees and the per-mesh BVHs.
//!
//! `ACCEL_SCREENSHOT=out.png cargo run --example picking` clicks a known cube (a synthetic
//! press and release at its screen position), saves a frame and exits, failing unless that
//! cube was selected.

use bevy::picking::backend::HitData;
use bevy::picking::pointer::PointerInput;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use bevy::window::PrimaryWindow;
use bevy_accel::prelude::*;

mod support;
use support::screenshot;

#[derive(Resource)]
struct Palette {
    normal: Handle<StandardMaterial>,
    selected: Handle<StandardMaterial>,
}

#[derive(Resource, Default)]
struct Selected(Option<Entity>);

/// The cube the synthetic click aims at.
#[derive(Resource)]
struct Target(Entity, Vec3);

fn main() -> AppExit {
    App::new()
        .add_plugins(DefaultPlugins)
        // The trees and the picking backend; this example shows nothing else.
        .add_plugins(
            AccelPlugins
                .build()
                .disable::<AccelCullingPlugin>()
                .disable::<AccelSpritePickingPlugin>()
                .disable::<AccelOverlaysPlugin>()
                .disable::<AccelPreviewPlugin>()
                .disable::<AccelPanelPlugin>(),
        )
        .init_resource::<Selected>()
        .add_systems(Startup, setup)
        .add_systems(Update, synthetic_click_and_screenshot)
        .run()
}

fn setup(
    mut commands: Commands,
    assets: Res<AssetServer>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let kinds = [
        meshes.add(Cuboid::new(0.9, 0.9, 0.9)),
        meshes.add(Sphere::new(0.5).mesh().uv(24, 16)),
        meshes.add(Torus::new(0.25, 0.5)),
        meshes.add(Cylinder::new(0.4, 1.0)),
    ];
    let normal = materials.add(Color::srgb(0.4, 0.5, 0.65));
    let selected = materials.add(Color::srgb(1.0, 0.55, 0.1));
    let mut target = None;
    for x in -10i32..10 {
        for z in -8..8 {
            let kind = ((x + z).rem_euclid(4)) as usize;
            let position = Vec3::new(x as f32 * 1.6, 0.0, z as f32 * 1.6);
            let rotation =
                Quat::from_rotation_x(0.3 * (x as f32)) * Quat::from_rotation_y(0.2 * z as f32);
            let id = commands
                .spawn((
                    Mesh3d(kinds[kind].clone()),
                    MeshMaterial3d(normal.clone()),
                    Transform::from_translation(position).with_rotation(rotation),
                ))
                .observe(select_on_click)
                .id();
            if (x, z) == (2, 2) {
                target = Some(Target(id, position));
            }
        }
    }
    // The model is about ten units across, standing on its y = 0 base.
    let bunny: Handle<Mesh> = assets.load(
        GltfAssetLabel::Primitive {
            mesh: 0,
            primitive: 0,
        }
        .from_asset("bunny.glb"),
    );
    for i in -3i32..=3 {
        commands
            .spawn((
                Mesh3d(bunny.clone()),
                MeshMaterial3d(normal.clone()),
                Transform::from_xyz(i as f32 * 4.0, -0.5, -16.0)
                    .with_rotation(Quat::from_rotation_y(0.5 * i as f32))
                    .with_scale(Vec3::splat(0.3)),
            ))
            .observe(select_on_click);
    }
    if let Some(target) = target {
        commands.insert_resource(target);
    }
    commands.insert_resource(Palette { normal, selected });
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(4.0, 10.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 16.0, 22.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
}

/// Highlights the clicked mesh and logs what the trees found.
fn select_on_click(
    click: On<Pointer<Click>>,
    palette: Res<Palette>,
    mut selected: ResMut<Selected>,
    mut materials: Query<&mut MeshMaterial3d<StandardMaterial>>,
) {
    let hit: &HitData = &click.hit;
    let triangle = hit
        .extra_as::<AccelHitExtra>()
        .and_then(|x| x.triangle_index);
    info!(
        "selected {} (triangle {:?}) at {:?}",
        click.entity, triangle, hit.position
    );
    for (entity, handle) in [
        (selected.0, &palette.normal),
        (Some(click.entity), &palette.selected),
    ] {
        if let Some(mut m) = entity.and_then(|e| materials.get_mut(e).ok()) {
            m.0 = handle.clone();
        }
    }
    selected.0 = Some(click.entity);
}

/// Screenshot mode: presses and releases the primary button over the target cube, saves a
/// frame, and exits with an error unless the cube was selected.
// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
fn synthetic_click_and_screenshot(
    mut commands: Commands,
    mut frame: Local<u32>,
    window: Single<Entity, With<PrimaryWindow>>,
    camera: Single<(&Camera, &GlobalTransform)>,
    target: Option<Res<Target>>,
    selected: Res<Selected>,
    bunnies: Query<&Mesh3d, Without<Camera>>,
    meshes: Res<Assets<Mesh>>,
    mut input: MessageWriter<PointerInput>,
    mut exit: MessageWriter<AppExit>,
) {
    let Ok(path) = std::env::var("ACCEL_SCREENSHOT") else {
        return;
    };
    *frame += 1;
    let (camera, camera_tf) = *camera;
    let Some(target) = target else { return };
    screenshot::synthetic_click(*frame, *window, (camera, camera_tf), target.1, &mut input);
    if *frame == 34 {
        commands
            .spawn(Screenshot::primary_window())
            .observe(save_to_disk(path));
    }
    if *frame == 44 {
        // Every mesh, the bunnies from the OBJ file included, loaded by now.
        let loaded = bunnies.iter().all(|m| meshes.contains(&m.0));
        if selected.0 == Some(target.0) && loaded {
            info!("selected the expected cube {}", target.0);
            exit.write(AppExit::Success);
        } else {
            error!(
                "selected {:?}, expected {}; every mesh loaded: {loaded}",
                selected.0, target.0
            );
            exit.write(AppExit::error());
        }
    }
}
