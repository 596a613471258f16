//! The trees over the world's entities, and the map between tree slots and entities.

use accel::dynamic::{DynamicBvh, LeafHandle, StaticDynamicPair};
use accel::{Aabb, BuildConfig, Bvh, SahCosts};
use bevy::ecs::entity::EntityHashMap;
use bevy::math::Affine3A;
use bevy::prelude::*;

/// An entity's own space as the trees last saw it: what an exact ray test needs once a ray
/// has reached the entity's world box.
///
/// Kept by slot, next to the world boxes, because a ray's candidates are scattered through the
/// ECS tables: reading the `GlobalTransform` and `Aabb` rows and inverting the transform for
/// each candidate cost three cache misses and an inversion (perf on the picking bench put the
/// transform read alone at a tenth of a ray). Written by the sync system whenever it places
/// the entity, so it is as current as the trees: a `GlobalTransform` edited after the sync
/// (by hand, in `PostUpdate`) is seen from the next frame, as the trees' boxes are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    /// World to the entity's space: the inverse of its `GlobalTransform`.
    pub local_from_world: Affine3A,
    /// The entity's `Aabb`, in its own space.
    pub local_bounds: Aabb,
}

impl LocalFrame {
    const NONE: Self = Self {
        local_from_world: Affine3A::IDENTITY,
        local_bounds: Aabb::EMPTY,
    };
}

/// Where a tracked entity lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TreeSlot {
    /// In the dynamic tree, under this leaf.
    Dynamic(LeafHandle),
    /// In the static tree.
    Static,
}

/// The static tree's build. A primitive here is an entity: testing one reads its slot entry
/// at a random place, and one that passes goes on to ECS lookups and a mesh BVH, so a
/// primitive test is costed at four node visits (the default costs a node visit at two
/// primitive tests, right for triangles). Leaves come out with one or two entities instead of
/// up to eight: on the picking bench, rays then reach about a third as many candidates.
fn entity_tree_config() -> BuildConfig {
    BuildConfig {
        max_leaf_size: 4,
        sah: SahCosts {
            traversal: 1.0,
            intersection: 4.0,
        },
        ..BuildConfig::default()
    }
}

/// What a query callback needs of a slot, side by side: a candidate's exact box is tested
/// first and its entity read only if that passes, so both sharing a cache line saves a miss
/// per candidate (two parallel arrays cost two).
#[derive(Clone, Copy, Debug)]
struct SlotEntry {
    bounds: Aabb,
    entity: Option<Entity>,
}

impl SlotEntry {
    const FREE: Self = Self {
        bounds: Aabb::EMPTY,
        entity: None,
    };
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
    /// The dynamic tree refused the entity (an error was logged); it stays untracked.
    Refused,
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
    slots: Vec<SlotEntry>,
    /// The entity's own space, by slot: see [`LocalFrame`].
    frames: Vec<LocalFrame>,
    /// The entity of each slot again, packed: see [`AccelTrees::slot_entities`].
    entities_by_slot: Vec<Option<Entity>>,
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
        self.slots.get(slot as usize).and_then(|s| s.entity)
    }

    /// The exact world box of the entity in a slot (the trees hold fattened boxes).
    #[inline]
    pub fn world_bounds(&self, slot: u32) -> Aabb {
        self.slots
            .get(slot as usize)
            .map_or(Aabb::EMPTY, |s| s.bounds)
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

    /// The entity's own space in a slot (meaningless for a free slot).
    #[inline]
    pub fn local_frame(&self, slot: u32) -> Option<&LocalFrame> {
        self.frames.get(slot as usize)
    }

    /// The entity in each slot, indexed by slot (`None` for free slots): for passes over many
    /// slots in order, where this array's 8 bytes per slot touch a quarter of the cache lines
    /// that [`AccelTrees::entity`]'s entries do.
    pub fn slot_entities(&self) -> &[Option<Entity>] {
        &self.entities_by_slot
    }

    /// Every tracked entity with its slot.
    pub fn iter(&self) -> impl Iterator<Item = (Entity, u32)> + '_ {
        self.tracked.iter().map(|(e, t)| (*e, t.slot))
    }

    pub(crate) fn dynamic_mut(&mut self) -> &mut DynamicBvh {
        self.pair.dynamic_mut()
    }

    fn allocate_slot(&mut self, entity: Entity, bounds: Aabb, frame: LocalFrame) -> u32 {
        let entry = SlotEntry {
            bounds,
            entity: Some(entity),
        };
        if let Some(slot) = self.free_slots.pop() {
            self.slots[slot as usize] = entry;
            self.frames[slot as usize] = frame;
            self.entities_by_slot[slot as usize] = Some(entity);
            slot
        } else {
            self.slots.push(entry);
            self.frames.push(frame);
            self.entities_by_slot.push(Some(entity));
            self.static_bounds.push(Aabb::EMPTY);
            (self.slots.len() - 1) as u32
        }
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
        match self.tracked.get(&entity).copied() {
            Some(t) => match (t.tree, is_static) {
                (TreeSlot::Dynamic(h), false) => {
                    self.slots[t.slot as usize].bounds = bounds;
                    self.frames[t.slot as usize] = frame;
                    match self.pair.dynamic_mut().update(h, bounds) {
                        Ok(true) => Placed::Moved,
                        Ok(false) => Placed::Unchanged,
                        Err(e) => {
                            // Cannot happen while handles and boxes are checked on the way in;
                            // if it does, re-inserting keeps the entity in the tree.
                            error!("bevy_accel: updating {entity} failed ({e}); re-inserting it");
                            self.remove(entity);
                            moved(self.place(entity, bounds, frame, false))
                        }
                    }
                }
                (TreeSlot::Static, true) => {
                    self.frames[t.slot as usize] = frame;
                    // Static entities are placed only when (re)marked; a changed box means
                    // rebuilding the static tree.
                    if self.static_bounds[t.slot as usize] != bounds {
                        self.slots[t.slot as usize].bounds = bounds;
                        self.static_bounds[t.slot as usize] = bounds;
                        self.static_dirty = true;
                        Placed::Moved
                    } else {
                        Placed::Unchanged
                    }
                }
                _ => {
                    self.remove(entity);
                    moved(self.place(entity, bounds, frame, is_static))
                }
            },
            None => {
                let slot = self.allocate_slot(entity, bounds, frame);
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
                            return Placed::Refused;
                        }
                    }
                };
                self.tracked.insert(entity, Tracked { slot, tree });
                Placed::Inserted
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
        self.slots[slot as usize] = SlotEntry::FREE;
        self.frames[slot as usize] = LocalFrame::NONE;
        self.entities_by_slot[slot as usize] = None;
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
            .set_static(Bvh::build(&self.static_bounds, &entity_tree_config()));
        true
    }

    /// Number of entities in the static tree.
    pub fn static_len(&self) -> usize {
        self.pair.static_tree().primitive_count()
    }
}
