//! A static tree under any dynamic index, queried as one.
//!
//! [`StaticDynamicPair`](super::StaticDynamicPair) fuses a static BVH and a dynamic BVH into
//! one tree under a virtual root. An index of another shape (an octree, a grid, a flat list)
//! cannot join that tree, so [`LayeredIndex`] asks the two layers in turn: the static tree
//! first, then the dynamic index, each query's visitor shared between them. A ray's closest
//! hit found in the static layer shortens the ray the dynamic layer walks, so the order still
//! prunes; the k-nearest query merges the two layers' answers.

use super::PreparedStatic;
use super::pair_rays::wide_for_rays;
use crate::bvh::wide::Bvh16;
use crate::query::views::{ViewClassification, ViewMasks};
use crate::query::{DynamicIndex, RayWalk};
use crate::{Aabb, Bvh, Containment, Frustum, Ray, SpatialQuery, Sphere};
use core::cell::Cell;
use core::ops::ControlFlow;
use glam::Vec3A;

/// A static [`Bvh`] and a [`DynamicIndex`] answering [`SpatialQuery`] as one.
///
/// As with the pair, queries report the ids each layer holds as they are: give the layers
/// disjoint ids when a callback must tell them apart. After edits of the dynamic layer, call
/// its [`DynamicIndex::maintain`] before querying.
///
/// ```
/// use spatial_accel::dynamic::LayeredIndex;
/// use spatial_accel::query::{BruteForceIndex, DynamicIndex};
/// use spatial_accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
/// use glam::Vec3A;
/// use std::time::Duration;
///
/// let wall = Aabb::new(Vec3A::new(10.0, 0.0, 0.0), Vec3A::new(11.0, 5.0, 5.0));
/// let mut layers = LayeredIndex::new(
///     Bvh::build(&[wall], &BuildConfig::default()),
///     BruteForceIndex::new(),
/// );
/// let crate_box = Aabb::new(Vec3A::new(3.0, 1.0, 1.0), Vec3A::new(4.0, 2.0, 2.0));
/// layers.dynamic_mut().insert(100, crate_box).unwrap();
/// layers.dynamic_mut().maintain(Duration::ZERO);
///
/// let boxes = |id: u32| if id == 100 { crate_box } else { wall };
/// let ray = Ray::new(Vec3A::new(0.0, 1.5, 1.5), Vec3A::X);
/// assert_eq!(layers.cast_ray(&ray, |id, r| r.intersect_aabb(&boxes(id))).unwrap().primitive, 100);
/// ```
#[derive(Clone, Debug, Default)]
pub struct LayeredIndex<D> {
    static_tree: Bvh,
    /// The static tree in its 16-wide form, for rays (see `pair_rays::wide_for_rays`).
    static_wide: Bvh16,
    dynamic: D,
}

impl<D: DynamicIndex> LayeredIndex<D> {
    /// The layers of a static tree and a dynamic index.
    pub fn new(static_tree: Bvh, dynamic: D) -> Self {
        Self {
            static_wide: wide_for_rays(&static_tree),
            static_tree,
            dynamic,
        }
    }

    /// The static tree.
    pub fn static_tree(&self) -> &Bvh {
        &self.static_tree
    }

    /// Replaces the static tree, returning the old one. Derives the tree's ray form here,
    /// O(n); [`Self::set_static_prepared`] takes it made elsewhere.
    pub fn set_static(&mut self, static_tree: Bvh) -> Bvh {
        self.static_wide = wide_for_rays(&static_tree);
        core::mem::replace(&mut self.static_tree, static_tree)
    }

    /// Replaces the static tree with one prepared ahead (on another thread, say), returning
    /// the old one with its ray form (and no spans: this index keeps none), so that a caller
    /// can free it off the frame too: O(1).
    pub fn set_static_prepared(&mut self, prepared: PreparedStatic) -> PreparedStatic {
        PreparedStatic {
            wide: core::mem::replace(&mut self.static_wide, prepared.wide),
            ranges: Vec::new(),
            tree: core::mem::replace(&mut self.static_tree, prepared.tree),
        }
    }

    /// The dynamic index.
    pub fn dynamic(&self) -> &D {
        &self.dynamic
    }

    /// The dynamic index, for edits and upkeep.
    pub fn dynamic_mut(&mut self) -> &mut D {
        &mut self.dynamic
    }

    /// Both layers, by value.
    pub fn into_parts(self) -> (Bvh, D) {
        (self.static_tree, self.dynamic)
    }
}

impl<D: DynamicIndex> RayWalk for LayeredIndex<D> {
    fn walk_ray<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        self.walk_ray_announcing(ray, |_| {}, visit);
    }

    fn walk_ray_any_order<V>(&self, ray: &mut Ray, mut visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        // A visitor that stops the walk must stop the second layer's walk too.
        let stopped = Cell::new(false);
        let mut visit = |p: u32, r: &mut Ray| {
            let flow = visit(p, r);
            stopped.set(flow.is_break());
            flow
        };
        self.static_wide.walk_ray_any_order(ray, &mut visit);
        if !stopped.get() {
            self.dynamic.walk_ray_any_order(ray, &mut visit);
        }
    }

    fn walk_ray_announcing<A, V>(&self, ray: &mut Ray, mut announce: A, mut visit: V)
    where
        A: FnMut(u32),
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        // One ray through both layers: a hit in the static layer shortens the dynamic
        // layer's walk.
        let stopped = Cell::new(false);
        let mut visit = |p: u32, r: &mut Ray| {
            let flow = visit(p, r);
            stopped.set(flow.is_break());
            flow
        };
        self.static_wide
            .walk_ray_announcing(ray, &mut announce, &mut visit);
        if !stopped.get() {
            self.dynamic
                .walk_ray_announcing(ray, &mut announce, &mut visit);
        }
    }
}

/// Keeps the `k` nearest of two lists each sorted by distance then id, in the same order:
/// how an index of several layers answers [`SpatialQuery::nearest_k`] from theirs.
///
/// ```
/// use spatial_accel::dynamic::merge_nearest;
/// let merged = merge_nearest(vec![(1, 0.5), (2, 4.0)], vec![(7, 1.0)], 2);
/// assert_eq!(merged, vec![(1, 0.5), (7, 1.0)]);
/// ```
pub fn merge_nearest(a: Vec<(u32, f32)>, b: Vec<(u32, f32)>, k: usize) -> Vec<(u32, f32)> {
    let mut out = Vec::with_capacity(k.min(a.len() + b.len()));
    let (mut a, mut b) = (a.into_iter().peekable(), b.into_iter().peekable());
    while out.len() < k {
        let take_a = match (a.peek(), b.peek()) {
            (Some(x), Some(y)) => x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)).is_le(),
            (Some(_), None) => true,
            (None, Some(_)) => false,
            (None, None) => break,
        };
        out.extend(if take_a { a.next() } else { b.next() });
    }
    out
}

/// Runs a query that a visitor can stop on the static layer, then on the dynamic one unless
/// the visitor stopped it.
macro_rules! static_then_dynamic {
    ($layers:ident, $method:ident, $arg:expr, $visit:ident) => {{
        let mut stopped = false;
        $layers.static_tree.$method($arg, |p| {
            let flow = $visit(p);
            stopped = flow.is_break();
            flow
        });
        if !stopped {
            $layers.dynamic.$method($arg, $visit);
        }
    }};
}

impl<D: DynamicIndex> SpatialQuery for LayeredIndex<D> {
    fn for_each_overlapping_aabb<F>(&self, aabb: &Aabb, mut visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        static_then_dynamic!(self, for_each_overlapping_aabb, aabb, visit);
    }

    fn for_each_overlapping_sphere<F>(&self, sphere: &Sphere, mut visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        static_then_dynamic!(self, for_each_overlapping_sphere, sphere, visit);
    }

    fn for_each_containing_point<F>(&self, point: Vec3A, mut visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        static_then_dynamic!(self, for_each_containing_point, point, visit);
    }

    fn for_each_in_frustum<F>(&self, frustum: &Frustum, mut visit: F)
    where
        F: FnMut(u32, Containment),
    {
        self.static_tree.for_each_in_frustum(frustum, &mut visit);
        self.dynamic.for_each_in_frustum(frustum, visit);
    }

    fn for_each_in_views<C, F>(&self, views: u32, mut classify: C, mut visit: F)
    where
        C: FnMut(&Aabb, u32) -> ViewClassification,
        F: FnMut(u32, ViewMasks),
    {
        self.static_tree
            .for_each_in_views(views, &mut classify, &mut visit);
        self.dynamic.for_each_in_views(views, classify, visit);
    }

    fn nearest_k<F>(&self, point: Vec3A, k: usize, mut distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32,
    {
        let from_static = self.static_tree.nearest_k(point, k, &mut distance_squared);
        let from_dynamic = self.dynamic.nearest_k(point, k, distance_squared);
        merge_nearest(from_static, from_dynamic, k)
    }
}
