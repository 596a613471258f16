//! Inserting, moving and removing entries, and the per-frame upkeep: the grid as a
//! [`DynamicIndex`].

use super::cells::item_for;
use super::config::{self, CellSize, Sizing};
use super::lattice::{CellRange, Lattice};
use super::slots::{GridHandle, IN_CELLS};
use super::uniform::{UniformGrid, valid_bounds};
use crate::Aabb;
use crate::query::{DynamicIndex, IndexError, IndexStats, NodeView, UpkeepReport};
use core::ops::{ControlFlow, RangeInclusive};
use std::time::Duration;

/// A re-size that would change the cell side by less than this fraction is skipped: it
/// would cost a pass over the entries for no measurable change in the cells.
const RESIZE_TOLERANCE: f32 = 0.1;

impl UniformGrid {
    /// Asks for what an [`update`](DynamicIndex::update) of this entry reads first: its
    /// slot entry and generation, scattered when only some entries move. A hint only: a caller
    /// updating many entries in turn calls it a few entries ahead, as the plugin's sync does.
    #[inline]
    pub fn prefetch_entry(&self, handle: GridHandle) {
        self.slots.prefetch(handle);
    }

    #[inline]
    fn is_oversize(&self, range: &CellRange) -> bool {
        range.count() > u64::from(self.config.max_cells_per_entry)
    }

    /// Files the entry at `slot` (its range already set) in its cells or the oversize list.
    fn place(&mut self, slot: u32) {
        let range = self.slots.entries[slot as usize].range;
        if self.is_oversize(&range) {
            self.slots.entries[slot as usize].place = self.oversize.len() as u32;
            self.oversize.push(slot);
        } else {
            self.slots.entries[slot as usize].place = IN_CELLS;
            for key in range.keys() {
                self.cells.add(key, item_for(slot, key, &range), &range);
            }
        }
    }

    /// Takes the entry at `slot` out of its cells or the oversize list.
    fn unplace(&mut self, slot: u32) {
        let e = self.slots.entries[slot as usize];
        if e.place == IN_CELLS {
            for key in e.range.keys() {
                self.cells.remove(key, slot);
            }
        } else {
            let at = e.place as usize;
            self.oversize.swap_remove(at);
            if let Some(&moved) = self.oversize.get(at) {
                self.slots.entries[moved as usize].place = at as u32;
            }
        }
    }

    /// Moves an entry that stays in the cells from the cells of `old` to those of `new`:
    /// only the cells in one range and not the other change membership; those in both get
    /// their item flags rewritten and their loose ranges grown.
    fn move_cells(&mut self, slot: u32, old: CellRange, new: CellRange) {
        for key in old.keys() {
            if new.contains(key) {
                self.cells
                    .rewrite(key, slot, item_for(slot, key, &new), &new);
            } else {
                self.cells.remove(key, slot);
            }
        }
        for key in new.keys() {
            if !old.contains(key) {
                self.cells.add(key, item_for(slot, key, &new), &new);
            }
        }
    }

    /// Bins every entry again on cells of side `size`.
    pub(super) fn rebin(&mut self, size: f32) {
        self.lattice = Lattice::new(size);
        self.cells.clear();
        self.oversize.clear();
        for slot in 0..self.slots.entries.len() as u32 {
            let e = &mut self.slots.entries[slot as usize];
            if e.is_live() {
                e.range = self.lattice.range_of(&e.bounds);
                self.place(slot);
            }
        }
    }

    /// The population and mean entry size now.
    fn sizing_now(&self) -> Sizing {
        let n = self.slots.len();
        Sizing {
            population: n,
            mean_side: if n == 0 {
                0.0
            } else {
                self.side_sum / n as f64
            },
        }
    }

    /// Picks the cell size again when the entries drifted since the last sizing (see
    /// [`GridConfig`](super::GridConfig)); true when the grid was re-binned.
    fn resize_if_drifted(&mut self) -> bool {
        if self.config.cell_size != CellSize::Auto {
            return false;
        }
        let now = self.sizing_now();
        let due = match self.sizing {
            None => now.population > 0,
            Some(at) => at.drifted(now, self.config.resize_min_change),
        };
        if !due {
            return false;
        }
        let boxes: Vec<Aabb> = self.entries().map(|(_, _, b)| b).collect();
        // The running sum drifts by rounding over many edits: start it afresh.
        self.side_sum = boxes.iter().map(|b| f64::from(config::mean_side(b))).sum();
        self.sizing = Some(self.sizing_now());
        let Some(size) = config::heuristic_cell_size(&boxes) else {
            return false;
        };
        let current = self.lattice.size();
        if (size / current - 1.0).abs() <= RESIZE_TOLERANCE {
            return false;
        }
        self.rebin(size);
        true
    }
}

impl DynamicIndex for UniformGrid {
    type Handle = GridHandle;

    fn insert(&mut self, id: u32, bounds: Aabb) -> Result<GridHandle, IndexError> {
        if !valid_bounds(&bounds) {
            return Err(IndexError::InvalidBounds);
        }
        if self.sizing.is_none() && self.slots.len() == 0 && self.config.cell_size == CellSize::Auto
        {
            // Nothing is binned yet, so the cells can change for free: size them after the
            // first entry, a better guess than any constant until `maintain` measures all.
            let side = 2.0 * config::mean_side(&bounds);
            if side > 0.0 {
                self.lattice = Lattice::new(config::sanitize(side));
            }
        }
        let range = self.lattice.range_of(&bounds);
        let slot = self.slots.alloc(id, bounds, range)?;
        self.place(slot);
        self.side_sum += f64::from(config::mean_side(&bounds));
        Ok(self.slots.handle(slot))
    }

    /// `Ok(false)` when the new box covers the same cells (only the box is written), or
    /// when the entry is oversize before and after (the list does not change).
    fn update(&mut self, handle: GridHandle, bounds: Aabb) -> Result<bool, IndexError> {
        let slot = self.slots.find(handle).ok_or(IndexError::StaleHandle)?;
        if !valid_bounds(&bounds) {
            return Err(IndexError::InvalidBounds);
        }
        let old = self.slots.entries[slot as usize];
        self.side_sum +=
            f64::from(config::mean_side(&bounds)) - f64::from(config::mean_side(&old.bounds));
        let new_range = self.lattice.range_of(&bounds);
        let (was_oversize, now_oversize) = (old.place != IN_CELLS, self.is_oversize(&new_range));
        let entry = &mut self.slots.entries[slot as usize];
        entry.bounds = bounds;
        if new_range == old.range || (was_oversize && now_oversize) {
            entry.range = new_range;
            return Ok(false);
        }
        if !was_oversize && !now_oversize {
            entry.range = new_range;
            self.move_cells(slot, old.range, new_range);
        } else {
            self.unplace(slot);
            self.slots.entries[slot as usize].range = new_range;
            self.place(slot);
        }
        Ok(true)
    }

    fn remove(&mut self, handle: GridHandle) -> Result<u32, IndexError> {
        let slot = self.slots.find(handle).ok_or(IndexError::StaleHandle)?;
        self.unplace(slot);
        let e = self.slots.entries[slot as usize];
        self.side_sum -= f64::from(config::mean_side(&e.bounds));
        self.slots.release(slot);
        Ok(e.id)
    }

    fn id(&self, handle: GridHandle) -> Option<u32> {
        self.slots
            .find(handle)
            .map(|s| self.slots.entries[s as usize].id)
    }

    fn bounds_of(&self, handle: GridHandle) -> Option<Aabb> {
        self.slots
            .find(handle)
            .map(|s| self.slots.entries[s as usize].bounds)
    }

    fn len(&self) -> usize {
        self.slots.len()
    }

    fn clear(&mut self) {
        self.cells.clear();
        self.oversize.clear();
        self.slots.clear();
        self.side_sum = 0.0;
    }

    /// Queries are correct after every edit, without this call; it does the upkeep that
    /// keeps them fast and the memory bounded, each part amortised to O(1) per edit:
    /// re-sizing the cells when the entries drifted ([`GridConfig`](super::GridConfig)),
    /// shrinking the occupied range that rays clip to, and giving back spare lists, free
    /// slots and table capacity. The grid has no optimiser to spend `budget` on. The report's
    /// `refit_nodes` counts the cells whose loose range grew since the last call.
    fn maintain(&mut self, _budget: Duration) -> UpkeepReport {
        let rebuilt = self.resize_if_drifted();
        self.cells.refresh_occupied();
        self.cells.trim();
        self.slots.trim();
        if self.oversize.capacity() > 4 * self.oversize.len() + 64 {
            self.oversize.shrink_to(2 * self.oversize.len());
        }
        UpkeepReport {
            refit_nodes: self.cells.take_grown(),
            improved: 0,
            rebuilt,
        }
    }

    fn index_stats(&self) -> IndexStats {
        IndexStats {
            entries: self.slots.len(),
            nodes: self.cells.len(),
            depth: 0,
            memory_bytes: self.memory_bytes(),
            quality_ratio: None,
        }
    }

    /// The grid has no hierarchy: every non-empty cell is a root at depth 0, in no
    /// particular order, its bounds the cell's cube (padded by a few hundred ulps against
    /// rounding, as the queries see it; the outermost cells of the lattice, at 2^30 cells
    /// from the origin, reach to infinity), `leaf` true and `entries` the entries
    /// overlapping it: an entry over several cells is counted in each. Then every entry of
    /// the oversize list (which every query tests whole) at depth 1, after all the cells,
    /// its bounds its own box and `entries` 1. The depth-0 count is
    /// [`index_stats`](DynamicIndex::index_stats)' `nodes`.
    fn visit_nodes(
        &self,
        depths: RangeInclusive<u32>,
        visit: &mut dyn FnMut(NodeView) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        if depths.contains(&0) {
            for (key, cell) in self.cells.iter() {
                visit(NodeView {
                    bounds: self.lattice.world_box(&CellRange::single(key)),
                    depth: 0,
                    leaf: true,
                    entries: cell.item_count(),
                })?;
            }
        }
        if depths.contains(&1) {
            for &slot in &self.oversize {
                visit(NodeView {
                    bounds: self.slots.entries[slot as usize].bounds,
                    depth: 1,
                    leaf: true,
                    entries: 1,
                })?;
            }
        }
        ControlFlow::Continue(())
    }
}
