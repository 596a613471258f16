//! Switching the movers' index off the frame.
//!
//! A switch moves every dynamic entity into a structure of another kind. Done in the frame,
//! that is one insertion each: at a million movers a stall of a whole build, which an
//! automatic choice must never cause. So a large switch fills the new structure on the async
//! compute pool from a snapshot of the dynamic entries while the old one keeps serving the
//! frames; when the fill lands, the entries that changed since the snapshot are brought up to
//! date (one update, insertion or removal each, found by comparing boxes, so no edit path has
//! to log anything) and the structures are swapped.

use super::placing::refusal;
use super::{AccelTrees, TreeSlot};
use crate::index::IndexChoice;
use bevy::prelude::*;
use bevy::tasks::{AsyncComputeTaskPool, Task, block_on, futures::check_ready};
use spatial_accel::Aabb;
use spatial_accel::query::{AnyHandle, AnyIndex, DynamicIndex, IndexError};

/// The dynamic entries at the snapshot, with the new structure's handle for each.
type Filled = (AnyIndex, Vec<(u32, Aabb, Result<AnyHandle, IndexError>)>);

/// A switch in flight.
pub(crate) struct IndexSwitch {
    target: IndexChoice,
    task: Task<Filled>,
}

/// What [`AccelTrees::advance_index_switch`] did this frame.
pub(crate) struct SwitchLanded {
    /// Dynamic entities now in the new structure.
    pub(crate) moved: usize,
    /// Entities the new structure refused, with why: they are out of the trees.
    pub(crate) refused: Vec<(Entity, &'static str)>,
}

impl AccelTrees {
    /// Moves the dynamic entities towards a `target` structure: at once when there are at
    /// most `in_frame_up_to` of them (or no task pool), else by a fill off the frame that
    /// lands in a later frame. Returns what landed, if anything did this frame. A target
    /// changed while a fill is in flight drops that fill.
    pub(crate) fn advance_index_switch(
        &mut self,
        target: IndexChoice,
        in_frame_up_to: usize,
    ) -> Option<SwitchLanded> {
        if self.switch.as_ref().is_some_and(|s| s.target != target) {
            // Dropping a task cancels it.
            self.switch = None;
        }
        if let Some(switch) = self.switch.as_mut() {
            let filled = check_ready(&mut switch.task)?;
            self.switch = None;
            return Some(self.land_switch(target, filled));
        }
        if self.index.choice() == target {
            return None;
        }
        let dynamic = self.index.dynamic_len();
        let pool = AsyncComputeTaskPool::try_get().filter(|_| dynamic > in_frame_up_to);
        let (Some(pool), Some(kind)) = (pool, target.kind()) else {
            let refused = self.switch_index(target);
            return Some(SwitchLanded {
                moved: dynamic - refused.len(),
                refused,
            });
        };
        let snapshot: Vec<(u32, Aabb)> = self
            .tracked_by_index
            .iter()
            .flatten()
            .filter(|r| matches!(r.tree, TreeSlot::Dynamic(_) | TreeSlot::StaticWaiting(_)))
            .map(|r| (r.slot, self.slots[r.slot as usize].bounds()))
            .collect();
        let task = pool.spawn(async move {
            let mut index = AnyIndex::new(kind);
            let entries = snapshot
                .into_iter()
                .map(|(slot, bounds)| (slot, bounds, index.insert(slot, bounds)))
                .collect();
            (index, entries)
        });
        self.switch = Some(IndexSwitch { target, task });
        None
    }

    /// Moves every dynamic entity into a new, empty index of the chosen kind, keeping the
    /// static tree. Returns the entities the new index refused, with the reason: they are
    /// out of the trees, and the caller reports them as it reports any refusal.
    ///
    /// Why one insertion each rather than a bulk build: the new structure's own insertion is
    /// what its later edits will do, so the switch leaves it as it would be after a run, and
    /// a switch is a rare, user-driven event.
    pub(crate) fn switch_index(&mut self, choice: IndexChoice) -> Vec<(Entity, &'static str)> {
        self.index.reset_dynamic(choice);
        self.note_index_changed();
        self.pending_upkeep = true;
        let mut refused = Vec::new();
        for record in self.tracked_by_index.iter_mut().flatten() {
            if let TreeSlot::Dynamic(handle) | TreeSlot::StaticWaiting(handle) = &mut record.tree {
                let bounds = self.slots[record.slot as usize].bounds();
                match self.index.insert(record.slot, bounds) {
                    Ok(new) => *handle = new,
                    Err(e) => refused.push((record.entity, refusal(e))),
                }
            }
        }
        self.untrack_refused(&refused);
        refused
    }

    /// Whether a switch of the movers' index is being filled off the frame.
    pub fn index_switch_in_flight(&self) -> bool {
        self.switch.is_some()
    }

    /// Waits for a switch being filled off the frame and lands it now; for tests and tools
    /// that need the new structure at once. Returns whether one was in flight.
    pub fn finish_index_switch(&mut self) -> bool {
        let Some(switch) = self.switch.take() else {
            return false;
        };
        let filled = block_on(switch.task);
        let refused = self.land_switch(switch.target, filled).refused;
        for (entity, why) in refused {
            warn!("bevy_accel: entity {entity} is left out of the trees: {why}");
        }
        true
    }

    /// Brings the filled structure up to date with the entries as they are now, and swaps it
    /// in under the static tree.
    fn land_switch(&mut self, target: IndexChoice, (mut dynamic, entries): Filled) -> SwitchLanded {
        let slots = self.slots.len();
        let mut filled: Vec<Option<(Aabb, AnyHandle)>> = vec![None; slots];
        for (slot, bounds, handle) in entries {
            // A box the new structure refused at the snapshot is tried again below, with the
            // box it has now.
            if let (Ok(handle), Some(cell)) = (handle, filled.get_mut(slot as usize)) {
                *cell = Some((bounds, handle));
            }
        }
        let mut refused = Vec::new();
        let mut moved = 0;
        for record in self.tracked_by_index.iter_mut().flatten() {
            let (TreeSlot::Dynamic(handle) | TreeSlot::StaticWaiting(handle)) = &mut record.tree
            else {
                continue;
            };
            let slot = record.slot as usize;
            let now = self.slots[slot].bounds();
            let result = match filled.get_mut(slot).and_then(Option::take) {
                Some((then, new)) if then == now => Ok(new),
                Some((_, new)) => dynamic.update(new, now).map(|_| new).inspect_err(|_| {
                    let _ = dynamic.remove(new);
                }),
                None => dynamic.insert(record.slot, now),
            };
            match result {
                Ok(new) => {
                    *handle = new;
                    moved += 1;
                }
                Err(e) => refused.push((record.entity, refusal(e))),
            }
        }
        // Entries whose entity left the dynamic index since the snapshot (despawned, made
        // static, or a waiting static entity taken into the static tree).
        for (_, handle) in filled.into_iter().flatten() {
            let _ = dynamic.remove(handle);
        }
        let old = self.index.swap_dynamic(dynamic);
        self.note_index_changed();
        debug_assert_eq!(self.index.choice(), target);
        // Freeing a structure of a million entries takes milliseconds; the pool pays them.
        match AsyncComputeTaskPool::try_get() {
            Some(pool) => pool.spawn(async move { drop(old) }).detach(),
            None => drop(old),
        }
        self.pending_upkeep = true;
        self.untrack_refused(&refused);
        SwitchLanded { moved, refused }
    }
}
