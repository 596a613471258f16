//! Static scenery in the trees: the static tree's builds landing, and static newcomers held
//! in the dynamic index until a tree holds them.

use super::{AccelTrees, Tracked, TreeSlot};
use crate::scenery::StaticSwap;
use bevy::prelude::*;

impl AccelTrees {
    /// Brings the static tree up to date with the static set, in the frame or off it (see
    /// `scenery`): lands a build that finished, or starts one. True when a new static tree
    /// was swapped in. The static tree is built over slot-indexed boxes (empty slots are
    /// left out by the builder), so its primitive ids are slots, like the dynamic index's.
    pub(crate) fn advance_static(
        &mut self,
        in_frame_up_to: usize,
        strategy: crate::StaticTreeBuild,
    ) -> bool {
        let swap = self.scenery.advance(in_frame_up_to, strategy);
        let built_in_frame = swap.as_ref().is_some_and(|swap| swap.built_in_frame);
        let swapped = swap.is_some();
        if let Some(swap) = swap {
            self.swap_static(swap);
        }
        let fresh = core::mem::take(&mut self.fresh_static);
        if !built_in_frame {
            // No tree holds this frame's newcomers yet: they wait in the dynamic index.
            for slot in fresh {
                self.index_waiting_static(slot);
            }
        }
        swapped
    }

    /// Puts a static newcomer placed this frame, if still tracked in `slot`, into the dynamic
    /// index until a static tree holds it.
    fn index_waiting_static(&mut self, slot: u32) {
        let Some(entity) = self.entities_by_slot[slot as usize] else {
            return;
        };
        let bounds = self.slots[slot as usize].bounds();
        let Some(Some(record)) = self.tracked_by_index.get_mut(entity.index_u32() as usize) else {
            return;
        };
        if record.slot != slot || record.tree != TreeSlot::Static {
            return;
        }
        match self.index.insert(slot, bounds) {
            Ok(handle) => {
                record.tree = TreeSlot::StaticWaiting(handle);
                self.static_waiting += 1;
                self.pending_upkeep = true;
            }
            // The static tree takes boxes the dynamic index refuses (a fat box that would
            // overflow): this one is found once the tree being built lands.
            Err(e) => warn!("bevy_accel: {entity} waits for the next static tree ({e})"),
        }
    }

    /// Waits for the static tree being built off the frame, if any, and swaps it in: for
    /// tests, and for a loading screen that wants every static entity in the static tree
    /// before play. True when a tree was swapped in.
    pub fn finish_static_build(&mut self) -> bool {
        match self.scenery.finish() {
            Some(swap) => {
                self.swap_static(swap);
                true
            }
            None => false,
        }
    }

    fn swap_static(&mut self, swap: StaticSwap) {
        self.note_index_changed();
        let old = self.index.set_static_prepared(swap.prepared);
        crate::scenery::free_off_the_frame(old);
        self.free_slots.extend(swap.freed);
        for slot in swap.newcomers {
            // A newcomer that left meanwhile has a cleared slot; one still here leaves the
            // dynamic index, since the new tree holds it.
            let Some(entity) = self.entities_by_slot[slot as usize] else {
                continue;
            };
            let record = &mut self.tracked_by_index[entity.index_u32() as usize];
            if let Some(Tracked { tree, .. }) = record
                && let TreeSlot::StaticWaiting(handle) = *tree
            {
                *tree = TreeSlot::Static;
                self.static_waiting -= 1;
                self.pending_upkeep = true;
                if let Err(e) = self.index.remove(handle) {
                    error!("bevy_accel: moving {entity} into the static tree failed: {e}");
                }
            }
        }
    }

    /// Number of static entities, those in the static tree and those waiting in the dynamic
    /// index for the next one.
    pub fn static_len(&self) -> usize {
        self.scenery.len()
    }

    /// Static entities held in the dynamic index until the static tree being built (or the
    /// next one) takes them in. Queries find them all the same.
    pub fn static_waiting_len(&self) -> usize {
        self.static_waiting
    }

    /// Whether a static tree is being built off the frame.
    pub fn static_build_in_flight(&self) -> bool {
        self.scenery.building()
    }
}
