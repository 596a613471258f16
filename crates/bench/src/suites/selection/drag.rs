//! The frames of a drag: `AccelSelectionPlugin` driven by the mouse (its button through
//! Bevy's `InputPlugin`, its position as bevy_picking's pointer) over the field of units, each
//! frame of the drag timed whole (`App::update`) against the same app's idle frame.
//!
//! A drag is a press, two moves and a release; the release selects (the query, then the
//! `Selected` inserts and removals). The first drag selects into an empty selection; the
//! second, over a box shifted by half its width, replaces it.

use crate::json::Point;
use crate::suites::point;
use crate::timing::median;
use bevy::camera::NormalizedRenderTarget;
use bevy::input::ButtonState;
use bevy::input::mouse::MouseButtonInput;
use bevy::picking::pointer::{Location, PointerId, PointerLocation};
use bevy::prelude::*;
use bevy::window::{PrimaryWindow, WindowRef};
use bevy_accel::prelude::*;
use std::time::Instant;

/// Drags timed a size; medians are reported.
const DRAGS: usize = 7;

/// The scene's app with the input a window would give, and the pointer.
struct DragApp {
    app: App,
    window: Entity,
    pointer: Entity,
    target: NormalizedRenderTarget,
}

impl DragApp {
    /// The query suite's app for its scene (with the input plugin), given a window and a
    /// pointer.
    fn new(mut app: App) -> Self {
        let window = app
            .world_mut()
            .spawn((
                Window {
                    resolution: (1280u32, 720u32).into(),
                    ..default()
                },
                PrimaryWindow,
            ))
            .id();
        let pointer = app
            .world_mut()
            .spawn((PointerId::Mouse, PointerLocation::default()))
            .id();
        let target = NormalizedRenderTarget::Window(
            WindowRef::Primary
                .normalize(Some(window))
                .expect("the primary window"),
        );
        app.update();
        Self {
            app,
            window,
            pointer,
            target,
        }
    }

    /// Runs one frame, the seconds it took.
    fn frame(&mut self) -> f64 {
        let start = Instant::now();
        self.app.update();
        start.elapsed().as_secs_f64()
    }

    fn move_to(&mut self, position: Vec2) {
        let location = Location {
            target: self.target.clone(),
            position,
        };
        self.app
            .world_mut()
            .entity_mut(self.pointer)
            .insert(PointerLocation::new(location));
    }

    fn button(&mut self, state: ButtonState) {
        let window = self.window;
        self.app.world_mut().write_message(MouseButtonInput {
            button: MouseButton::Left,
            state,
            window,
        });
    }

    /// One drag from `a` to `b`: the press frame, the two move frames, the release frame.
    fn drag(&mut self, a: Vec2, b: Vec2) -> [f64; 4] {
        self.move_to(a);
        self.button(ButtonState::Pressed);
        let press = self.frame();
        self.move_to((a + b) / 2.0);
        let move1 = self.frame();
        self.move_to(b);
        let move2 = self.frame();
        self.button(ButtonState::Released);
        let release = self.frame();
        [press, move1, move2, release]
    }

    /// Deselects everything, untimed.
    fn clear(&mut self) {
        let world = self.app.world_mut();
        let selected: Vec<Entity> = world
            .query_filtered::<Entity, With<Selected>>()
            .iter(world)
            .collect();
        for entity in selected {
            world.entity_mut(entity).remove::<Selected>();
        }
        self.app.update();
    }

    fn selected(&mut self) -> usize {
        let world = self.app.world_mut();
        world
            .query_filtered::<(), With<Selected>>()
            .iter(world)
            .count()
    }
}

/// Times the drags over the app's scene (`units` names it) with boxes holding about each
/// of `shares` of the units; markdown rows and plot points.
pub(super) fn run(
    app: App,
    units: &str,
    shares: &[f32],
    rows: &mut Vec<String>,
    points: &mut Vec<Point>,
) {
    let mut app = DragApp::new(app);
    for &share in shares {
        drags(&mut app, units, share, rows, points);
    }
}

fn drags(
    app: &mut DragApp,
    units: &str,
    share: f32,
    rows: &mut Vec<String>,
    points: &mut Vec<Point>,
) {
    // The rectangle of the query suite (a centred square of `share` of the screen), in
    // logical pixels, and the same shifted right by half its width.
    let size = Vec2::new(1280.0, 720.0);
    let half = Vec2::splat(share.sqrt()) * size / 2.0;
    let (a, b) = (size / 2.0 - half, size / 2.0 + half);
    let shift = Vec2::new(half.x, 0.0);
    let (mut idle, mut moves, mut first, mut replace) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut selected = 0;
    for _ in 0..DRAGS {
        app.clear();
        // Idle frames between the drags, so that a drift of the machine moves both alike.
        idle.extend([app.frame(), app.frame(), app.frame()]);
        let [p, m1, m2, r] = app.drag(a, b);
        moves.extend([p, m1, m2]);
        first.push(r);
        selected = app.selected();
        let [p, m1, m2, r] = app.drag(a + shift, b + shift);
        moves.extend([p, m1, m2]);
        replace.push(r);
    }
    // The median: a frame of the scene is now and then a few milliseconds slower, drag or
    // not (the VM, the trees' upkeep), and the drag adds nothing to these frames.
    let moves = median(moves);
    let idle = median(idle);
    let first = median(first);
    let replace = median(replace);
    let scene = format!("{units} units, {}% inside, drag", share * 100.0);
    for (name, seconds) in [
        ("idle frame", idle),
        ("press or move frame", moves),
        ("release frame, empty selection", first),
        ("release frame, replacing", replace),
    ] {
        points.push(point(
            &scene,
            "accel",
            name,
            ("ms", seconds * 1e3),
            ("selected", Some(selected as f64)),
        ));
    }
    rows.push(format!(
        "| {} | {}% | {} | {} | {} (+{}) | {} (+{}) | {} (+{}) |",
        units,
        share * 100.0,
        selected,
        super::ms(idle),
        super::ms(moves),
        super::ms((moves - idle).max(0.0)),
        super::ms(first),
        super::ms((first - idle).max(0.0)),
        super::ms(replace),
        super::ms((replace - idle).max(0.0)),
    ));
}
