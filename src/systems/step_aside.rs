//! The run conditions that step the trees aside in a world nothing reads (see
//! [`AccelTrees::stepped_aside`]): one decision a frame, made by the condition of the first
//! set of the plugin's chain, which the executor evaluates before any later system's.
//!
//! Why conditions and not a system: a system costs the executor a task and a thread wake-up
//! a frame whatever it does, which is what a small world cannot afford; a condition that
//! comes out false spawns no task.

use super::membership::PendingMembership;
use crate::settings::AccelSettings;
use crate::trees::AccelTrees;
use bevy::prelude::*;

/// Decides whether the trees step aside this frame; true while they are kept current.
/// Counts the entities waiting to join (spawned while aside, or re-inserted) as members: an
/// over-count wakes the trees early, never late.
pub(crate) fn decide_step_aside(
    trees: Res<AccelTrees>,
    settings: Res<AccelSettings>,
    pending: Res<PendingMembership>,
) -> bool {
    let members = trees.tracked_len() + pending.0.len();
    trees.step_aside.decide(
        members < settings.step_aside_below,
        settings.step_aside_when_slower,
    )
}

/// True while the trees are kept current this frame (read after [`decide_step_aside`]).
pub(crate) fn trees_awake(trees: Res<AccelTrees>) -> bool {
    !trees.stepped_aside()
}

/// True while Bevy's own culling passes run this frame (read after [`decide_step_aside`]): in
/// place of the trees' while they stand aside, or before them in a frame that times both.
#[cfg_attr(not(feature = "culling"), allow(dead_code))]
pub(crate) fn bevy_passes_run(trees: Res<AccelTrees>) -> bool {
    trees.step_aside.bevy_passes_run()
}
