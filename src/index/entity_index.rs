//! The index over the tracked entities: one of the core's structures, chosen at run time,
//! under the static tree.

use super::IndexChoice;
use accel::dynamic::{
    DynamicBvh, DynamicBvhConfig, LayeredIndex, PreparedStatic, StaticDynamicPair,
};
use accel::query::views::{ViewClassification, ViewMasks};
use accel::query::{
    AnyHandle, AnyIndex, DynamicIndex, IndexError, IndexKind, IndexStats, NodeView, RayWalk,
};
use accel::{Aabb, Bvh, Containment, Frustum, Ray, SpatialQuery, Sphere};
use bevy::math::Vec3A;
use core::ops::ControlFlow;

/// The static tree and the dynamic index over the tracked entities, queried as one
/// [`SpatialQuery`] whose primitive ids are slots (see
/// [`AccelTrees`](crate::AccelTrees)).
///
/// Which structure holds the moving entities is [`AccelSettings::index`](crate::AccelSettings::index);
/// the static entities are always in a static BVH, since they are built once and never
/// refit.
///
/// Why two variants rather than one generic layer: the BVH backend fuses the static tree
/// and the dynamic BVH into one tree ([`StaticDynamicPair`]), so a closest hit in either
/// prunes the other's walk from the root down, and keeps a 16-wide snapshot of the dynamic
/// tree for rays; every other structure answers beside the static tree
/// ([`LayeredIndex`]).
#[derive(Debug)]
#[expect(
    clippy::large_enum_variant,
    reason = "one index per world, queried in hot loops: a box would add a pointer chase to \
              every query to save a few hundred bytes once"
)]
pub enum EntityIndex {
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
        match $index {
            EntityIndex::Bvh($inner) => $body,
            EntityIndex::Layered($inner) => $body,
        }
    };
}

impl EntityIndex {
    /// An empty dynamic index of the chosen kind over `static_tree`; the BVH for
    /// [`IndexChoice::Automatic`], which starts there.
    pub fn new(choice: IndexChoice, static_tree: Bvh) -> Self {
        match choice.kind() {
            None | Some(IndexKind::DynamicBvh) => {
                Self::Bvh(StaticDynamicPair::new(static_tree, DynamicBvh::new()))
            }
            Some(kind) => Self::Layered(LayeredIndex::new(static_tree, AnyIndex::new(kind))),
        }
    }

    /// A filled dynamic structure under an empty static tree (swap one in with
    /// [`set_static_prepared`](Self::set_static_prepared)).
    pub(crate) fn with_dynamic(dynamic: AnyIndex) -> Self {
        match dynamic {
            AnyIndex::DynamicBvh(bvh) => Self::Bvh(StaticDynamicPair::new(Bvh::default(), bvh)),
            other => Self::Layered(LayeredIndex::new(Bvh::default(), other)),
        }
    }

    /// Which structure holds the moving entities.
    pub fn choice(&self) -> IndexChoice {
        match self {
            Self::Bvh(_) => IndexChoice::Bvh,
            Self::Layered(layers) => IndexChoice::of_kind(layers.dynamic().kind()),
        }
    }

    /// The static tree.
    pub fn static_tree(&self) -> &Bvh {
        on_layers!(self, layers => layers.static_tree())
    }

    /// Replaces the static tree with one prepared off the frame, returning the old one.
    pub(crate) fn set_static_prepared(&mut self, prepared: PreparedStatic) -> PreparedStatic {
        on_layers!(self, layers => layers.set_static_prepared(prepared))
    }

    /// Takes the static tree out, leaving an empty one.
    pub(crate) fn take_static(&mut self) -> Bvh {
        on_layers!(self, layers => layers.set_static(Bvh::default()))
    }

    /// The BVH backend's pair, when the BVH is the choice.
    pub fn bvh_pair(&self) -> Option<&StaticDynamicPair> {
        match self {
            Self::Bvh(pair) => Some(pair),
            Self::Layered(_) => None,
        }
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

    /// Entities held by the dynamic index.
    pub fn dynamic_len(&self) -> usize {
        match self {
            Self::Bvh(pair) => pair.dynamic().len(),
            Self::Layered(layers) => layers.dynamic().len(),
        }
    }

    /// The dynamic index's shape and cost, in O(1).
    pub fn dynamic_stats(&self) -> IndexStats {
        match self {
            Self::Bvh(pair) => pair.dynamic().index_stats(),
            Self::Layered(layers) => layers.dynamic().index_stats(),
        }
    }

    /// Visits the dynamic index's nodes with depth in `depths`, shallowest first (see
    /// [`DynamicIndex::visit_nodes`]): what the tree-node overlay draws.
    pub fn visit_dynamic_nodes(
        &self,
        depths: core::ops::RangeInclusive<u32>,
        visit: &mut dyn FnMut(NodeView) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        match self {
            Self::Bvh(pair) => pair.dynamic().visit_nodes(depths, visit),
            Self::Layered(layers) => layers.dynamic().visit_nodes(depths, visit),
        }
    }

    /// A box around everything both layers hold (the dynamic index's fat or loose boxes
    /// included): O(1) for the trees, a pass over the occupied cells for the grid.
    pub fn bounds(&self) -> Aabb {
        let mut bounds = self.static_tree().bounds();
        let _ = self.visit_dynamic_nodes(0..=0, &mut |node| {
            bounds = bounds.union(&node.bounds);
            ControlFlow::Continue(())
        });
        bounds
    }

    /// Adds a moving entity's slot with its world box.
    pub(crate) fn insert(&mut self, slot: u32, bounds: Aabb) -> Result<AnyHandle, IndexError> {
        match self {
            Self::Bvh(pair) => pair
                .dynamic_mut()
                .insert(slot, bounds)
                .map(AnyHandle::DynamicBvh),
            Self::Layered(layers) => layers.dynamic_mut().insert(slot, bounds),
        }
    }

    /// Gives a moving entity its new world box; `Ok(false)` when no query can see the
    /// difference (the box stayed inside its fat leaf or loose cell).
    #[inline]
    pub(crate) fn update(&mut self, handle: AnyHandle, bounds: Aabb) -> Result<bool, IndexError> {
        match (self, handle) {
            // Through the pair, so that the dynamic tree's ray snapshot is refit instead of
            // dropped.
            (Self::Bvh(pair), AnyHandle::DynamicBvh(h)) => pair.update_dynamic(h, bounds),
            (Self::Layered(layers), h) => layers.dynamic_mut().update(h, bounds),
            _ => Err(IndexError::StaleHandle),
        }
    }

    /// Takes a moving entity out.
    pub(crate) fn remove(&mut self, handle: AnyHandle) -> Result<u32, IndexError> {
        match (self, handle) {
            (Self::Bvh(pair), AnyHandle::DynamicBvh(h)) => pair.dynamic_mut().remove(h),
            (Self::Layered(layers), h) => layers.dynamic_mut().remove(h),
            _ => Err(IndexError::StaleHandle),
        }
    }

    /// Asks for what an [`update`](Self::update) of this entry reads first. A hint only.
    #[inline]
    pub(crate) fn prefetch_entry(&self, handle: AnyHandle) {
        match (self, handle) {
            (Self::Bvh(pair), AnyHandle::DynamicBvh(h)) => pair.dynamic().prefetch_leaf(h),
            (Self::Layered(layers), h) => layers.dynamic().prefetch_entry(h),
            _ => {}
        }
    }

    /// Applies the BVH backend's settings to its dynamic tree (the other backends have none
    /// yet). Touches the tree only when they differ.
    pub(crate) fn configure_bvh(&mut self, config: DynamicBvhConfig) {
        if let Self::Bvh(pair) = self
            && *pair.dynamic().config() != config
        {
            pair.dynamic_mut().set_config(config);
        }
    }
}

impl RayWalk for EntityIndex {
    #[inline]
    fn walk_ray<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        on_layers!(self, layers => layers.walk_ray(ray, visit))
    }

    #[inline]
    fn walk_ray_any_order<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        on_layers!(self, layers => layers.walk_ray_any_order(ray, visit))
    }

    #[inline]
    fn walk_ray_announcing<A, V>(&self, ray: &mut Ray, announce: A, visit: V)
    where
        A: FnMut(u32),
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        on_layers!(self, layers => layers.walk_ray_announcing(ray, announce, visit))
    }
}

impl SpatialQuery for EntityIndex {
    fn for_each_overlapping_aabb<F>(&self, aabb: &Aabb, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        on_layers!(self, layers => layers.for_each_overlapping_aabb(aabb, visit))
    }

    fn for_each_overlapping_sphere<F>(&self, sphere: &Sphere, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        on_layers!(self, layers => layers.for_each_overlapping_sphere(sphere, visit))
    }

    fn for_each_containing_point<F>(&self, point: Vec3A, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        on_layers!(self, layers => layers.for_each_containing_point(point, visit))
    }

    fn for_each_in_frustum<F>(&self, frustum: &Frustum, visit: F)
    where
        F: FnMut(u32, Containment),
    {
        on_layers!(self, layers => layers.for_each_in_frustum(frustum, visit))
    }

    fn for_each_in_views<C, F>(&self, views: u32, classify: C, visit: F)
    where
        C: FnMut(&Aabb, u32) -> ViewClassification,
        F: FnMut(u32, ViewMasks),
    {
        on_layers!(self, layers => layers.for_each_in_views(views, classify, visit))
    }

    fn nearest_k<F>(&self, point: Vec3A, k: usize, distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32,
    {
        on_layers!(self, layers => layers.nearest_k(point, k, distance_squared))
    }
}
