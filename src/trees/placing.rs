//! Placing entities in the trees and taking them out: the edits the sync makes, with the
//! slot bookkeeping behind them.

use super::busy_movers::busy_tag;
use super::slot_record::SlotEntry;
use super::{AccelTrees, LocalFrame, Tracked, TreeSlot};
use bevy::prelude::*;
use spatial_accel::Aabb;
use spatial_accel::prefetch::prefetch_all;
use spatial_accel::query::IndexError;

/// What [`AccelTrees::place`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Placed {
    /// The entity was not tracked and now is.
    Inserted,
    /// A tree changed for an entity already tracked (its box moved, or it changed tree).
    Moved,
    /// Nothing a query can see changed (the move stayed inside the leaf's fat box).
    Unchanged,
    /// The entity's world box is the one it had (its transform changed without moving the
    /// box, or was only marked changed, as in the frames after a spawn): no index work, and
    /// not a mover for the automatic choice.
    Same,
    /// The dynamic tree refused a new entity's box, for the reason given; it stays untracked,
    /// and the caller reports it.
    Refused(&'static str),
    /// The dynamic tree refused a tracked entity's new box, for the reason given; it was taken
    /// out, and the caller reports it.
    Evicted(&'static str),
}

/// Why the dynamic index refused an entity, as the warning about it says.
pub(super) fn refusal(e: IndexError) -> &'static str {
    match e {
        IndexError::InvalidBounds => {
            "its bounds are too close to the end of the float range for the dynamic index"
        }
        IndexError::CapacityExceeded => "the dynamic index is full",
        IndexError::StaleHandle => "the dynamic index lost its entry",
    }
}

impl AccelTrees {
    fn allocate_slot(&mut self, entity: Entity, bounds: Aabb, frame: LocalFrame) -> u32 {
        let entry = SlotEntry::new(entity, bounds, frame);
        let slot = if let Some(slot) = self.free_slots.pop() {
            self.slots[slot as usize] = entry;
            self.entities_by_slot[slot as usize] = Some(entity);
            slot
        } else {
            self.slots.push(entry);
            self.entities_by_slot.push(Some(entity));
            (self.slots.len() - 1) as u32
        };
        self.assigned_slots.push(slot);
        slot
    }

    /// Puts an entity in the tree it belongs in, or moves it there, with a valid world box and
    /// its own space. Says what changed, so the caller needs no lookup of its own.
    pub(crate) fn place(
        &mut self,
        entity: Entity,
        bounds: Aabb,
        frame: LocalFrame,
        is_static: bool,
    ) -> Placed {
        let moved = |placed: Placed| match placed {
            Placed::Inserted => Placed::Moved,
            other => other,
        };
        match self.tracked(entity) {
            Some(t) => match (t.tree, is_static) {
                (TreeSlot::Dynamic(h), false) => {
                    let same_box = self.slots[t.slot as usize].bounds() == bounds;
                    // The frame is written even then: a turn can keep the world box.
                    self.slots[t.slot as usize] = SlotEntry::new(entity, bounds, frame);
                    if same_box {
                        return Placed::Same;
                    }
                    self.pending_upkeep = true;
                    if self.busy.enabled && self.busy.transfers_left > 0 {
                        self.busy.transfers_left -= 1;
                        if let Some(placed) = self.make_busy(entity, t.slot, h, bounds) {
                            return placed;
                        }
                    }
                    match self.index.update(h, bounds) {
                        Ok(true) => Placed::Moved,
                        Ok(false) => Placed::Unchanged,
                        Err(IndexError::InvalidBounds) => {
                            // Finite, but its fat box would overflow: no tree can hold it.
                            self.remove(entity);
                            Placed::Evicted(refusal(IndexError::InvalidBounds))
                        }
                        Err(e) => {
                            // Cannot happen while handles are kept with their slots; if it
                            // does, re-inserting keeps the entity in the tree.
                            error!("bevy_accel: updating {entity} failed ({e}); re-inserting it");
                            self.remove(entity);
                            moved(self.place(entity, bounds, frame, false))
                        }
                    }
                }
                (TreeSlot::Busy, false) => match self.move_busy(entity, bounds) {
                    Some(placed) => placed,
                    None => {
                        error!("bevy_accel: {entity} lost its busy entry; re-inserting it");
                        self.remove(entity);
                        moved(self.place(entity, bounds, frame, false))
                    }
                },
                (TreeSlot::Static | TreeSlot::StaticWaiting(_), true)
                    if self.slots[t.slot as usize].bounds() == bounds =>
                {
                    // Static entities are placed only when (re)marked.
                    self.slots[t.slot as usize].frame = frame;
                    Placed::Unchanged
                }
                _ => {
                    self.remove(entity);
                    moved(self.place(entity, bounds, frame, is_static))
                }
            },
            None => {
                let index = entity.index_u32() as usize;
                if let Some(Some(stale)) = self.tracked_by_index.get(index) {
                    let stale = stale.entity;
                    // Bevy reuses an index only after its entity was despawned: the entity
                    // still here is dead, and its removal, queued in the same frame, may come
                    // after this insertion. Remove it now so no dead entity stays in a tree.
                    self.remove(stale);
                }
                let slot = self.allocate_slot(entity, bounds, frame);
                // A static newcomer is wanted in the next static tree (see `scenery`); a
                // static box that changed comes here too, as a leaver and a newcomer in a new
                // slot, since the trees may still hold the old slot. It is marked static
                // here and goes into the dynamic index only if that tree is not built in
                // this frame (`advance_static`): a level loaded in one frame would otherwise
                // be inserted into the dynamic index one entity at a time and taken out again.
                let tree = if is_static {
                    self.scenery.add(slot, bounds);
                    self.fresh_static.push(slot);
                    TreeSlot::Static
                } else {
                    self.pending_upkeep = true;
                    match self.index.insert(slot, bounds) {
                        Ok(handle) => TreeSlot::Dynamic(handle),
                        Err(e) => {
                            self.release_slot(slot);
                            return Placed::Refused(refusal(e));
                        }
                    }
                };
                if self.tracked_by_index.len() <= index {
                    self.tracked_by_index.resize(index + 1, None);
                }
                self.tracked_by_index[index] = Some(Tracked { entity, slot, tree });
                self.tracked_count += 1;
                Placed::Inserted
            }
        }
    }

    /// Asks for the record [`place`](Self::place) reads first to find an entity's slot (see
    /// [`prefetch_placement`](Self::prefetch_placement), the step after). A hint only.
    #[inline]
    pub(crate) fn prefetch_record(&self, entity: Entity) {
        let busy = self.index.busy_movers();
        // With busy movers about, most movers are among them and need only their position
        // by key: the tracked record would be a line read for nothing.
        if !busy.is_empty() {
            busy.prefetch_key(entity.index_u32());
        } else if let Some(record) = self.tracked_by_index.get(entity.index_u32() as usize) {
            prefetch_all(record);
        }
    }

    /// Asks for what [`place`](Self::place) of a tracked entity writes and reads at scattered
    /// places: its slot record and its dynamic leaf. A hint only.
    ///
    /// Why: after a rebuild or the optimiser's reinsertions, a leaf's place in the dynamic
    /// tree's arena no longer follows the entity order in which the sync visits movers, so
    /// each update waited on a leaf node and its tight box (BENCHMARKS.md, Plugin sync). The
    /// slot record comes
    /// after the per-entity record in a chain of dependent reads, so it is asked for here,
    /// once that record (asked for earlier by [`prefetch_record`](Self::prefetch_record)) has
    /// arrived.
    #[inline]
    pub(crate) fn prefetch_placement(&self, entity: Entity) {
        if self.index.busy_movers().prefetch_entry(entity.index_u32()) {
            return;
        }
        let Some(t) = self.tracked(entity) else {
            return;
        };
        let slot = t.slot as usize;
        prefetch_all(&self.slots[slot]);
        if let TreeSlot::Dynamic(handle) = t.tree {
            self.index.prefetch_entry(handle);
        }
    }

    /// Asks for what a ray's candidate test reads first of a slot: its record (exact box,
    /// entity and own space). A hint only; see
    /// [`RayWalk::walk_ray_announcing`](spatial_accel::query::RayWalk::walk_ray_announcing), which
    /// says when.
    #[inline]
    #[cfg_attr(not(feature = "picking"), allow(dead_code))]
    pub(crate) fn prefetch_candidate(&self, slot: u32) {
        if let Some(entry) = self.slots.get(slot as usize) {
            prefetch_all(entry);
        }
    }

    /// Takes an entity out of its tree. Returns whether it was in one.
    pub(crate) fn remove(&mut self, entity: Entity) -> bool {
        let Some(t) = self.tracked(entity) else {
            return false;
        };
        self.tracked_by_index[entity.index_u32() as usize] = None;
        self.tracked_count -= 1;
        if let TreeSlot::Dynamic(h) | TreeSlot::StaticWaiting(h) = t.tree {
            self.pending_upkeep = true;
            if let Err(e) = self.index.remove(h) {
                error!("bevy_accel: removing {entity} from the dynamic index failed: {e}");
            }
        }
        if t.tree == TreeSlot::Busy
            && self
                .index
                .busy_movers_mut()
                .remove(entity.index_u32(), busy_tag(entity))
                .is_none()
        {
            error!("bevy_accel: {entity} was not among the busy movers");
        }
        self.vacate(t);
        true
    }

    /// Gives up the slot of an entity no longer tracked.
    pub(super) fn vacate(&mut self, t: Tracked) {
        if let TreeSlot::StaticWaiting(_) = t.tree {
            self.static_waiting -= 1;
        }
        if let TreeSlot::Dynamic(_) | TreeSlot::Busy = t.tree {
            self.release_slot(t.slot);
        } else {
            // The static tree (or one being built) may hold the slot: cleared, it reports
            // nothing, and it is freed when a tree without it lands.
            self.scenery.retire(t.slot);
            self.clear_slot(t.slot);
        }
    }

    fn clear_slot(&mut self, slot: u32) {
        self.slots[slot as usize] = SlotEntry::FREE;
        self.entities_by_slot[slot as usize] = None;
    }

    pub(super) fn release_slot(&mut self, slot: u32) {
        self.clear_slot(slot);
        self.free_slots.push(slot);
    }

    /// Takes out the entities a new index refused during a switch: their records still name
    /// the old index's handles, which that index took with it.
    pub(super) fn untrack_refused(&mut self, refused: &[(Entity, &'static str)]) {
        for &(entity, _) in refused {
            let t = self
                .tracked(entity)
                .expect("a refused entity is still tracked");
            self.tracked_by_index[entity.index_u32() as usize] = None;
            self.tracked_count -= 1;
            self.vacate(t);
        }
    }
}
