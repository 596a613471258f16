//! Select many: 6,000 units wander on a field; drag a box to select the units whose centre it
//! holds (`AccelSelectionPlugin`, through the trees), shift to add, a click selects one,
//! Escape clears. Selected units turn orange; the window's title counts them.
//!
//! `ACCEL_SCREENSHOT=out.png cargo run --example selection` holds the units still, drags a box
//! over part of the field (a synthetic press, move and release), saves a frame and exits,
//! failing unless the selection is exactly the units whose centre projects inside the box
//! (each unit projected by Bevy's `Camera::world_to_viewport`, as a game would).

use bevy::picking::pointer::PointerInput;
use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy_accel::prelude::*;

mod support;
use support::screenshot;

/// Units a side of the field.
const SIDE: i32 = 80;
/// The field's other side.
const ROWS: i32 = 75;

#[derive(Resource)]
struct Palette {
    normal: Handle<StandardMaterial>,
    selected: Handle<StandardMaterial>,
}

/// A unit's home on the field and its phase.
#[derive(Component)]
struct Unit {
    home: Vec3,
    phase: f32,
}

fn main() -> AppExit {
    App::new()
        .add_plugins(DefaultPlugins)
        .add_plugins(
            AccelPlugins
                .build()
                .disable::<AccelSpritePickingPlugin>()
                .disable::<AccelPreviewPlugin>()
                .disable::<AccelPanelPlugin>(),
        )
        .add_systems(Startup, setup)
        .add_systems(
            Update,
            (
                wander,
                count_in_title,
                drag_in_screenshot_mode.before(AccelSelectionSystems),
            ),
        )
        .add_observer(tint_selected)
        .add_observer(untint_deselected)
        .run()
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let unit = meshes.add(Cuboid::new(0.8, 0.8, 0.8));
    let normal = materials.add(Color::srgb(0.35, 0.45, 0.7));
    let selected = materials.add(Color::srgb(1.0, 0.55, 0.1));
    for x in 0..SIDE {
        for z in 0..ROWS {
            let home = Vec3::new(
                (x - SIDE / 2) as f32 * 1.5,
                0.4,
                (z - ROWS / 2) as f32 * 1.5,
            );
            commands.spawn((
                Mesh3d(unit.clone()),
                MeshMaterial3d(normal.clone()),
                Transform::from_translation(home),
                Unit {
                    home,
                    phase: (x * 7 + z * 13) as f32 * 0.1,
                },
            ));
        }
    }
    commands.insert_resource(Palette { normal, selected });
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(140.0, 130.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.3, 0.36, 0.3))),
        // The ground is not a unit.
        Pickable::IGNORE,
    ));
    commands.spawn((
        DirectionalLight::default(),
        Transform::from_xyz(4.0, 10.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 55.0, 60.0).looking_at(Vec3::new(0.0, 0.0, 5.0), Vec3::Y),
    ));
}

/// Each unit wanders in a small circle around its home (still in screenshot mode).
fn wander(time: Res<Time>, mut units: Query<(&mut Transform, &Unit)>) {
    if screenshot::screenshot_mode() {
        return;
    }
    let t = time.elapsed_secs();
    for (mut transform, unit) in &mut units {
        let a = unit.phase + 0.8 * t;
        transform.translation = unit.home + 0.4 * Vec3::new(a.cos(), 0.0, a.sin());
    }
}

fn tint_selected(
    added: On<Add, Selected>,
    palette: Res<Palette>,
    mut units: Query<&mut MeshMaterial3d<StandardMaterial>>,
) {
    if let Ok(mut material) = units.get_mut(added.entity) {
        material.0 = palette.selected.clone();
    }
}

fn untint_deselected(
    removed: On<Remove, Selected>,
    palette: Res<Palette>,
    mut units: Query<&mut MeshMaterial3d<StandardMaterial>>,
) {
    if let Ok(mut material) = units.get_mut(removed.entity) {
        material.0 = palette.normal.clone();
    }
}

fn count_in_title(
    selected: Query<(), With<Selected>>,
    mut window: Single<&mut Window, With<PrimaryWindow>>,
    mut last: Local<Option<usize>>,
) {
    let count = selected.iter().count();
    if *last != Some(count) {
        *last = Some(count);
        window.title =
            format!("bevy_accel selection: {count} selected (drag a box, Escape clears)");
    }
}

/// Screenshot mode: drags from one point of the field to another (the pointer moved there,
/// the button pressed, moved, released), then checks the selection against every unit's
/// projected centre, saves a frame and exits.
// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
fn drag_in_screenshot_mode(
    mut commands: Commands,
    mut frame: Local<u32>,
    window: Single<Entity, With<PrimaryWindow>>,
    camera: Single<(&Camera, &GlobalTransform)>,
    units: Query<(Entity, &GlobalTransform), With<Unit>>,
    selected: Query<Entity, With<Selected>>,
    mut buttons: ResMut<ButtonInput<MouseButton>>,
    mut input: MessageWriter<PointerInput>,
    mut exit: MessageWriter<AppExit>,
) {
    if !screenshot::screenshot_mode() {
        return;
    }
    let (camera, camera_tf) = *camera;
    let corner = |p: Vec3| camera.world_to_viewport(camera_tf, p).ok();
    let (Some(start), Some(end)) = (
        corner(Vec3::new(-20.3, 0.4, -8.3)),
        corner(Vec3::new(12.7, 0.4, 14.7)),
    ) else {
        return;
    };
    let window = *window;
    let mut move_to = |position: Vec2| screenshot::move_pointer(window, position, &mut input);
    match *frame {
        10 => move_to(start),
        12 => buttons.press(MouseButton::Left),
        13 => move_to((start + end) / 2.0),
        14 => move_to(end),
        16 => buttons.release(MouseButton::Left),
        _ => {}
    }
    if screenshot::check_due(&mut commands, &mut frame) {
        let rect = Rect::from_corners(start, end);
        let mut want: Vec<Entity> = units
            .iter()
            .filter(|(_, at)| corner(at.translation()).is_some_and(|p| rect.contains(p)))
            .map(|(e, _)| e)
            .collect();
        let mut got: Vec<Entity> = selected.iter().collect();
        want.sort_unstable();
        got.sort_unstable();
        let missed = want
            .iter()
            .filter(|e| got.binary_search(e).is_err())
            .count();
        let extra = got
            .iter()
            .filter(|e| want.binary_search(e).is_err())
            .count();
        screenshot::exit_with(
            &mut exit,
            !want.is_empty() && missed == 0 && extra == 0,
            format!(
                "selected {} units, {} projected inside the box: {missed} missed, {extra} extra",
                got.len(),
                want.len()
            ),
        );
    }
}
