//! Runtime settings of the plugin.

use crate::index::{AutomaticIndexSettings, BvhIndexSettings, IndexChoice};
use crate::trees::BusyMoverSettings;
use bevy::prelude::*;
use core::time::Duration;

/// What the trees keep and how hard they work to stay good. Change it at runtime as a
/// resource; the plugin reads it every frame.
///
/// The fields here hold for every index; [`bvh`](Self::bvh) holds the BVH backend's own.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default)]
pub struct AccelSettings {
    /// Master switch: when off, no system touches the trees (they keep their last state, and
    /// catch up when it is turned back on).
    pub enabled: bool,
    /// Track only entities with [`AccelTracked`](crate::AccelTracked) instead of every entity
    /// with an `Aabb` and a `GlobalTransform`.
    pub require_marker: bool,
    /// Watch [`AccelStatic`](crate::AccelStatic) entities for motion too, rebuilding the
    /// static tree when one moves. Off by default: the marker promises the entity does not
    /// move, and watching costs a change-detection scan over every static entity each frame
    /// (BENCHMARKS.md, Plugin sync). A static entity that moves while this is off
    /// keeps its old box until the marker is removed or inserted again.
    pub watch_static_motion: bool,
    /// The structure that holds the moving entities; [`IndexChoice::Automatic`] by default.
    /// Changing it moves every dynamic entity into a new index of that kind at the next sync
    /// (one insertion each); queries see the same entities before and after.
    pub index: IndexChoice,
    /// A change of [`index`](Self::index) (or of the automatic choice) with at most this many
    /// dynamic entities moves them in the frame; with more, the new structure is filled on
    /// Bevy's async compute pool while the old one serves, and swapped in when done (see
    /// [`AccelTrees::index_switch_in_flight`](crate::AccelTrees::index_switch_in_flight)),
    /// so that a switch never stalls a frame by a whole fill.
    pub index_switch_in_frame_up_to: usize,
    /// Time the dynamic index may spend per frame improving itself (the BVH's optimiser), in
    /// microseconds.
    pub upkeep_budget_micros: u32,
    /// Static sets up to this many entities get their static tree rebuilt in the frame that
    /// changes them; larger ones build it off the frame on Bevy's async compute pool, and
    /// hold the static entities spawned meanwhile in the dynamic index (see
    /// [`AccelTrees::static_waiting_len`](crate::AccelTrees::static_waiting_len)), so that
    /// streaming scenery in or out never stalls a frame by a whole build. A first load, or
    /// one that more than doubles the static set, is built in its frame whatever this says.
    /// The default, 0, sends every other rebuild off the frame: even a level of a thousand
    /// entities streamed its frames faster so (BENCHMARKS.md, Static scenery streaming).
    /// Raise it for tests that want the static tree complete after each update.
    pub static_rebuild_in_frame_up_to: usize,
    /// How the static tree is built. Changing it rebuilds the static tree (as a change of the
    /// static set does: off the frame for large sets).
    pub static_build: StaticTreeBuild,
    /// The BVH backend's settings, read while the BVH holds the movers ([`IndexChoice::Bvh`],
    /// or [`IndexChoice::Automatic`] on the BVH).
    pub bvh: BvhIndexSettings,
    /// The thresholds of [`IndexChoice::Automatic`].
    pub automatic: AutomaticIndexSettings,
    /// When entities that move frame after frame leave the dynamic index for a flat list.
    pub busy_movers: BusyMoverSettings,
    /// Below this many entities in the trees (and those waiting to join), with no plugin or
    /// system registered as their reader, the trees step aside after a short while: the
    /// plugin's systems skip their upkeep and Bevy's own culling runs in place of theirs, so
    /// a small world pays next to nothing for the plugin. Readers register by being there:
    /// the picking, selection, overlay, preview and panel plugins, and every system with an
    /// `AccelRayCast`, an `AccelSelection` or an [`AccelSpatialQuery`](crate::AccelSpatialQuery).
    /// The trees catch up, from every change made meanwhile, in the frame the world grows
    /// past it or a reader appears (see [`AccelTrees::stepped_aside`](crate::AccelTrees::stepped_aside)).
    /// 0 turns this rule off; with [`step_aside_when_slower`](Self::step_aside_when_slower)
    /// off too, the trees are kept current at every size. The default lies where the trees
    /// stop paying for their upkeep at one and two compute threads (BENCHMARKS.md, Whole
    /// frame).
    pub step_aside_below: usize,
    /// In a world of any size whose trees serve culling alone (no registered reader, as for
    /// [`step_aside_below`](Self::step_aside_below)), step aside while Bevy's own culling
    /// costs less than the trees' upkeep and culling. Both are timed, now and then, in one
    /// frame that runs Bevy's passes before the trees' (their verdicts are the same); a few
    /// such frames in a row finding Bevy's clearly cheaper step the trees aside, and a trial
    /// wakes them now and then to time both again. Probes and trials grow rare while their
    /// answer holds. Which side wins depends on the views, the movers and the compute threads
    /// (BENCHMARKS.md, Whole frame); [`AccelTrees::last_step_aside_probe`](crate::AccelTrees::last_step_aside_probe)
    /// gives the last timing. Off, only the size decides.
    pub step_aside_when_slower: bool,
    /// Where the trees serve culling alone (no registered reader, as for
    /// [`step_aside_below`](Self::step_aside_below)) and no view read the busy movers last
    /// frame, leave their moves unwritten. A camera that sees most of the world takes a flat
    /// pass that gives every busy mover Bevy's own test and never reads their boxes, so with
    /// every view such a view (a ground or third-person camera) writing them is upkeep
    /// nothing uses. While they are out of date every view takes that flat pass and light
    /// views test every caster; the first frame a view would walk the trees (the camera
    /// turned to a narrow view) or a reader appears, the next sync writes every busy mover's
    /// current box. Off, their moves are written every frame. A scene whose lights cast
    /// shadows through the trees keeps them current.
    pub skip_unread_mover_upkeep: bool,
}

impl Default for AccelSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            require_marker: false,
            watch_static_motion: false,
            index: IndexChoice::default(),
            index_switch_in_frame_up_to: 10_000,
            upkeep_budget_micros: 500,
            static_rebuild_in_frame_up_to: 0,
            static_build: StaticTreeBuild::default(),
            bvh: BvhIndexSettings::default(),
            automatic: AutomaticIndexSettings::default(),
            busy_movers: BusyMoverSettings::default(),
            step_aside_below: 5_000,
            step_aside_when_slower: true,
            skip_unread_mover_upkeep: true,
        }
    }
}

impl AccelSettings {
    /// The dynamic index's per-frame improvement budget as a duration.
    pub fn upkeep_budget(&self) -> Duration {
        Duration::from_micros(self.upkeep_budget_micros as u64)
    }
}

/// The builder of the static tree, one of the core's [`spatial_accel::SplitStrategy`] choices.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default)]
pub enum StaticTreeBuild {
    /// PLOC, bottom-up clustering: the fastest build, and trees as good as binned SAH's for
    /// rays and views over entities (BENCHMARKS.md, Static BVH builds). The default, since the
    /// tree is rebuilt whenever scenery streams in or out.
    #[default]
    Ploc,
    /// Binned SAH, top-down (32 bins).
    BinnedSah,
    /// Full-sweep SAH: the quality reference, the slowest build.
    SweepSah,
    /// LBVH: a Morton sort and two linear passes; the fastest to build, the costliest tree.
    Lbvh,
    /// Object median on the longest axis: balanced, blind to empty space.
    Median,
}

impl StaticTreeBuild {
    /// Every choice, in declaration order.
    pub const ALL: [StaticTreeBuild; 5] = [
        StaticTreeBuild::Ploc,
        StaticTreeBuild::BinnedSah,
        StaticTreeBuild::SweepSah,
        StaticTreeBuild::Lbvh,
        StaticTreeBuild::Median,
    ];

    /// The core's split strategy behind this choice.
    ///
    /// ```
    /// use bevy_accel::StaticTreeBuild;
    /// assert_eq!(StaticTreeBuild::Lbvh.split(), bevy_accel::spatial_accel::SplitStrategy::Lbvh);
    /// ```
    pub fn split(self) -> spatial_accel::SplitStrategy {
        match self {
            Self::Ploc => spatial_accel::SplitStrategy::PLOC_FASTEST,
            Self::BinnedSah => spatial_accel::SplitStrategy::BinnedSah { bins: 32 },
            Self::SweepSah => spatial_accel::SplitStrategy::SweepSah,
            Self::Lbvh => spatial_accel::SplitStrategy::Lbvh,
            Self::Median => spatial_accel::SplitStrategy::Median,
        }
    }
}
