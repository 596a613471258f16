//! `AccelSelectionPlugin` driven as a player drives it: the window's cursor and button
//! messages (what winit writes) through bevy_picking's input and hover, and the keys through
//! Bevy's `InputPlugin`. A click selects the entity under the pointer, shift-click toggles, a
//! drag selects what its rectangle holds (against the projection a game would write), shift
//! adds, Escape clears, and a click on nothing deselects.

use bevy::camera::RenderTargetInfo;
use bevy::input::ButtonState;
use bevy::input::keyboard::{Key, KeyboardInput};
use bevy::input::mouse::MouseButtonInput;
use bevy::picking::input::PointerInputPlugin;
use bevy::picking::mesh_picking::ray_cast::RayCastVisibility;
use bevy::picking::{InteractionPlugin, PickingPlugin};
use bevy::prelude::*;
use bevy::window::{CursorMoved, PrimaryWindow, WindowEvent};
use bevy_accel::picking::AccelPickingSettings;
use bevy_accel::prelude::*;

mod common;

const SIZE: UVec2 = UVec2::new(1280, 720);

struct Scene {
    app: App,
    window: Entity,
    camera: Entity,
    cubes: Vec<Entity>,
}

/// Counts the `SelectionChanged` events and what they report, and the lifecycle events of
/// `Selected` itself (which must agree with them).
#[derive(Resource, Default)]
struct Changes {
    events: usize,
    added: usize,
    removed: usize,
    on_add: usize,
    on_remove: usize,
}

/// A 12 x 12 grid of unit cubes seen from above at an angle, a window the camera draws to,
/// and the input and picking plugins that a window's messages go through.
fn scene() -> Scene {
    let mut app = common::headless_app();
    app.add_plugins((
        bevy::input::InputPlugin,
        PointerInputPlugin,
        PickingPlugin,
        InteractionPlugin,
        AccelPickingPlugin,
        AccelSelectionPlugin,
    ))
    .add_message::<WindowEvent>()
    // No renderer computes `ViewVisibility` here.
    .insert_resource(AccelPickingSettings {
        ray_cast_visibility: RayCastVisibility::Visible,
        ..default()
    })
    .insert_resource(AccelSelectionSettings {
        visibility: RayCastVisibility::Visible,
        ..default()
    })
    .init_resource::<Changes>()
    .add_observer(
        |changed: On<SelectionChanged>, mut changes: ResMut<Changes>| {
            changes.events += 1;
            changes.added += changed.added;
            changes.removed += changed.removed;
        },
    )
    .add_observer(|_: On<Add, Selected>, mut changes: ResMut<Changes>| {
        changes.on_add += 1;
    })
    .add_observer(|_: On<Remove, Selected>, mut changes: ResMut<Changes>| {
        changes.on_remove += 1;
    });
    app.finish();
    let window = app
        .world_mut()
        .spawn((
            Window {
                resolution: SIZE.into(),
                ..default()
            },
            PrimaryWindow,
        ))
        .id();
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::default());
    let mut cubes = Vec::new();
    for x in -6..6 {
        for z in -6..6 {
            let at = Vec3::new(x as f32 * 2.0 + 1.0, 0.0, z as f32 * 2.0 + 1.0);
            cubes.push(
                app.world_mut()
                    .spawn((Mesh3d(cube.clone()), Transform::from_translation(at)))
                    .id(),
            );
        }
    }
    // The camera's matrices set by hand, as Bevy's camera system would with a renderer.
    let transform = Transform::from_xyz(0.0, 26.0, 18.0).looking_at(Vec3::ZERO, Vec3::Y);
    let mut camera = Camera::default();
    camera.computed.clip_from_view =
        Mat4::perspective_infinite_reverse_rh(0.8, SIZE.x as f32 / SIZE.y as f32, 0.1);
    camera.computed.target_info = Some(RenderTargetInfo {
        physical_size: SIZE,
        scale_factor: 1.0,
    });
    let camera = app
        .world_mut()
        .spawn((camera, transform, GlobalTransform::from(transform)))
        .id();
    app.update();
    app.update();
    Scene {
        app,
        window,
        camera,
        cubes,
    }
}

impl Scene {
    /// Where `point` is drawn, in the window's logical pixels.
    fn screen(&self, point: Vec3) -> Vec2 {
        let world = self.app.world();
        let camera = world.get::<Camera>(self.camera).unwrap();
        let transform = world.get::<GlobalTransform>(self.camera).unwrap();
        camera.world_to_viewport(transform, point).unwrap()
    }

    fn cube_on_screen(&self, cube: Entity) -> Vec2 {
        let at = self.app.world().get::<GlobalTransform>(cube).unwrap();
        self.screen(at.translation())
    }

    /// The cursor moves to `position`, and a frame runs.
    fn move_to(&mut self, position: Vec2) {
        let window = self.window;
        self.app
            .world_mut()
            .write_message(WindowEvent::CursorMoved(CursorMoved {
                window,
                position,
                delta: None,
            }));
        self.app.update();
    }

    /// The left button goes down or up, and a frame runs.
    fn button(&mut self, state: ButtonState) {
        let input = MouseButtonInput {
            button: MouseButton::Left,
            state,
            window: self.window,
        };
        // Winit writes both: the window event feeds the pointer, the message the buttons.
        self.app
            .world_mut()
            .write_message(WindowEvent::MouseButtonInput(input));
        self.app.world_mut().write_message(input);
        self.app.update();
    }

    fn key(&mut self, key_code: KeyCode, state: ButtonState) {
        let window = self.window;
        self.app.world_mut().write_message(KeyboardInput {
            key_code,
            logical_key: Key::Unidentified(bevy::input::keyboard::NativeKey::Unidentified),
            state,
            text: None,
            repeat: false,
            window,
        });
        self.app.update();
    }

    fn click(&mut self, position: Vec2) {
        self.move_to(position);
        self.button(ButtonState::Pressed);
        self.button(ButtonState::Released);
    }

    fn drag(&mut self, from: Vec2, to: Vec2) {
        self.move_to(from);
        self.button(ButtonState::Pressed);
        self.move_to((from + to) / 2.0);
        self.move_to(to);
        self.button(ButtonState::Released);
    }

    fn changes(&self) -> &Changes {
        self.app.world().resource::<Changes>()
    }

    fn selected(&mut self) -> Vec<Entity> {
        let world = self.app.world_mut();
        let mut q = world.query_filtered::<Entity, With<Selected>>();
        let mut found: Vec<Entity> = q.iter(world).collect();
        found.sort_unstable();
        found
    }

    /// The cubes whose centre projects inside the rectangle: what a game would compute.
    fn projected_inside(&self, a: Vec2, b: Vec2) -> Vec<Entity> {
        let rect = Rect::from_corners(a, b);
        let mut inside: Vec<Entity> = self
            .cubes
            .iter()
            .copied()
            .filter(|&c| rect.contains(self.cube_on_screen(c)))
            .collect();
        inside.sort_unstable();
        inside
    }
}

fn sorted(mut entities: Vec<Entity>) -> Vec<Entity> {
    entities.sort_unstable();
    entities
}

#[test]
fn clicks_select_shift_toggles_and_a_click_on_nothing_clears() {
    let mut s = scene();
    let (a, b) = (s.cubes[30], s.cubes[77]);
    let at_a = s.cube_on_screen(a);
    let at_b = s.cube_on_screen(b);
    s.click(at_a);
    assert_eq!(
        s.selected(),
        [a],
        "a click selects the cube under the pointer"
    );
    s.click(at_b);
    assert_eq!(s.selected(), [b], "a second click replaces the selection");
    s.key(KeyCode::ShiftLeft, ButtonState::Pressed);
    s.click(at_a);
    assert_eq!(s.selected(), sorted(vec![a, b]), "shift-click adds");
    s.click(at_b);
    assert_eq!(
        s.selected(),
        [a],
        "shift-click on a selected cube removes it"
    );
    s.key(KeyCode::ShiftLeft, ButtonState::Released);
    // Between the cubes: the gap of the grid, seen from above.
    let gap = s.screen(Vec3::new(0.0, 0.5, 0.0));
    s.click(gap);
    assert!(s.selected().is_empty(), "a click on nothing deselects");
    let changes = s.app.world().resource::<Changes>();
    assert_eq!((changes.events, changes.added, changes.removed), (5, 3, 3));
    assert_eq!((changes.on_add, changes.on_remove), (3, 3));
}

#[test]
fn a_drag_selects_what_its_rectangle_holds_shift_adds_and_escape_clears() {
    let mut s = scene();
    // Corners at the grid's gaps, so that no centre lies on an edge.
    let (from, to) = (
        s.screen(Vec3::new(-6.0, 0.0, -4.0)),
        s.screen(Vec3::new(4.0, 0.0, 2.0)),
    );
    let want = s.projected_inside(from, to);
    assert!(want.len() > 10, "the box holds {} cubes", want.len());
    s.drag(from, to);
    assert_eq!(
        s.selected(),
        want,
        "a drag selects the cubes whose centre it holds"
    );
    // Inverted (dragged up and left), elsewhere, replacing the selection.
    let (from2, to2) = (
        s.screen(Vec3::new(10.0, 0.0, 10.0)),
        s.screen(Vec3::new(6.0, 0.0, 6.0)),
    );
    let want2 = s.projected_inside(from2, to2);
    assert!(!want2.is_empty());
    s.drag(from2, to2);
    assert_eq!(s.selected(), want2, "a drag replaces the selection");
    s.key(KeyCode::ShiftRight, ButtonState::Pressed);
    s.drag(from, to);
    let mut union = [want.clone(), want2.clone()].concat();
    union.sort_unstable();
    union.dedup();
    assert_eq!(s.selected(), union, "shift adds a drag's cubes");
    s.key(KeyCode::ShiftRight, ButtonState::Released);
    // Replacing a selection it overlaps: what both hold stays (neither removed nor added
    // again), the rest of the old goes, the rest of the new comes.
    let from3 = s.screen(Vec3::new(-2.0, 0.0, -8.0));
    let want3 = s.projected_inside(from3, to);
    let kept = union.iter().filter(|e| want3.contains(e)).count();
    assert!(kept > 0 && kept < want3.len() && kept < union.len());
    let before = (s.changes().added, s.changes().removed);
    s.drag(from3, to);
    assert_eq!(
        s.selected(),
        want3,
        "a drag replaces an overlapping selection"
    );
    let after = (s.changes().added, s.changes().removed);
    assert_eq!(
        (after.0 - before.0, after.1 - before.1),
        (want3.len() - kept, union.len() - kept),
        "the change reports only what came and went"
    );
    // A press that moves less than the threshold is a click, not a drag.
    s.move_to(from);
    s.button(ButtonState::Pressed);
    s.move_to(from + Vec2::splat(1.0));
    assert!(
        s.app
            .world()
            .resource::<AccelSelectionDrag>()
            .rectangle()
            .is_none(),
        "a pointer that moved a pixel is not dragging"
    );
    s.button(ButtonState::Released);
    s.key(KeyCode::Escape, ButtonState::Pressed);
    assert!(s.selected().is_empty(), "Escape clears");
    s.key(KeyCode::Escape, ButtonState::Released);
    // Each entity selected or deselected went through `Selected`'s own lifecycle once.
    let changes = s.changes();
    assert!(changes.removed > 0);
    assert_eq!(
        (changes.on_add, changes.on_remove),
        (changes.added, changes.removed),
        "`On<Add, Selected>` and `On<Remove, Selected>` as the changes report"
    );
    // The mouse off: nothing changes.
    s.app
        .world_mut()
        .resource_mut::<AccelSelectionSettings>()
        .enabled = false;
    s.drag(from, to);
    assert!(
        s.selected().is_empty(),
        "a disabled selection ignores the mouse"
    );
}
