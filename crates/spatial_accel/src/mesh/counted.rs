//! Closest-hit walks that count their work: the nodes a ray visits, the triangles it tests
//! and the depth of the leaf its hit came from, for traversal heat maps.
//!
//! A separate walk rather than counters in [`MeshBvh::cast_ray`]: the fast walk is tuned
//! instruction by instruction (`bvh/wide/ray.rs`), and a counter carried through it is a
//! live register and a store per node on every ray of every query, for a view that is on
//! only while someone looks at it. This walk is a plain ordered traversal (scalar slab test
//! per slot, leaves nearest first, interior children pushed farthest first), slower but
//! with the same answers: every box test is conservative and the leaf tests are the fast
//! walk's, so the closest distance is the same to the bit.

use super::{InstanceHit, InstancedScene, MeshBvh, MeshHit};
use crate::bvh::wide::{WideBvh, WideLayout};
use crate::query::TraversalStack;
use crate::{Backfaces, Ray, WatertightRay};
use core::ops::AddAssign;

/// The work one ray's walk did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TraversalCost {
    /// Wide nodes visited (every level of a two-level scene counted).
    pub nodes: u32,
    /// Triangles tested (the used lanes of every packet tested).
    pub triangles: u32,
}

impl AddAssign for TraversalCost {
    fn add_assign(&mut self, other: Self) {
        self.nodes = self.nodes.saturating_add(other.nodes);
        self.triangles = self.triangles.saturating_add(other.triangles);
    }
}

/// A closest hit with what finding it cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CountedHit<H> {
    /// The closest hit, as the uncounted walk finds it (the same distance, to the bit).
    pub hit: Option<H>,
    /// The walk's work, hit or miss.
    pub cost: TraversalCost,
    /// Nodes from the root to the node holding the hit's leaf, the root counting 1 (in a
    /// two-level scene, the top level's path plus the mesh's); `None` on a miss.
    pub leaf_depth: Option<u32>,
}

/// Walks `tree` nearest first, calling `visit(primitive, ray, depth)` for each primitive of
/// each leaf the ray reaches within its range; `visit` returns the distance of a hit that is
/// closer than any before it, which shrinks the range. `depth` is that of the node holding
/// the leaf (root 1). Returns the nodes visited.
fn walk_counted<const N: usize, L: WideLayout<N>>(
    tree: &WideBvh<N, L>,
    ray: &mut Ray,
    mut visit: impl FnMut(u32, &Ray, u32) -> Option<f32>,
) -> u32 {
    let nodes = tree.nodes();
    if nodes.is_empty() || ray.is_degenerate() {
        return 0;
    }
    let mut visited = 0u32;
    let mut stack: TraversalStack<(u32, f32, u32)> = TraversalStack::new();
    stack.push((0, ray.t_min, 1));
    while let Some((index, entry, depth)) = stack.pop() {
        if entry > ray.t_max {
            continue;
        }
        let node = &nodes[index as usize];
        visited = visited.saturating_add(1);
        let mut order = [(0.0f32, 0usize); N];
        let mut count = 0;
        for slot in (0..N).filter(|&s| node.is_used(s)) {
            if let Some(t) = ray.intersect_aabb(&node.child_aabb(slot)) {
                let mut j = count;
                while j > 0 && order[j - 1].0 > t {
                    order[j] = order[j - 1];
                    j -= 1;
                }
                order[j] = (t, slot);
                count += 1;
            }
        }
        let order = &order[..count];
        for &(t, slot) in order.iter().filter(|(_, s)| node.is_leaf(*s)) {
            if t > ray.t_max {
                break;
            }
            let mut leaf = |p: u32| {
                if let Some(hit_t) = visit(p, ray, depth) {
                    ray.t_max = ray.t_max.min(hit_t);
                }
            };
            if let Some(p) = node.inline_primitive(slot) {
                leaf(p);
            } else {
                let (first, n) = (node.child(slot) as usize, node.count(slot) as usize);
                for &p in tree
                    .primitive_indices()
                    .get(first..first + n)
                    .unwrap_or(&[])
                {
                    leaf(p);
                }
            }
        }
        // Farthest first, so that the nearest child is popped next.
        for &(t, slot) in order.iter().rev().filter(|(_, s)| !node.is_leaf(*s)) {
            if t <= ray.t_max {
                stack.push((node.child(slot), t, depth + 1));
            }
        }
    }
    visited
}

impl MeshBvh {
    /// [`MeshBvh::cast_ray`] with its work counted (see [`CountedHit`]): the same closest
    /// distance, by a slower walk kept apart from the fast one.
    ///
    /// ```
    /// use spatial_accel::{Backfaces, Ray};
    /// use spatial_accel::mesh::MeshBvh;
    /// use glam::{Vec3, Vec3A};
    /// let vertices = [Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(1., 1., 0.), Vec3::new(0., 1., 0.)];
    /// let mesh = MeshBvh::new(&vertices, &[0, 1, 2, 0, 2, 3]).unwrap();
    /// let ray = Ray::new(Vec3A::new(0.25, 0.75, 5.0), Vec3A::NEG_Z);
    /// let counted = mesh.cast_ray_counted(&ray, Backfaces::Cull);
    /// assert_eq!(counted.hit, mesh.cast_ray(&ray, Backfaces::Cull));
    /// assert!(counted.cost.nodes >= 1 && counted.cost.triangles >= 1);
    /// assert_eq!(counted.leaf_depth, Some(1));
    /// ```
    pub fn cast_ray_counted(&self, ray: &Ray, backfaces: Backfaces) -> CountedHit<MeshHit> {
        let mut wt = WatertightRay::new(ray);
        let mut best: Option<(u32, usize, crate::TriangleHit, u32)> = None;
        let mut triangles = 0u32;
        let mut walked = *ray;
        let nodes = walk_counted(self.tree(), &mut walked, |packet, r, depth| {
            wt.set_t_max(r.t_max);
            triangles = triangles.saturating_add(self.packets.used_lanes(packet).count() as u32);
            let (lane, h) = wt
                .intersect4(self.packets.corners4(packet), backfaces)
                .closest()?;
            // The fast walk's rule: a later hit replaces the best only when strictly closer.
            if best.is_some_and(|(_, _, b, _)| h.t >= b.t) {
                return None;
            }
            best = Some((packet, lane, h, depth));
            Some(h.t)
        });
        CountedHit {
            hit: best.map(|(packet, lane, h, _)| self.hit_record(packet, lane, h)),
            cost: TraversalCost { nodes, triangles },
            leaf_depth: best.map(|(.., depth)| depth),
        }
    }
}

impl InstancedScene {
    /// [`InstancedScene::cast_ray`] with its work counted over both levels (see
    /// [`CountedHit`]): the same closest distance and instance, by a slower walk.
    pub fn cast_ray_counted(&self, ray: &Ray, backfaces: Backfaces) -> CountedHit<InstanceHit> {
        let mut cost = TraversalCost::default();
        let mut best: Option<(u32, MeshHit, u32)> = None;
        let mut walked = *ray;
        let top_nodes = walk_counted(&self.top, &mut walked, |i, r, top_depth| {
            let inst = self.instance(i);
            let counted = inst
                .mesh
                .cast_ray_counted(&r.transformed(&inst.local_from_world), backfaces);
            cost += counted.cost;
            let h = counted.hit?;
            if best.is_some_and(|(_, b, _)| h.t >= b.t) {
                return None;
            }
            best = Some((i, h, top_depth + counted.leaf_depth.unwrap_or(0)));
            Some(h.t)
        });
        cost.nodes = cost.nodes.saturating_add(top_nodes);
        CountedHit {
            hit: best.map(|(i, h, _)| self.to_world(i, h)),
            cost,
            leaf_depth: best.map(|(.., depth)| depth),
        }
    }
}
