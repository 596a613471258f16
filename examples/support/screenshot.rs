//! The examples' screenshot mode: `ACCEL_SCREENSHOT=out.png` saves a frame and exits, with an
//! error unless the example's own check passes. How `.ci/real-window` tests them.

// Each example uses part of it.
#![allow(dead_code)]

use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, save_to_disk};

/// Whether the example runs in screenshot mode.
pub fn screenshot_mode() -> bool {
    std::env::var_os("ACCEL_SCREENSHOT").is_some()
}

/// Counts screenshot-mode frames: saves frame 30 to the `ACCEL_SCREENSHOT` path and returns
/// true at frame 40, when the example checks itself and exits. Always false outside
/// screenshot mode.
pub fn check_due(commands: &mut Commands, frame: &mut u32) -> bool {
    let Ok(path) = std::env::var("ACCEL_SCREENSHOT") else {
        return false;
    };
    *frame += 1;
    if *frame == 30 {
        commands
            .spawn(Screenshot::primary_window())
            .observe(save_to_disk(path));
    }
    *frame == 40
}

/// Exits with success when `passed`, logging `what` either way.
pub fn exit_with(exit: &mut MessageWriter<AppExit>, passed: bool, what: String) {
    if passed {
        info!("{what}");
        exit.write(AppExit::Success);
    } else {
        error!("{what}");
        exit.write(AppExit::error());
    }
}

/// Screenshot mode's pointer: moves the mouse over `target` (a world point seen by
/// `camera`) at frame 10, presses its primary button at 12 and releases it at 14, as
/// bevy_picking's input from a window would. `frame` counts from the first call.
pub fn synthetic_click(
    frame: u32,
    window: Entity,
    (camera, camera_tf): (&Camera, &GlobalTransform),
    target: Vec3,
    input: &mut MessageWriter<bevy::picking::pointer::PointerInput>,
) {
    use bevy::camera::NormalizedRenderTarget;
    use bevy::picking::pointer::{Location, PointerAction, PointerButton, PointerId, PointerInput};
    use bevy::window::WindowRef;
    let (Ok(position), Some(window_ref)) = (
        camera.world_to_viewport(camera_tf, target),
        WindowRef::Primary.normalize(Some(window)),
    ) else {
        return;
    };
    let location = Location {
        target: NormalizedRenderTarget::Window(window_ref),
        position,
    };
    let action = match frame {
        10 => PointerAction::Move { delta: Vec2::ZERO },
        12 => PointerAction::Press(PointerButton::Primary),
        14 => PointerAction::Release(PointerButton::Primary),
        _ => return,
    };
    input.write(PointerInput::new(PointerId::Mouse, location, action));
}

/// Screenshot mode's pointer motion: moves the mouse to `position` (logical pixels) of the
/// primary `window`, as bevy_picking's input from a window would.
pub fn move_pointer(
    window: Entity,
    position: Vec2,
    input: &mut MessageWriter<bevy::picking::pointer::PointerInput>,
) {
    use bevy::camera::NormalizedRenderTarget;
    use bevy::picking::pointer::{Location, PointerAction, PointerId, PointerInput};
    use bevy::window::WindowRef;
    let Some(window_ref) = WindowRef::Primary.normalize(Some(window)) else {
        return;
    };
    let location = Location {
        target: NormalizedRenderTarget::Window(window_ref),
        position,
    };
    let action = PointerAction::Move { delta: Vec2::ZERO };
    input.write(PointerInput::new(PointerId::Mouse, location, action));
}
