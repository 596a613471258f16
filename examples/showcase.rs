//! Thousands of moving cubes kept in the trees by `AccelPlugin`; the cube under the cursor (or
//! under the screen centre) is found through the trees every frame and highlighted. The camera
//! and the shadow views of the sun and of a point light are culled on the trees
//! (`AccelCullingPlugin`).
//!
//! Debug overlays (`AccelOverlaysPlugin`), toggled by keys:
//! - `1`: the dynamic index's nodes, by depth; `2`: the static tree's nodes;
//! - `3`: every cube's box, green where the camera sees it, red where it was culled;
//! - `4`: the camera's frustum (seen from elsewhere: it frames this view);
//! - `[` and `]`: the deepest tree level drawn; `I`: the next index choice for the movers.
//!
//! `ACCEL_SCREENSHOT=out.png cargo run --example showcase` saves a frame and exits (the cubes'
//! motion then follows the frame count, not the clock, so runs can be compared). With
//! `ACCEL_BEVY_CULLING=1` Bevy's own culling runs instead of the trees', for comparison;
//! `ACCEL_OVERLAYS=all` starts with the node and box overlays on.

use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy_accel::AccelCullingPlugin;
use bevy_accel::accel::{Ray, SpatialQuery};
use bevy_accel::overlays::{AccelOverlaySettings, AccelOverlaysPlugin};
use bevy_accel::prelude::*;

#[path = "support/screenshot.rs"]
mod screenshot;

const GRID: i32 = 40;

#[derive(Component)]
struct Bob {
    home: Vec3,
    phase: f32,
}

#[derive(Resource)]
struct Palette {
    normal: Handle<StandardMaterial>,
    highlighted: Handle<StandardMaterial>,
}

#[derive(Resource, Default)]
struct Highlighted(Option<Entity>);

/// In screenshot mode, the static cube the pointer is placed over, and that must end up
/// highlighted.
#[derive(Resource)]
struct Target(Entity, Vec3);

fn main() -> AppExit {
    let mut app = App::new();
    app.add_plugins((DefaultPlugins, AccelPlugin::default(), AccelOverlaysPlugin));
    if std::env::var_os("ACCEL_BEVY_CULLING").is_none() {
        app.add_plugins(AccelCullingPlugin);
    }
    if std::env::var("ACCEL_OVERLAYS").is_ok_and(|v| v == "all") {
        app.insert_resource(AccelOverlaySettings {
            dynamic_nodes: true,
            static_nodes: true,
            entity_bounds: true,
            max_depth: 4,
            ..default()
        });
    }
    app.init_resource::<Highlighted>()
        .add_systems(Startup, setup)
        .add_systems(Update, (bob, toggle_overlays, screenshot_and_exit))
        .add_systems(
            PostUpdate,
            highlight_under_cursor.after(AccelSystems::Maintain),
        )
        .run()
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let cube = meshes.add(Cuboid::new(0.8, 0.8, 0.8));
    let normal = materials.add(Color::srgb(0.35, 0.45, 0.6));
    let highlighted = materials.add(Color::srgb(1.0, 0.55, 0.1));
    let mut target = None;
    for x in -GRID / 2..GRID / 2 {
        for z in -GRID / 2..GRID / 2 {
            let home = Vec3::new(x as f32 * 1.5, 0.0, z as f32 * 1.5);
            let mut e = commands.spawn((
                Mesh3d(cube.clone()),
                MeshMaterial3d(normal.clone()),
                Transform::from_translation(home),
            ));
            // Every other row bobs; the rest never move and live in the static tree.
            if z % 2 == 0 {
                e.insert(Bob {
                    home,
                    phase: (x * 7 + z * 3) as f32 * 0.3,
                });
            } else {
                e.insert(AccelStatic);
                if (x, z) == (2, 5) {
                    target = Some(Target(e.id(), home));
                }
            }
        }
    }
    commands.insert_resource(Palette {
        normal,
        highlighted,
    });
    if let Some(target) = target {
        commands.insert_resource(target);
    }
    commands.spawn((
        DirectionalLight {
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(3.0, 10.0, 5.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        PointLight {
            shadow_maps_enabled: true,
            intensity: 4_000_000.0,
            range: 18.0,
            color: Color::srgb(1.0, 0.8, 0.6),
            ..default()
        },
        Transform::from_xyz(-12.0, 4.0, 8.0),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(80.0, 80.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.5, 0.5, 0.5))),
        Transform::from_xyz(0.0, -2.0, 0.0),
        // The floor only receives shadows: kept out of the trees, so the pointer never
        // selects it (Bevy's own tests cull it).
        AccelIgnore,
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 28.0, 38.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
}

fn bob(time: Res<Time>, mut frame: Local<u32>, mut q: Query<(&Bob, &mut Transform)>) {
    *frame += 1;
    let t = if screenshot::screenshot_mode() {
        *frame as f32 / 30.0
    } else {
        time.elapsed_secs()
    };
    for (b, mut tf) in &mut q {
        tf.translation = b.home + Vec3::Y * (t * 2.0 + b.phase).sin() * 1.5;
    }
}

/// The overlay keys of the module docs.
fn toggle_overlays(
    keys: Res<ButtonInput<KeyCode>>,
    mut overlays: ResMut<AccelOverlaySettings>,
    mut settings: ResMut<AccelSettings>,
) {
    let overlays = &mut *overlays;
    for (key, toggle) in [
        (KeyCode::Digit1, &mut overlays.dynamic_nodes),
        (KeyCode::Digit2, &mut overlays.static_nodes),
        (KeyCode::Digit3, &mut overlays.entity_bounds),
        (KeyCode::Digit4, &mut overlays.frustum),
    ] {
        if keys.just_pressed(key) {
            *toggle = !*toggle;
        }
    }
    if keys.just_pressed(KeyCode::BracketLeft) {
        overlays.max_depth = overlays.max_depth.saturating_sub(1).max(overlays.min_depth);
    }
    if keys.just_pressed(KeyCode::BracketRight) {
        overlays.max_depth += 1;
    }
    if keys.just_pressed(KeyCode::KeyI) {
        settings.index = settings.index.next();
        info!("movers now in {:?}", settings.index);
    }
}

/// Casts the pointer's ray through the trees: candidates by box, nearest first.
fn highlight_under_cursor(
    window: Single<&Window, With<PrimaryWindow>>,
    camera: Single<(&Camera, &GlobalTransform)>,
    trees: Res<AccelTrees>,
    target: Option<Res<Target>>,
    palette: Res<Palette>,
    mut highlighted: ResMut<Highlighted>,
    mut materials: Query<&mut MeshMaterial3d<StandardMaterial>>,
) {
    let (camera, camera_tf) = *camera;
    // In screenshot mode the pointer is placed over a known static cube.
    let aimed = target
        .filter(|_| screenshot::screenshot_mode())
        .and_then(|t| camera.world_to_viewport(camera_tf, t.1).ok());
    let pointer = aimed
        .or(window.cursor_position())
        .unwrap_or(window.size() * 0.5);
    let Ok(ray) = camera.viewport_to_world(camera_tf, pointer) else {
        return;
    };
    let ray = Ray::new(ray.origin, Vec3::from(ray.direction));
    let hit = trees
        .query()
        .cast_ray(&ray, |slot, r| r.intersect_aabb(&trees.world_bounds(slot)))
        .and_then(|h| trees.entity(h.primitive));
    if hit == highlighted.0 {
        return;
    }
    for (entity, handle) in [
        (highlighted.0, &palette.normal),
        (hit, &palette.highlighted),
    ] {
        if let Some(mut m) = entity.and_then(|e| materials.get_mut(e).ok()) {
            m.0 = handle.clone();
        }
    }
    if let Some(e) = hit {
        info!("pointer over {e}");
    }
    highlighted.0 = hit;
}

/// Screenshot mode: saves frame 30 and exits at frame 40, failing unless the cube under the
/// placed pointer is the one highlighted.
fn screenshot_and_exit(
    mut commands: Commands,
    mut frame: Local<u32>,
    highlighted: Res<Highlighted>,
    target: Option<Res<Target>>,
    mut exit: MessageWriter<AppExit>,
) {
    if !screenshot::check_due(&mut commands, &mut frame) {
        return;
    }
    let expected = target.map(|t| t.0);
    screenshot::exit_with(
        &mut exit,
        highlighted.0.is_some() && highlighted.0 == expected,
        format!("highlighted {:?}, expected {expected:?}", highlighted.0),
    );
}
