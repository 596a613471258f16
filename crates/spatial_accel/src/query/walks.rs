//! The traversals every [`BoundingTree`] shares, whatever its branching factor: the static,
//! dynamic, wide and sphere BVHs and the static/dynamic pair answer their queries with this
//! code, and the octree will.
//!
//! Each is a stack traversal that prunes by the query's test against a node's volume; the ray
//! walk enters the nearest child first and prunes by the best distance found so far.

use super::{BoundingTree, NodeVolume, RayHit, TraversalStack};
use crate::{Aabb, Containment, Frustum, Ray, Sphere};
use core::cmp::Ordering;
use core::ops::ControlFlow;
use glam::Vec3A;
use std::collections::BinaryHeap;

/// Sorts hits by distance, then id, so results are deterministic whatever the tree's shape.
pub fn sort_hits(hits: &mut [RayHit]) {
    hits.sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(a.primitive.cmp(&b.primitive)));
}

/// Calls `visit` for each primitive stored at `node` (a leaf's, or an interior node's where
/// the tree keeps primitives there), stopping when it breaks.
#[inline(always)]
fn visit_node_primitives<T, F>(tree: &T, node: u32, visit: &mut F) -> ControlFlow<()>
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32) -> ControlFlow<()>,
{
    for &prim in tree.node_primitives(node) {
        visit(prim)?;
    }
    ControlFlow::Continue(())
}

/// Walks the nodes a ray reaches, nearest child first, skipping subtrees that start beyond
/// `ray.t_max`, which the visitor may shrink as it finds hits: the [`RayWalk`](super::RayWalk)
/// of every tree without a walk of its own.
///
/// Only the nearest child is ordered: it is entered next, and the others wait on the stack in
/// the order they came. For a binary tree that is the full front-to-back order; for wider
/// nodes, a sort of every entry costs more than the few pops it saves.
pub fn visit_ray_front_to_back<T, F>(tree: &T, ray: &mut Ray, mut visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32, &mut Ray) -> ControlFlow<()>,
{
    // A NaN direction passes every slab test (NaN distances do not constrain), so it would
    // visit the whole tree: turn it away as a miss (see `Ray::is_traceable`).
    if !ray.is_traceable() {
        return;
    }
    let Some(root) = tree.root() else { return };
    let Some(root_t) = tree.node_bounds(root).ray_entry(ray) else {
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
            let children = tree.node_children(node);
            if children.is_none() || T::INTERIOR_PRIMITIVES {
                for &prim in tree.node_primitives(node) {
                    if visit(prim, ray).is_break() {
                        return;
                    }
                }
            }
            let Some(children) = children else { break };
            let mut nearest: Option<(u32, f32)> = None;
            for child in children {
                let Some(t) = tree.node_bounds(child).ray_entry(ray) else {
                    continue;
                };
                // The children of each child the ray enters are read next (the nearest's at
                // once, the others' when popped): ask for them now, so in a scattered tree
                // the misses overlap instead of queueing one level at a time.
                tree.prefetch_children(child);
                nearest = match nearest {
                    Some((near, t_near)) if t < t_near => {
                        stack.push((near, t_near));
                        Some((child, t))
                    }
                    Some(near) => {
                        stack.push((child, t));
                        Some(near)
                    }
                    None => Some((child, t)),
                };
            }
            match nearest {
                Some((near, _)) => node = near,
                None => break,
            }
        }
    }
}

/// Visits the primitives of every node whose bounds pass `node_test`, depth first, in the
/// order of each node's children.
pub fn visit_primitives_where<T, P, F>(tree: &T, mut node_test: P, mut visit: F)
where
    T: BoundingTree + ?Sized,
    P: FnMut(&T::Volume) -> bool,
    F: FnMut(u32) -> ControlFlow<()>,
{
    let Some(root) = tree.root() else { return };
    let mut stack: TraversalStack<u32> = TraversalStack::new();
    stack.push(root);
    while let Some(node) = stack.pop() {
        if !node_test(&tree.node_bounds(node)) {
            continue;
        }
        let children = tree.node_children(node);
        if (children.is_none() || T::INTERIOR_PRIMITIVES)
            && visit_node_primitives(tree, node, &mut visit).is_break()
        {
            return;
        }
        // Each is read soon: overlap their misses in a scattered tree.
        for child in children.into_iter().flatten().rev() {
            tree.prefetch_node(child);
            stack.push(child);
        }
    }
}

/// Every primitive below `node`, without a test: a subtree a query holds whole. One slice
/// where the tree stores the subtree's primitives contiguously, else a walk.
pub fn visit_subtree<T, F>(tree: &T, node: u32, mut visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32),
{
    if let Some(prims) = tree.subtree_primitives(node) {
        prims.iter().for_each(|&p| visit(p));
        return;
    }
    visit_scattered_subtree(tree, node, visit);
}

/// Nodes a whole-subtree walk has asked for ahead of reading them.
const SUBTREE_LOOKAHEAD: usize = 32;

/// [`visit_subtree`] where the nodes lie scattered in memory (a dynamic tree after motion):
/// every node is read, and a depth-first walk reads the child it just pushed at once, so
/// half its reads wait on a miss. Nothing orders a whole subtree's primitives, so the walk
/// reads nodes first in, first out from a ring of [`SUBTREE_LOOKAHEAD`], each prefetched as
/// it enters: a node is read that many nodes after its load began, and the misses overlap.
/// Nodes the ring has no room for wait on a stack until it does.
fn visit_scattered_subtree<T, F>(tree: &T, node: u32, mut visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32),
{
    let mut ring = [0u32; SUBTREE_LOOKAHEAD];
    let (mut head, mut len) = (0usize, 1usize);
    ring[0] = node;
    let mut waiting: TraversalStack<u32> = TraversalStack::new();
    while len > 0 {
        let node = ring[head];
        head = (head + 1) % SUBTREE_LOOKAHEAD;
        len -= 1;
        let children = tree.node_children(node);
        if children.is_none() || T::INTERIOR_PRIMITIVES {
            tree.node_primitives(node).iter().for_each(|&p| visit(p));
        }
        for child in children.into_iter().flatten() {
            waiting.push(child);
        }
        while len < SUBTREE_LOOKAHEAD
            && let Some(next) = waiting.pop()
        {
            tree.prefetch_node(next);
            ring[(head + len) % SUBTREE_LOOKAHEAD] = next;
            len += 1;
        }
    }
}

/// Overlap with a box; see [`super::SpatialQuery::for_each_overlapping_aabb`].
pub fn for_each_overlapping_aabb<T, F>(tree: &T, aabb: &Aabb, visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32) -> ControlFlow<()>,
{
    visit_primitives_where(tree, |b| b.overlaps_aabb(aabb), visit);
}

/// Overlap with a sphere; see [`super::SpatialQuery::for_each_overlapping_sphere`].
pub fn for_each_overlapping_sphere<T, F>(tree: &T, sphere: &Sphere, visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32) -> ControlFlow<()>,
{
    visit_primitives_where(tree, |b| b.overlaps_sphere(sphere), visit);
}

/// Point containment; see [`super::SpatialQuery::for_each_containing_point`].
pub fn for_each_containing_point<T, F>(tree: &T, point: Vec3A, visit: F)
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32) -> ControlFlow<()>,
{
    visit_primitives_where(tree, |b| b.contains_point(point), visit);
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
        match tree.node_bounds(node).classify_frustum(frustum) {
            Containment::Outside => {}
            // The whole subtree is in view: emit it without testing another plane.
            Containment::Inside => visit_subtree(tree, node, |p| visit(p, Containment::Inside)),
            Containment::Intersecting => {
                let children = tree.node_children(node);
                if children.is_none() || T::INTERIOR_PRIMITIVES {
                    for &p in tree.node_primitives(node) {
                        visit(p, Containment::Intersecting);
                    }
                }
                for child in children.into_iter().flatten().rev() {
                    tree.prefetch_node(child);
                    stack.push(child);
                }
            }
        }
    }
}

/// At most this many k-nearest candidates are allocated for before the walk starts.
pub(crate) const NEAREST_PREALLOCATION: usize = 1024;

/// k nearest; see [`super::SpatialQuery::nearest_k`].
pub fn nearest_k<T, F>(tree: &T, point: Vec3A, k: usize, mut distance_squared: F) -> Vec<(u32, f32)>
where
    T: BoundingTree + ?Sized,
    F: FnMut(u32) -> f32,
{
    // Capped: `k` is the caller's, and a huge one (`usize::MAX` for "all of them") made
    // `k + 1` overflow, or asked for the memory of k entries up front (the stress suite's
    // non-finite cases). The heap grows past the cap as it needs to.
    let mut best: BinaryHeap<Candidate> =
        BinaryHeap::with_capacity(k.min(NEAREST_PREALLOCATION) + 1);
    let Some(root) = tree.root() else {
        return Vec::new();
    };
    if k == 0 {
        return Vec::new();
    }
    let mut consider = |best: &mut BinaryHeap<Candidate>, p: u32| {
        let d2 = distance_squared(p);
        if d2.is_nan() {
            return;
        }
        let cand = Candidate { d2, id: p };
        if best.len() < k {
            best.push(cand);
        } else if best.peek().is_some_and(|w| cand < *w) {
            best.pop();
            best.push(cand);
        }
    };
    // Best-first: a min-heap of nodes by volume distance (Reverse order through `Candidate`).
    let mut frontier: BinaryHeap<core::cmp::Reverse<Candidate>> = BinaryHeap::new();
    frontier.push(core::cmp::Reverse(Candidate {
        d2: tree.node_bounds(root).distance_squared_to_point(point),
        id: root,
    }));
    while let Some(core::cmp::Reverse(Candidate { d2, id: node })) = frontier.pop() {
        if best.len() == k && best.peek().is_some_and(|w| d2 > w.d2) {
            break;
        }
        let children = tree.node_children(node);
        if children.is_none() || T::INTERIOR_PRIMITIVES {
            tree.node_primitives(node)
                .iter()
                .for_each(|&p| consider(&mut best, p));
        }
        for c in children.into_iter().flatten() {
            let d2 = tree.node_bounds(c).distance_squared_to_point(point);
            frontier.push(core::cmp::Reverse(Candidate { d2, id: c }));
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

/// Implements [`super::RayWalk`] and [`super::SpatialQuery`] for a [`BoundingTree`] through
/// the traversals of this module, so every tree answers queries with the same code. The
/// `@queries` form leaves out `RayWalk`, for a tree that walks rays its own way.
#[macro_export]
macro_rules! impl_spatial_query_for_tree {
    ($ty:ty) => {
        $crate::impl_spatial_query_for_tree!(impl[] $ty);
    };
    (impl[$($generics:tt)*] $ty:ty) => {
        impl<$($generics)*> $crate::query::RayWalk for $ty {
            fn walk_ray<V>(&self, ray: &mut $crate::Ray, visit: V)
            where
                V: FnMut(u32, &mut $crate::Ray) -> core::ops::ControlFlow<()>,
            {
                $crate::query::walks::visit_ray_front_to_back(self, ray, visit)
            }
        }
        $crate::impl_spatial_query_for_tree!(@queries impl[$($generics)*] $ty);
    };
    (@queries $ty:ty) => {
        $crate::impl_spatial_query_for_tree!(@queries impl[] $ty);
    };
    (@queries impl[$($generics:tt)*] $ty:ty) => {
        impl<$($generics)*> $crate::SpatialQuery for $ty {
            fn for_each_overlapping_aabb<F>(&self, aabb: &$crate::Aabb, visit: F)
            where
                F: FnMut(u32) -> core::ops::ControlFlow<()>,
            {
                $crate::query::walks::for_each_overlapping_aabb(self, aabb, visit)
            }
            fn for_each_overlapping_sphere<F>(&self, sphere: &$crate::Sphere, visit: F)
            where
                F: FnMut(u32) -> core::ops::ControlFlow<()>,
            {
                $crate::query::walks::for_each_overlapping_sphere(self, sphere, visit)
            }
            fn for_each_containing_point<F>(&self, point: glam::Vec3A, visit: F)
            where
                F: FnMut(u32) -> core::ops::ControlFlow<()>,
            {
                $crate::query::walks::for_each_containing_point(self, point, visit)
            }
            fn for_each_in_frustum<F>(&self, frustum: &$crate::Frustum, visit: F)
            where
                F: FnMut(u32, $crate::Containment),
            {
                $crate::query::walks::for_each_in_frustum(self, frustum, visit)
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
                $crate::query::walks::nearest_k(self, point, k, distance_squared)
            }
        }
    };
}
