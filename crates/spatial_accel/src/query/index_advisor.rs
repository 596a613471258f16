//! Choosing the dynamic index from the workload an engine observes, frame by frame.
//!
//! The rules come from the whole-frame measurements (BENCHMARKS.md, Whole frame): with many
//! movers, the uniform grid's O(1) update saves the BVH's refit and optimiser, while the BVH's
//! rays are the faster ones. With a tenth or a quarter of the entities moving, the grid wins
//! every measured frame, under a strategy camera as under a ground camera (its culling walk
//! costs a little more than the BVH's, far less than the upkeep it saves); with nothing
//! moving the two tie. So the grid is chosen for a busy set of movers that few rays walk,
//! whatever is in view, the BVH otherwise. The octree, the quadtree and the flat list win no
//! measured workload, and the advisor never picks them.

use super::IndexKind;

/// The thresholds of [`IndexAdvisor`]. Defaults follow the measurements cited in the module
/// documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IndexAdvice {
    /// Below this many dynamic entries the choice costs or saves little either way: the
    /// advisor keeps the BVH, whose rays are the fastest.
    pub min_entries: usize,
    /// The grid is chosen when at least this share of the dynamic entries moves per frame
    /// (averaged) ...
    pub grid_above_moved_share: f32,
    /// ... and left again when the share falls below this one (hysteresis: a workload at the
    /// threshold must not flip the index every few frames).
    pub bvh_below_moved_share: f32,
    /// The grid is left, or not taken, when more rays than this walk the index per frame
    /// (averaged): its DDA rays cost several times the BVH's snapshot rays.
    pub max_rays_for_grid: f32,
    /// The evidence must point the same way for this many consecutive frames before the
    /// advisor recommends a switch.
    pub hold_frames: u32,
    /// Frames after a switch before the next one may be recommended: a switch moves every
    /// dynamic entry, which must stay rare.
    pub frames_between_switches: u32,
}

impl Default for IndexAdvice {
    fn default() -> Self {
        Self {
            min_entries: 20_000,
            grid_above_moved_share: 0.05,
            bvh_below_moved_share: 0.02,
            max_rays_for_grid: 16.0,
            hold_frames: 60,
            frames_between_switches: 600,
        }
    }
}

/// One frame's workload of the dynamic index, as the engine saw it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IndexWorkload {
    /// Entries in the dynamic index.
    pub entries: usize,
    /// Entries moved (updated) this frame.
    pub moved: usize,
    /// Rays cast through the index this frame.
    pub rays: f32,
}

/// Follows the workload and recommends an [`IndexKind`], with hysteresis: the same
/// workload always leads to the same choice, and a recommendation changes only after the
/// evidence has held for [`IndexAdvice::hold_frames`] frames and
/// [`IndexAdvice::frames_between_switches`] have passed since the last change.
///
/// ```
/// use spatial_accel::query::{IndexAdvice, IndexAdvisor, IndexKind, IndexWorkload};
/// let mut advisor = IndexAdvisor::new(IndexAdvice { hold_frames: 3, ..Default::default() });
/// let busy = IndexWorkload { entries: 1_000_000, moved: 250_000, rays: 1.0 };
/// let kinds: Vec<IndexKind> = (0..5).map(|_| advisor.observe(busy)).collect();
/// // The evidence held for three frames, and the third recommended the grid.
/// assert_eq!(kinds[..2], [IndexKind::DynamicBvh; 2]);
/// assert_eq!(kinds[2..], [IndexKind::Grid; 3]);
/// ```
#[derive(Clone, Debug)]
pub struct IndexAdvisor {
    advice: IndexAdvice,
    current: IndexKind,
    moved_share: f32,
    rays: f32,
    observed: u64,
    leaning_frames: u32,
    since_switch: u32,
}

impl IndexAdvisor {
    /// An advisor that starts on the BVH.
    pub fn new(advice: IndexAdvice) -> Self {
        Self {
            advice,
            current: IndexKind::DynamicBvh,
            moved_share: 0.0,
            rays: 0.0,
            observed: 0,
            leaning_frames: 0,
            // The first choice may come as soon as the evidence holds.
            since_switch: u32::MAX,
        }
    }

    /// The thresholds in use.
    pub fn advice(&self) -> &IndexAdvice {
        &self.advice
    }

    /// Replaces the thresholds; the averages and the current choice are kept.
    pub fn set_advice(&mut self, advice: IndexAdvice) {
        self.advice = advice;
    }

    /// The kind recommended now.
    pub fn current(&self) -> IndexKind {
        self.current
    }

    /// The averaged share of dynamic entries moved per frame.
    pub fn moved_share(&self) -> f32 {
        self.moved_share
    }

    /// The averaged rays per frame.
    pub fn rays_per_frame(&self) -> f32 {
        self.rays
    }

    /// Records one frame and returns the kind recommended after it.
    pub fn observe(&mut self, frame: IndexWorkload) -> IndexKind {
        let share = if frame.entries == 0 {
            0.0
        } else {
            (frame.moved as f32 / frame.entries as f32).min(1.0)
        };
        let rays = if frame.rays.is_finite() {
            frame.rays.max(0.0)
        } else {
            0.0
        };
        // An average over about ten frames: one burst of spawns or one frame of many rays
        // does not decide, a steady workload does within the hold time.
        let k = if self.observed < 10 {
            1.0 / (self.observed + 1) as f32
        } else {
            0.1
        };
        self.moved_share += (share - self.moved_share) * k;
        self.rays += (rays - self.rays) * k;
        self.observed += 1;
        self.since_switch = self.since_switch.saturating_add(1);

        let wanted = self.wanted(frame.entries);
        if wanted == self.current {
            self.leaning_frames = 0;
        } else {
            self.leaning_frames += 1;
            if self.leaning_frames >= self.advice.hold_frames
                && self.since_switch >= self.advice.frames_between_switches
            {
                self.current = wanted;
                self.leaning_frames = 0;
                self.since_switch = 0;
            }
        }
        self.current
    }

    /// What the averages ask for, the current choice breaking ties inside the hysteresis band.
    fn wanted(&self, entries: usize) -> IndexKind {
        let a = &self.advice;
        if entries < a.min_entries || self.rays > a.max_rays_for_grid {
            return IndexKind::DynamicBvh;
        }
        if self.moved_share >= a.grid_above_moved_share {
            IndexKind::Grid
        } else if self.moved_share < a.bvh_below_moved_share {
            IndexKind::DynamicBvh
        } else {
            self.current
        }
    }
}

impl Default for IndexAdvisor {
    fn default() -> Self {
        Self::new(IndexAdvice::default())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(advisor: &mut IndexAdvisor, frame: IndexWorkload, frames: usize) -> IndexKind {
        for _ in 0..frames {
            advisor.observe(frame);
        }
        advisor.current()
    }

    const BUSY: IndexWorkload = IndexWorkload {
        entries: 1_000_000,
        moved: 250_000,
        rays: 1.0,
    };
    const CALM: IndexWorkload = IndexWorkload {
        entries: 1_000_000,
        moved: 1_000,
        rays: 1.0,
    };

    #[test]
    fn many_movers_and_few_rays_take_the_grid_and_calm_returns_to_the_bvh() {
        let mut a = IndexAdvisor::new(IndexAdvice {
            frames_between_switches: 0,
            ..IndexAdvice::default()
        });
        assert_eq!(run(&mut a, BUSY, 200), IndexKind::Grid);
        assert_eq!(run(&mut a, CALM, 200), IndexKind::DynamicBvh);
    }

    #[test]
    fn the_band_between_the_thresholds_keeps_the_current_choice() {
        let mut a = IndexAdvisor::new(IndexAdvice {
            frames_between_switches: 0,
            ..IndexAdvice::default()
        });
        let middle = IndexWorkload {
            moved: 30_000,
            ..BUSY
        };
        assert_eq!(run(&mut a, middle, 500), IndexKind::DynamicBvh);
        run(&mut a, BUSY, 200);
        assert_eq!(run(&mut a, middle, 500), IndexKind::Grid);
    }

    #[test]
    fn a_smaller_busy_set_takes_the_grid_too() {
        let mut a = IndexAdvisor::new(IndexAdvice {
            frames_between_switches: 0,
            ..IndexAdvice::default()
        });
        let busy_100k = IndexWorkload {
            entries: 100_000,
            moved: 10_000,
            rays: 1.0,
        };
        assert_eq!(run(&mut a, busy_100k, 300), IndexKind::Grid);
        let below_the_minimum = IndexWorkload {
            entries: 19_999,
            ..busy_100k
        };
        let mut a = IndexAdvisor::default();
        assert_eq!(run(&mut a, below_the_minimum, 300), IndexKind::DynamicBvh);
    }

    #[test]
    fn rays_small_sets_and_bursts_keep_the_bvh() {
        let mut a = IndexAdvisor::default();
        let rays = IndexWorkload {
            rays: 500.0,
            ..BUSY
        };
        assert_eq!(run(&mut a, rays, 500), IndexKind::DynamicBvh);
        let small = IndexWorkload {
            entries: 5_000,
            moved: 5_000,
            rays: 0.0,
        };
        assert_eq!(run(&mut a, small, 500), IndexKind::DynamicBvh);
        // A burst shorter than the hold time does not switch.
        let mut a = IndexAdvisor::default();
        run(&mut a, CALM, 50);
        assert_eq!(run(&mut a, BUSY, 30), IndexKind::DynamicBvh);
        assert_eq!(run(&mut a, CALM, 100), IndexKind::DynamicBvh);
    }

    #[test]
    fn switches_are_spaced_and_hostile_figures_are_harmless() {
        let mut a = IndexAdvisor::new(IndexAdvice {
            hold_frames: 5,
            frames_between_switches: 300,
            ..IndexAdvice::default()
        });
        assert_eq!(run(&mut a, BUSY, 40), IndexKind::Grid);
        // Calm right away: the switch back waits for the spacing.
        assert_eq!(run(&mut a, CALM, 100), IndexKind::Grid);
        assert_eq!(run(&mut a, CALM, 300), IndexKind::DynamicBvh);
        for rays in [f32::NAN, f32::INFINITY, -1.0] {
            let frame = IndexWorkload {
                entries: 0,
                moved: usize::MAX,
                rays,
            };
            a.observe(frame);
            assert!(a.moved_share().is_finite() && a.rays_per_frame().is_finite());
        }
    }
}
