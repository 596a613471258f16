//! The loose tree behind the [`DynamicIndex`] interface.

use super::cells::NONE;
use super::handle::OctreeHandle;
use super::tree::LooseTree;
use crate::Aabb;
use crate::query::{DynamicIndex, IndexError, IndexStats, NodeView, UpkeepReport};
use core::cmp::Reverse;
use core::ops::{ControlFlow, RangeInclusive};
use std::collections::BinaryHeap;
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

    /// Every octant in use (quadrant on the quadtree), shallowest first and by arena index
    /// within a depth:
    /// - `depth`: the levels below the root, so every octant of one depth has a cell of one
    ///   size, the root's halved `depth` times. Cells that would hold nothing but one child
    ///   are not made, so a child may be several levels below its parent; the deepest depth
    ///   is [`index_stats`](DynamicIndex::index_stats)' `depth`.
    /// - `bounds`: the loose cell ([`OctreeConfig::looseness`](super::OctreeConfig::looseness)
    ///   times the cell, about its centre), which holds every entry kept at the octant. On
    ///   the quadtree the cell spans all of z; its z range is shown as that of the octant's
    ///   node bounds (what it and its subtree hold), so the box stays finite.
    /// - `leaf`: no child; `entries`: the entries kept at the octant itself (interior octants
    ///   keep the objects their size places there).
    ///
    /// The octants are the same before and after [`maintain`](LooseTree::maintain); only the
    /// quadtree's z ranges wait for it.
    fn visit_nodes(
        &self,
        depths: RangeInclusive<u32>,
        visit: &mut dyn FnMut(NodeView) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        if self.root == NONE || depths.is_empty() {
            return ControlFlow::Continue(());
        }
        let root_level = self.arena.get(self.root).level;
        let last = *depths.end();
        // Links may skip levels, so a queue by link count would not keep depths in order: a
        // heap by depth does (and by arena index within one, for a repeatable order).
        let mut queue = BinaryHeap::from([Reverse((0u32, self.root))]);
        while let Some(Reverse((depth, o))) = queue.pop() {
            let octant = self.arena.get(o);
            for &child in octant.children() {
                let below = (self.arena.get(child).level - root_level) as u32;
                if below <= last {
                    queue.push(Reverse((below, child)));
                }
            }
            if depths.contains(&depth) {
                visit(NodeView {
                    bounds: self.drawn_cell(o),
                    depth,
                    leaf: octant.child_mask == 0,
                    entries: crate::query::node_entry_count(octant.ids.len()),
                })?;
            }
        }
        ControlFlow::Continue(())
    }
}

impl<const AXES: usize> LooseTree<AXES> {
    /// The loose cell of an octant with a finite z range: on the quadtree, whose cells span
    /// all of z, that of what the octant holds (its node bounds and its own entries, the
    /// latter current even before a refit); left unbounded only for an octant that holds
    /// nothing yet.
    fn drawn_cell(&self, o: u32) -> Aabb {
        let mut cell = self.cell_bounds(o, self.config.looseness);
        if AXES < 3 {
            let octant = self.arena.get(o);
            let held = octant.tight.union(&octant.own);
            if held.min.z <= held.max.z {
                cell.min.z = held.min.z;
                cell.max.z = held.max.z;
            }
        }
        cell
    }
}
