//! Box, sphere, point, frustum and view queries: each visits the cells its region covers and
//! reports every entry from its owner cell only (see `UniformGrid` on duplicates), after
//! testing the entry's own box.

use super::cells::{Cell, LO_CELL, SLOT_MASK};
use super::slots::Entry;
use super::uniform::UniformGrid;
use crate::query::SpatialQuery;
use crate::query::views::{ViewClassification, ViewMasks};
use crate::{Aabb, Containment, Frustum, Sphere};
use core::ops::ControlFlow;
use glam::Vec3A;

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
    /// entry: every entry once, for queries over the whole occupied range. `skip(cell)` drops
    /// a cell whose entries all fail the query: it is asked about the world box of the
    /// cell's loose range, which holds every entry box of the cell. Both get `state`, the
    /// query's own test, which they share.
    fn for_each_lowest<S, K, F>(&self, state: &mut S, skip: K, mut visit: F)
    where
        K: Fn(&mut S, &Aabb) -> bool,
        F: FnMut(&mut S, &Entry),
    {
        let entries = &self.slots.entries;
        for &slot in &self.oversize {
            visit(state, &entries[slot as usize]);
        }
        for (_, cell) in self.cells.iter() {
            if skip(state, &self.loose_box(cell)) {
                continue;
            }
            for item in cell.items() {
                if item & LO_CELL != 0 {
                    visit(state, &entries[(item & SLOT_MASK) as usize]);
                }
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
