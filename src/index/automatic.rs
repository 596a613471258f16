//! [`IndexChoice::Automatic`]: the movers' index chosen from the frames the plugin sees,
//! by the core's [`IndexAdvisor`].

use super::IndexChoice;
use crate::settings::AccelSettings;
use crate::stats::AccelStats;
use bevy::prelude::*;
use spatial_accel::query::{IndexAdvice, IndexAdvisor, IndexWorkload};

/// The thresholds of [`IndexChoice::Automatic`], in
/// [`AccelSettings::automatic`](crate::AccelSettings::automatic). The defaults follow the
/// whole-frame figures (BENCHMARKS.md, Whole frame): the grid for a busy set of movers that
/// few rays walk, whatever the views see; the BVH otherwise.
#[derive(Reflect, Clone, Debug, PartialEq)]
#[reflect(Default)]
pub struct AutomaticIndexSettings {
    /// Below this many dynamic entities the BVH is kept.
    pub min_entities: usize,
    /// The grid is taken when at least this share of the dynamic entities moves a frame.
    pub grid_above_moved_share: f32,
    /// The BVH is taken back when the share falls below this (below the other threshold,
    /// so that a workload between them does not flip the index back and forth).
    pub bvh_below_moved_share: f32,
    /// More rays than this per frame (picking, the preview, `AccelRayCast` users) keep the
    /// BVH, whose rays are several times faster.
    pub max_rays_for_grid: f32,
    /// Frames the evidence must hold before a switch.
    pub hold_frames: u32,
    /// Frames after a switch before another: each moves every dynamic entity.
    pub frames_between_switches: u32,
}

impl Default for AutomaticIndexSettings {
    fn default() -> Self {
        let a = IndexAdvice::default();
        Self {
            min_entities: a.min_entries,
            grid_above_moved_share: a.grid_above_moved_share,
            bvh_below_moved_share: a.bvh_below_moved_share,
            max_rays_for_grid: a.max_rays_for_grid,
            hold_frames: a.hold_frames,
            frames_between_switches: a.frames_between_switches,
        }
    }
}

impl AutomaticIndexSettings {
    /// The core's thresholds.
    pub fn advice(&self) -> IndexAdvice {
        IndexAdvice {
            min_entries: self.min_entities,
            grid_above_moved_share: self.grid_above_moved_share,
            bvh_below_moved_share: self.bvh_below_moved_share,
            max_rays_for_grid: self.max_rays_for_grid,
            hold_frames: self.hold_frames,
            frames_between_switches: self.frames_between_switches,
        }
    }
}

/// What the automatic choice last saw, in [`AccelStats::automatic`](crate::AccelStats).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AutomaticIndexStats {
    /// The structure it recommends now.
    pub recommended: IndexChoice,
    /// Averaged share of the dynamic entities moved a frame.
    pub moved_share: f32,
    /// Averaged rays a frame.
    pub rays_per_frame: f32,
}

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

/// Feeds the last frame's workload to the advisor, before the sync that may act on it. Runs
/// only while the choice is automatic, so a fixed index pays nothing for it.
pub(crate) fn advise_index(
    settings: Res<AccelSettings>,
    mut automatic: ResMut<AutomaticIndex>,
    mut stats: ResMut<AccelStats>,
) {
    if settings.index != IndexChoice::Automatic {
        stats.automatic = None;
        return;
    }
    let advice = settings.automatic.advice();
    if *automatic.0.advice() != advice {
        automatic.0.set_advice(advice);
    }
    let kind = automatic.0.observe(IndexWorkload {
        entries: stats.dynamic_entities,
        // The index's own movers: the busy movers' moves are no work of the index's.
        moved: stats.moved - stats.busy_moved,
        rays: stats.rays_per_frame,
    });
    stats.automatic = Some(AutomaticIndexStats {
        recommended: IndexChoice::of_kind(kind),
        moved_share: automatic.0.moved_share(),
        rays_per_frame: automatic.0.rays_per_frame(),
    });
}

#[cfg(test)]
mod tests {
    use super::*;

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
