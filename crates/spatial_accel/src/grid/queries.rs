//! Box, sphere, point, frustum and view queries: each visits the cells its region covers and
//! reports every entry from its owner cell only (see `UniformGrid` on duplicates), after
//! testing the entry's own box.

use super::cells::{Cell, LO_CELL, SLOT_MASK};
use super::lattice::{CellRange, LIMIT};
use super::slots::Entry;
use super::uniform::UniformGrid;
use crate::query::SpatialQuery;
use crate::query::views::{ViewClassification, ViewMasks};
use crate::{Aabb, Containment, Frustum, Sphere};
use core::ops::ControlFlow;
use glam::Vec3A;

/// The most cells of a block that the view walks look up cell by cell instead of halving
/// it again: small enough that a block straddling a view's edge costs a few lookups, large
/// enough that the halving's own box tests stay few beside them.
const VIEW_BLOCK_CELLS: u64 = 64;

impl UniformGrid {
    /// Calls `visit` on each entry whose box passes `test`, among the oversize list and the
    /// cells overlapping `region` (which must hold every box that can pass), once each.
    ///
    /// The owner of an entry is the low corner of its cells within the region's cells:
    /// `max(entry.lo, region.lo)` on each axis. It is one cell of both ranges, so it is
    /// visited and holds the entry. An entry's lowest cell is its owner whenever it lies in
    /// the region, and only cells on the region's low faces can own entries that start
    /// below it: everywhere else the item's flag decides without reading the entry.
    fn for_each_owned<T, F>(&self, region: &Aabb, test: T, mut visit: F)
    where
        T: Fn(&Aabb) -> bool,
        F: FnMut(u32) -> ControlFlow<()>,
    {
        let entries = &self.slots.entries;
        for &slot in &self.oversize {
            let e = &entries[slot as usize];
            if test(&e.bounds) && visit(e.id).is_break() {
                return;
            }
        }
        let range = self.lattice.range_of(region);
        self.cells.for_each_in(&range, |key, cell| {
            let low_face = (0..3).any(|a| key.0[a] == range.lo[a]);
            for item in cell.items() {
                let e = &entries[(item & SLOT_MASK) as usize];
                let owned =
                    item & LO_CELL != 0 || (low_face && e.range.intersection(&range).lo == key.0);
                if owned && test(&e.bounds) {
                    visit(e.id)?;
                }
            }
            ControlFlow::Continue(())
        });
    }

    /// Calls `visit` on each entry of a cell that is its lowest cell, and on each oversize
    /// entry: every entry once, for queries over the whole occupied range. `skip(region)`
    /// drops a region whose entries all fail the query: it is asked about world boxes that
    /// hold every entry box reported from the region. Both get `state`, the query's own
    /// test, which they share.
    ///
    /// Why blocks: a view sees a small part of a large grid, and a pass over every cell of
    /// the table costs the frustum far more than the BVH's walk (BENCHMARKS.md, Uniform grid).
    /// Where the cells fill most of their occupied range, that range is halved down to blocks
    /// of [`VIEW_BLOCK_CELLS`], each skipped whole when the box of what its cells can report
    /// fails (an implicit octree over the cell keys, built by the query itself); the cells of
    /// the blocks left are found by lookups. A sparse table is passed over whole, since
    /// lookups of empty keys would cost more than the pass.
    fn for_each_lowest<S, K, F>(&self, state: &mut S, skip: K, mut visit: F)
    where
        K: Fn(&mut S, &Aabb) -> bool,
        F: FnMut(&mut S, &Entry),
    {
        let entries = &self.slots.entries;
        for &slot in &self.oversize {
            visit(state, &entries[slot as usize]);
        }
        let occupied = self.cells.occupied();
        if occupied.is_empty() {
            return;
        }
        if occupied.count() <= 2 * self.cells.len() as u64 {
            self.for_each_lowest_in_block(occupied, state, &skip, &mut visit);
            return;
        }
        for (_, cell) in self.cells.iter() {
            self.visit_lowest_of_cell(cell, state, &skip, &mut visit);
        }
    }

    /// [`Self::for_each_lowest`] over the cells of `block`, halving it while it is large.
    fn for_each_lowest_in_block<S, K, F>(
        &self,
        block: CellRange,
        state: &mut S,
        skip: &K,
        visit: &mut F,
    ) where
        K: Fn(&mut S, &Aabb) -> bool,
        F: FnMut(&mut S, &Entry),
    {
        // An entry reported here has its lowest cell in the block and reaches at most the
        // widest span past it.
        let span = self.cells.max_span();
        let reach = CellRange {
            lo: block.lo,
            hi: [0, 1, 2].map(|a| block.hi[a].saturating_add(span[a]).min(LIMIT)),
        };
        if skip(state, &self.lattice.world_box(&reach)) {
            return;
        }
        if block.count() <= VIEW_BLOCK_CELLS {
            for key in block.keys() {
                if let Some(cell) = self.cells.get(key) {
                    self.visit_lowest_of_cell(cell, state, skip, visit);
                }
            }
            return;
        }
        let widths = [0, 1, 2].map(|a| i64::from(block.hi[a]) - i64::from(block.lo[a]));
        let axis = (0..3).max_by_key(|&a| widths[a]).unwrap_or(0);
        let mid = (i64::from(block.lo[axis]) + widths[axis] / 2) as i32;
        let (mut low, mut high) = (block, block);
        low.hi[axis] = mid;
        high.lo[axis] = mid + 1;
        self.for_each_lowest_in_block(low, state, skip, visit);
        self.for_each_lowest_in_block(high, state, skip, visit);
    }

    /// The entries whose lowest cell is `cell`, unless its loose box (which holds every entry
    /// box of the cell) is skipped.
    #[inline]
    fn visit_lowest_of_cell<S, K, F>(&self, cell: &Cell, state: &mut S, skip: &K, visit: &mut F)
    where
        K: Fn(&mut S, &Aabb) -> bool,
        F: FnMut(&mut S, &Entry),
    {
        if skip(state, &self.loose_box(cell)) {
            return;
        }
        let entries = &self.slots.entries;
        for item in cell.items() {
            if item & LO_CELL != 0 {
                visit(state, &entries[(item & SLOT_MASK) as usize]);
            }
        }
    }

    /// A world box holding every entry box of `cell`.
    #[inline]
    fn loose_box(&self, cell: &Cell) -> Aabb {
        self.lattice.world_box(&cell.loose)
    }
}

/// True when a vector has a NaN component.
#[inline]
fn has_nan(v: Vec3A) -> bool {
    v.is_nan_mask().any()
}

impl SpatialQuery for UniformGrid {
    fn for_each_overlapping_aabb<F>(&self, aabb: &Aabb, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        if has_nan(aabb.min) || has_nan(aabb.max) {
            return;
        }
        // An inverted query box still overlaps the boxes that span its swapped corners
        // (`intersects_aabb` compares across): cover the box between the corners.
        let region = Aabb::new(aabb.min.min(aabb.max), aabb.min.max(aabb.max));
        self.for_each_owned(&region, |b| b.intersects_aabb(aabb), visit);
    }

    fn for_each_overlapping_sphere<F>(&self, sphere: &Sphere, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        // An invalid sphere (a non-finite centre, a NaN or negative radius) holds nothing.
        if !sphere.is_valid() {
            return;
        }
        // `intersects_aabb` passes only boxes that meet `sphere.aabb()`, so its cells hold
        // every answer.
        self.for_each_owned(&sphere.aabb(), |b| sphere.intersects_aabb(b), visit);
    }

    fn for_each_containing_point<F>(&self, point: Vec3A, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        if has_nan(point) {
            return;
        }
        self.for_each_owned(&Aabb::from_point(point), |b| b.contains_point(point), visit);
    }

    /// Each entry with its own box classified against the frustum: `Inside` is exact, so
    /// the caller needs no test for those.
    fn for_each_in_frustum<F>(&self, frustum: &Frustum, mut visit: F)
    where
        F: FnMut(u32, Containment),
    {
        self.for_each_lowest(
            &mut (),
            |_, b| frustum.classify_aabb(b) == Containment::Outside,
            |_, e| match frustum.classify_aabb(&e.bounds) {
                Containment::Outside => {}
                c => visit(e.id, c),
            },
        );
    }

    /// Each entry with its own box classified against every view; cells whose entries no
    /// view can reach are skipped by their loose box. `classify` sees entry boxes and those
    /// cell boxes, always with all of `views` undecided.
    fn for_each_in_views<C, F>(&self, views: u32, mut classify: C, mut visit: F)
    where
        C: FnMut(&Aabb, u32) -> ViewClassification,
        F: FnMut(u32, ViewMasks),
    {
        if views == 0 {
            return;
        }
        let start = ViewMasks::undecided(views);
        self.for_each_lowest(
            &mut classify,
            |classify, b| start.below(classify(b, views)).is_none(),
            |classify, e| {
                if let Some(masks) = start.below(classify(&e.bounds, views)) {
                    visit(e.id, masks);
                }
            },
        );
    }

    fn nearest_k<F>(&self, point: Vec3A, k: usize, distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32,
    {
        self.nearest(point, k, distance_squared)
    }
}
