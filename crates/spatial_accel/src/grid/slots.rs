//! Entries by slot, and the generational handles that name them.

use super::cells::SLOT_MASK;
use super::lattice::CellRange;
use crate::Aabb;
use crate::query::IndexError;

/// A handle to one entry of a [`UniformGrid`](super::UniformGrid): its slot and the slot's
/// generation, so a handle kept past `remove` is stale rather than naming a later entry.
pub type GridHandle = crate::query::Handle<super::UniformGrid>;

/// `Entry::place` of a free slot.
pub(super) const FREE: u32 = u32::MAX;
/// `Entry::place` of an entry stored in the cells of its range.
pub(super) const IN_CELLS: u32 = u32::MAX - 1;

/// One slot: a live entry or a free one. What a query reads of a candidate, in one cache
/// line (aligned so that no entry straddles two): a query's time goes to fetching entries
/// from scattered slots, one line each.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct Entry {
    pub bounds: Aabb,
    /// The cells its box overlaps (also kept for oversize entries, to notice when an update
    /// brings one back into the cells).
    pub range: CellRange,
    pub id: u32,
    /// `IN_CELLS`, `FREE`, or its position in the oversize list.
    pub place: u32,
}

impl Entry {
    #[inline]
    pub fn is_live(&self) -> bool {
        self.place != FREE
    }
}

/// The slot array with its free list.
#[derive(Clone, Debug, Default)]
pub(super) struct Slots {
    pub entries: Vec<Entry>,
    /// Each slot's generation, apart from the entries: only handle checks read it.
    generations: Vec<u32>,
    /// Free slots, the lowest last so that it is reused first and the array stays short.
    free: Vec<u32>,
    live: usize,
    /// The generation a newly pushed slot starts with: above that of every slot trimmed
    /// off the end, so their old handles stay stale when the slot index comes back.
    fresh_generation: u32,
}

impl Slots {
    #[inline]
    pub fn len(&self) -> usize {
        self.live
    }

    /// Asks for the entry and generation [`Self::find`] and an update read. A hint only.
    #[inline]
    pub fn prefetch(&self, handle: GridHandle) {
        let slot = handle.index() as usize;
        if let (Some(entry), Some(generation)) =
            (self.entries.get(slot), self.generations.get(slot))
        {
            crate::prefetch::prefetch_node(entry);
            crate::prefetch::prefetch_node(generation);
        }
    }

    /// The slot of a live handle.
    #[inline]
    pub fn find(&self, handle: GridHandle) -> Option<u32> {
        let e = self.entries.get(handle.index() as usize)?;
        (e.is_live() && self.generations[handle.index() as usize] == handle.generation())
            .then_some(handle.index())
    }

    #[inline]
    pub fn handle(&self, slot: u32) -> GridHandle {
        GridHandle::new(slot, self.generations[slot as usize])
    }

    /// A slot for a new entry; its `place` is left for the caller to set.
    pub fn alloc(&mut self, id: u32, bounds: Aabb, range: CellRange) -> Result<u32, IndexError> {
        let slot = match self.free.pop() {
            Some(slot) => slot,
            // Slots share a u32 with the cell flags: at most 2^30 - 1 of them.
            None if self.entries.len() < SLOT_MASK as usize => {
                self.entries.push(Entry {
                    bounds,
                    range,
                    id,
                    place: FREE,
                });
                self.generations.push(self.fresh_generation);
                (self.entries.len() - 1) as u32
            }
            None => return Err(IndexError::CapacityExceeded),
        };
        let e = &mut self.entries[slot as usize];
        e.bounds = bounds;
        e.id = id;
        e.range = range;
        e.place = IN_CELLS;
        self.live += 1;
        Ok(slot)
    }

    /// Frees a live slot; its handles become stale.
    pub fn release(&mut self, slot: u32) {
        self.entries[slot as usize].place = FREE;
        let g = &mut self.generations[slot as usize];
        *g = g.wrapping_add(1);
        self.free.push(slot);
        self.live -= 1;
    }

    /// Frees every slot.
    pub fn clear(&mut self) {
        for (e, g) in self.entries.iter_mut().zip(&mut self.generations) {
            if e.is_live() {
                e.place = FREE;
                *g = g.wrapping_add(1);
            }
        }
        self.live = 0;
        self.rebuild_free_list();
    }

    /// Drops free slots off the end of the array once they are many (a quarter of it, or
    /// all of it): each trim is a pass over the array, paid for by the removals that freed
    /// them. Their generations are carried over, so no old handle comes back to life.
    pub fn trim(&mut self) {
        let trailing = self
            .entries
            .iter()
            .rev()
            .take_while(|e| !e.is_live())
            .count();
        if trailing == 0 || (trailing < self.entries.len() && trailing * 4 < self.entries.len()) {
            return;
        }
        let keep = self.entries.len() - trailing;
        for &g in &self.generations[keep..] {
            self.fresh_generation = self.fresh_generation.max(g);
        }
        self.entries.truncate(keep);
        self.generations.truncate(keep);
        if self.entries.capacity() > 2 * keep + 16 {
            self.entries.shrink_to(keep + keep / 2);
            self.generations.shrink_to(keep + keep / 2);
        }
        self.rebuild_free_list();
        if self.free.capacity() > 2 * self.free.len() + 16 {
            self.free.shrink_to(self.free.len());
        }
    }

    fn rebuild_free_list(&mut self) {
        self.free.clear();
        let entries = &self.entries;
        self.free.extend(
            (0..entries.len() as u32)
                .rev()
                .filter(|&s| !entries[s as usize].is_live()),
        );
    }

    /// The free list, for the validator.
    pub fn free_list(&self) -> &[u32] {
        &self.free
    }

    pub fn memory_bytes(&self) -> usize {
        self.entries.capacity() * size_of::<Entry>()
            + (self.generations.capacity() + self.free.capacity()) * size_of::<u32>()
    }
}
