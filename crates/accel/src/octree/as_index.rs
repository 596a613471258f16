//! The loose tree behind the [`DynamicIndex`] interface.

use super::handle::OctreeHandle;
use super::tree::LooseTree;
use crate::Aabb;
use crate::query::{DynamicIndex, IndexError, IndexStats, UpkeepReport};
use std::time::Duration;

impl<const AXES: usize> DynamicIndex for LooseTree<AXES> {
    type Handle = OctreeHandle;

    fn insert(&mut self, id: u32, bounds: Aabb) -> Result<OctreeHandle, IndexError> {
        LooseTree::insert(self, id, bounds)
    }

    fn update(&mut self, handle: OctreeHandle, bounds: Aabb) -> Result<bool, IndexError> {
        LooseTree::update(self, handle, bounds)
    }

    fn remove(&mut self, handle: OctreeHandle) -> Result<u32, IndexError> {
        LooseTree::remove(self, handle)
    }

    fn id(&self, handle: OctreeHandle) -> Option<u32> {
        LooseTree::id(self, handle)
    }

    fn bounds_of(&self, handle: OctreeHandle) -> Option<Aabb> {
        LooseTree::bounds_of(self, handle)
    }

    fn len(&self) -> usize {
        LooseTree::len(self)
    }

    fn clear(&mut self) {
        LooseTree::clear(self)
    }

    /// [`LooseTree::maintain`]. The budget goes unused: where an entry sits follows from its
    /// box alone, and every edit leaves it there, so there is nothing to improve.
    fn maintain(&mut self, _budget: Duration) -> UpkeepReport {
        UpkeepReport {
            refit_nodes: LooseTree::maintain(self),
            improved: 0,
            rebuilt: false,
        }
    }

    fn index_stats(&self) -> IndexStats {
        IndexStats {
            entries: self.len(),
            nodes: self.octant_count(),
            depth: self.depth(),
            memory_bytes: self.memory_bytes(),
            quality_ratio: None,
        }
    }
}
