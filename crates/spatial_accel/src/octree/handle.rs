//! Handles to the tree's entries: a slot table with generations, so a handle kept past
//! `remove` is reported stale instead of naming whatever later reused its slot.

use super::cells::NONE;

/// A stable reference to one entry of a [`LooseTree`](super::LooseTree) (a
/// [`LooseOctree`](super::LooseOctree) or a [`Quadtree`](super::Quadtree)): valid from
/// `insert` until `remove`.
///
/// Entries move between octants as they move in space; the handle names a slot that follows
/// them, and the slot's generation, which `remove` advances.
pub type OctreeHandle = crate::query::Handle<AnyLooseTree>;

/// The structure marker of [`OctreeHandle`]: octrees and quadtrees share their code and one
/// handle type. Never constructed.
#[derive(Debug)]
pub enum AnyLooseTree {}

/// Where a live entry is: its octant and its position in that octant's arrays.
#[derive(Clone, Copy, Debug)]
pub(super) struct Slot {
    /// The octant holding the entry, or [`NONE`] when the slot is free.
    pub(super) octant: u32,
    pub(super) position: u32,
    pub(super) generation: u32,
}

/// The slot table.
#[derive(Clone, Debug, Default)]
pub(super) struct Slots {
    pub(super) slots: Vec<Slot>,
    pub(super) free: Vec<u32>,
}

impl Slots {
    /// The slot of a live handle.
    #[inline]
    pub(super) fn get(&self, handle: OctreeHandle) -> Option<Slot> {
        let slot = *self.slots.get(handle.index() as usize)?;
        (slot.generation == handle.generation() && slot.octant != NONE).then_some(slot)
    }

    /// Whether [`Self::allocate`] can succeed, checked before an insert changes anything.
    #[inline]
    pub(super) fn has_room(&self) -> bool {
        !self.free.is_empty() || self.slots.len() < NONE as usize
    }

    /// A slot for a new entry at `octant`, `position`. Call [`Self::has_room`] first.
    pub(super) fn allocate(&mut self, octant: u32, position: u32) -> OctreeHandle {
        let slot = match self.free.pop() {
            Some(slot) => slot,
            None => {
                self.slots.push(Slot {
                    octant: NONE,
                    position: 0,
                    generation: 0,
                });
                (self.slots.len() - 1) as u32
            }
        };
        let s = &mut self.slots[slot as usize];
        s.octant = octant;
        s.position = position;
        OctreeHandle::new(slot, s.generation)
    }

    /// Frees a slot; its handles become stale.
    pub(super) fn release(&mut self, slot: u32) {
        let s = &mut self.slots[slot as usize];
        s.octant = NONE;
        s.generation = s.generation.wrapping_add(1);
        self.free.push(slot);
    }

    /// Points a live slot at the entry's new place.
    #[inline]
    pub(super) fn relocate(&mut self, slot: u32, octant: u32, position: u32) {
        let s = &mut self.slots[slot as usize];
        s.octant = octant;
        s.position = position;
    }

    /// Frees every live slot: every handle becomes stale.
    pub(super) fn release_all(&mut self) {
        for slot in 0..self.slots.len() as u32 {
            if self.slots[slot as usize].octant != NONE {
                self.release(slot);
            }
        }
    }

    pub(super) fn memory_bytes(&self) -> usize {
        self.slots.capacity() * size_of::<Slot>() + self.free.capacity() * size_of::<u32>()
    }
}
