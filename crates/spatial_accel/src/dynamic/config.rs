//! The dynamic tree's settings, and the fat boxes its leaves store.

use crate::{Aabb, SahCosts};
use core::time::Duration;
use glam::Vec3A;

/// Tuning of a [`DynamicBvh`](super::DynamicBvh); the defaults suit game worlds measured in
/// metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DynamicBvhConfig {
    /// Absolute growth of each side of a leaf's box, in world units. Box2D uses 0.1 m: motion
    /// within it touches nothing but the leaf.
    pub margin: f32,
    /// Further growth of each side as a fraction of the box's extent on that axis, so large
    /// objects (whose absolute motion is typically larger) get proportionally fatter leaves.
    pub relative_margin: f32,
    /// When a leaf outgrows its fat box, the new fat box also reaches ahead along the leaf's
    /// last displacement, by this multiple of it (Box2D 2.4's `b2_aabbMultiplier`, 4 there):
    /// a steadily moving object then leaves its fat box every few steps instead of every
    /// step, and each escape costs a refit of its path. 0 turns it off.
    pub motion_prediction: f32,
    /// Apply Kopta 2012 local rotations on insertion and on refit paths.
    pub rotations: bool,
    /// Wall-clock budget of the optimiser per
    /// [`DynamicBvh::maintain`](super::DynamicBvh::maintain) call.
    pub optimize_budget: Duration,
    /// Most internal nodes the optimiser reinserts per call (also bounds the work when the
    /// clock is coarse). [`DynamicBvh::maintain`](super::DynamicBvh::maintain) takes at most
    /// a thirty-second of the tree's leaves (16 at least) of it.
    pub optimize_max_reinsertions: usize,
    /// Rebuild when the estimated SAH cost exceeds this multiple of a fresh build's.
    pub rebuild_threshold: f32,
    /// Run rebuilds on a background thread and swap the result in at a later `maintain`.
    pub background_rebuild: bool,
    /// Below this many leaves `maintain` never rebuilds (a rebuild costs more than it saves).
    pub min_leaves_for_rebuild: usize,
    /// The SAH cost model for the quality monitor and the optimiser.
    pub sah: SahCosts,
    /// Run the whole-tree refit (the refit of a frame in which most leaves moved) on rayon's
    /// pool, level by level, the wide levels in chunks. The result is the same bits as on one
    /// thread. Needs the cargo feature `rayon`; without it this is ignored.
    ///
    /// Off by default: on a two-vCPU machine the parallel replay gains little or nothing over
    /// one thread (BENCHMARKS.md, Dynamic BVH), the replay being bound by memory bandwidth the
    /// vCPUs share. Worth measuring on a machine with more
    /// cores and memory channels.
    pub parallel_refit: bool,
}

impl Default for DynamicBvhConfig {
    fn default() -> Self {
        Self {
            margin: 0.1,
            relative_margin: 0.05,
            motion_prediction: 2.0,
            rotations: true,
            optimize_budget: Duration::from_micros(800),
            optimize_max_reinsertions: 512,
            rebuild_threshold: 1.3,
            background_rebuild: false,
            min_leaves_for_rebuild: 256,
            sah: SahCosts::default(),
            parallel_refit: false,
        }
    }
}

impl DynamicBvhConfig {
    /// The fat box stored for a tight one.
    #[inline]
    pub fn fatten(&self, tight: &Aabb) -> Aabb {
        tight.expanded(Vec3A::splat(self.margin) + tight.extent() * self.relative_margin)
    }

    /// The fat box for a leaf that moved from `previous` to `tight`: [`Self::fatten`], reaching
    /// further ahead along the displacement by [`Self::motion_prediction`] times it.
    #[inline]
    pub fn fatten_moving(&self, previous: &Aabb, tight: &Aabb) -> Aabb {
        let fat = self.fatten(tight);
        let ahead = (tight.center() - previous.center()) * self.motion_prediction;
        if !ahead.is_finite() {
            return fat;
        }
        Aabb::new(
            fat.min + ahead.min(Vec3A::ZERO),
            fat.max + ahead.max(Vec3A::ZERO),
        )
    }
}
