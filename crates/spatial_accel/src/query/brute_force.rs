//! The flat list: every query a loop over every entry. The oracle every structure is checked
//! against, and the right index for a handful of objects.

use super::dynamic_index::{DynamicIndex, IndexError, IndexStats, UpkeepReport};
use super::flat_loops;
use super::views::{ViewClassification, ViewMasks};
use super::{BoundingTree, NodeView, RayWalk, SpatialQuery};
use crate::{Aabb, Containment, Frustum, Ray, Sphere};
use core::ops::{ControlFlow, RangeInclusive};
use glam::Vec3A;
use std::time::Duration;

/// A handle to one entry of a [`BruteForceIndex`].
pub type FlatHandle = super::Handle<BruteForceIndex>;

/// Where a slot's entry sits in the dense arrays, and the slot's generation.
#[derive(Clone, Copy, Debug)]
struct Slot {
    /// Position in `ids` / `boxes`, or `FREE`.
    position: u32,
    generation: u32,
}

const FREE: u32 = u32::MAX;

/// Boxes in a flat list, answering every query by testing each one.
///
/// Its answers are exact by construction: a primitive is reported when its own box passes
/// the query's test, with no tree bounds in between, so it is the reference the conformance
/// suite compares every structure with. It implements every interface of [`crate::query`]:
/// [`SpatialQuery`] by loops of its own (never through the shared walks it checks),
/// [`DynamicIndex`] by handle, and [`BoundingTree`] as a tree of one leaf.
///
/// ```
/// use spatial_accel::query::BruteForceIndex;
/// use spatial_accel::{Aabb, Ray, SpatialQuery};
/// use glam::Vec3A;
/// let index = BruteForceIndex::from_boxes(&[
///     Aabb::new(Vec3A::new(2.0, -1.0, -1.0), Vec3A::new(3.0, 1.0, 1.0)),
///     Aabb::new(Vec3A::new(5.0, -1.0, -1.0), Vec3A::new(6.0, 1.0, 1.0)),
/// ]);
/// let ray = Ray::new(Vec3A::ZERO, Vec3A::X);
/// let boxes = [index.boxes()[0], index.boxes()[1]];
/// let hit = index.cast_ray(&ray, |id, r| r.intersect_aabb(&boxes[id as usize])).unwrap();
/// assert_eq!(hit.primitive, 0);
/// ```
#[derive(Clone, Debug, Default)]
pub struct BruteForceIndex {
    ids: Vec<u32>,
    boxes: Vec<Aabb>,
    /// The slot of each dense entry, to fix its handle when a removal moves it.
    slot_of: Vec<u32>,
    slots: Vec<Slot>,
    free_slots: Vec<u32>,
}

impl BruteForceIndex {
    /// An empty index.
    pub fn new() -> Self {
        Self::default()
    }

    /// An index over `boxes`, entry `i` with id `i`. Invalid boxes are left out, as a tree
    /// build leaves them out.
    pub fn from_boxes(boxes: &[Aabb]) -> Self {
        let mut index = Self::new();
        for (i, b) in boxes.iter().enumerate() {
            let _ = index.insert(i as u32, *b);
        }
        index
    }

    /// The ids of the entries, in storage order.
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// The boxes of the entries, in storage order (entry `i` has id `ids()[i]`).
    pub fn boxes(&self) -> &[Aabb] {
        &self.boxes
    }

    fn position(&self, handle: FlatHandle) -> Option<usize> {
        let slot = self.slots.get(handle.index() as usize)?;
        (slot.generation == handle.generation() && slot.position != FREE)
            .then_some(slot.position as usize)
    }

    fn entries(&self) -> impl Iterator<Item = (u32, &Aabb)> {
        self.ids.iter().copied().zip(&self.boxes)
    }
}

impl DynamicIndex for BruteForceIndex {
    type Handle = FlatHandle;

    fn insert(&mut self, id: u32, bounds: Aabb) -> Result<FlatHandle, IndexError> {
        if !(bounds.is_valid() && bounds.is_finite()) {
            return Err(IndexError::InvalidBounds);
        }
        let slot = match self.free_slots.pop() {
            Some(slot) => slot,
            None if self.slots.len() < FREE as usize => {
                self.slots.push(Slot {
                    position: FREE,
                    generation: 0,
                });
                (self.slots.len() - 1) as u32
            }
            None => return Err(IndexError::CapacityExceeded),
        };
        self.slots[slot as usize].position = self.ids.len() as u32;
        self.ids.push(id);
        self.boxes.push(bounds);
        self.slot_of.push(slot);
        Ok(FlatHandle::new(slot, self.slots[slot as usize].generation))
    }

    fn update(&mut self, handle: FlatHandle, bounds: Aabb) -> Result<bool, IndexError> {
        let position = self.position(handle).ok_or(IndexError::StaleHandle)?;
        if !(bounds.is_valid() && bounds.is_finite()) {
            return Err(IndexError::InvalidBounds);
        }
        self.boxes[position] = bounds;
        Ok(false)
    }

    fn remove(&mut self, handle: FlatHandle) -> Result<u32, IndexError> {
        let position = self.position(handle).ok_or(IndexError::StaleHandle)?;
        let id = self.ids.swap_remove(position);
        self.boxes.swap_remove(position);
        self.slot_of.swap_remove(position);
        if let Some(&moved) = self.slot_of.get(position) {
            self.slots[moved as usize].position = position as u32;
        }
        let slot = &mut self.slots[handle.index() as usize];
        slot.position = FREE;
        slot.generation = slot.generation.wrapping_add(1);
        self.free_slots.push(handle.index());
        Ok(id)
    }

    fn id(&self, handle: FlatHandle) -> Option<u32> {
        self.position(handle).map(|p| self.ids[p])
    }

    fn bounds_of(&self, handle: FlatHandle) -> Option<Aabb> {
        self.position(handle).map(|p| self.boxes[p])
    }

    fn len(&self) -> usize {
        self.ids.len()
    }

    fn clear(&mut self) {
        for &slot in &self.slot_of {
            let slot = &mut self.slots[slot as usize];
            slot.position = FREE;
            slot.generation = slot.generation.wrapping_add(1);
        }
        self.free_slots.append(&mut self.slot_of);
        self.ids.clear();
        self.boxes.clear();
    }

    fn maintain(&mut self, _budget: Duration) -> UpkeepReport {
        UpkeepReport::default()
    }

    fn index_stats(&self) -> IndexStats {
        IndexStats {
            entries: self.ids.len(),
            nodes: 1,
            depth: 0,
            memory_bytes: (self.ids.capacity() + self.slot_of.capacity()) * 4
                + self.boxes.capacity() * size_of::<Aabb>()
                + self.slots.capacity() * size_of::<Slot>()
                + self.free_slots.capacity() * 4,
            quality_ratio: None,
        }
    }

    /// The list keeps no node, and no box over its entries: it is shown as what
    /// [`index_stats`](DynamicIndex::index_stats) counts and its [`BoundingTree`] view
    /// walks, one leaf at depth 0 holding every entry, its bounds the union of the boxes
    /// (computed for the visit, a pass over them). Nothing when the list is empty or 0 is
    /// not in `depths`.
    fn visit_nodes(
        &self,
        depths: RangeInclusive<u32>,
        visit: &mut dyn FnMut(NodeView) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        super::visit_tree_nodes(self, depths, visit)
    }
}

impl RayWalk for BruteForceIndex {
    /// Every entry whose box the ray enters within its current range, in storage order.
    fn walk_ray<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        let _ = flat_loops::walk_ray(self.entries(), ray, visit);
    }
}

impl SpatialQuery for BruteForceIndex {
    fn for_each_overlapping_aabb<F>(&self, aabb: &Aabb, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        flat_loops::overlapping_aabb(self.entries(), aabb, visit);
    }

    fn for_each_overlapping_sphere<F>(&self, sphere: &Sphere, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        flat_loops::overlapping_sphere(self.entries(), sphere, visit);
    }

    fn for_each_containing_point<F>(&self, point: Vec3A, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        flat_loops::containing_point(self.entries(), point, visit);
    }

    fn for_each_in_frustum<F>(&self, frustum: &Frustum, visit: F)
    where
        F: FnMut(u32, Containment),
    {
        flat_loops::in_frustum(self.entries(), frustum, visit);
    }

    fn for_each_in_views<C, F>(&self, views: u32, classify: C, visit: F)
    where
        C: FnMut(&Aabb, u32) -> ViewClassification,
        F: FnMut(u32, ViewMasks),
    {
        flat_loops::in_views(self.entries(), views, classify, visit);
    }

    fn nearest_k<F>(&self, _point: Vec3A, k: usize, distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32,
    {
        flat_loops::nearest_k(self.ids.iter().copied(), k, distance_squared)
    }
}

/// The list seen as a tree of one leaf holding every entry: the smallest hierarchy the
/// shared walks accept.
impl BoundingTree for BruteForceIndex {
    type Volume = Aabb;
    type Children<'a>
        = core::iter::Empty<u32>
    where
        Self: 'a;

    fn root(&self) -> Option<u32> {
        (!self.ids.is_empty()).then_some(0)
    }

    fn node_bounds(&self, _node: u32) -> Aabb {
        self.boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b))
    }

    fn node_children(&self, _node: u32) -> Option<Self::Children<'_>> {
        None
    }

    fn node_primitives(&self, _node: u32) -> &[u32] {
        &self.ids
    }

    fn subtree_primitives(&self, _node: u32) -> Option<&[u32]> {
        Some(&self.ids)
    }
}
