//! Traversals of binary trees, shared by the static and the dynamic BVH.
//!
//! Each is a stack traversal that visits the nearer child first (for rays) and prunes by the
//! best distance found so far. They work on any [`BoundingTree`].

use super::{BoundingTree, RayHit, TraversalStack};
use crate::{Aabb, Containment, Frustum, Ray, Sphere};
use core::cmp::Ordering;
use core::ops::ControlFlow;
use glam::Vec3A;
use std::collections::BinaryHeap;

/// Sorts hits by distance, then id, so results are deterministic whatever the tree's shape.
pub fn sort_hits(hits: &mut [RayHit]) {
    hits.sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(a.primitive.cmp(&b.primitive)));
}

/// Walks the leaves a ray reaches, nearer child first, skipping subtrees that start beyond
/// `ray.t_max`, which the visitor may shrink as it finds hits: the [`RayWalk`](super::RayWalk)
/// of every binary tree.
pub fn visit_ray_front_to_back<T, F>(tree: &T, ray: &mut Ray, mut visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32, &mut Ray) -> ControlFlow<()>,
{
    let Some(root) = tree.root() else { return };
    let Some(root_t) = ray.intersect_aabb(&tree.node_bounds(root)) else {
        return;
    };
    let mut stack: TraversalStack<(u32, f32)> = TraversalStack::new();
    stack.push((root, root_t));
    while let Some((mut node, t_enter)) = stack.pop() {
        // The entry distance was computed when the node was pushed; a hit found since may
        // have moved the far end of the ray in front of it.
        if t_enter > ray.t_max {
            continue;
        }
        loop {
            match tree.node_children(node) {
                Some([a, b]) => {
                    let ta = ray.intersect_aabb(&tree.node_bounds(a));
                    let tb = ray.intersect_aabb(&tree.node_bounds(b));
                    // The children of each child the ray enters are read next (the nearer's
                    // at once, the farther's when popped): ask for them now, so in a scattered
                    // tree the misses overlap instead of queueing one level at a time.
                    for (child, t) in [(a, ta), (b, tb)] {
                        if t.is_some()
                            && let Some([x, y]) = tree.node_children(child)
                        {
                            tree.prefetch_node(x);
                            tree.prefetch_node(y);
                        }
                    }
                    node = match (ta, tb) {
                        (Some(ta), Some(tb)) => {
                            let (near, far, t_far) = if ta <= tb { (a, b, tb) } else { (b, a, ta) };
                            stack.push((far, t_far));
                            near
                        }
                        (Some(_), None) => a,
                        (None, Some(_)) => b,
                        (None, None) => break,
                    };
                }
                None => {
                    for &prim in tree.leaf_primitives(node) {
                        if visit(prim, ray).is_break() {
                            return;
                        }
                    }
                    break;
                }
            }
        }
    }
}

/// Visits the primitives of every leaf whose bounds pass `node_test`, depth first.
pub fn for_each_leaf_primitive<T, P, F>(tree: &T, mut node_test: P, mut visit: F)
where
    T: BoundingTree + ?Sized,
    P: FnMut(&Aabb) -> bool,
    F: FnMut(u32) -> ControlFlow<()>,
{
    let Some(root) = tree.root() else { return };
    let mut stack: TraversalStack<u32> = TraversalStack::new();
    stack.push(root);
    while let Some(node) = stack.pop() {
        if !node_test(&tree.node_bounds(node)) {
            continue;
        }
        match tree.node_children(node) {
            Some([a, b]) => {
                // Both are read soon: overlap their misses in a scattered tree.
                tree.prefetch_node(b);
                tree.prefetch_node(a);
                stack.push(b);
                stack.push(a);
            }
            None => {
                for &prim in tree.leaf_primitives(node) {
                    if visit(prim).is_break() {
                        return;
                    }
                }
            }
        }
    }
}

/// Overlap with a box; see [`super::SpatialQuery::for_each_overlapping_aabb`].
pub fn for_each_overlapping_aabb<T, F>(tree: &T, aabb: &Aabb, visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32) -> ControlFlow<()>,
{
    for_each_leaf_primitive(tree, |b| b.intersects_aabb(aabb), visit);
}

/// Overlap with a sphere; see [`super::SpatialQuery::for_each_overlapping_sphere`].
pub fn for_each_overlapping_sphere<T, F>(tree: &T, sphere: &Sphere, visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32) -> ControlFlow<()>,
{
    for_each_leaf_primitive(tree, |b| sphere.intersects_aabb(b), visit);
}

/// Point containment; see [`super::SpatialQuery::for_each_containing_point`].
pub fn for_each_containing_point<T, F>(tree: &T, point: Vec3A, visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32) -> ControlFlow<()>,
{
    for_each_leaf_primitive(tree, |b| b.contains_point(point), visit);
}

/// Frustum query; see [`super::SpatialQuery::for_each_in_frustum`].
pub fn for_each_in_frustum<T, F>(tree: &T, frustum: &Frustum, mut visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32, Containment),
{
    let Some(root) = tree.root() else { return };
    let mut stack: TraversalStack<u32> = TraversalStack::new();
    stack.push(root);
    while let Some(node) = stack.pop() {
        match frustum.classify_aabb(&tree.node_bounds(node)) {
            Containment::Outside => {}
            Containment::Inside => {
                // The whole subtree is in view: emit it without testing another plane.
                if let Some(prims) = tree.subtree_primitives(node) {
                    prims.iter().for_each(|&p| visit(p, Containment::Inside));
                    continue;
                }
                for_each_leaf_primitive(
                    &tree.subtree(node),
                    |_| true,
                    |p| {
                        visit(p, Containment::Inside);
                        ControlFlow::Continue(())
                    },
                );
            }
            Containment::Intersecting => match tree.node_children(node) {
                Some([a, b]) => {
                    tree.prefetch_node(b);
                    tree.prefetch_node(a);
                    stack.push(b);
                    stack.push(a);
                }
                None => {
                    for &p in tree.leaf_primitives(node) {
                        visit(p, Containment::Intersecting);
                    }
                }
            },
        }
    }
}

/// k nearest; see [`super::SpatialQuery::nearest_k`].
pub fn nearest_k<T, F>(tree: &T, point: Vec3A, k: usize, mut distance_squared: F) -> Vec<(u32, f32)>
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32) -> f32,
{
    let mut best: BinaryHeap<Candidate> = BinaryHeap::with_capacity(k + 1);
    let Some(root) = tree.root() else {
        return Vec::new();
    };
    if k == 0 {
        return Vec::new();
    }
    // Best-first: a min-heap of nodes by box distance (Reverse order through `Candidate`).
    let mut frontier: BinaryHeap<core::cmp::Reverse<Candidate>> = BinaryHeap::new();
    frontier.push(core::cmp::Reverse(Candidate {
        d2: tree.node_bounds(root).distance_squared_to_point(point),
        id: root,
    }));
    while let Some(core::cmp::Reverse(Candidate { d2, id: node })) = frontier.pop() {
        if best.len() == k && best.peek().is_some_and(|w| d2 > w.d2) {
            break;
        }
        match tree.node_children(node) {
            Some(children) => {
                for c in children {
                    let d2 = tree.node_bounds(c).distance_squared_to_point(point);
                    frontier.push(core::cmp::Reverse(Candidate { d2, id: c }));
                }
            }
            None => {
                for &p in tree.leaf_primitives(node) {
                    let d2 = distance_squared(p);
                    if d2.is_nan() {
                        continue;
                    }
                    let cand = Candidate { d2, id: p };
                    if best.len() < k {
                        best.push(cand);
                    } else if best.peek().is_some_and(|w| cand < *w) {
                        best.pop();
                        best.push(cand);
                    }
                }
            }
        }
    }
    let mut out: Vec<(u32, f32)> = best.into_iter().map(|c| (c.id, c.d2)).collect();
    out.sort_unstable_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    out
}

/// A (distance, id) pair ordered by distance then id, so heaps give deterministic ties.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Candidate {
    d2: f32,
    id: u32,
}

impl Eq for Candidate {}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        self.d2.total_cmp(&other.d2).then(self.id.cmp(&other.id))
    }
}

/// A subtree of a [`BoundingTree`], itself a tree rooted at one of its nodes.
pub struct Subtree<'a, T: ?Sized> {
    tree: &'a T,
    root: u32,
}

/// Rooting any tree at one of its nodes.
pub trait SubtreeExt: BoundingTree {
    /// The subtree below `node`.
    fn subtree(&self, node: u32) -> Subtree<'_, Self> {
        Subtree {
            tree: self,
            root: node,
        }
    }
}

impl<T: BoundingTree + ?Sized> SubtreeExt for T {}

impl<T: BoundingTree + ?Sized> BoundingTree for Subtree<'_, T> {
    fn root(&self) -> Option<u32> {
        Some(self.root)
    }
    fn node_bounds(&self, node: u32) -> Aabb {
        self.tree.node_bounds(node)
    }
    fn node_children(&self, node: u32) -> Option<[u32; 2]> {
        self.tree.node_children(node)
    }
    fn leaf_primitives(&self, node: u32) -> &[u32] {
        self.tree.leaf_primitives(node)
    }
    fn subtree_primitives(&self, node: u32) -> Option<&[u32]> {
        self.tree.subtree_primitives(node)
    }
    fn prefetch_node(&self, node: u32) {
        self.tree.prefetch_node(node)
    }
}

/// Implements [`super::RayWalk`] and [`super::SpatialQuery`] for a [`BoundingTree`] through the traversals of this
/// module, so every binary tree answers queries with the same code. The `@queries` form
/// leaves out `RayWalk`, for a tree that walks rays its own way.
#[macro_export]
macro_rules! impl_spatial_query_for_binary_tree {
    ($ty:ty) => {
        impl $crate::query::RayWalk for $ty {
            fn walk_ray<V>(&self, ray: &mut $crate::Ray, visit: V)
            where
                V: FnMut(u32, &mut $crate::Ray) -> core::ops::ControlFlow<()>,
            {
                $crate::query::binary::visit_ray_front_to_back(self, ray, visit)
            }
        }
        $crate::impl_spatial_query_for_binary_tree!(@queries $ty);
    };
    (@queries $ty:ty) => {
        impl $crate::SpatialQuery for $ty {
            fn for_each_overlapping_aabb<F>(&self, aabb: &$crate::Aabb, visit: F)
            where
                F: FnMut(u32) -> core::ops::ControlFlow<()>,
            {
                $crate::query::binary::for_each_overlapping_aabb(self, aabb, visit)
            }
            fn for_each_overlapping_sphere<F>(&self, sphere: &$crate::Sphere, visit: F)
            where
                F: FnMut(u32) -> core::ops::ControlFlow<()>,
            {
                $crate::query::binary::for_each_overlapping_sphere(self, sphere, visit)
            }
            fn for_each_containing_point<F>(&self, point: glam::Vec3A, visit: F)
            where
                F: FnMut(u32) -> core::ops::ControlFlow<()>,
            {
                $crate::query::binary::for_each_containing_point(self, point, visit)
            }
            fn for_each_in_frustum<F>(&self, frustum: &$crate::Frustum, visit: F)
            where
                F: FnMut(u32, $crate::Containment),
            {
                $crate::query::binary::for_each_in_frustum(self, frustum, visit)
            }
            fn for_each_in_views<C, F>(&self, views: u32, classify: C, visit: F)
            where
                C: FnMut(&$crate::Aabb, u32) -> $crate::query::views::ViewClassification,
                F: FnMut(u32, $crate::query::views::ViewMasks),
            {
                $crate::query::views::for_each_in_views(self, views, classify, visit)
            }
            fn nearest_k<F>(
                &self,
                point: glam::Vec3A,
                k: usize,
                distance_squared: F,
            ) -> Vec<(u32, f32)>
            where
                F: FnMut(u32) -> f32,
            {
                $crate::query::binary::nearest_k(self, point, k, distance_squared)
            }
        }
    };
}
