//! When entities that move frame after frame leave the dynamic index for a flat list.

use bevy::prelude::*;

/// Whether movers may become busy movers (see [`BusyMoverSettings`]).
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default)]
pub enum BusyMovers {
    /// Every mover stays in the dynamic index.
    Off,
    /// Every dynamic entity that moves joins the list (and leaves it once quiet).
    On,
    /// The list is used while many entities move and few rays are cast (the thresholds of
    /// [`BusyMoverSettings`]): the whole-frame figures behind it are in BENCHMARKS.md,
    /// Whole frame.
    #[default]
    Automatic,
}

/// The busy movers: dynamic entities that moved in the last frames, held in a flat list
/// outside the dynamic index ([`EntityIndex::busy_movers`](crate::EntityIndex::busy_movers)).
///
/// A mover in a tree costs its sync several cache misses and the tree a refit; in the list
/// it costs one entry write, and every query tests it flat (one box test an entry for a
/// frustum or a ray). So the list pays where many entities move and queries are few
/// (culling, one pointer ray), and loses where many rays are cast (the preview, ray-heavy
/// gameplay). Queries, culling and picking see the same entities either way.
#[derive(Reflect, Clone, Debug, PartialEq)]
#[reflect(Default)]
pub struct BusyMoverSettings {
    /// When the list is used.
    pub mode: BusyMovers,
    /// Frames without a move after which a busy mover goes back into the dynamic index.
    pub quiet_frames: u32,
    /// Entities that may join or leave the list in one frame: each is an edit of the
    /// dynamic index, so a crowd starting or stopping is spread over frames.
    pub transfers_per_frame: usize,
    /// Busy movers checked for quiet each frame, at least (the sweep goes round the list,
    /// an eighth of it a frame when it is longer).
    pub checks_per_frame: usize,
    /// [`BusyMovers::Automatic`] uses the list from this many movers a frame, and stops
    /// below half of it.
    pub min_movers: usize,
    /// [`BusyMovers::Automatic`] uses the list while at most this many rays a frame are
    /// cast through the trees ([`AccelStats::rays_per_frame`](crate::AccelStats)), and
    /// stops above twice it.
    pub max_rays: f32,
}

impl Default for BusyMoverSettings {
    fn default() -> Self {
        Self {
            mode: BusyMovers::default(),
            quiet_frames: 30,
            transfers_per_frame: 32_768,
            checks_per_frame: 4_096,
            min_movers: 2_000,
            max_rays: 16.0,
        }
    }
}

impl BusyMoverSettings {
    /// Whether movers may join the list this frame, from the last frame's `movers` and
    /// averaged `rays`, and whether they could last frame (`was_on`, for the hysteresis).
    ///
    /// ```
    /// use bevy_accel::{BusyMoverSettings, BusyMovers};
    /// let auto = BusyMoverSettings::default();
    /// assert!(auto.wanted(false, 50_000, 1.0));
    /// assert!(!auto.wanted(false, 50_000, 5_000.0));
    /// // Between the thresholds, the last answer holds.
    /// assert!(auto.wanted(true, auto.min_movers * 3 / 4, 1.0));
    /// assert!(!auto.wanted(false, auto.min_movers * 3 / 4, 1.0));
    /// let off = BusyMoverSettings { mode: BusyMovers::Off, ..auto };
    /// assert!(!off.wanted(true, 50_000, 1.0));
    /// ```
    pub fn wanted(&self, was_on: bool, movers: usize, rays: f32) -> bool {
        match self.mode {
            BusyMovers::Off => false,
            BusyMovers::On => true,
            BusyMovers::Automatic if was_on => {
                movers >= self.min_movers / 2 && rays <= self.max_rays * 2.0
            }
            BusyMovers::Automatic => movers >= self.min_movers && rays <= self.max_rays,
        }
    }

    /// Busy movers to check for quiet this frame, out of `len`.
    pub fn checks(&self, len: usize) -> usize {
        self.checks_per_frame.max(len / 8)
    }
}
