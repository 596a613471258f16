//! The trees over the world's entities, and the map between tree slots and entities.

use crate::index::EntityIndex;
pub use crate::local_frame::LocalFrame;
use crate::prefetch::prefetch_all;
use crate::scenery::StaticScenery;
use bevy::prelude::*;
use core::sync::atomic::{AtomicU32, Ordering};
use spatial_accel::dynamic::DynamicBvh;
use spatial_accel::query::{AnyHandle, IndexError};
use spatial_accel::{Aabb, Bvh};

/// Where a tracked entity lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TreeSlot {
    /// In the dynamic index, under this handle.
    Dynamic(AnyHandle),
    /// In the static tree.
    Static,
    /// Static, and held in the dynamic index under this handle until the next static tree,
    /// built off the frame, takes it in (see [`AccelTrees::static_waiting_len`]).
    StaticWaiting(AnyHandle),
    /// Moving frame after frame: among the busy movers, a flat list outside the dynamic
    /// index ([`EntityIndex::busy_movers`], [`BusyMoverSettings`](crate::BusyMoverSettings)).
    Busy,
}

/// What the sync writes for a slot each time its entity moves, and what a ray's candidate
/// reads once its exact box is hit: the box, then the entity's own space.
///
/// One record of exactly two cache lines, aligned to them. Why: the sync writes both parts
/// for every moved entity, and as two arrays (a 48-byte box-and-entity entry, a 96-byte
/// frame) they spanned four lines on average, each a miss at a scattered slot; a ray's
/// candidate reads the box on the first line and the frame mostly on the second.
///
/// The box is stored as plain coordinates so the entity fits on the first line too: a ray's
/// candidate then finds its entity on the line its box test loaded, where reading it from the
/// packed [`AccelTrees::slot_entities`] array cost one more miss per candidate (rays at 100k
/// entities ran faster, paired: docs/experiments.md, Picking). The packed array stays for
/// culling, which walks slots in order and reads 8 bytes per entity instead of a line.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct SlotEntry {
    min: [f32; 3],
    max: [f32; 3],
    entity: Option<Entity>,
    frame: LocalFrame,
}

const _: () = assert!(core::mem::size_of::<SlotEntry>() == 128);

impl SlotEntry {
    const FREE: Self = Self {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
        entity: None,
        frame: LocalFrame::NONE,
    };

    /// The record of a busy mover's slot: its box lives in the busy movers' list, and its
    /// own space is not kept (the sync would have to write it for every move, which is what
    /// the list exists to avoid). The NaN box marks it, and hides it from any test that
    /// reads it by mistake.
    const fn busy(entity: Entity) -> Self {
        Self {
            min: [f32::NAN; 3],
            max: [f32::NAN; 3],
            entity: Some(entity),
            frame: LocalFrame::NONE,
        }
    }

    #[inline]
    fn is_busy(&self) -> bool {
        self.min[0].is_nan()
    }

    fn new(entity: Entity, bounds: Aabb, frame: LocalFrame) -> Self {
        Self {
            min: bounds.min.to_array(),
            max: bounds.max.to_array(),
            entity: Some(entity),
            frame,
        }
    }

    #[inline]
    fn bounds(&self) -> Aabb {
        Aabb::new(Vec3A::from_array(self.min), Vec3A::from_array(self.max))
    }
}

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
fn refusal(e: IndexError) -> &'static str {
    match e {
        IndexError::InvalidBounds => {
            "its bounds are too close to the end of the float range for the dynamic index"
        }
        IndexError::CapacityExceeded => "the dynamic index is full",
        IndexError::StaleHandle => "the dynamic index lost its entry",
    }
}

/// The busy movers' tag of an entity, kept with its entry: the list's key is the entity's
/// index, which Bevy reuses.
#[inline]
fn busy_tag(entity: Entity) -> u32 {
    entity.generation().to_bits()
}

/// What the sync asks of the busy movers this frame (see [`AccelTrees::begin_busy_frame`]).
#[derive(Clone, Copy, Debug, Default)]
struct BusyFrame {
    /// Whether movers may join the list.
    enabled: bool,
    /// The frame's number, stamped on each busy move.
    stamp: u32,
    /// Entities that may still join or leave the list this frame.
    transfers_left: usize,
    /// Where the next search for quiet entries starts.
    sweep_from: usize,
}

/// A tracked entity's record, kept at its entity index.
#[derive(Clone, Copy, Debug)]
struct Tracked {
    /// The entity itself: Bevy reuses an index with a new generation, and the record is the
    /// tracked entity's only while this equals the entity asked for.
    entity: Entity,
    slot: u32,
    tree: TreeSlot,
}

/// The acceleration trees over the tracked entities: a dynamic index for things that move
/// (the BVH, or the grid for many movers, as [`AccelSettings::index`](crate::AccelSettings::index)
/// chooses) and a
/// static BVH for things marked [`AccelStatic`](crate::AccelStatic), queried as one
/// ([`EntityIndex`]).
///
/// Trees name primitives by *slot*: a small integer per tracked entity, reused after the
/// entity leaves. [`AccelTrees::entity`] and [`AccelTrees::world_bounds`] turn a slot from a
/// query callback into the entity and its exact world box.
///
/// The plugin keeps this resource in sync in [`AccelSystems::Sync`](crate::AccelSystems);
/// read it in any system that runs after it. It is marked changed (Bevy's change detection)
/// only in frames where the trees changed, so `Res<AccelTrees>::is_changed` tells a reader
/// whether what it computed from them last frame still holds.
#[derive(Resource, Default)]
pub struct AccelTrees {
    index: EntityIndex,
    /// Whether the dynamic index was edited since its last upkeep.
    pending_upkeep: bool,
    /// Each tracked entity's slot and tree, by entity index (`None` where none).
    /// Why not a hash map: every moved entity is looked up each frame, and sync visits them in
    /// table order, which is nearly index order, so a direct array read is nearly sequential
    /// where a hash map costs a hash and a probe at a random place. Why one record rather than
    /// a slot by index and a tree by slot: a lookup is then one read, not three dependent ones
    /// (the sync bench's lookups stalled on each in turn).
    tracked_by_index: Vec<Option<Tracked>>,
    tracked_count: usize,
    /// Each slot's exact world box and own space (see [`LocalFrame`]).
    slots: Vec<SlotEntry>,
    /// The entity of each slot, packed: see [`AccelTrees::slot_entities`].
    entities_by_slot: Vec<Option<Entity>>,
    free_slots: Vec<u32>,
    /// A switch of the movers' index being filled off the frame (see `trees_switch`).
    switch: Option<switch::IndexSwitch>,
    /// Slots handed to an entity since the last sync began (see [`Self::assigned_slots`]).
    assigned_slots: Vec<u32>,
    /// The static set wanted, and the build that makes it the static tree.
    scenery: StaticScenery,
    /// Tracked entities in [`TreeSlot::StaticWaiting`].
    static_waiting: usize,
    /// Slots of static newcomers placed since the last [`Self::advance_static`]: marked
    /// [`TreeSlot::Static`] before any tree holds them (see [`Self::place`]).
    fresh_static: Vec<u32>,
    /// Rays cast through `AccelRayCast` (and other users of [`Self::count_rays`]) since the
    /// last maintenance: what decides whether the dynamic tree's ray snapshot is worth refitting.
    rays_cast: AtomicU32,
    /// This frame's rules for the busy movers.
    busy: BusyFrame,
    /// See [`Self::index_generation`].
    index_generation: u64,
}

impl AccelTrees {
    /// Both trees, as one [`SpatialQuery`](spatial_accel::SpatialQuery): primitive ids are slots.
    pub fn query(&self) -> &EntityIndex {
        &self.index
    }

    /// The dynamic BVH, while it is the index of the moving entities.
    pub fn dynamic_bvh(&self) -> Option<&DynamicBvh> {
        self.index.dynamic_bvh()
    }

    /// The static tree.
    pub fn static_tree(&self) -> &Bvh {
        self.index.static_tree()
    }

    /// The entity in a slot, if the slot is in use.
    #[inline]
    pub fn entity(&self, slot: u32) -> Option<Entity> {
        self.slots.get(slot as usize).and_then(|s| s.entity)
    }

    /// The exact world box of the entity in a slot (the trees hold fattened boxes).
    #[inline]
    pub fn world_bounds(&self, slot: u32) -> Aabb {
        match self.slots.get(slot as usize) {
            Some(entry) if entry.is_busy() => entry.entity.map_or(Aabb::EMPTY, |entity| {
                self.index
                    .busy_movers()
                    .get(entity.index_u32(), busy_tag(entity))
                    .map_or(Aabb::EMPTY, |e| e.bounds)
            }),
            Some(entry) => entry.bounds(),
            None => Aabb::EMPTY,
        }
    }

    /// The slot and tree of a tracked entity.
    #[inline]
    pub fn location(&self, entity: Entity) -> Option<(u32, TreeSlot)> {
        self.tracked(entity).map(|t| (t.slot, t.tree))
    }

    /// True when the entity is in a tree.
    #[inline]
    pub fn contains(&self, entity: Entity) -> bool {
        self.tracked(entity).is_some()
    }

    /// Number of tracked entities.
    pub fn len(&self) -> usize {
        self.tracked_count
    }

    /// True when nothing is tracked.
    pub fn is_empty(&self) -> bool {
        self.tracked_count == 0
    }

    #[inline]
    fn tracked(&self, entity: Entity) -> Option<Tracked> {
        let t = (*self.tracked_by_index.get(entity.index_u32() as usize)?)?;
        (t.entity == entity).then_some(t)
    }

    /// The entity's own space in a slot (meaningless for a free slot); `None` for a busy
    /// mover ([`TreeSlot::Busy`]), whose own space is not kept: take it from its
    /// `GlobalTransform` and `Aabb`.
    #[inline]
    pub fn local_frame(&self, slot: u32) -> Option<&LocalFrame> {
        self.slots
            .get(slot as usize)
            .filter(|s| !s.is_busy())
            .map(|s| &s.frame)
    }

    /// Whether the entity in a slot is a busy mover ([`TreeSlot::Busy`]).
    #[inline]
    pub fn is_busy(&self, slot: u32) -> bool {
        self.slots
            .get(slot as usize)
            .is_some_and(SlotEntry::is_busy)
    }

    /// The entity in each slot, indexed by slot (`None` for free slots): for passes over many
    /// slots in order, 8 bytes per slot.
    pub fn slot_entities(&self) -> &[Option<Entity>] {
        &self.entities_by_slot
    }

    /// Every tracked entity with its slot, in slot order.
    pub fn iter(&self) -> impl Iterator<Item = (Entity, u32)> + '_ {
        self.entities_by_slot
            .iter()
            .enumerate()
            .filter_map(|(slot, e)| e.map(|e| (e, slot as u32)))
    }

    /// The index, for its upkeep (marks `AccelTrees` changed through `ResMut`).
    pub(crate) fn index_mut(&mut self) -> &mut EntityIndex {
        self.note_index_changed();
        &mut self.index
    }

    /// A number that changes whenever the static tree or the dynamic index may have changed,
    /// and not when only busy movers moved (they change the trees, as
    /// [`is_changed`](bevy::prelude::DetectChanges::is_changed) tells, but no tree): what a
    /// reader keeps from the index alone stays valid while it holds.
    pub fn index_generation(&self) -> u64 {
        self.index_generation
    }

    /// Marks the static tree or the dynamic index changed (see [`Self::index_generation`]).
    pub(crate) fn note_index_changed(&mut self) {
        self.index_generation = self.index_generation.wrapping_add(1);
    }

    /// Whether the dynamic index was edited since the last call.
    pub(crate) fn take_pending_upkeep(&mut self) -> bool {
        core::mem::take(&mut self.pending_upkeep)
    }

    /// Counts `rays` cast through the trees. The BVH backend keeps the dynamic tree's ray
    /// snapshot through motion only while rays are many next to the entities that move (see
    /// [`BvhIndexSettings::ray_snapshot_rays_per_mover`](crate::index::BvhIndexSettings::ray_snapshot_rays_per_mover));
    /// `AccelRayCast` counts its rays, and a system walking [`Self::query`] with rays of its
    /// own should count them too.
    #[inline]
    pub fn count_rays(&self, rays: u32) {
        self.rays_cast.fetch_add(rays, Ordering::Relaxed);
    }

    /// The rays counted since the last call, and restarts the count.
    pub(crate) fn take_rays_cast(&self) -> u32 {
        self.rays_cast.swap(0, Ordering::Relaxed)
    }

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

    /// The slots handed to an entity (a new one, or one that changed tree) in this frame's
    /// sync, maybe more than once each: for per-slot data kept beside the trees, such as
    /// picking's slot mesh table, which must learn a slot's new entity.
    #[cfg_attr(not(feature = "picking"), allow(dead_code))]
    pub(crate) fn assigned_slots(&self) -> &[u32] {
        &self.assigned_slots
    }

    /// Starts a new frame's [`Self::assigned_slots`].
    pub(crate) fn clear_assigned_slots(&mut self) {
        self.assigned_slots.clear();
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
    /// each update waited on a leaf node and its tight box (perf and phase timers on the sync
    /// bench: about half the sync; docs/experiments.md, Plugin sync). The slot record comes
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
    pub fn prefetch_candidate(&self, slot: u32) {
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
    fn vacate(&mut self, t: Tracked) {
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

    fn release_slot(&mut self, slot: u32) {
        self.clear_slot(slot);
        self.free_slots.push(slot);
    }

    /// Takes out the entities a new index refused during a switch: their records still name
    /// the old index's handles, which that index took with it.
    fn untrack_refused(&mut self, refused: &[(Entity, &'static str)]) {
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

#[cfg(test)]
#[path = "trees_tests.rs"]
mod tests;

#[path = "trees_busy.rs"]
mod busy;

#[path = "trees_static.rs"]
mod static_scenery;

#[path = "trees_switch.rs"]
mod switch;
