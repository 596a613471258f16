//! Whether the trees stand still this frame because nothing would gain from them, in a world
//! that no registered reader walks: a small one (below
//! [`AccelSettings::step_aside_below`](crate::AccelSettings::step_aside_below) entities),
//! where Bevy's own culling costs less than the trees' upkeep and the plugin's systems cost
//! the executor (BENCHMARKS.md, Whole frame); or one of any size in which Bevy's culling,
//! timed beside the trees', costs less (`cost_probe`).
//!
//! The state is atomics because it is decided in a run condition, which reads resources
//! only: one decision a frame, before any of the plugin's other conditions in `PostUpdate`
//! (see `systems::step_aside`), so every system of a frame sees the same answer.

use super::AccelTrees;
use super::cost_probe::{CostProbe, FrameCosts, ProbeVerdict, StepAsideProbe};
use bevy::log::warn;
use bevy::prelude::{FromWorld, World};
use core::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

/// Frames a small world with no reader must stay so before the trees step aside. Why wait:
/// a world being spawned passes through small sizes, and readers in schedules that first
/// run a few frames in register late; stepping aside and back would cost a catch-up each.
pub(crate) const STEP_ASIDE_AFTER_FRAMES: u32 = 30;

/// The step-aside state kept in [`AccelTrees`].
#[derive(Default)]
pub(crate) struct StepAside {
    /// This frame's decision: the trees stand still.
    aside: AtomicBool,
    /// Bevy's own culling is in the app to stand in for the trees' (the culling plugin put it
    /// back): without it nothing gains from stepping aside, as whoever added the trees
    /// alone reads them.
    stand_in: AtomicBool,
    /// Readers that need current trees whatever the world's size: the plugins that read them
    /// and the systems with a reading parameter (`AccelRayCast`, `AccelSpatialQuery`), each
    /// counted once when it is set up.
    readers: AtomicUsize,
    /// The trees were read directly while aside: a reader the plugin could not see.
    read_while_aside: AtomicBool,
    /// Whether that read was warned about (once).
    warned: AtomicBool,
    /// Consecutive frames the world could have stepped aside.
    quiet_frames: AtomicU32,
    /// This frame runs Bevy's passes before the trees' to time both (`cost_probe`).
    probing: AtomicBool,
    /// The running frame's costs, added to by the systems of both sides (shared with the
    /// timers around Bevy's passes).
    costs: Arc<FrameCosts>,
    /// The measured choice's state; locked once a frame, by the decision.
    probe: Mutex<CostProbe>,
}

impl StepAside {
    /// Decides this frame from whether the world is small, whether the measured choice may
    /// step it aside (`measure`) and the last frame's costs; returns true while the trees are
    /// kept current. Called once a frame.
    pub(crate) fn decide(&self, small_world: bool, measure: bool) -> bool {
        let costs = self.costs.take();
        if self.read_while_aside.swap(false, Ordering::Relaxed) {
            // An unseen reader stays a reader: waking only for its next read would leave that
            // read stale again after the next step aside.
            self.readers.fetch_add(1, Ordering::Relaxed);
        }
        let may =
            self.stand_in.load(Ordering::Relaxed) && self.readers.load(Ordering::Relaxed) == 0;
        let mut probe = self.probe.lock().unwrap_or_else(PoisonError::into_inner);
        let verdict = if may && small_world {
            probe.reset();
            self.small_world_verdict()
        } else if may && measure {
            self.quiet_frames.store(0, Ordering::Relaxed);
            probe.next(costs)
        } else {
            probe.reset();
            self.quiet_frames.store(0, Ordering::Relaxed);
            ProbeVerdict::Awake
        };
        self.aside
            .store(verdict == ProbeVerdict::Aside, Ordering::Relaxed);
        self.probing
            .store(verdict == ProbeVerdict::Probe, Ordering::Relaxed);
        verdict != ProbeVerdict::Aside
    }

    /// A small world with no reader steps aside once it has stayed so for a while.
    fn small_world_verdict(&self) -> ProbeVerdict {
        if self.aside.load(Ordering::Relaxed) {
            return ProbeVerdict::Aside;
        }
        let quiet = self.quiet_frames.fetch_add(1, Ordering::Relaxed) + 1;
        if quiet >= STEP_ASIDE_AFTER_FRAMES {
            ProbeVerdict::Aside
        } else {
            ProbeVerdict::Awake
        }
    }

    /// Whether Bevy's passes run this frame: aside, or beside the trees' in a probe frame.
    #[inline]
    #[cfg_attr(not(feature = "culling"), allow(dead_code))]
    pub(crate) fn bevy_passes_run(&self) -> bool {
        self.is_aside() || self.probing.load(Ordering::Relaxed)
    }

    /// The running frame's costs, for the systems of both sides to add to.
    #[inline]
    pub(crate) fn costs(&self) -> &Arc<FrameCosts> {
        &self.costs
    }

    /// This frame's decision (false before the first).
    #[inline]
    pub(crate) fn is_aside(&self) -> bool {
        self.aside.load(Ordering::Relaxed)
    }

    /// Notes that Bevy's culling stands ready to run in place of the trees'.
    #[cfg_attr(not(feature = "culling"), allow(dead_code))]
    pub(crate) fn set_stand_in(&self) {
        self.stand_in.store(true, Ordering::Relaxed);
    }

    /// Registers a reader for as long as the app lives.
    pub(crate) fn add_reader(&self) {
        self.readers.fetch_add(1, Ordering::Relaxed);
    }

    /// Whether a plugin or system that reads the trees is registered (or was seen reading).
    #[inline]
    pub(crate) fn has_readers(&self) -> bool {
        self.readers.load(Ordering::Relaxed) > 0
    }

    /// Notes a public read of the trees made while they stood aside or while the busy movers'
    /// boxes were out of date: they are kept current from the next decision on, with one
    /// warning.
    #[cold]
    pub(crate) fn note_unseen_read(&self) {
        self.read_while_aside.store(true, Ordering::Relaxed);
        if !self.warned.swap(true, Ordering::Relaxed) {
            warn!(
                "bevy_accel: `AccelTrees` was read while the trees stood aside (a world with \
                 no registered reader, below `AccelSettings::step_aside_below` entities or \
                 whose culling Bevy's own pass was timed doing for less) or while no view read \
                 the busy movers' boxes (`AccelSettings::skip_unread_mover_upkeep`), so this \
                 read may have seen entities where they were some frames ago; they are kept \
                 current from the next frame on. Read them through `AccelSpatialQuery::trees` \
                 or `AccelRayCast::trees`, which register their system, or turn those settings \
                 off."
            );
        }
    }
}

/// Registers the system that holds it as a reader of the trees, when the system is set up
/// (through `Local`, whose `FromWorld` runs then): the trees of a world it reads never step
/// aside.
pub(crate) struct TreeReaderPin;

impl FromWorld for TreeReaderPin {
    fn from_world(world: &mut World) -> Self {
        if let Some(trees) = world.get_resource::<AccelTrees>() {
            trees.step_aside.add_reader();
        }
        Self
    }
}

impl AccelTrees {
    /// Whether the trees stand still this frame: they serve
    /// [`AccelCullingPlugin`](crate::AccelCullingPlugin) alone (no other plugin or system
    /// that reads them is registered), and the world is small
    /// ([`AccelSettings::step_aside_below`](crate::AccelSettings::step_aside_below)) or
    /// Bevy's own culling was timed cheaper than the trees'
    /// ([`AccelSettings::step_aside_when_slower`](crate::AccelSettings::step_aside_when_slower)).
    /// The plugin's systems then skip their upkeep and Bevy's own culling runs in place of the
    /// trees'. They catch up, from every change made meanwhile, in the frame they wake: the
    /// world grows, a reader appears, or a trial wakes them to time both sides again.
    pub fn stepped_aside(&self) -> bool {
        self.step_aside.is_aside()
    }

    /// The costs timed in the last probe frame of
    /// [`AccelSettings::step_aside_when_slower`](crate::AccelSettings::step_aside_when_slower):
    /// the trees' upkeep and culling, and Bevy's culling run beside them. `None` before the
    /// first probe (or in an app whose trees have readers, which never probes).
    pub fn last_step_aside_probe(&self) -> Option<StepAsideProbe> {
        self.step_aside
            .probe
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .last()
    }

    /// Registers a reader that needs current trees at any size (a plugin that reads them).
    pub(crate) fn add_reader(&self) {
        self.step_aside.add_reader();
    }

    /// Tracked entities, for the plugin's own bookkeeping (not a read that wakes the trees).
    pub(crate) fn tracked_len(&self) -> usize {
        self.tracked_count
    }
}

/// Registers a plugin that reads the trees every frame (called from its `Plugin::finish`,
/// when every plugin is built and `AccelTrees` exists whatever the order they were added in).
#[cfg_attr(
    not(any(
        feature = "picking",
        feature = "sprite_picking",
        feature = "selection",
        feature = "overlays",
        feature = "preview",
        feature = "egui"
    )),
    allow(dead_code)
)]
pub(crate) fn register_reader_plugin(app: &bevy::app::App) {
    if let Some(trees) = app.world().get_resource::<AccelTrees>() {
        trees.add_reader();
    }
}
