//! The invariant checker: what the tests ask of the grid after every change.

use super::cells::{SLOT_MASK, item_for};
use super::config::mean_side;
use super::lattice::CellRange;
use super::slots::{FREE, IN_CELLS};
use super::uniform::UniformGrid;
use std::fmt;

/// A broken grid invariant.
#[derive(Clone, Debug, PartialEq)]
pub enum GridValidationError {
    /// A live entry's stored cell range is not the range of its box.
    WrongRange {
        /// The entry's slot.
        slot: u32,
    },
    /// An entry is filed in the cells but spans more than the oversize limit, or in the
    /// oversize list but spans fewer, or the list and the entry disagree on its place.
    Misfiled {
        /// The entry's slot.
        slot: u32,
    },
    /// A cell that a live entry's box overlaps does not hold it exactly once, with the
    /// right flags.
    MissingFromCell {
        /// The entry's slot.
        slot: u32,
        /// The cell.
        cell: [i32; 3],
    },
    /// A cell holds an item naming a free slot, an oversize entry, an entry whose box does
    /// not overlap the cell, or the same entry twice.
    StaleItem {
        /// The slot named.
        slot: u32,
        /// The cell.
        cell: [i32; 3],
    },
    /// A cell's loose range does not hold the cell ranges of all its entries.
    LooseRange {
        /// The cell.
        cell: [i32; 3],
    },
    /// A cell lies outside the occupied range that rays clip to.
    OutsideOccupied {
        /// The cell.
        cell: [i32; 3],
    },
    /// The free list names a live slot, names one twice, or misses a free one.
    FreeList,
    /// A count kept alongside the structure (entries, items, a cell's items, the sum of
    /// entry sizes) disagrees with a recount, or a cell is empty.
    Count(&'static str),
    /// The memory kept track of for the spill lists disagrees with their capacities.
    Memory,
}

impl fmt::Display for GridValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "grid invariant broken: {self:?}")
    }
}

impl std::error::Error for GridValidationError {}

impl UniformGrid {
    /// Checks every invariant: each live entry is in exactly the cells its box overlaps (or
    /// in the oversize list), cells hold no stale or repeated items, loose and occupied
    /// ranges hold what they must, and the counts and memory kept alongside agree with a
    /// recount. A pass over everything: for tests.
    pub fn validate(&self) -> Result<(), GridValidationError> {
        use GridValidationError as E;
        let entries = &self.slots.entries;
        let mut live = 0;
        let mut filed_items = 0usize;
        let mut side_sum = 0.0f64;
        for (slot, e) in entries.iter().enumerate() {
            let slot = slot as u32;
            if e.place == FREE {
                continue;
            }
            live += 1;
            side_sum += f64::from(mean_side(&e.bounds));
            if e.range != self.lattice.range_of(&e.bounds) {
                return Err(E::WrongRange { slot });
            }
            let oversize = e.range.count() > u64::from(self.config.max_cells_per_entry);
            if e.place != IN_CELLS {
                if !oversize || self.oversize.get(e.place as usize) != Some(&slot) {
                    return Err(E::Misfiled { slot });
                }
                continue;
            }
            if oversize {
                return Err(E::Misfiled { slot });
            }
            for key in e.range.keys() {
                let want = item_for(slot, key, &e.range);
                let held = self
                    .cells
                    .get(key)
                    .map_or(0, |c| c.items().filter(|&i| i == want).count());
                if held != 1 {
                    return Err(E::MissingFromCell { slot, cell: key.0 });
                }
                filed_items += 1;
            }
        }
        for (at, &slot) in self.oversize.iter().enumerate() {
            if entries.get(slot as usize).map(|e| e.place) != Some(at as u32) {
                return Err(E::Misfiled { slot });
            }
        }
        let occupied = self.cells.occupied();
        if !self.cells.lists_consistent() {
            return Err(E::Count("items of a cell"));
        }
        for (key, cell) in self.cells.iter() {
            if !occupied.contains(key) {
                return Err(E::OutsideOccupied { cell: key.0 });
            }
            let mut slots: Vec<u32> = cell.items().map(|i| i & SLOT_MASK).collect();
            slots.sort_unstable();
            let mut loose = CellRange::single(key);
            for (n, &slot) in slots.iter().enumerate() {
                let e = entries.get(slot as usize);
                let stale = e.is_none_or(|e| e.place != IN_CELLS || !e.range.contains(key))
                    || slots.get(n + 1) == Some(&slot);
                if stale {
                    return Err(E::StaleItem { slot, cell: key.0 });
                }
                loose = loose.union(&entries[slot as usize].range);
            }
            if cell.loose.union(&loose) != cell.loose {
                return Err(E::LooseRange { cell: key.0 });
            }
        }
        let mut free = self.slots.free_list().to_vec();
        free.sort_unstable();
        let free_ok = free.windows(2).all(|w| w[0] < w[1])
            && free
                .iter()
                .all(|&s| entries.get(s as usize).is_some_and(|e| e.place == FREE))
            && free.len() + live == entries.len();
        if !free_ok {
            return Err(E::FreeList);
        }
        if live != self.slots.len() {
            return Err(E::Count("live entries"));
        }
        if filed_items != self.cells.item_count() {
            return Err(E::Count("items in cells"));
        }
        if (side_sum - self.side_sum).abs() > 1e-6 * (side_sum.abs() + 1.0) * (live as f64 + 1.0) {
            return Err(E::Count("sum of entry sizes"));
        }
        let (kept, counted) = self.cells.spill_capacity();
        if kept != counted {
            return Err(E::Memory);
        }
        Ok(())
    }
}
