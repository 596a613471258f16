//! A static tree and a dynamic tree, queried as one.
//!
//! Level geometry never moves; entities do. Keeping them in one dynamic tree makes every
//! refit and rebuild pay for the level too, and keeping them in two makes every query run
//! twice by hand. [`StaticDynamicPair`] presents both as one [`BoundingTree`] under a virtual
//! root, so every query is one traversal through the shared code of [`crate::query::binary`]
//! (a closest hit found in one tree prunes the other), while the static tree is never refit.
//! Rays, the hottest query (picking, the preview), walk the static tree in its 8-wide form
//! instead, then the dynamic tree, the nearer first so its hits prune the other.

use super::DynamicBvh;
use crate::bvh::wide::Bvh8;
use crate::query::{BoundingTree, RayWalk};
use crate::{Aabb, Bvh, Ray};
use core::ops::ControlFlow;

/// Static node ids are tagged with the top bit (dynamic node ids stay below 2^31).
const STATIC_TAG: u32 = 1 << 31;
/// The virtual root above the two trees.
const VIRTUAL_ROOT: u32 = u32::MAX;

/// A static [`Bvh`] and a [`DynamicBvh`] answering [`SpatialQuery`](crate::SpatialQuery) as
/// one tree.
///
/// Queries report the primitive ids each tree holds, as they are: give the two trees
/// disjoint id ranges (for example static ids from `1 << 31` up, or a lookup the callback
/// can tell apart) when the callback must know which tree a primitive came from. As with
/// the dynamic tree alone, call [`DynamicBvh::maintain`] (or `refit`) after updates and
/// before querying.
///
/// ```
/// use accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
/// use accel::dynamic::{DynamicBvh, StaticDynamicPair};
/// use glam::Vec3A;
///
/// // Level walls: ids 0..10, static.
/// let walls: Vec<Aabb> = (0..10)
///     .map(|i| Aabb::new(Vec3A::new(10.0 * i as f32, 0.0, 0.0), Vec3A::new(10.0 * i as f32 + 1.0, 5.0, 5.0)))
///     .collect();
/// let mut pair = StaticDynamicPair::new(Bvh::build(&walls, &BuildConfig::default()), DynamicBvh::new());
/// // A moving crate: id 100, dynamic, in front of the first wall.
/// let crate_box = Aabb::new(Vec3A::new(-3.0, 1.0, 1.0), Vec3A::new(-2.0, 2.0, 2.0));
/// pair.dynamic_mut().insert(100, crate_box).unwrap();
/// pair.dynamic_mut().maintain();
///
/// let boxes = |id: u32| if id == 100 { crate_box } else { walls[id as usize] };
/// let ray = Ray::new(Vec3A::new(-10.0, 1.5, 1.5), Vec3A::X);
/// let hit = pair.cast_ray(&ray, |id, r| r.intersect_aabb(&boxes(id))).unwrap();
/// assert_eq!(hit.primitive, 100);
/// ```
#[derive(Clone, Debug, Default)]
pub struct StaticDynamicPair {
    static_tree: Bvh,
    /// The static tree collapsed to 8-wide nodes, for rays (same primitive ids).
    static_wide: Bvh8,
    dynamic: DynamicBvh,
}

impl StaticDynamicPair {
    /// The pair of a static tree and a dynamic one.
    pub fn new(static_tree: Bvh, dynamic: DynamicBvh) -> Self {
        Self {
            static_wide: Bvh8::from_bvh(&static_tree),
            static_tree,
            dynamic,
        }
    }

    /// The static tree (read-only: it is never refit; replace it with
    /// [`set_static`](Self::set_static) when the level changes).
    pub fn static_tree(&self) -> &Bvh {
        &self.static_tree
    }

    /// Replaces the static tree, returning the old one.
    pub fn set_static(&mut self, static_tree: Bvh) -> Bvh {
        self.static_wide = Bvh8::from_bvh(&static_tree);
        core::mem::replace(&mut self.static_tree, static_tree)
    }

    /// The dynamic tree.
    pub fn dynamic(&self) -> &DynamicBvh {
        &self.dynamic
    }

    /// The dynamic tree, for insertions, updates and `maintain`.
    pub fn dynamic_mut(&mut self) -> &mut DynamicBvh {
        &mut self.dynamic
    }

    /// Both trees, by value.
    pub fn into_parts(self) -> (Bvh, DynamicBvh) {
        (self.static_tree, self.dynamic)
    }

    /// Bounds of everything in either tree.
    pub fn bounds(&self) -> Aabb {
        self.static_tree.bounds().union(&self.dynamic.bounds())
    }
}

impl BoundingTree for StaticDynamicPair {
    #[inline]
    fn root(&self) -> Option<u32> {
        match (self.static_tree.root(), self.dynamic.root()) {
            (Some(_), Some(_)) => Some(VIRTUAL_ROOT),
            (Some(s), None) => Some(s | STATIC_TAG),
            (None, d) => d,
        }
    }

    #[inline]
    fn node_bounds(&self, node: u32) -> Aabb {
        if node == VIRTUAL_ROOT {
            self.bounds()
        } else if node & STATIC_TAG != 0 {
            self.static_tree.node_bounds(node & !STATIC_TAG)
        } else {
            self.dynamic.node_bounds(node)
        }
    }

    #[inline]
    fn node_children(&self, node: u32) -> Option<[u32; 2]> {
        if node == VIRTUAL_ROOT {
            let s = self.static_tree.root()?;
            let d = self.dynamic.root()?;
            Some([s | STATIC_TAG, d])
        } else if node & STATIC_TAG != 0 {
            self.static_tree
                .node_children(node & !STATIC_TAG)
                .map(|c| c.map(|c| c | STATIC_TAG))
        } else {
            self.dynamic.node_children(node)
        }
    }

    #[inline]
    fn prefetch_node(&self, node: u32) {
        // Static nodes lie in build order, children next to their parent: no hint needed.
        if node & STATIC_TAG == 0 {
            self.dynamic.prefetch_node(node);
        }
    }

    #[inline]
    fn leaf_primitives(&self, node: u32) -> &[u32] {
        if node == VIRTUAL_ROOT {
            &[]
        } else if node & STATIC_TAG != 0 {
            self.static_tree.leaf_primitives(node & !STATIC_TAG)
        } else {
            self.dynamic.leaf_primitives(node)
        }
    }

    #[inline]
    fn subtree_primitives(&self, node: u32) -> Option<&[u32]> {
        (node != VIRTUAL_ROOT && node & STATIC_TAG != 0)
            .then(|| self.static_tree.subtree_primitives(node & !STATIC_TAG))
            .flatten()
    }
}

impl RayWalk for StaticDynamicPair {
    fn walk_ray<V>(&self, ray: &mut Ray, mut visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        let entry = |bounds: Aabb| ray.intersect_aabb(&bounds).unwrap_or(f32::INFINITY);
        let static_first = entry(self.static_wide.bounds()) <= entry(self.dynamic.bounds());
        // A visitor that stops the walk must stop the second tree's walk too.
        let stopped = core::cell::Cell::new(false);
        let mut visit = |p: u32, r: &mut Ray| {
            let flow = visit(p, r);
            stopped.set(flow.is_break());
            flow
        };
        if static_first {
            self.static_wide.walk_ray(ray, &mut visit);
            if !stopped.get() {
                self.dynamic.walk_ray(ray, &mut visit);
            }
        } else {
            self.dynamic.walk_ray(ray, &mut visit);
            if !stopped.get() {
                self.static_wide.walk_ray(ray, &mut visit);
            }
        }
    }
}

crate::impl_spatial_query_for_binary_tree!(@queries StaticDynamicPair);
