//! Which structure holds the moving entities this frame: [`IndexChoice::Automatic`] resolved
//! by the core's [`IndexAdvisor`] from the last frames' workload, and a switch to another
//! structure started or landed.

use super::membership::RejectedEntities;
use crate::index::{AutomaticIndexStats, IndexChoice};
use crate::settings::AccelSettings;
use crate::stats::AccelStats;
use crate::trees::AccelTrees;
use bevy::prelude::*;
use core::time::Duration;
use spatial_accel::query::{IndexAdvisor, IndexWorkload};
use std::time::Instant;

/// The advisor behind [`IndexChoice::Automatic`].
#[derive(Resource, Default)]
pub(crate) struct AutomaticIndex(IndexAdvisor);

impl AutomaticIndex {
    /// The concrete structure `choice` asks for now.
    pub(crate) fn resolve(&self, choice: IndexChoice) -> IndexChoice {
        match choice {
            IndexChoice::Automatic => IndexChoice::of_kind(self.0.current()),
            fixed => fixed,
        }
    }
}

/// Starts, advances or lands the switch of the movers' index that the settings (or the
/// automatic choice) ask for. Runs only while one is due ([`index_switch_due`]): the choice
/// itself is made at the end of each frame's maintenance, so a frame with nothing to switch
/// spends no system on it (each costs the executor a task and a thread wake-up, which a small
/// world notices).
pub(crate) fn choose_index(
    settings: Res<AccelSettings>,
    automatic: Res<AutomaticIndex>,
    mut trees: ResMut<AccelTrees>,
    mut rejected: ResMut<RejectedEntities>,
    mut report: ResMut<IndexSwitchReport>,
) {
    switch_index(
        &settings,
        &automatic,
        &mut trees,
        &mut rejected,
        &mut report,
    );
}

/// Whether [`choose_index`] has work: a switch in flight, or an index other than the one the
/// settings ask for now.
pub(crate) fn index_switch_due(
    settings: Res<AccelSettings>,
    automatic: Res<AutomaticIndex>,
    trees: Res<AccelTrees>,
) -> bool {
    // Trees that stand aside switch nothing (and a read through `query` would wake them).
    !trees.stepped_aside()
        && (trees.index_switch_in_flight()
            || trees.index().choice() != automatic.resolve(settings.index))
}

/// Feeds the frame's workload to the advisor, once the frame's figures are published; the
/// next frame's [`choose_index`] acts on its advice. Does nothing while the choice is fixed.
pub(super) fn advise_index(
    settings: &AccelSettings,
    trees: &AccelTrees,
    automatic: &mut AutomaticIndex,
    stats: &mut AccelStats,
) {
    if settings.index != IndexChoice::Automatic {
        stats.automatic = None;
        return;
    }
    let advice = settings.automatic.advice();
    if *automatic.0.advice() != advice {
        automatic.0.set_advice(advice);
    }
    // Why: the frame's moves must be the index's own lasting work. While the busy movers'
    // list is off but will take the movers next frame (the first frame they move, or the
    // list coming back on), or is still filling (a frame's transfers spent, the rest of the
    // movers waiting), their moves are about to leave the index; and an entity joining the
    // list is counted moved once, as it is taken out. Counted as the index's, such frames
    // made the grid look wanted in a world whose movers all end up in the list, where the
    // BVH serves the still entities left in the index better (BENCHMARKS.md, Whole frame).
    let list_takes_movers_next = (!trees.busy_enabled()
        && settings
            .busy_movers
            .wanted(false, stats.moved, stats.rays_per_frame))
        || trees.busy_transfers_spent();
    let kind = if list_takes_movers_next {
        automatic.0.current()
    } else {
        automatic.0.observe(IndexWorkload {
            entries: stats.dynamic_entities,
            moved: stats
                .moved
                .saturating_sub(stats.busy_moved + trees.busy_joined()),
            rays: stats.rays_per_frame,
        })
    };
    stats.automatic = Some(AutomaticIndexStats {
        recommended: IndexChoice::of_kind(kind),
        moved_share: automatic.0.moved_share(),
        rays_per_frame: automatic.0.rays_per_frame(),
    });
}

/// What the index switch did this frame, for the sync's counts (which take it, so that a
/// frame without a switch counts nothing).
#[derive(Resource, Default)]
pub(crate) struct IndexSwitchReport {
    /// Dynamic entities moved into a new structure that landed this frame.
    pub(crate) moved: usize,
    /// Entities the new structure refused: they are out of the trees.
    pub(crate) refused: usize,
    /// Time the switch took this frame (counted in the sync's time).
    pub(crate) time: Duration,
}

/// Moves the dynamic entities towards the structure the settings (or the automatic choice)
/// ask for: at once for a few, else by a fill off the frame that lands in a later frame
/// ([`AccelSettings::index_switch_in_frame_up_to`]).
fn switch_index(
    settings: &AccelSettings,
    automatic: &AutomaticIndex,
    trees: &mut ResMut<AccelTrees>,
    rejected: &mut RejectedEntities,
    report: &mut IndexSwitchReport,
) {
    let start = Instant::now();
    let target = automatic.resolve(settings.index);
    let tree_state = trees.bypass_change_detection();
    let landed = tree_state.advance_index_switch(target, settings.index_switch_in_frame_up_to);
    let (mut moved, mut refused) = (0, 0);
    if let Some(landed) = landed {
        for (entity, why) in landed.refused.iter().copied() {
            rejected.reject(entity, why);
        }
        moved = landed.moved;
        refused = landed.refused.len();
        tree_state.note_index_changed();
        trees.set_changed();
    }
    *report = IndexSwitchReport {
        moved,
        refused,
        time: start.elapsed(),
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::index::AutomaticIndexSettings;
    use spatial_accel::query::IndexAdvice;

    #[test]
    fn automatic_resolves_to_the_advisors_structure_and_fixed_choices_to_themselves() {
        let auto = AutomaticIndex::default();
        assert_eq!(auto.resolve(IndexChoice::Automatic), IndexChoice::Bvh);
        for choice in IndexChoice::ALL {
            if choice != IndexChoice::Automatic {
                assert_eq!(auto.resolve(choice), choice);
            }
        }
        assert_eq!(
            AutomaticIndexSettings::default().advice(),
            IndexAdvice::default()
        );
    }
}
