//! The dynamic BVH behind the [`DynamicIndex`] interface.

use super::{DynamicBvh, LeafHandle};
use crate::Aabb;
use crate::query::{DynamicIndex, IndexError, IndexStats, UpkeepReport};
use std::time::Duration;

impl DynamicIndex for DynamicBvh {
    type Handle = LeafHandle;

    fn insert(&mut self, id: u32, bounds: Aabb) -> Result<LeafHandle, IndexError> {
        DynamicBvh::insert(self, id, bounds)
    }

    fn update(&mut self, handle: LeafHandle, bounds: Aabb) -> Result<bool, IndexError> {
        DynamicBvh::update(self, handle, bounds)
    }

    fn remove(&mut self, handle: LeafHandle) -> Result<u32, IndexError> {
        DynamicBvh::remove(self, handle)
    }

    fn id(&self, handle: LeafHandle) -> Option<u32> {
        DynamicBvh::id(self, handle)
    }

    fn bounds_of(&self, handle: LeafHandle) -> Option<Aabb> {
        self.tight_bounds(handle)
    }

    fn len(&self) -> usize {
        DynamicBvh::len(self)
    }

    fn clear(&mut self) {
        DynamicBvh::clear(self)
    }

    /// [`DynamicBvh::maintain`] with `budget` for the optimiser in place of the configured
    /// [`optimize_budget`](super::DynamicBvhConfig::optimize_budget).
    fn maintain(&mut self, budget: Duration) -> UpkeepReport {
        let configured = core::mem::replace(&mut self.config.optimize_budget, budget);
        let report = DynamicBvh::maintain(self);
        self.config.optimize_budget = configured;
        UpkeepReport {
            refit_nodes: report.refit_nodes,
            improved: report.optimize.reinserted,
            rebuilt: report.rebuilt,
        }
    }

    fn index_stats(&self) -> IndexStats {
        IndexStats {
            entries: DynamicBvh::len(self),
            // A binary tree over n leaves has n - 1 interior nodes.
            nodes: (2 * DynamicBvh::len(self)).saturating_sub(1),
            depth: self.height(),
            memory_bytes: self.memory_bytes(),
            quality_ratio: self.quality().fresh_estimate.map(|_| self.quality().ratio),
        }
    }
}
