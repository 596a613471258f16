//! Thousands of moving cubes kept in the trees by `AccelPlugin`. The cube under the pointer is
//! lit, and a click selects it, through `AccelPickingPlugin` (the trees, then each mesh's
//! BVH). The camera and the shadow views of the sun and of a point light are culled on the
//! trees (`AccelCullingPlugin`). The panel (`AccelPanelPlugin`, `F1`) switches every service
//! and overlay, picks the movers' index and the static tree's builder, and plots each
//! service's time; it also names what the pointer is over, with its triangle and distance.
//! `F2` switches the ray-traced preview (`AccelPreviewPlugin`) over the view: the same trees
//! and mesh BVHs, traced on the CPU.
//!
//! Debug overlays (`AccelOverlaysPlugin`), in the panel or by keys:
//! - `1`: the dynamic index's nodes, by depth; `2`: the static tree's nodes;
//! - `3`: every cube's box, green where the camera sees it, red where it was culled;
//! - `4`: the camera's frustum (seen from elsewhere: it frames this view);
//! - `[` and `]`: the deepest tree level drawn; `I`: the next index choice for the movers.
//!
//! `ACCEL_SCREENSHOT=out.png cargo run --example showcase` clicks a known cube (a synthetic
//! press and release at its screen position), saves a frame and exits, failing unless that
//! cube was selected (the cubes' motion then follows the frame count, not the clock, so runs
//! can be compared). With `ACCEL_BEVY_CULLING=1` Bevy's own culling runs instead of the
//! trees', for comparison; `ACCEL_OVERLAYS=all` starts with the node and box overlays on.

use bevy::diagnostic::FrameTimeDiagnosticsPlugin;
use bevy::picking::hover::HoverMap;
use bevy::picking::pointer::{PointerId, PointerInput};
use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy_accel::prelude::*;

mod support;
use support::screenshot;

const GRID: i32 = 40;

#[derive(Component)]
struct Bob {
    home: Vec3,
    phase: f32,
}

#[derive(Resource)]
struct Palette {
    normal: Handle<StandardMaterial>,
    hovered: Handle<StandardMaterial>,
    selected: Handle<StandardMaterial>,
}

/// Marks the cubes (the floor and the camera are not selectable).
#[derive(Component)]
struct Cube;

/// The cube under the pointer and the one last clicked.
#[derive(Resource, Default, PartialEq)]
struct Highlight {
    hovered: Option<Entity>,
    selected: Option<Entity>,
}

/// In screenshot mode, the static cube the synthetic click aims at, and that must end up
/// selected.
#[derive(Resource)]
struct Target(Entity, Vec3);

fn main() -> AppExit {
    let mut app = App::new();
    // Every service on the cubes (there are no sprites to pick); with `ACCEL_BEVY_CULLING`,
    // Bevy's own culling instead of the trees', to compare the two frames.
    let mut accel = AccelPlugins.build().disable::<AccelSpritePickingPlugin>();
    if std::env::var_os("ACCEL_BEVY_CULLING").is_some() {
        accel = accel.disable::<AccelCullingPlugin>();
    }
    app.add_plugins((DefaultPlugins, FrameTimeDiagnosticsPlugin::default(), accel));
    if std::env::var("ACCEL_OVERLAYS").is_ok_and(|v| v == "all") {
        app.insert_resource(AccelOverlaySettings {
            dynamic_nodes: true,
            static_nodes: true,
            entity_bounds: true,
            max_depth: 4,
            ..default()
        });
    }
    app.init_resource::<Highlight>()
        .add_systems(Startup, setup)
        .add_systems(
            Update,
            (
                bob,
                toggle_overlays,
                (track_hover, paint_highlight).chain(),
                synthetic_click,
                screenshot_and_exit,
            ),
        )
        .add_observer(select_on_click)
        .run()
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let cube = meshes.add(Cuboid::new(0.8, 0.8, 0.8));
    let normal = materials.add(Color::srgb(0.35, 0.45, 0.6));
    let hovered = materials.add(Color::srgb(0.75, 0.85, 1.0));
    let selected = materials.add(Color::srgb(1.0, 0.55, 0.1));
    let mut target = None;
    for x in -GRID / 2..GRID / 2 {
        for z in -GRID / 2..GRID / 2 {
            let home = Vec3::new(x as f32 * 1.5, 0.0, z as f32 * 1.5);
            let mut e = commands.spawn((
                Mesh3d(cube.clone()),
                MeshMaterial3d(normal.clone()),
                Transform::from_translation(home),
                Cube,
                Name::new(format!("cube ({x}, {z})")),
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
        hovered,
        selected,
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

/// The nearest cube among the mouse's hover hits (bevy_picking's, through the trees). Over
/// the panel, bevy_egui's own hit blocks the scene, and nothing is hovered.
fn track_hover(
    hovers: Res<HoverMap>,
    cubes: Query<(), With<Cube>>,
    mut highlight: ResMut<Highlight>,
) {
    let hovered = hovers.get(&PointerId::Mouse).and_then(|hits| {
        hits.iter()
            .filter(|(e, _)| cubes.contains(**e))
            .min_by(|a, b| a.1.depth.total_cmp(&b.1.depth))
            .map(|(e, _)| *e)
    });
    if highlight.hovered != hovered {
        highlight.hovered = hovered;
    }
}

fn select_on_click(
    click: On<Pointer<Click>>,
    cubes: Query<(), With<Cube>>,
    mut highlight: ResMut<Highlight>,
) {
    if cubes.contains(click.entity) {
        info!(
            "selected {} at distance {:.2}",
            click.entity, click.hit.depth
        );
        highlight.selected = Some(click.entity);
    }
}

/// Repaints the cubes whose state changed: selected orange, hovered pale.
fn paint_highlight(
    highlight: Res<Highlight>,
    mut painted: Local<Highlight>,
    palette: Res<Palette>,
    mut materials: Query<&mut MeshMaterial3d<StandardMaterial>, With<Cube>>,
) {
    if *highlight == *painted {
        return;
    }
    let look = |e: Entity| {
        if highlight.selected == Some(e) {
            &palette.selected
        } else if highlight.hovered == Some(e) {
            &palette.hovered
        } else {
            &palette.normal
        }
    };
    for entity in [
        painted.hovered,
        painted.selected,
        highlight.hovered,
        highlight.selected,
    ]
    .into_iter()
    .flatten()
    {
        if let Ok(mut m) = materials.get_mut(entity) {
            m.0 = look(entity).clone();
        }
    }
    *painted = Highlight {
        hovered: highlight.hovered,
        selected: highlight.selected,
    };
}

/// Screenshot mode: moves the mouse pointer over the target cube, then presses and releases
/// its primary button there, as bevy_picking's input from a window would.
fn synthetic_click(
    mut frame: Local<u32>,
    window: Single<Entity, With<PrimaryWindow>>,
    camera: Single<(&Camera, &GlobalTransform)>,
    target: Option<Res<Target>>,
    mut input: MessageWriter<PointerInput>,
) {
    if !screenshot::screenshot_mode() {
        return;
    }
    *frame += 1;
    let Some(target) = target else { return };
    screenshot::synthetic_click(*frame, *window, *camera, target.1, &mut input);
}

/// Screenshot mode: saves frame 30 and exits at frame 40, failing unless the clicked cube is
/// the one selected.
fn screenshot_and_exit(
    mut commands: Commands,
    mut frame: Local<u32>,
    highlight: Res<Highlight>,
    target: Option<Res<Target>>,
    mut exit: MessageWriter<AppExit>,
) {
    if !screenshot::check_due(&mut commands, &mut frame) {
        return;
    }
    let expected = target.map(|t| t.0);
    screenshot::exit_with(
        &mut exit,
        highlight.selected.is_some() && highlight.selected == expected,
        format!("selected {:?}, expected {expected:?}", highlight.selected),
    );
}
