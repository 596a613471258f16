//! Static scenery: the static tree's set and builds, streamed in and out without a frame
//! stall, and static newcomers held in the dynamic index until a tree holds them.
//!
//! A static BVH is built once and never refit, which is what makes it fast to query; the
//! price is that its set cannot change in place. Rebuilding it in the frame that spawns or
//! despawns one static entity stalls that frame by the whole build, which grows with the
//! static set. So a change of the static set is split in two:
//!
//! - **In the frame**, O(1) per entity: a newcomer goes into the dynamic index, where queries
//!   find it at once (unless a tree holding it is built in the same frame); a leaver's slot
//!   is *retired*: its entity and exact box are cleared, so the static tree may still report
//!   the slot but no query callback finds anything there, and the slot is not reused while
//!   any tree still holds it.
//! - **Off the frame**: the next static tree, with its ray form and spans
//!   ([`PreparedStatic`]), is built on Bevy's async compute pool over the wanted boxes; when
//!   it is done it is swapped in (a move), the newcomers it holds leave the dynamic index,
//!   and the retired slots it no longer holds are freed.
//!
//! A load that more than doubles the set is built in its frame: a loading frame builds
//! faster in one go than by a million insertions into the dynamic index. So are sets up to
//! [`AccelSettings::static_rebuild_in_frame_up_to`](crate::AccelSettings::static_rebuild_in_frame_up_to),
//! and every set when there is no async compute pool (BENCHMARKS.md, Static scenery
//! streaming).

use super::{AccelTrees, Tracked, TreeSlot};
use crate::settings::StaticTreeBuild;
use bevy::prelude::*;
use bevy::tasks::{AsyncComputeTaskPool, Task, block_on, futures::check_ready};
use spatial_accel::dynamic::PreparedStatic;
use spatial_accel::{Aabb, BuildConfig, Bvh, SahCosts};

/// What a build takes and gives back: the boxes by slot (handed back so the next build
/// reuses them without a copy).
type BuildOutput = (PreparedStatic, Vec<Aabb>);

/// A static tree being built off the frame, with what to do when it lands.
struct InFlight {
    task: Task<BuildOutput>,
    /// Slots of the newcomers the new tree holds.
    newcomers: Vec<u32>,
    /// Slots retired before the build started: the new tree does not hold them.
    retired: Vec<u32>,
}

/// A new static tree to swap in, with the slots it settles.
struct StaticSwap {
    prepared: PreparedStatic,
    /// Newcomers the tree holds: they leave the dynamic index (if still tracked in that slot).
    newcomers: Vec<u32>,
    /// Retired slots no tree holds any more: free for reuse.
    freed: Vec<u32>,
    /// Built in this call, over every newcomer so far (else it was built off the frame, over
    /// the newcomers when it started).
    built_in_frame: bool,
}

/// The wanted static set by slot, and the build that will make it the static tree.
#[derive(Default)]
pub(super) struct StaticScenery {
    /// The box of each slot's static entity (`Aabb::EMPTY` where none): the next build's
    /// input. Empty while a build holds it.
    bounds: Vec<Aabb>,
    /// Writes to `bounds` made while a build holds it, applied when it comes back.
    edits: Vec<(u32, Aabb)>,
    /// Static entities wanted (newcomers included).
    live: usize,
    /// Newcomers not yet in any build.
    waiting: Vec<u32>,
    /// Slots retired since the last build started.
    retired: Vec<u32>,
    in_flight: Option<InFlight>,
    /// The build strategy of the last tree started: a change of strategy rebuilds the tree.
    built_with: Option<StaticTreeBuild>,
}

impl StaticScenery {
    /// Static entities wanted: those in the static tree and those waiting for the next one.
    fn len(&self) -> usize {
        self.live
    }

    /// Whether a static tree is being built off the frame.
    fn building(&self) -> bool {
        self.in_flight.is_some()
    }

    fn write(&mut self, slot: u32, bounds: Aabb) {
        if self.in_flight.is_some() {
            self.edits.push((slot, bounds));
            return;
        }
        let slot = slot as usize;
        if self.bounds.len() <= slot {
            self.bounds.resize(slot + 1, Aabb::EMPTY);
        }
        self.bounds[slot] = bounds;
    }

    /// A static entity arrives in `slot` with its world box (the caller keeps it in the
    /// dynamic index until the swap that lists the slot among its newcomers).
    pub(super) fn add(&mut self, slot: u32, bounds: Aabb) {
        self.write(slot, bounds);
        self.live += 1;
        self.waiting.push(slot);
    }

    /// The static entity in `slot` leaves. The caller clears the slot but must not reuse it
    /// before a swap lists it as freed.
    pub(super) fn retire(&mut self, slot: u32) {
        self.write(slot, Aabb::EMPTY);
        self.live -= 1;
        self.retired.push(slot);
    }

    /// Lands a finished build, or starts one when the set or the strategy changed: the
    /// once-per-frame call. `in_frame_up_to` is the set size up to which a build runs here
    /// rather than off the frame.
    fn advance(&mut self, in_frame_up_to: usize, strategy: StaticTreeBuild) -> Option<StaticSwap> {
        if let Some(build) = &mut self.in_flight {
            let output = check_ready(&mut build.task)?;
            return Some(self.land(output));
        }
        let restyled = self.built_with.is_some_and(|b| b != strategy) && self.live > 0;
        if self.waiting.is_empty() && self.retired.is_empty() && !restyled {
            return None;
        }
        self.built_with = Some(strategy);
        let config = entity_tree_config(strategy);
        let tree_len = self.live + self.retired.len() - self.waiting.len();
        let mass_load = self.waiting.len() > tree_len;
        match AsyncComputeTaskPool::try_get() {
            Some(pool) if self.live > in_frame_up_to && !mass_load => {
                let bounds = core::mem::take(&mut self.bounds);
                let task = pool.spawn(async move { build(bounds, &config) });
                self.in_flight = Some(InFlight {
                    task,
                    newcomers: core::mem::take(&mut self.waiting),
                    retired: core::mem::take(&mut self.retired),
                });
                None
            }
            _ => {
                let (prepared, bounds) = build(core::mem::take(&mut self.bounds), &config);
                self.bounds = bounds;
                Some(StaticSwap {
                    prepared,
                    newcomers: core::mem::take(&mut self.waiting),
                    freed: core::mem::take(&mut self.retired),
                    built_in_frame: true,
                })
            }
        }
    }

    /// Waits for the build in flight, if any, and lands it.
    fn finish(&mut self) -> Option<StaticSwap> {
        let build = self.in_flight.as_mut()?;
        let output = block_on(&mut build.task);
        Some(self.land(output))
    }

    fn land(&mut self, (prepared, bounds): BuildOutput) -> StaticSwap {
        let build = self
            .in_flight
            .take()
            .expect("a build lands only while in flight");
        self.bounds = bounds;
        for (slot, bounds) in core::mem::take(&mut self.edits) {
            self.write(slot, bounds);
        }
        StaticSwap {
            prepared,
            newcomers: build.newcomers,
            freed: build.retired,
            built_in_frame: false,
        }
    }
}

/// The static tree's build. A primitive here is an entity: testing one reads its slot entry
/// at a random place, and one that passes goes on to ECS lookups and a mesh BVH, so a
/// primitive test is costed at four node visits (the default costs a node visit at two
/// primitive tests, right for triangles). Leaves then hold one or two entities instead of up
/// to eight, and rays reach fewer candidates (BENCHMARKS.md, Picking).
///
/// Built with PLOC rather than binned SAH: the static tree is rebuilt whenever static
/// entities come or go (off the frame, or in it at a load), PLOC builds it much faster, and
/// rays and views run as fast on its trees (BENCHMARKS.md, Static BVH builds). Another
/// [`StaticTreeBuild`] changes only the split strategy.
pub(crate) fn entity_tree_config(strategy: StaticTreeBuild) -> BuildConfig {
    BuildConfig {
        split: strategy.split(),
        max_leaf_size: 4,
        sah: SahCosts {
            traversal: 1.0,
            intersection: 4.0,
        },
        ..BuildConfig::default()
    }
}

/// Frees a replaced static tree on the async compute pool: freeing the arrays of a large
/// tree returns their pages to the system, milliseconds at a million entities, which the swap
/// frame need not pay. Frees it here when there is no pool.
fn free_off_the_frame(old: PreparedStatic) {
    match AsyncComputeTaskPool::try_get() {
        Some(pool) if old.tree().primitive_count() > 0 => {
            pool.spawn(async move { drop(old) }).detach();
        }
        _ => drop(old),
    }
}

/// The static tree over `bounds` (empty boxes are left out, so primitive ids are slots).
fn build(bounds: Vec<Aabb>, config: &BuildConfig) -> BuildOutput {
    let prepared = PreparedStatic::new(Bvh::build(&bounds, config));
    (prepared, bounds)
}

impl AccelTrees {
    /// Brings the static tree up to date with the static set, in the frame or off it (see
    /// the module docs): lands a build that finished, or starts one. True when a new static tree
    /// was swapped in. The static tree is built over slot-indexed boxes (empty slots are
    /// left out by the builder), so its primitive ids are slots, like the dynamic index's.
    pub(crate) fn advance_static(
        &mut self,
        in_frame_up_to: usize,
        strategy: StaticTreeBuild,
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
        free_off_the_frame(old);
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
