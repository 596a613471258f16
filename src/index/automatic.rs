//! [`IndexChoice::Automatic`]: the movers' index chosen from the frames the plugin sees,
//! by the core's [`IndexAdvisor`].

use super::IndexChoice;
use bevy::prelude::*;
use spatial_accel::query::IndexAdvice;

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
    /// The structure it recommends after this frame's figures: the next frame's switch
    /// moves the movers there (at once for a few, off the frame for many).
    pub recommended: IndexChoice,
    /// Averaged share of the dynamic entities moved a frame.
    pub moved_share: f32,
    /// Averaged rays a frame.
    pub rays_per_frame: f32,
}
