//! The busy movers' moves left unwritten while nothing reads them (see
//! [`AccelSettings::skip_unread_mover_upkeep`](crate::AccelSettings::skip_unread_mover_upkeep)).
//!
//! Why: a camera that sees most of the world takes the flat pass, which gives every busy mover
//! Bevy's own frustum test and never reads the list's boxes (`TreeVerdicts`). Where the trees
//! serve culling alone and every view is such a view, writing the busy movers' moves is upkeep
//! that nothing uses, and where many entities move it costs about what Bevy's whole culling
//! pass does (BENCHMARKS.md, Whole frame).
//!
//! How: each frame the culling says whether it read (or would have read) the busy movers; the
//! next frame's sync skips their moves only if it did not, and no reader is registered. While
//! their boxes are stale, every view takes the flat pass and light views test every caster;
//! one that would have walked the trees says so, and the next sync writes every busy mover's
//! current box before anything reads them again.

use core::sync::atomic::{AtomicBool, Ordering};

/// Whether the busy movers' boxes are current, and what last frame's culling read of them.
#[derive(Default)]
pub(crate) struct UnreadMovers {
    /// The busy movers' boxes are out of date: the sync skipped their moves.
    stale: bool,
    /// Last frame's camera culling ran and read no busy mover's box, nor would have with
    /// them current.
    cameras_unread: AtomicBool,
    /// Last frame a light view read the busy movers (or would have).
    lights_read: AtomicBool,
}

impl UnreadMovers {
    /// Whether the busy movers' boxes are out of date.
    #[inline]
    pub(crate) fn is_stale(&self) -> bool {
        self.stale
    }

    /// The sync's choice for this frame, from last frame's reports (taken): skip the busy
    /// movers' moves when `allowed` (the setting is on and no reader is registered) and no
    /// view read them.
    pub(crate) fn take_skip(&self, allowed: bool) -> bool {
        let cameras_unread = self.cameras_unread.swap(false, Ordering::Relaxed);
        let lights_read = self.lights_read.swap(false, Ordering::Relaxed);
        allowed && cameras_unread && !lights_read
    }

    /// Notes whether the busy movers' boxes are left out of date this frame.
    pub(crate) fn set_stale(&mut self, stale: bool) {
        self.stale = stale;
    }

    /// The camera culling's report for the frame: whether some view read the busy movers or
    /// would have (a view that walks the trees).
    #[cfg_attr(not(feature = "culling"), allow(dead_code))]
    pub(crate) fn report_cameras(&self, read: bool) {
        self.cameras_unread.store(!read, Ordering::Relaxed);
    }

    /// A light view read the busy movers this frame, or would have.
    #[cfg_attr(not(feature = "light_culling"), allow(dead_code))]
    pub(crate) fn note_light_read(&self) {
        self.lights_read.store(true, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn skips_only_after_a_frame_that_read_nothing() {
        let mut movers = UnreadMovers::default();
        // No report yet (the culling has not run): the moves are written.
        assert!(!movers.take_skip(true));
        movers.report_cameras(false);
        assert!(!movers.take_skip(false), "a registered reader keeps them");
        movers.report_cameras(false);
        assert!(movers.take_skip(true));
        // The report is used once: a frame whose culling did not run writes them again.
        assert!(!movers.take_skip(true));
        movers.report_cameras(true);
        assert!(!movers.take_skip(true));
        movers.report_cameras(false);
        movers.note_light_read();
        assert!(!movers.take_skip(true));
        movers.set_stale(true);
        assert!(movers.is_stale());
    }
}
