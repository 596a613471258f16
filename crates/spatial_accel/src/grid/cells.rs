//! The cell table: a hash map from cell coordinates to the non-empty cells, each holding its
//! first few items in place.
//!
//! A hashed sparse grid rather than a dense array (Ericson, Real-Time Collision Detection,
//! ch. 7, on hashed storage for unbounded grids): the world is unbounded and mostly empty,
//! and a cell costs memory only while an entry overlaps it. A cell is freed the moment its
//! last entry leaves. The cell lives in the map's own bucket, its items in place up to
//! `INLINE` of them: one probe reaches everything a query or an edit needs of the cell, where
//! an index into an array of cells, each with a list on the heap, cost two more cache misses.
//! Crowded cells spill the rest into a list; emptied lists go to a spare pool for reuse, and
//! `trim` returns the pool when it outgrows what the grid holds.
//!
//! Each item is an entry slot with two flags, so queries can settle most duplicates without
//! reading the entry (see `UniformGrid`'s docs on duplicates).

use super::lattice::{CellHashBuilder, CellKey, CellRange};
use core::ops::ControlFlow;
use std::collections::HashMap;

/// Item flag: this cell is the entry's lowest cell (`range.lo`).
pub(super) const LO_CELL: u32 = 1 << 31;
/// Item flag: the entry overlaps more than one cell.
pub(super) const MULTI: u32 = 1 << 30;
/// The slot bits of an item. Slots are below `MULTI`.
pub(super) const SLOT_MASK: u32 = MULTI - 1;

/// Items a cell holds in place before it spills into a list: enough for the few entries per
/// cell the automatic size aims at, with room for a crowd's cells to vary.
const INLINE: usize = 6;

/// The item an entry with cells `range` leaves in cell `key`.
#[inline]
pub(super) fn item_for(slot: u32, key: CellKey, range: &CellRange) -> u32 {
    let mut item = slot;
    if key.0 == range.lo {
        item |= LO_CELL;
    }
    if range.lo != range.hi {
        item |= MULTI;
    }
    item
}

/// One non-empty cell.
#[derive(Clone, Debug)]
pub(super) struct Cell {
    /// A range holding the cell ranges of all its entries: every entry box of the cell lies
    /// in its world box, so a query may skip the cell when that box fails (a cell's own box
    /// would not do: an entry that crosses into it may reach a query elsewhere). Grown as
    /// entries come or spread, never shrunk while the cell lives: shrinking would read every
    /// other entry of the cell at each departure, and a larger range is only a weaker skip.
    pub loose: CellRange,
    len: u32,
    inline: [u32; INLINE],
    spill: Vec<u32>,
}

impl Cell {
    /// How many entries the cell holds.
    #[inline]
    pub fn item_count(&self) -> u32 {
        self.len
    }

    /// The items, in place and spilled.
    #[inline]
    pub fn items(&self) -> impl Iterator<Item = u32> + '_ {
        let n = (self.len as usize).min(INLINE);
        self.inline[..n].iter().chain(&self.spill).copied()
    }

    #[inline]
    fn get_mut(&mut self, i: usize) -> &mut u32 {
        if i < INLINE {
            &mut self.inline[i]
        } else {
            &mut self.spill[i - INLINE]
        }
    }

    #[inline]
    fn position(&self, slot: u32) -> Option<usize> {
        self.items().position(|i| i & SLOT_MASK == slot)
    }
}

/// The cells and what they cost.
#[derive(Clone, Debug, Default)]
pub(super) struct CellTable {
    map: HashMap<CellKey, Cell, CellHashBuilder>,
    /// Emptied spill lists kept for the next crowded cells.
    spare: Vec<Vec<u32>>,
    /// Items held by all cells.
    items: usize,
    /// Capacity of every spill list, in cells and in `spare`, kept current on each change so
    /// that memory is reported without a walk.
    spill_capacity: usize,
    /// A range holding every cell: grown at once, shrunk by `refresh_occupied`.
    occupied: CellRange,
    /// Cells freed since `occupied` was last recomputed.
    freed_since_refresh: usize,
    /// Loose ranges grown by edits since the last `take_grown`.
    grown: usize,
    /// `spill_capacity` as the last pass over the cells in `trim` left it. Lists that pass
    /// keeps (a cell's empty list of a few slots, say) can outweigh the items they could
    /// hold, and without this floor every later `trim` would walk every cell again to free
    /// nothing: O(cells) a frame instead of O(1) an edit.
    spill_after_trim: usize,
    /// On each axis, at least the widest cell range (`hi - lo`) of any item added since the
    /// last `clear`: how far past its lowest cell an entry can reach. Only grows, so it may
    /// overstate the entries of now, never understate them.
    max_span: [i32; 3],
}

impl CellTable {
    #[inline]
    pub fn get(&self, key: CellKey) -> Option<&Cell> {
        self.map.get(&key)
    }

    /// Every non-empty cell with its key, in no particular order.
    #[inline]
    pub fn iter(&self) -> impl Iterator<Item = (CellKey, &Cell)> {
        self.map.iter().map(|(&k, c)| (k, c))
    }

    #[inline]
    pub fn len(&self) -> usize {
        self.map.len()
    }

    #[inline]
    pub fn item_count(&self) -> usize {
        self.items
    }

    /// A range that holds every cell (perhaps more: it shrinks only at `refresh_occupied`).
    #[inline]
    pub fn occupied(&self) -> CellRange {
        self.occupied
    }

    /// How far past its lowest cell, on each axis, an entry of the cells may reach (see
    /// `max_span`).
    #[inline]
    pub fn max_span(&self) -> [i32; 3] {
        self.max_span
    }

    #[inline]
    fn note_span(&mut self, range: &CellRange) {
        for a in 0..3 {
            self.max_span[a] = self.max_span[a].max(range.hi[a].saturating_sub(range.lo[a]));
        }
    }

    /// Calls `f` on each cell of `range`. By lookups when the range has fewer cells than the
    /// table, else by a pass over the table: a query over a huge or unbounded region costs
    /// the cells that exist, never the cells it spans.
    pub fn for_each_in<F>(&self, range: &CellRange, mut f: F)
    where
        F: FnMut(CellKey, &Cell) -> ControlFlow<()>,
    {
        let range = range.intersection(&self.occupied);
        if range.is_empty() {
            return;
        }
        if range.count() <= self.map.len() as u64 {
            for key in range.keys() {
                if let Some(cell) = self.map.get(&key)
                    && f(key, cell).is_break()
                {
                    return;
                }
            }
        } else {
            for (&key, cell) in &self.map {
                if range.contains(key) && f(key, cell).is_break() {
                    return;
                }
            }
        }
    }

    /// Adds `item` (an entry with cells `range`) to the cell `key`, creating the cell.
    pub fn add(&mut self, key: CellKey, item: u32, range: &CellRange) {
        self.note_span(range);
        let cell = self.map.entry(key).or_insert_with(|| {
            self.occupied = self.occupied.union(&CellRange::single(key));
            Cell {
                loose: *range,
                len: 0,
                inline: [0; INLINE],
                spill: Vec::new(),
            }
        });
        let at = cell.len as usize;
        if at < INLINE {
            cell.inline[at] = item;
        } else {
            if cell.spill.capacity() == 0
                && let Some(list) = self.spare.pop()
            {
                cell.spill = list;
            }
            let before = cell.spill.capacity();
            cell.spill.push(item);
            self.spill_capacity += cell.spill.capacity() - before;
        }
        cell.len += 1;
        if !cell.loose.contains_range(range) {
            cell.loose = cell.loose.union(range);
            self.grown += 1;
        }
        self.items += 1;
    }

    /// Removes the item of `slot` from cell `key`, freeing the cell when it empties.
    pub fn remove(&mut self, key: CellKey, slot: u32) {
        let Some(cell) = self.map.get_mut(&key) else {
            debug_assert!(false, "entry {slot} missing from cell {key:?}");
            return;
        };
        let Some(at) = cell.position(slot) else {
            debug_assert!(false, "entry {slot} missing from cell {key:?}");
            return;
        };
        let last = cell.len as usize - 1;
        let moved = *cell.get_mut(last);
        *cell.get_mut(at) = moved;
        if last >= INLINE {
            cell.spill.pop();
        }
        cell.len -= 1;
        self.items -= 1;
        if cell.len == 0 {
            let cell = self.map.remove(&key).expect("the cell was just found");
            if cell.spill.capacity() > 0 {
                self.spare.push(cell.spill);
            }
            self.freed_since_refresh += 1;
        }
    }

    /// Rewrites the item of `slot` in cell `key` as `item`, its entry's cells now `range`.
    pub fn rewrite(&mut self, key: CellKey, slot: u32, item: u32, range: &CellRange) {
        self.note_span(range);
        let Some(cell) = self.map.get_mut(&key) else {
            debug_assert!(false, "entry {slot} missing from cell {key:?}");
            return;
        };
        if let Some(at) = cell.position(slot) {
            *cell.get_mut(at) = item;
        }
        if !cell.loose.contains_range(range) {
            cell.loose = cell.loose.union(range);
            self.grown += 1;
        }
    }

    /// Empties every cell, keeping the spill lists for reuse.
    pub fn clear(&mut self) {
        for (_, mut cell) in self.map.drain() {
            if cell.spill.capacity() > 0 {
                cell.spill.clear();
                self.spare.push(cell.spill);
            }
        }
        self.items = 0;
        self.spill_after_trim = 0;
        self.occupied = CellRange::EMPTY;
        self.freed_since_refresh = 0;
        self.max_span = [0; 3];
    }

    /// Recomputes the occupied range once enough cells were freed for it to have shrunk by
    /// much: a pass over the cells then costs O(1) per freed cell. A stale range only makes
    /// rays clip later and region queries test a few more keys; it is never too small.
    pub fn refresh_occupied(&mut self) {
        if self.freed_since_refresh == 0 || self.freed_since_refresh * 8 < self.map.len() {
            return;
        }
        self.occupied = self
            .map
            .keys()
            .fold(CellRange::EMPTY, |acc, &k| acc.union(&CellRange::single(k)));
        self.freed_since_refresh = 0;
    }

    /// Gives memory back once it is far above what the cells hold: spare lists beyond a
    /// small pool, oversized spill lists, and the map's capacity. A pass over the cells is
    /// taken only when the waste is at least as large as what is held and the spill capacity
    /// at least doubled since the last pass, so it costs O(1) per edit that created the waste
    /// (the doubling argument of `Vec`). Says whether it walked the cells.
    pub fn trim(&mut self) -> bool {
        const POOL: usize = 64;
        if self.spare.len() > POOL.max(self.map.len() / 16) {
            let keep = POOL.max(self.map.len() / 32);
            for list in self.spare.drain(keep..) {
                self.spill_capacity -= list.capacity();
            }
        }
        if self.spare.capacity() > 4 * self.spare.len() + POOL {
            self.spare.shrink_to(2 * self.spare.len());
        }
        // What the spill lists may hold after a trim: twice their items, and a few more
        // per list.
        let spilled = self.items.saturating_sub(INLINE * self.map.len());
        let tolerated = 2 * spilled + 8 * self.spare.len() + 8 * POOL;
        let walk = self.spill_capacity > 2 * tolerated.max(self.spill_after_trim);
        if walk {
            for list in &mut self.spare {
                self.spill_capacity -= list.capacity();
                list.shrink_to(8);
                self.spill_capacity += list.capacity();
            }
            for cell in self.map.values_mut() {
                if cell.spill.capacity() > 2 * cell.spill.len() + 8 {
                    self.spill_capacity -= cell.spill.capacity();
                    cell.spill.shrink_to(cell.spill.len() + 4);
                    self.spill_capacity += cell.spill.capacity();
                }
            }
            self.spill_after_trim = self.spill_capacity;
        }
        if self.map.capacity() > 4 * self.map.len() + POOL {
            self.map.shrink_to(self.map.len() + self.map.len() / 4);
        }
        walk
    }

    /// Loose ranges grown by moves since the last call (the maintain report's refit count).
    pub fn take_grown(&mut self) -> usize {
        core::mem::take(&mut self.grown)
    }

    /// Bytes held: the map from its capacity (hashbrown's buckets, a control byte each, and
    /// the group padding), the spill lists and the spare pool.
    pub fn memory_bytes(&self) -> usize {
        let map = match self.map.capacity() {
            0 => 0,
            cap => {
                let buckets = (cap * 8 / 7).next_power_of_two();
                buckets * (size_of::<(CellKey, Cell)>() + 1) + 16
            }
        };
        map + self.spare.capacity() * size_of::<Vec<u32>>() + self.spill_capacity * size_of::<u32>()
    }

    /// The spill capacity as kept and as recounted from the lists, for the validator.
    pub fn spill_capacity(&self) -> (usize, usize) {
        let counted = self.map.values().map(|c| c.spill.capacity()).sum::<usize>()
            + self.spare.iter().map(Vec::capacity).sum::<usize>();
        (self.spill_capacity, counted)
    }

    /// True when every cell's item count matches its lists (for the validator).
    pub fn lists_consistent(&self) -> bool {
        self.map.values().all(|c| {
            let n = c.len as usize;
            n > 0 && c.spill.len() == n.saturating_sub(INLINE)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cells that once spilled and fell back to their inline items keep small empty lists,
    /// which no trim frees. Later trims must not walk every cell again while the waste has
    /// not grown since the last walk: in a large world that walk is a real share of the
    /// upkeep.
    #[test]
    fn trim_walks_the_cells_again_only_once_the_waste_doubled() {
        let mut table = CellTable::default();
        let cells = 4_000;
        for c in 0..cells {
            let key = CellKey([c, 0, 0]);
            let range = CellRange::single(key);
            for slot in 0..=INLINE as u32 {
                table.add(key, c as u32 * 8 + slot, &range);
            }
            // Back to its inline items: an empty list with room stays in the cell.
            table.remove(key, c as u32 * 8 + INLINE as u32);
        }
        assert!(table.spill_capacity().0 >= cells as usize);
        assert!(table.trim(), "the first trim walks the wasteful cells");
        assert!(!table.trim(), "nothing changed: no second walk");
        assert!(!table.trim());
        let (kept, counted) = table.spill_capacity();
        assert_eq!(kept, counted);
        // Twice as much waste again: the next trim walks.
        for c in cells..cells * 3 {
            let key = CellKey([c, 0, 0]);
            let range = CellRange::single(key);
            for slot in 0..=INLINE as u32 {
                table.add(key, c as u32 * 8 + slot, &range);
            }
            table.remove(key, c as u32 * 8 + INLINE as u32);
        }
        assert!(table.trim());
        assert!(!table.trim());
    }
}
