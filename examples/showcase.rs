//! Thousands of moving cubes kept in the trees by `AccelPlugin`. The cube under the pointer is
//! lit through `AccelPickingPlugin` (the trees, then each mesh's BVH); a click selects it, a
//! drag selects every cube whose centre its box holds, shift adds, Escape clears
//! (`AccelSelectionPlugin`); selected cubes turn orange. The camera and the shadow views of the
//! sun and of a point light are culled on the trees (`AccelCullingPlugin`). The panel
//! (`AccelPanelPlugin`, `F1`) switches every service and overlay, picks the movers' index and
//! the static tree's builder, and plots each service's time; it also names what the pointer is
//! over, with its triangle and distance. `F2` switches the ray-traced preview
//! (`AccelPreviewPlugin`) over the view: the same trees and mesh BVHs, traced on the CPU.
//!
//! Debug overlays (`AccelOverlaysPlugin`), in the panel or by keys:
//! - `1`: the dynamic index's nodes, by depth; `2`: the static tree's nodes;
//! - `3`: every cube's box, green where the camera sees it, red where it was culled;
//! - `4`: the camera's frustum (seen from elsewhere: it frames this view);
//! - `[` and `]`: the deepest tree level drawn; `I`: the next index choice for the movers.
//!
//! `ACCEL_SCREENSHOT=out.png cargo run --example showcase` clicks a known cube, then drags a
//! box with shift held over part of the grid (synthetic pointer moves and button presses),
//! saves a frame and exits, failing unless the selection is that cube and exactly the cubes
//! whose centre Bevy's `Camera::world_to_viewport` puts inside the box (the cubes' motion then
//! follows the frame count, not the clock, so runs can be compared). With
//! `ACCEL_BEVY_CULLING=1` Bevy's own culling runs instead of the trees', for comparison;
//! `ACCEL_OVERLAYS=all` starts with the node and box overlays on.

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

/// The cube under the pointer.
#[derive(Resource, Default, PartialEq)]
struct Highlight {
    hovered: Option<Entity>,
}

/// In screenshot mode, the static cube the synthetic click aims at, and that must end up
/// selected.
#[derive(Resource)]
struct Target(Entity, Vec3);

/// In screenshot mode, the cubes whose centre projected inside the dragged box when it was
/// released: with the clicked cube, what must end up selected.
#[derive(Resource, Default)]
struct ExpectedDrag(Vec<Entity>);

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
        .init_resource::<ExpectedDrag>()
        .add_systems(Startup, setup)
        .add_systems(
            Update,
            (
                bob,
                toggle_overlays,
                (track_hover, paint_highlight)
                    .chain()
                    .after(AccelSelectionSystems),
                synthetic_click_and_drag.before(AccelSelectionSystems),
                screenshot_and_exit,
            ),
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

/// Repaints the cubes whose state changed: selected orange, hovered pale.
fn paint_highlight(
    highlight: Res<Highlight>,
    mut painted: Local<Highlight>,
    palette: Res<Palette>,
    newly_selected: Query<Entity, Added<Selected>>,
    mut deselected: RemovedComponents<Selected>,
    selected: Query<(), With<Selected>>,
    mut materials: Query<&mut MeshMaterial3d<StandardMaterial>, With<Cube>>,
) {
    let look = |e: Entity| {
        if selected.contains(e) {
            &palette.selected
        } else if highlight.hovered == Some(e) {
            &palette.hovered
        } else {
            &palette.normal
        }
    };
    let hover_changed = *highlight != *painted;
    let changed = newly_selected.iter().chain(deselected.read()).chain(
        [painted.hovered, highlight.hovered]
            .into_iter()
            .flatten()
            .filter(|_| hover_changed),
    );
    for entity in changed {
        if let Ok(mut m) = materials.get_mut(entity) {
            m.0 = look(entity).clone();
        }
    }
    painted.hovered = highlight.hovered;
}

/// Screenshot mode: moves the mouse pointer over the target cube and clicks it (frames 10 to
/// 14), then holds shift and drags a box over part of the grid (18 to 25), as a window's input
/// would; at the release, notes the cubes whose centre projects inside the box.
// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
fn synthetic_click_and_drag(
    mut frame: Local<u32>,
    window: Single<Entity, With<PrimaryWindow>>,
    camera: Single<(&Camera, &GlobalTransform)>,
    target: Option<Res<Target>>,
    cubes: Query<(Entity, &GlobalTransform), With<Cube>>,
    mut expected: ResMut<ExpectedDrag>,
    mut buttons: ResMut<ButtonInput<MouseButton>>,
    mut keys: ResMut<ButtonInput<KeyCode>>,
    mut input: MessageWriter<PointerInput>,
) {
    if !screenshot::screenshot_mode() {
        return;
    }
    *frame += 1;
    let Some(target) = target else {
        return;
    };
    let (camera, camera_tf) = *camera;
    let screen = |p: Vec3| camera.world_to_viewport(camera_tf, p).ok();
    // The box's corners fall between the cubes (1.5 apart), away from the clicked one.
    let (Some(at_target), Some(start), Some(end)) = (
        screen(target.1),
        screen(Vec3::new(-9.75, 0.0, -5.25)),
        screen(Vec3::new(-2.25, 0.0, 3.75)),
    ) else {
        return;
    };
    let window = *window;
    let mut move_to = |position: Vec2| screenshot::move_pointer(window, position, &mut input);
    match *frame {
        10 => move_to(at_target),
        12 | 20 => buttons.press(MouseButton::Left),
        14 => buttons.release(MouseButton::Left),
        18 => {
            keys.press(KeyCode::ShiftLeft);
            move_to(start);
        }
        21 => move_to((start + end) / 2.0),
        22 => move_to(end),
        24 => {
            buttons.release(MouseButton::Left);
            // The selection runs after this system, on the trees as the last frame left
            // them: the transforms read here.
            let rect = Rect::from_corners(start, end);
            expected.0 = cubes
                .iter()
                .filter(|(_, at)| screen(at.translation()).is_some_and(|p| rect.contains(p)))
                .map(|(e, _)| e)
                .collect();
        }
        25 => keys.release(KeyCode::ShiftLeft),
        _ => {}
    }
}

/// Screenshot mode: saves frame 30 and exits at frame 40, failing unless the selection is the
/// clicked cube and the cubes the drag's box held.
fn screenshot_and_exit(
    mut commands: Commands,
    mut frame: Local<u32>,
    selected: Query<Entity, With<Selected>>,
    target: Option<Res<Target>>,
    expected: Res<ExpectedDrag>,
    mut exit: MessageWriter<AppExit>,
) {
    if !screenshot::check_due(&mut commands, &mut frame) {
        return;
    }
    let mut want: Vec<Entity> = expected
        .0
        .iter()
        .copied()
        .chain(target.map(|t| t.0))
        .collect();
    let mut got: Vec<Entity> = selected.iter().collect();
    want.sort_unstable();
    want.dedup();
    got.sort_unstable();
    screenshot::exit_with(
        &mut exit,
        expected.0.len() > 10 && got == want,
        format!(
            "selected {} cubes; expected the clicked one and the {} the box held",
            got.len(),
            expected.0.len()
        ),
    );
}
