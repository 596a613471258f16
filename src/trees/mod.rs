//! [`AccelTrees`]: the trees over the world's entities, and the map between tree slots and
//! entities.
//!
//! Where an entity's data goes, in the order a frame writes it:
//!
//! - `placing`: the sync's edits: an entity placed in the tree it belongs in (a slot, its
//!   record, an entry of the dynamic index) or taken out.
//! - `slot_record`: each slot's exact world box and own space, as the sync last wrote them.
//! - `placement`: an entity's world box and own space ([`LocalFrame`]) from its Bevy
//!   components.
//! - `busy_movers`: entities that move frame after frame, kept in a flat list outside the
//!   dynamic index ([`BusyMoverSettings`]).
//! - `index_switch`: every dynamic entity moved into another kind of index, off the frame
//!   when they are many.
//! - `static_scenery`: the static tree, rebuilt off the frame when scenery streams in or out.
//!
//! The structures themselves are the [`index`](crate::index) module's; the systems that call
//! all this each frame are in `systems`.

mod busy_movers;
mod cost_probe;
mod index_switch;
mod placement;
mod placing;
mod slot_record;
mod static_scenery;
pub(crate) mod step_aside;
#[cfg(test)]
mod tests;
mod unread_movers;

pub use busy_movers::{BusyMoverSettings, BusyMovers};
#[cfg(feature = "culling")]
pub(crate) use cost_probe::FrameCosts;
pub use cost_probe::StepAsideProbe;
pub use placement::LocalFrame;
pub(crate) use placement::placement;
pub(crate) use placing::Placed;
pub(crate) use static_scenery::entity_tree_config;
pub(crate) use step_aside::TreeReaderPin;

use crate::index::EntityIndex;
use bevy::prelude::*;
use busy_movers::{BusyFrame, busy_tag};
use core::sync::atomic::{AtomicU32, Ordering};
use slot_record::SlotEntry;
use spatial_accel::dynamic::DynamicBvh;
use spatial_accel::query::AnyHandle;
use spatial_accel::{Aabb, Bvh};
use static_scenery::StaticScenery;

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
    /// index ([`EntityIndex::busy_movers`], [`BusyMoverSettings`]).
    Busy,
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
/// read it in any system that runs after it, through [`AccelSpatialQuery::trees`](crate::AccelSpatialQuery::trees)
/// (which registers the system as a reader): in a small world that nothing reads, the trees
/// stand still (see [`AccelTrees::stepped_aside`]). It is marked changed (Bevy's change detection)
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
    /// A switch of the movers' index being filled off the frame (see `index_switch`).
    switch: Option<index_switch::IndexSwitch>,
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
    /// Whether the trees stand still this frame (see [`Self::stepped_aside`]).
    pub(crate) step_aside: step_aside::StepAside,
    /// Whether the busy movers' moves are written (see `unread_movers`).
    pub(crate) unread_movers: unread_movers::UnreadMovers,
}

impl AccelTrees {
    /// Notes a public read of the trees: one made while they stand aside wakes them from the
    /// next frame on, with one warning.
    #[inline]
    fn note_read(&self) {
        if self.step_aside.is_aside() {
            self.step_aside.note_unseen_read();
        }
    }

    /// [`Self::note_read`] for a read that may reach the busy movers' boxes: one made while
    /// they are out of date (see [`Self::busy_movers_current`]) also keeps them current from
    /// the next frame on.
    #[inline]
    fn note_read_with_busy_movers(&self) {
        if self.step_aside.is_aside() || self.unread_movers.is_stale() {
            self.step_aside.note_unseen_read();
        }
    }

    /// Whether the busy movers' boxes are current. They are not while the trees serve culling
    /// alone and every view takes the flat pass, which never reads them
    /// ([`AccelSettings::skip_unread_mover_upkeep`](crate::AccelSettings::skip_unread_mover_upkeep)):
    /// a read through [`Self::query`] or [`Self::world_bounds`] then sees them where they were
    /// when their moves were last written, and keeps them current from the next frame on.
    /// Systems with an `AccelRayCast` or an [`AccelSpatialQuery`](crate::AccelSpatialQuery)
    /// never see them out of date.
    pub fn busy_movers_current(&self) -> bool {
        !self.unread_movers.is_stale()
    }

    /// [`Self::query`] for the plugin's own upkeep and culling, which read the trees only while
    /// they are current and the busy movers only while their boxes are (see
    /// `unread_movers`): without the read check.
    #[inline]
    pub(crate) fn index(&self) -> &EntityIndex {
        &self.index
    }

    /// Both trees, as one [`SpatialQuery`](spatial_accel::SpatialQuery): primitive ids are slots.
    pub fn query(&self) -> &EntityIndex {
        self.note_read_with_busy_movers();
        &self.index
    }

    /// The dynamic BVH, while it is the index of the moving entities.
    pub fn dynamic_bvh(&self) -> Option<&DynamicBvh> {
        self.note_read();
        self.index.dynamic_bvh()
    }

    /// The static tree.
    pub fn static_tree(&self) -> &Bvh {
        self.note_read();
        self.index.static_tree()
    }

    /// The entity in a slot, if the slot is in use.
    #[inline]
    pub fn entity(&self, slot: u32) -> Option<Entity> {
        self.slots.get(slot as usize).and_then(|s| s.entity)
    }

    /// The exact world box of the entity in a slot (the trees hold fattened boxes). A busy
    /// mover's may be out of date while no view reads them (see
    /// [`Self::busy_movers_current`]); such a read keeps them current from the next frame on.
    #[inline]
    pub fn world_bounds(&self, slot: u32) -> Aabb {
        match self.slots.get(slot as usize) {
            Some(entry) if entry.is_busy() => entry.entity.map_or(Aabb::EMPTY, |entity| {
                self.note_read_with_busy_movers();
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
        self.note_read();
        self.tracked_location(entity)
    }

    /// [`Self::location`] for the plugin's own passes, which run only while the trees are
    /// current or on behalf of a registered reader: without the step-aside check, which the
    /// culling's flat pass would otherwise pay per entity.
    #[inline]
    pub(crate) fn tracked_location(&self, entity: Entity) -> Option<(u32, TreeSlot)> {
        self.tracked(entity).map(|t| (t.slot, t.tree))
    }

    /// True when the entity is in a tree.
    #[inline]
    pub fn contains(&self, entity: Entity) -> bool {
        self.note_read();
        self.tracked(entity).is_some()
    }

    /// Number of tracked entities.
    pub fn len(&self) -> usize {
        self.note_read();
        self.tracked_count
    }

    /// True when nothing is tracked.
    pub fn is_empty(&self) -> bool {
        self.note_read();
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
    #[cfg_attr(not(any(feature = "culling", feature = "selection")), allow(dead_code))]
    pub(crate) fn slot_entities(&self) -> &[Option<Entity>] {
        &self.entities_by_slot
    }

    /// Every tracked entity with its slot, in slot order.
    pub fn iter(&self) -> impl Iterator<Item = (Entity, u32)> + '_ {
        self.note_read();
        self.culling_iter()
    }

    /// [`Self::iter`] for the plugin's culling, without the read check (see
    /// [`Self::index`]).
    pub(crate) fn culling_iter(&self) -> impl Iterator<Item = (Entity, u32)> + '_ {
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
    #[cfg_attr(not(feature = "culling"), allow(dead_code))]
    pub(crate) fn index_generation(&self) -> u64 {
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
    /// `AccelRayCast` and the sprite backend count their rays.
    #[inline]
    #[cfg_attr(not(feature = "picking"), allow(dead_code))]
    pub(crate) fn count_rays(&self, rays: u32) {
        self.rays_cast.fetch_add(rays, Ordering::Relaxed);
    }

    /// The rays counted since the last call, and restarts the count.
    pub(crate) fn take_rays_cast(&self) -> u32 {
        self.rays_cast.swap(0, Ordering::Relaxed)
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
}
