//! The examples' screenshot mode: `ACCEL_SCREENSHOT=out.png` saves a frame and exits, with an
//! error unless the example's own check passes. How `.ci/real-window` tests them.

// Each example includes this file and uses part of it.
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
