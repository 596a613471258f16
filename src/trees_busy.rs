//! The busy movers: entities that move frame after frame, kept in a flat list outside the
//! dynamic index.
//!
//! Why: a mover in a tree costs its sync a tracked record, a slot record of two lines and
//! the index's entry, each a cache miss at a million entities, and the tree its refit; the
//! least any upkeep of a mover can cost (the `Changed` scan, its rows, its world box and one
//! store) is well under that (BENCHMARKS.md, Plugin sync). A busy mover's sync reads a 4-byte
//! position by entity index and writes one list entry, in the order the sync visits movers;
//! queries test the list flat, one box test an entry. Entities that stay still for
//! [`BusyMoverSettings::quiet_frames`](crate::BusyMoverSettings::quiet_frames) go back into
//! the dynamic index, where queries pay nothing for them.

use super::{AccelTrees, Placed, SlotEntry, TreeSlot, busy_tag};
use crate::LocalFrame;
use bevy::prelude::*;
use spatial_accel::Aabb;
use spatial_accel::query::AnyHandle;

impl AccelTrees {
    /// Starts a frame of the busy movers: whether movers may join, and how many entities may
    /// join or leave (each costs an edit of the dynamic index, so a switch of a million
    /// movers is spread over frames rather than stalling one).
    pub(crate) fn begin_busy_frame(&mut self, enabled: bool, transfers: usize) {
        self.busy.enabled = enabled;
        self.busy.stamp = self.busy.stamp.wrapping_add(1);
        self.busy.transfers_left = transfers;
    }

    /// Whether movers may join the busy movers this frame.
    pub(crate) fn busy_enabled(&self) -> bool {
        self.busy.enabled
    }

    /// Number of busy movers.
    pub fn busy_len(&self) -> usize {
        self.index.busy_movers().len()
    }

    /// Gives a busy mover its new box: one entry write. `None` when the entity is not a
    /// busy mover (the caller places it in the trees).
    #[inline]
    pub(crate) fn move_busy(&mut self, entity: Entity, bounds: Aabb) -> Option<Placed> {
        let stamp = self.busy.stamp;
        let busy = self.index.busy_movers_mut();
        let at = busy.position(entity.index_u32(), busy_tag(entity))?;
        Some(if busy.set_bounds(at, bounds, stamp) {
            Placed::Moved
        } else {
            Placed::Same
        })
    }

    /// Moves a dynamic entity out of the dynamic index into the busy movers, with its new
    /// box. `None` when the list refused it (the caller updates it in the index instead).
    pub(super) fn make_busy(
        &mut self,
        entity: Entity,
        slot: u32,
        handle: AnyHandle,
        bounds: Aabb,
    ) -> Option<Placed> {
        let stamp = self.busy.stamp;
        self.index
            .busy_movers_mut()
            .insert(entity.index_u32(), busy_tag(entity), slot, bounds, stamp)
            .ok()?;
        if let Err(e) = self.index.remove(handle) {
            error!("bevy_accel: moving {entity} out of the dynamic index failed: {e}");
        }
        self.slots[slot as usize] = SlotEntry::busy(entity);
        if let Some(Some(record)) = self.tracked_by_index.get_mut(entity.index_u32() as usize) {
            record.tree = TreeSlot::Busy;
        }
        Some(Placed::Moved)
    }

    /// Busy movers that have not moved for `quiet_frames` frames (all of them when movers
    /// may not be busy this frame), found among the next `check_up_to` entries of a sweep
    /// that goes round the list over the frames, and at most as many as may leave this
    /// frame. Each goes back with [`Self::settle_busy`].
    pub(crate) fn quiet_busy_movers(
        &mut self,
        quiet_frames: u32,
        check_up_to: usize,
        out: &mut Vec<Entity>,
    ) {
        out.clear();
        let entries = self.index.busy_movers().entries();
        if entries.is_empty() {
            return;
        }
        let from = if self.busy.sweep_from < entries.len() {
            self.busy.sweep_from
        } else {
            0
        };
        let to = (from + check_up_to).min(entries.len());
        let stamp = self.busy.stamp;
        let everyone = !self.busy.enabled;
        for entry in &entries[from..to] {
            if out.len() >= self.busy.transfers_left {
                break;
            }
            if everyone || stamp.wrapping_sub(entry.stamp) > quiet_frames {
                out.extend(self.entities_by_slot[entry.id as usize]);
            }
        }
        self.busy.sweep_from = to;
        self.busy.transfers_left -= out.len();
    }

    /// Puts a busy mover back into the dynamic index with its current box and own space.
    /// Returns false when the index refused it: it is then out of the trees, and the caller
    /// reports it.
    pub(crate) fn settle_busy(&mut self, entity: Entity, bounds: Aabb, frame: LocalFrame) -> bool {
        let Some(t) = self.tracked(entity).filter(|t| t.tree == TreeSlot::Busy) else {
            return true;
        };
        self.index
            .busy_movers_mut()
            .remove(entity.index_u32(), busy_tag(entity));
        self.pending_upkeep = true;
        self.slots[t.slot as usize] = SlotEntry::new(entity, bounds, frame);
        let tree = match self.index.insert(t.slot, bounds) {
            Ok(handle) => TreeSlot::Dynamic(handle),
            Err(_) => {
                self.tracked_by_index[entity.index_u32() as usize] = None;
                self.tracked_count -= 1;
                self.release_slot(t.slot);
                return false;
            }
        };
        if let Some(Some(record)) = self.tracked_by_index.get_mut(entity.index_u32() as usize) {
            record.tree = tree;
        }
        true
    }
}
