//! Choosing the dynamic index at run time.
//!
//! The queries take closures, so [`SpatialQuery`] and [`DynamicIndex`] have generic methods
//! and no `dyn` form: the choice is an enum over every implementation instead, each call one
//! `match` away from the chosen structure's code.

use super::dynamic_index::{DynamicIndex, IndexError, IndexStats, UpkeepReport};
use super::views::{ViewClassification, ViewMasks};
use super::{BruteForceIndex, FlatHandle, NodeView, RayWalk, SpatialQuery};
use crate::dynamic::{DynamicBvh, DynamicBvhConfig, LeafHandle};
use crate::grid::{GridHandle, UniformGrid};
use crate::octree::{LooseOctree, OctreeHandle, Quadtree};
use crate::{Aabb, Containment, Frustum, Ray, Sphere};
use core::ops::{ControlFlow, RangeInclusive};
use glam::Vec3A;
use std::time::Duration;

/// The structures a [`AnyIndex`] can be.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum IndexKind {
    /// [`DynamicBvh`]: SAH insertion, fat leaves, refit of moved paths, an optimiser.
    #[default]
    DynamicBvh,
    /// [`LooseOctree`]: an object at the depth its size gives, a move inside its loose cell
    /// one box write.
    Octree,
    /// [`Quadtree`]: the loose octree's code over x and y, for 2D worlds.
    Quadtree,
    /// [`UniformGrid`]: a hashed grid, objects in every cell they overlap, rays by 3D DDA.
    Grid,
    /// [`BruteForceIndex`]: a flat list, every query a loop. For a handful of objects, and
    /// as the oracle in tests.
    BruteForce,
}

impl IndexKind {
    /// Every kind, in declaration order.
    pub const ALL: [IndexKind; 5] = [
        IndexKind::DynamicBvh,
        IndexKind::Octree,
        IndexKind::Quadtree,
        IndexKind::Grid,
        IndexKind::BruteForce,
    ];
}

/// One of the dynamic indexes, chosen at run time ([`IndexKind`]).
///
/// ```
/// use spatial_accel::query::{AnyIndex, DynamicIndex, IndexKind};
/// use spatial_accel::{Aabb, Ray, SpatialQuery};
/// use glam::Vec3A;
/// use std::time::Duration;
/// for kind in IndexKind::ALL {
///     let mut index = AnyIndex::new(kind);
///     let b = Aabb::new(Vec3A::splat(2.0), Vec3A::splat(3.0));
///     index.insert(7, b).unwrap();
///     index.maintain(Duration::ZERO);
///     let ray = Ray::new(Vec3A::ZERO, Vec3A::ONE);
///     let hit = index.cast_ray(&ray, |_, r| r.intersect_aabb(&b)).unwrap();
///     assert_eq!((index.kind(), hit.primitive), (kind, 7));
/// }
/// ```
#[derive(Clone, Debug)]
#[expect(
    clippy::large_enum_variant,
    reason = "one index per world, queried in hot loops: a box would add a pointer chase to \
              every query to save a few hundred bytes once"
)]
pub enum AnyIndex {
    /// A [`DynamicBvh`].
    DynamicBvh(DynamicBvh),
    /// A [`LooseOctree`].
    Octree(LooseOctree),
    /// A [`Quadtree`].
    Quadtree(Quadtree),
    /// A [`UniformGrid`].
    Grid(UniformGrid),
    /// A [`BruteForceIndex`].
    BruteForce(BruteForceIndex),
}

/// A handle into an [`AnyIndex`]: the handle of the structure it came from. A handle of one
/// kind given to an index of another is stale.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AnyHandle {
    /// A [`DynamicBvh`] leaf.
    DynamicBvh(LeafHandle),
    /// A [`LooseOctree`] or [`Quadtree`] entry.
    Octree(OctreeHandle),
    /// A [`UniformGrid`] entry.
    Grid(GridHandle),
    /// A [`BruteForceIndex`] entry.
    BruteForce(FlatHandle),
}

impl Default for AnyIndex {
    fn default() -> Self {
        Self::new(IndexKind::default())
    }
}

/// Runs `$body` on whichever structure `$index` holds, bound to `$inner`.
macro_rules! on_inner {
    ($index:expr, $inner:ident => $body:expr) => {
        match $index {
            AnyIndex::DynamicBvh($inner) => $body,
            AnyIndex::Octree($inner) => $body,
            AnyIndex::Quadtree($inner) => $body,
            AnyIndex::Grid($inner) => $body,
            AnyIndex::BruteForce($inner) => $body,
        }
    };
}

impl AnyIndex {
    /// An empty index of the given kind, with that structure's default settings.
    pub fn new(kind: IndexKind) -> Self {
        match kind {
            IndexKind::DynamicBvh => Self::DynamicBvh(DynamicBvh::new()),
            IndexKind::Octree => Self::Octree(LooseOctree::new()),
            IndexKind::Quadtree => Self::Quadtree(Quadtree::new()),
            IndexKind::Grid => Self::Grid(UniformGrid::new()),
            IndexKind::BruteForce => Self::BruteForce(BruteForceIndex::new()),
        }
    }

    /// An empty dynamic BVH with the given settings.
    pub fn dynamic_bvh(config: DynamicBvhConfig) -> Self {
        Self::DynamicBvh(DynamicBvh::with_config(config))
    }

    /// Which structure this is.
    pub fn kind(&self) -> IndexKind {
        match self {
            Self::DynamicBvh(_) => IndexKind::DynamicBvh,
            Self::Octree(_) => IndexKind::Octree,
            Self::Quadtree(_) => IndexKind::Quadtree,
            Self::Grid(_) => IndexKind::Grid,
            Self::BruteForce(_) => IndexKind::BruteForce,
        }
    }

    /// Asks for what an update of this entry reads at a scattered place, where the
    /// structure says (the BVH's leaf, the loose tree's octant). A hint only.
    #[inline]
    pub fn prefetch_entry(&self, handle: AnyHandle) {
        match (self, handle) {
            (Self::DynamicBvh(tree), AnyHandle::DynamicBvh(h)) => tree.prefetch_leaf(h),
            (Self::Octree(tree), AnyHandle::Octree(h)) => tree.prefetch_entry(h),
            (Self::Quadtree(tree), AnyHandle::Octree(h)) => tree.prefetch_entry(h),
            (Self::Grid(grid), AnyHandle::Grid(h)) => grid.prefetch_entry(h),
            _ => {}
        }
    }

    /// The dynamic BVH, when that is the structure.
    pub fn as_dynamic_bvh(&self) -> Option<&DynamicBvh> {
        match self {
            Self::DynamicBvh(tree) => Some(tree),
            _ => None,
        }
    }

    /// The dynamic BVH, mutably, when that is the structure.
    pub fn as_dynamic_bvh_mut(&mut self) -> Option<&mut DynamicBvh> {
        match self {
            Self::DynamicBvh(tree) => Some(tree),
            _ => None,
        }
    }
}

impl DynamicIndex for AnyIndex {
    type Handle = AnyHandle;

    fn insert(&mut self, id: u32, bounds: Aabb) -> Result<AnyHandle, IndexError> {
        match self {
            Self::DynamicBvh(tree) => tree.insert(id, bounds).map(AnyHandle::DynamicBvh),
            Self::Octree(tree) => DynamicIndex::insert(tree, id, bounds).map(AnyHandle::Octree),
            Self::Quadtree(tree) => DynamicIndex::insert(tree, id, bounds).map(AnyHandle::Octree),
            Self::Grid(grid) => DynamicIndex::insert(grid, id, bounds).map(AnyHandle::Grid),
            Self::BruteForce(list) => {
                DynamicIndex::insert(list, id, bounds).map(AnyHandle::BruteForce)
            }
        }
    }

    fn update(&mut self, handle: AnyHandle, bounds: Aabb) -> Result<bool, IndexError> {
        match (self, handle) {
            (Self::DynamicBvh(tree), AnyHandle::DynamicBvh(h)) => tree.update(h, bounds),
            (Self::Octree(tree), AnyHandle::Octree(h)) => tree.update(h, bounds),
            (Self::Quadtree(tree), AnyHandle::Octree(h)) => tree.update(h, bounds),
            (Self::Grid(grid), AnyHandle::Grid(h)) => grid.update(h, bounds),
            (Self::BruteForce(list), AnyHandle::BruteForce(h)) => list.update(h, bounds),
            _ => Err(IndexError::StaleHandle),
        }
    }

    fn remove(&mut self, handle: AnyHandle) -> Result<u32, IndexError> {
        match (self, handle) {
            (Self::DynamicBvh(tree), AnyHandle::DynamicBvh(h)) => tree.remove(h),
            (Self::Octree(tree), AnyHandle::Octree(h)) => tree.remove(h),
            (Self::Quadtree(tree), AnyHandle::Octree(h)) => tree.remove(h),
            (Self::Grid(grid), AnyHandle::Grid(h)) => grid.remove(h),
            (Self::BruteForce(list), AnyHandle::BruteForce(h)) => list.remove(h),
            _ => Err(IndexError::StaleHandle),
        }
    }

    fn id(&self, handle: AnyHandle) -> Option<u32> {
        match (self, handle) {
            (Self::DynamicBvh(tree), AnyHandle::DynamicBvh(h)) => tree.id(h),
            (Self::Octree(tree), AnyHandle::Octree(h)) => tree.id(h),
            (Self::Quadtree(tree), AnyHandle::Octree(h)) => tree.id(h),
            (Self::Grid(grid), AnyHandle::Grid(h)) => DynamicIndex::id(grid, h),
            (Self::BruteForce(list), AnyHandle::BruteForce(h)) => list.id(h),
            _ => None,
        }
    }

    fn bounds_of(&self, handle: AnyHandle) -> Option<Aabb> {
        match (self, handle) {
            (Self::DynamicBvh(tree), AnyHandle::DynamicBvh(h)) => tree.bounds_of(h),
            (Self::Octree(tree), AnyHandle::Octree(h)) => tree.bounds_of(h),
            (Self::Quadtree(tree), AnyHandle::Octree(h)) => tree.bounds_of(h),
            (Self::Grid(grid), AnyHandle::Grid(h)) => DynamicIndex::bounds_of(grid, h),
            (Self::BruteForce(list), AnyHandle::BruteForce(h)) => list.bounds_of(h),
            _ => None,
        }
    }

    fn len(&self) -> usize {
        on_inner!(self, inner => DynamicIndex::len(inner))
    }

    fn clear(&mut self) {
        on_inner!(self, inner => DynamicIndex::clear(inner))
    }

    fn maintain(&mut self, budget: Duration) -> UpkeepReport {
        on_inner!(self, inner => DynamicIndex::maintain(inner, budget))
    }

    fn index_stats(&self) -> IndexStats {
        on_inner!(self, inner => inner.index_stats())
    }

    /// The chosen structure's nodes, as its own implementation gives them.
    fn visit_nodes(
        &self,
        depths: RangeInclusive<u32>,
        visit: &mut dyn FnMut(NodeView) -> ControlFlow<()>,
    ) -> ControlFlow<()> {
        on_inner!(self, inner => inner.visit_nodes(depths, visit))
    }
}

impl RayWalk for AnyIndex {
    fn walk_ray<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        on_inner!(self, inner => inner.walk_ray(ray, visit))
    }

    fn walk_ray_any_order<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        on_inner!(self, inner => inner.walk_ray_any_order(ray, visit))
    }

    fn walk_ray_announcing<A, V>(&self, ray: &mut Ray, announce: A, visit: V)
    where
        A: FnMut(u32),
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        on_inner!(self, inner => inner.walk_ray_announcing(ray, announce, visit))
    }
}

impl SpatialQuery for AnyIndex {
    fn for_each_overlapping_aabb<F>(&self, aabb: &Aabb, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        on_inner!(self, inner => inner.for_each_overlapping_aabb(aabb, visit))
    }

    fn for_each_overlapping_sphere<F>(&self, sphere: &Sphere, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        on_inner!(self, inner => inner.for_each_overlapping_sphere(sphere, visit))
    }

    fn for_each_containing_point<F>(&self, point: Vec3A, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        on_inner!(self, inner => inner.for_each_containing_point(point, visit))
    }

    fn for_each_in_frustum<F>(&self, frustum: &Frustum, visit: F)
    where
        F: FnMut(u32, Containment),
    {
        on_inner!(self, inner => inner.for_each_in_frustum(frustum, visit))
    }

    fn for_each_in_views<C, F>(&self, views: u32, classify: C, visit: F)
    where
        C: FnMut(&Aabb, u32) -> ViewClassification,
        F: FnMut(u32, ViewMasks),
    {
        on_inner!(self, inner => inner.for_each_in_views(views, classify, visit))
    }

    fn nearest_k<F>(&self, point: Vec3A, k: usize, distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32,
    {
        on_inner!(self, inner => inner.nearest_k(point, k, distance_squared))
    }
}
