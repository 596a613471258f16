//! The index over the tracked entities: one of the core's structures, chosen at run time,
//! under the static tree.

use super::IndexChoice;
use bevy::math::Vec3A;
use core::cell::Cell;
use core::ops::ControlFlow;
use spatial_accel::dynamic::{
    DynamicBvh, DynamicBvhConfig, LayeredIndex, PreparedStatic, StaticDynamicPair, merge_nearest,
};
use spatial_accel::query::views::{ViewClassification, ViewMasks};
use spatial_accel::query::{
    AnyHandle, AnyIndex, DynamicIndex, IndexError, IndexKind, IndexStats, KeyedList, NodeView,
    RayWalk,
};
use spatial_accel::{Aabb, Bvh, Containment, Frustum, Ray, SpatialQuery, Sphere};

/// The static tree, the dynamic index and the busy movers over the tracked entities,
/// queried as one [`SpatialQuery`] whose primitive ids are slots (see
/// [`AccelTrees`](crate::AccelTrees)).
///
/// Which structure holds the moving entities is [`AccelSettings::index`](crate::AccelSettings::index);
/// the static entities are always in a static BVH, since they are built once and never
/// refit. Entities that move frame after frame may leave that structure for a flat list, the
/// *busy movers* ([`BusyMoverSettings`](crate::BusyMoverSettings)), which every query tests
/// after the trees.
///
/// Why two kinds of layers rather than one generic layer: the BVH backend fuses the static
/// tree and the dynamic BVH into one tree ([`StaticDynamicPair`]), so a closest hit in either
/// prunes the other's walk from the root down, and keeps a 16-wide snapshot of the dynamic
/// tree for rays; every other structure answers beside the static tree
/// ([`LayeredIndex`]).
#[derive(Debug)]
pub struct EntityIndex {
    layers: Layers,
    /// Busy movers, keyed by entity index, their ids slots.
    busy: KeyedList,
}

/// The trees of an [`EntityIndex`].
#[derive(Debug)]
#[expect(
    clippy::large_enum_variant,
    reason = "one index per world, queried in hot loops: a box would add a pointer chase to \
              every query to save a few hundred bytes once"
)]
enum Layers {
    /// The dynamic BVH, fused with the static tree.
    Bvh(StaticDynamicPair),
    /// Any other dynamic index of the core, beside the static tree.
    Layered(LayeredIndex<AnyIndex>),
}

impl Default for EntityIndex {
    fn default() -> Self {
        Self::new(IndexChoice::default(), Bvh::default())
    }
}

/// Runs `$body` on whichever query structure `$index` is, bound to `$inner`.
macro_rules! on_layers {
    ($index:expr, $inner:ident => $body:expr) => {
        match &$index.layers {
            Layers::Bvh($inner) => $body,
            Layers::Layered($inner) => $body,
        }
    };
}

impl Layers {
    fn new(choice: IndexChoice, static_tree: Bvh) -> Self {
        match choice.kind() {
            None | Some(IndexKind::DynamicBvh) => {
                Self::Bvh(StaticDynamicPair::new(static_tree, DynamicBvh::new()))
            }
            Some(kind) => Self::Layered(LayeredIndex::new(static_tree, AnyIndex::new(kind))),
        }
    }

    fn with_dynamic(dynamic: AnyIndex) -> Self {
        match dynamic {
            AnyIndex::DynamicBvh(bvh) => Self::Bvh(StaticDynamicPair::new(Bvh::default(), bvh)),
            other => Self::Layered(LayeredIndex::new(Bvh::default(), other)),
        }
    }
}

impl EntityIndex {
    /// An empty dynamic index of the chosen kind over `static_tree`; the BVH for
    /// [`IndexChoice::Automatic`], which starts there.
    pub fn new(choice: IndexChoice, static_tree: Bvh) -> Self {
        Self {
            layers: Layers::new(choice, static_tree),
            busy: KeyedList::new(),
        }
    }

    /// Replaces the dynamic index with an empty one of the chosen kind, keeping the static
    /// tree and the busy movers.
    pub(crate) fn reset_dynamic(&mut self, choice: IndexChoice) {
        let static_tree = self.take_static();
        self.layers = Layers::new(choice, static_tree);
    }

    /// Swaps in a filled dynamic structure, keeping the static tree and the busy movers;
    /// returns the old structure, to be freed where it costs the frame nothing.
    pub(crate) fn swap_dynamic(&mut self, dynamic: AnyIndex) -> impl Send + 'static {
        let mut layers = Layers::with_dynamic(dynamic);
        let prepared = self.set_static_prepared(PreparedStatic::default());
        core::mem::swap(&mut self.layers, &mut layers);
        self.set_static_prepared(prepared);
        layers
    }

    /// Which structure holds the moving entities.
    pub fn choice(&self) -> IndexChoice {
        match &self.layers {
            Layers::Bvh(_) => IndexChoice::Bvh,
            Layers::Layered(layers) => IndexChoice::of_kind(layers.dynamic().kind()),
        }
    }

    /// The static tree.
    pub fn static_tree(&self) -> &Bvh {
        on_layers!(self, layers => layers.static_tree())
    }

    /// Replaces the static tree with one prepared off the frame, returning the old one.
    pub(crate) fn set_static_prepared(&mut self, prepared: PreparedStatic) -> PreparedStatic {
        match &mut self.layers {
            Layers::Bvh(pair) => pair.set_static_prepared(prepared),
            Layers::Layered(layers) => layers.set_static_prepared(prepared),
        }
    }

    /// Takes the static tree out, leaving an empty one.
    pub(crate) fn take_static(&mut self) -> Bvh {
        match &mut self.layers {
            Layers::Bvh(pair) => pair.set_static(Bvh::default()),
            Layers::Layered(layers) => layers.set_static(Bvh::default()),
        }
    }

    /// The BVH backend's pair, when the BVH is the choice.
    pub fn bvh_pair(&self) -> Option<&StaticDynamicPair> {
        match &self.layers {
            Layers::Bvh(pair) => Some(pair),
            Layers::Layered(_) => None,
        }
    }

    /// The BVH backend's pair, for its upkeep, when the BVH is the choice.
    pub(crate) fn bvh_pair_mut(&mut self) -> Option<&mut StaticDynamicPair> {
        match &mut self.layers {
            Layers::Bvh(pair) => Some(pair),
            Layers::Layered(_) => None,
        }
    }

    /// The dynamic index of another kind than the BVH, for its upkeep.
    pub(crate) fn layered_dynamic_mut(&mut self) -> Option<&mut AnyIndex> {
        match &mut self.layers {
            Layers::Bvh(_) => None,
            Layers::Layered(layers) => Some(layers.dynamic_mut()),
        }
    }

    /// [`SpatialQuery::for_each_in_views`] over the static tree and the dynamic index only,
    /// without the busy movers: for callers that test the list their own way.
    #[cfg_attr(not(feature = "culling"), allow(dead_code))]
    pub(crate) fn for_each_in_views_of_trees<C, F>(&self, views: u32, mut classify: C, mut visit: F)
    where
        C: FnMut(&Aabb, u32) -> ViewClassification,
        F: FnMut(u32, ViewMasks),
    {
        on_layers!(self, layers => layers.for_each_in_views(views, &mut classify, &mut visit));
    }

    /// The busy movers: entities that moved in each of the last frames, kept flat out of
    /// the dynamic index (see [`BusyMoverSettings`](crate::BusyMoverSettings)). Their ids
    /// are slots; their keys, entity indices.
    pub fn busy_movers(&self) -> &KeyedList {
        &self.busy
    }

    /// The busy movers, for the sync.
    pub(crate) fn busy_movers_mut(&mut self) -> &mut KeyedList {
        &mut self.busy
    }

    /// The dynamic BVH, when the BVH is the choice.
    pub fn dynamic_bvh(&self) -> Option<&DynamicBvh> {
        self.bvh_pair().map(StaticDynamicPair::dynamic)
    }

    /// Whether rays walk a 16-wide snapshot of the dynamic BVH (see
    /// [`BvhIndexSettings::ray_snapshot_after_stable_frames`](super::BvhIndexSettings::ray_snapshot_after_stable_frames));
    /// false for the other backends, which keep none.
    pub fn has_dynamic_ray_snapshot(&self) -> bool {
        self.bvh_pair()
            .is_some_and(StaticDynamicPair::has_dynamic_ray_snapshot)
    }

    /// Entities held by the dynamic index (the busy movers not included).
    pub fn dynamic_len(&self) -> usize {
        match &self.layers {
            Layers::Bvh(pair) => pair.dynamic().len(),
            Layers::Layered(layers) => layers.dynamic().len(),
        }
    }

    /// The dynamic index's shape and cost, in O(1).
    pub fn dynamic_stats(&self) -> IndexStats {
        match &self.layers {
            Layers::Bvh(pair) => pair.dynamic().index_stats(),
            Layers::Layered(layers) => layers.dynamic().index_stats(),
        }
    }

    /// Visits the dynamic index's nodes with depth in `depths`, shallowest first (see
    /// [`DynamicIndex::visit_nodes`]): what the tree-node overlay draws.
    pub fn visit_dynamic_nodes(
        &self,
        depths: core::ops::RangeInclusive<u32>,
        visit: &mut dyn FnMut(NodeView) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        match &self.layers {
            Layers::Bvh(pair) => pair.dynamic().visit_nodes(depths, visit),
            Layers::Layered(layers) => layers.dynamic().visit_nodes(depths, visit),
        }
    }

    /// A box around everything the layers hold (the dynamic index's fat or loose boxes
    /// included): O(1) for the trees, a pass over the occupied cells for the grid and over
    /// the busy movers.
    pub fn bounds(&self) -> Aabb {
        let mut bounds = self.static_tree().bounds().union(&self.busy.bounds());
        let _ = self.visit_dynamic_nodes(0..=0, &mut |node| {
            bounds = bounds.union(&node.bounds);
            ControlFlow::Continue(())
        });
        bounds
    }

    /// Adds a moving entity's slot with its world box.
    pub(crate) fn insert(&mut self, slot: u32, bounds: Aabb) -> Result<AnyHandle, IndexError> {
        match &mut self.layers {
            Layers::Bvh(pair) => pair
                .dynamic_mut()
                .insert(slot, bounds)
                .map(AnyHandle::DynamicBvh),
            Layers::Layered(layers) => layers.dynamic_mut().insert(slot, bounds),
        }
    }

    /// Gives a moving entity its new world box; `Ok(false)` when no query can see the
    /// difference (the box stayed inside its fat leaf or loose cell).
    #[inline]
    pub(crate) fn update(&mut self, handle: AnyHandle, bounds: Aabb) -> Result<bool, IndexError> {
        match (&mut self.layers, handle) {
            // Through the pair, so that the dynamic tree's ray snapshot is refit instead of
            // dropped.
            (Layers::Bvh(pair), AnyHandle::DynamicBvh(h)) => pair.update_dynamic(h, bounds),
            (Layers::Layered(layers), h) => layers.dynamic_mut().update(h, bounds),
            _ => Err(IndexError::StaleHandle),
        }
    }

    /// Takes a moving entity out.
    pub(crate) fn remove(&mut self, handle: AnyHandle) -> Result<u32, IndexError> {
        match (&mut self.layers, handle) {
            (Layers::Bvh(pair), AnyHandle::DynamicBvh(h)) => pair.dynamic_mut().remove(h),
            (Layers::Layered(layers), h) => layers.dynamic_mut().remove(h),
            _ => Err(IndexError::StaleHandle),
        }
    }

    /// Asks for what an [`update`](Self::update) of this entry reads first. A hint only.
    #[inline]
    pub(crate) fn prefetch_entry(&self, handle: AnyHandle) {
        match (&self.layers, handle) {
            (Layers::Bvh(pair), AnyHandle::DynamicBvh(h)) => pair.dynamic().prefetch_leaf(h),
            (Layers::Layered(layers), h) => layers.dynamic().prefetch_entry(h),
            _ => {}
        }
    }

    /// Applies the BVH backend's settings to its dynamic tree (the other backends have none
    /// yet). Touches the tree only when they differ.
    pub(crate) fn configure_bvh(&mut self, config: DynamicBvhConfig) {
        if let Layers::Bvh(pair) = &mut self.layers
            && *pair.dynamic().config() != config
        {
            pair.dynamic_mut().set_config(config);
        }
    }
}

/// Runs a visitor through the trees, then through the busy movers unless the trees' walk
/// stopped: one ray's range, shortened by a hit in the trees, bounds the list's tests too.
macro_rules! then_busy {
    ($self:expr, $visit:ident, $walk:ident ( $($arg:expr),* )) => {{
        let stopped = Cell::new(false);
        let mut $visit = |p: u32, r: &mut Ray| {
            let flow = $visit(p, r);
            stopped.set(flow.is_break());
            flow
        };
        on_layers!($self, layers => layers.$walk($($arg,)* &mut $visit));
        if !stopped.get() && !$self.busy.is_empty() {
            $self.busy.$walk($($arg,)* &mut $visit);
        }
    }};
}

impl RayWalk for EntityIndex {
    #[inline]
    fn walk_ray<V>(&self, ray: &mut Ray, mut visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        then_busy!(self, visit, walk_ray(ray));
    }

    #[inline]
    fn walk_ray_any_order<V>(&self, ray: &mut Ray, mut visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        then_busy!(self, visit, walk_ray_any_order(ray));
    }

    #[inline]
    fn walk_ray_announcing<A, V>(&self, ray: &mut Ray, mut announce: A, mut visit: V)
    where
        A: FnMut(u32),
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        then_busy!(self, visit, walk_ray_announcing(ray, &mut announce));
    }
}

/// Runs a visitor that may stop through the trees, then through the busy movers unless it
/// stopped.
macro_rules! then_busy_until_break {
    ($self:expr, $visit:ident, $walk:ident ( $($arg:expr),* )) => {{
        let stopped = Cell::new(false);
        let mut $visit = |p: u32| {
            let flow = $visit(p);
            stopped.set(flow.is_break());
            flow
        };
        on_layers!($self, layers => layers.$walk($($arg,)* &mut $visit));
        if !stopped.get() && !$self.busy.is_empty() {
            $self.busy.$walk($($arg,)* &mut $visit);
        }
    }};
}

impl SpatialQuery for EntityIndex {
    fn for_each_overlapping_aabb<F>(&self, aabb: &Aabb, mut visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        then_busy_until_break!(self, visit, for_each_overlapping_aabb(aabb));
    }

    fn for_each_overlapping_sphere<F>(&self, sphere: &Sphere, mut visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        then_busy_until_break!(self, visit, for_each_overlapping_sphere(sphere));
    }

    fn for_each_containing_point<F>(&self, point: Vec3A, mut visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        then_busy_until_break!(self, visit, for_each_containing_point(point));
    }

    fn for_each_in_frustum<F>(&self, frustum: &Frustum, mut visit: F)
    where
        F: FnMut(u32, Containment),
    {
        on_layers!(self, layers => layers.for_each_in_frustum(frustum, &mut visit));
        self.busy.for_each_in_frustum(frustum, visit);
    }

    fn for_each_in_views<C, F>(&self, views: u32, mut classify: C, mut visit: F)
    where
        C: FnMut(&Aabb, u32) -> ViewClassification,
        F: FnMut(u32, ViewMasks),
    {
        on_layers!(self, layers => layers.for_each_in_views(views, &mut classify, &mut visit));
        self.busy.for_each_in_views(views, classify, visit);
    }

    fn nearest_k<F>(&self, point: Vec3A, k: usize, mut distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32,
    {
        let trees = on_layers!(self, layers => layers.nearest_k(point, k, &mut distance_squared));
        if self.busy.is_empty() {
            return trees;
        }
        let busy = self.busy.nearest_k(point, k, distance_squared);
        merge_nearest(trees, busy, k)
    }
}

#[cfg(test)]
#[path = "entity_index_tests.rs"]
mod tests;
