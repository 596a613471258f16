//! The dynamic BVH behind the [`DynamicIndex`] interface.

use super::node::NULL;
use super::{DynamicBvh, LeafHandle};
use crate::Aabb;
use crate::query::{DynamicIndex, IndexError, IndexStats, NodeView, UpkeepReport};
use core::ops::{ControlFlow, RangeInclusive};
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

    /// Every node, as [`visit_tree_nodes`](crate::query::visit_tree_nodes) walks the tree:
    /// breadth first, `depth` the edges from the root (0), a leaf's bounds its *fat* box (the
    /// tight box grown by the margin, what queries test) with `entries` 1, an internal
    /// node's the union of its children's with `entries` 0. Before [`refit`](DynamicBvh::refit)
    /// the boxes are shown as they are: moved leaves' new fat boxes under ancestors not yet
    /// grown to them.
    fn visit_nodes(
        &self,
        depths: RangeInclusive<u32>,
        visit: &mut dyn FnMut(NodeView) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        let root = (self.root != NULL).then_some(self.root);
        crate::query::visit_levels(self, root, &depths, visit)
    }
}
