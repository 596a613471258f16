//! The trees over the world's entities, and the map between tree slots and entities.

use accel::dynamic::{DynamicBvh, LeafHandle, StaticDynamicPair};
use accel::{Aabb, BuildConfig, Bvh};
use bevy::ecs::entity::EntityHashMap;
use bevy::prelude::*;

/// Where a tracked entity lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TreeSlot {
    /// In the dynamic tree, under this leaf.
    Dynamic(LeafHandle),
    /// In the static tree.
    Static,
}

#[derive(Clone, Copy, Debug)]
struct Tracked {
    slot: u32,
    tree: TreeSlot,
}

/// The acceleration trees over the tracked entities: a dynamic BVH for things that move and a
/// static BVH for things marked [`AccelStatic`](crate::AccelStatic), queried as one.
///
/// Trees name primitives by *slot*: a small integer per tracked entity, reused after the
/// entity leaves. [`AccelTrees::entity`] and [`AccelTrees::world_bounds`] turn a slot from a
/// query callback into the entity and its exact world box.
///
/// The plugin keeps this resource in sync in [`AccelSystems::Sync`](crate::AccelSystems);
/// read it in any system that runs after it.
#[derive(Resource, Default)]
pub struct AccelTrees {
    pub(crate) pair: StaticDynamicPair,
    tracked: EntityHashMap<Tracked>,
    slot_entity: Vec<Option<Entity>>,
    slot_bounds: Vec<Aabb>,
    free_slots: Vec<u32>,
    /// Static boxes by slot (empty for slots that are not static), the static tree's input.
    static_bounds: Vec<Aabb>,
    static_dirty: bool,
}

impl AccelTrees {
    /// Both trees, as one [`SpatialQuery`](accel::SpatialQuery): primitive ids are slots.
    pub fn query(&self) -> &StaticDynamicPair {
        &self.pair
    }

    /// The dynamic tree.
    pub fn dynamic(&self) -> &DynamicBvh {
        self.pair.dynamic()
    }

    /// The static tree.
    pub fn static_tree(&self) -> &Bvh {
        self.pair.static_tree()
    }

    /// The entity in a slot, if the slot is in use.
    #[inline]
    pub fn entity(&self, slot: u32) -> Option<Entity> {
        self.slot_entity.get(slot as usize).copied().flatten()
    }

    /// The exact world box of the entity in a slot (the trees hold fattened boxes).
    #[inline]
    pub fn world_bounds(&self, slot: u32) -> Aabb {
        self.slot_bounds
            .get(slot as usize)
            .copied()
            .unwrap_or(Aabb::EMPTY)
    }

    /// The slot and tree of a tracked entity.
    pub fn location(&self, entity: Entity) -> Option<(u32, TreeSlot)> {
        self.tracked.get(&entity).map(|t| (t.slot, t.tree))
    }

    /// True when the entity is in a tree.
    pub fn contains(&self, entity: Entity) -> bool {
        self.tracked.contains_key(&entity)
    }

    /// Number of tracked entities.
    pub fn len(&self) -> usize {
        self.tracked.len()
    }

    /// True when nothing is tracked.
    pub fn is_empty(&self) -> bool {
        self.tracked.is_empty()
    }

    /// Every tracked entity with its slot.
    pub fn iter(&self) -> impl Iterator<Item = (Entity, u32)> + '_ {
        self.tracked.iter().map(|(e, t)| (*e, t.slot))
    }

    pub(crate) fn dynamic_mut(&mut self) -> &mut DynamicBvh {
        self.pair.dynamic_mut()
    }

    fn allocate_slot(&mut self, entity: Entity, bounds: Aabb) -> u32 {
        if let Some(slot) = self.free_slots.pop() {
            self.slot_entity[slot as usize] = Some(entity);
            self.slot_bounds[slot as usize] = bounds;
            slot
        } else {
            self.slot_entity.push(Some(entity));
            self.slot_bounds.push(bounds);
            self.static_bounds.push(Aabb::EMPTY);
            (self.slot_entity.len() - 1) as u32
        }
    }

    /// Puts an entity in the tree it belongs in, or moves it there, with a valid world box.
    /// Returns whether a tree changed.
    pub(crate) fn place(&mut self, entity: Entity, bounds: Aabb, is_static: bool) -> bool {
        match self.tracked.get(&entity).copied() {
            Some(t) => match (t.tree, is_static) {
                (TreeSlot::Dynamic(h), false) => {
                    self.slot_bounds[t.slot as usize] = bounds;
                    match self.pair.dynamic_mut().update(h, bounds) {
                        Ok(changed) => changed,
                        Err(e) => {
                            // Cannot happen while handles and boxes are checked on the way in;
                            // if it does, re-inserting keeps the entity in the tree.
                            error!("bevy_accel: updating {entity} failed ({e}); re-inserting it");
                            self.remove(entity);
                            self.place(entity, bounds, false)
                        }
                    }
                }
                (TreeSlot::Static, true) => {
                    // Static entities are placed only when (re)marked; a changed box means
                    // rebuilding the static tree.
                    if self.static_bounds[t.slot as usize] != bounds {
                        self.slot_bounds[t.slot as usize] = bounds;
                        self.static_bounds[t.slot as usize] = bounds;
                        self.static_dirty = true;
                    }
                    self.static_dirty
                }
                _ => {
                    self.remove(entity);
                    self.place(entity, bounds, is_static)
                }
            },
            None => {
                let slot = self.allocate_slot(entity, bounds);
                let tree = if is_static {
                    self.static_bounds[slot as usize] = bounds;
                    self.static_dirty = true;
                    TreeSlot::Static
                } else {
                    match self.pair.dynamic_mut().insert(slot, bounds) {
                        Ok(handle) => TreeSlot::Dynamic(handle),
                        Err(e) => {
                            error!("bevy_accel: {entity} could not enter the dynamic tree: {e}");
                            self.release_slot(slot);
                            return false;
                        }
                    }
                };
                self.tracked.insert(entity, Tracked { slot, tree });
                true
            }
        }
    }

    /// Takes an entity out of its tree. Returns whether it was in one.
    pub(crate) fn remove(&mut self, entity: Entity) -> bool {
        let Some(t) = self.tracked.remove(&entity) else {
            return false;
        };
        match t.tree {
            TreeSlot::Dynamic(h) => {
                if let Err(e) = self.pair.dynamic_mut().remove(h) {
                    error!("bevy_accel: removing {entity} from the dynamic tree failed: {e}");
                }
            }
            TreeSlot::Static => {
                self.static_bounds[t.slot as usize] = Aabb::EMPTY;
                self.static_dirty = true;
            }
        }
        self.release_slot(t.slot);
        true
    }

    fn release_slot(&mut self, slot: u32) {
        self.slot_entity[slot as usize] = None;
        self.slot_bounds[slot as usize] = Aabb::EMPTY;
        self.free_slots.push(slot);
    }

    /// Rebuilds the static tree if its set changed since the last call. The static tree is
    /// built over the slot-indexed boxes (empty slots are left out by the builder), so its
    /// primitive ids are slots, like the dynamic tree's.
    pub(crate) fn rebuild_static_if_dirty(&mut self) -> bool {
        if !std::mem::take(&mut self.static_dirty) {
            return false;
        }
        self.pair
            .set_static(Bvh::build(&self.static_bounds, &BuildConfig::default()));
        true
    }

    /// Number of entities in the static tree.
    pub fn static_len(&self) -> usize {
        self.pair.static_tree().primitive_count()
    }
}
