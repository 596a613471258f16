//! Whether the trees stand still this frame because nothing would gain from them: a small
//! world (below [`AccelSettings::step_aside_below`](crate::AccelSettings::step_aside_below)
//! entities) that no registered reader walks, where Bevy's own culling costs less than the
//! trees' upkeep and the plugin's systems cost the executor (BENCHMARKS.md, Whole frame).
//!
//! The state is atomics because it is decided in a run condition, which reads resources
//! only: one decision a frame, before any of the plugin's other conditions in `PostUpdate`
//! (see `systems::step_aside`), so every system of a frame sees the same answer.

use super::AccelTrees;
use bevy::log::warn;
use bevy::prelude::{FromWorld, World};
use core::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};

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
}

impl StepAside {
    /// Decides this frame from whether the world may step aside (small, no reader); returns
    /// true while the trees are kept current. Called once a frame.
    pub(crate) fn decide(&self, small_world: bool) -> bool {
        if self.read_while_aside.swap(false, Ordering::Relaxed) {
            // An unseen reader stays a reader: waking only for its next read would leave that
            // read stale again after the next step aside.
            self.readers.fetch_add(1, Ordering::Relaxed);
        }
        let may = small_world
            && self.stand_in.load(Ordering::Relaxed)
            && self.readers.load(Ordering::Relaxed) == 0;
        if !may {
            self.quiet_frames.store(0, Ordering::Relaxed);
            self.aside.store(false, Ordering::Relaxed);
            return true;
        }
        if self.aside.load(Ordering::Relaxed) {
            return false;
        }
        let quiet = self.quiet_frames.fetch_add(1, Ordering::Relaxed) + 1;
        let aside = quiet >= STEP_ASIDE_AFTER_FRAMES;
        self.aside.store(aside, Ordering::Relaxed);
        !aside
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

    /// Notes a public read of the trees: one made while aside wakes them from the next
    /// decision on, with one warning.
    #[inline]
    pub(crate) fn note_read(&self) {
        if self.is_aside() {
            self.read_while_aside_slow();
        }
    }

    #[cold]
    fn read_while_aside_slow(&self) {
        self.read_while_aside.store(true, Ordering::Relaxed);
        if !self.warned.swap(true, Ordering::Relaxed) {
            warn!(
                "bevy_accel: `AccelTrees` was read while the trees stood aside (a world below \
                 `AccelSettings::step_aside_below` entities with no registered reader), so \
                 this read saw them as they were when they stepped aside; they are kept \
                 current from the next frame on. Read them through `AccelSpatialQuery::trees` \
                 or `AccelRayCast::trees`, which register their system, or set \
                 `step_aside_below` to 0."
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
    /// Whether the trees stand still this frame: the world is small
    /// ([`AccelSettings::step_aside_below`](crate::AccelSettings::step_aside_below)), the
    /// trees serve [`AccelCullingPlugin`](crate::AccelCullingPlugin) alone (no other plugin
    /// or system that reads them is registered), so the plugin's systems skip their upkeep and
    /// Bevy's own culling runs in place of the trees'. They catch up, from every
    /// change made meanwhile, in the frame the world grows or a reader appears.
    pub fn stepped_aside(&self) -> bool {
        self.step_aside.is_aside()
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
