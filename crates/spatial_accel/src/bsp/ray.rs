//! Rays and boxes through the tree, answered with the source triangles.

use super::tree::{BspTree, NONE};
use crate::mesh::MeshHit;
use crate::query::{BruteForceMesh, TraversalStack, TriangleQuery};
use crate::{Aabb, Backfaces, Ray, TriangleHit, WatertightRay};
use core::ops::ControlFlow;
use glam::Vec3A;

impl BspTree {
    /// Calls `visit(source)` for the source of every piece in the nodes whose boxes the ray
    /// reaches within the limit `visit` last returned (the near side of each plane first),
    /// and for every degenerate triangle; a source may come once per piece. `Break` stops.
    ///
    /// A reached piece stands for its whole source triangle, which the caller tests: the
    /// watertight test on the source gives brute force's answer to the bit, where a test on
    /// the rounded pieces could let a ray through the seam between two of them. The walk
    /// prunes by the node boxes alone, not by where the ray crosses each plane: a piece may
    /// miss its source's edge by the rounding of a cut, and a hit there would fall on the
    /// wrong side of the crossing; the boxes' margin covers it.
    fn walk_ray<F: FnMut(u32) -> ControlFlow<(), f32>>(&self, ray: &Ray, mut visit: F) {
        let mut limit = ray.t_max;
        for &source in &self.loose {
            match visit(source) {
                ControlFlow::Break(()) => return,
                ControlFlow::Continue(t) => limit = t,
            }
        }
        let Some(root) = self.nodes.first() else {
            return;
        };
        let mut stack: TraversalStack<(u32, f32)> = TraversalStack::new();
        if let Some(t) = ray.intersect_aabb(&root.bounds) {
            stack.push((0, t));
        }
        while let Some((n, entry)) = stack.pop() {
            if entry > limit {
                continue;
            }
            let node = &self.nodes[n as usize];
            for piece in &self.pieces[node.range()] {
                match visit(piece.source) {
                    ControlFlow::Break(()) => return,
                    ControlFlow::Continue(t) => limit = t,
                }
            }
            let origin_in_front = node.plane.signed_distance(ray.origin) >= 0.0;
            let (near, far) = if origin_in_front {
                (node.front, node.back)
            } else {
                (node.back, node.front)
            };
            let ray = ray.with_t_max(limit);
            // The far child first, so the stack pops the near one first.
            for child in [far, near] {
                if child != NONE
                    && let Some(t) = ray.intersect_aabb(&self.nodes[child as usize].bounds)
                {
                    stack.push((child, t));
                }
            }
        }
    }

    /// The watertight test of source triangle `source` (a miss for a non-finite one).
    #[inline]
    fn test_source(
        &self,
        wt: &WatertightRay,
        source: u32,
        backfaces: Backfaces,
    ) -> Option<TriangleHit> {
        let triangle = self.sources[source as usize].as_ref()?;
        wt.intersect(triangle, backfaces)
    }

    fn record(&self, source: u32, hit: TriangleHit) -> Option<MeshHit> {
        let triangle = self.sources[source as usize].as_ref()?;
        Some(BruteForceMesh::record(source, triangle, hit))
    }
}

impl TriangleQuery for BspTree {
    fn triangle_count(&self) -> usize {
        self.sources.len()
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }

    fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<MeshHit> {
        let mut wt = WatertightRay::new(ray);
        let mut best: Option<(u32, TriangleHit)> = None;
        self.walk_ray(ray, |source| {
            // A tie keeps the lower index, as brute force's loop in index order does.
            if let Some(hit) = self.test_source(&wt, source, backfaces)
                && best.is_none_or(|(s, b)| hit.t < b.t || (hit.t == b.t && source < s))
            {
                wt.set_t_max(hit.t);
                best = Some((source, hit));
            }
            ControlFlow::Continue(wt.t_max())
        });
        best.and_then(|(source, hit)| self.record(source, hit))
    }

    fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool {
        let wt = WatertightRay::new(ray);
        let mut found = false;
        self.walk_ray(ray, |source| {
            if self.test_source(&wt, source, backfaces).is_some() {
                found = true;
                return ControlFlow::Break(());
            }
            ControlFlow::Continue(wt.t_max())
        });
        found
    }

    fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<MeshHit>) {
        let wt = WatertightRay::new(ray);
        let mut hits: Vec<(u32, TriangleHit)> = Vec::new();
        self.walk_ray(ray, |source| {
            if let Some(hit) = self.test_source(&wt, source, backfaces) {
                hits.push((source, hit));
            }
            ControlFlow::Continue(wt.t_max())
        });
        hits.sort_unstable_by(|a, b| a.1.t.total_cmp(&b.1.t).then(a.0.cmp(&b.0)));
        // A source reached through several pieces gave the same hit each time.
        hits.dedup_by_key(|h| h.0);
        out.extend(hits.into_iter().filter_map(|(s, hit)| self.record(s, hit)));
    }

    fn for_each_triangle_overlapping<F: FnMut(u32)>(&self, aabb: &Aabb, mut visit: F) {
        let overlaps = |source: u32| {
            self.sources[source as usize]
                .as_ref()
                .is_some_and(|t| t.aabb().intersects_aabb(aabb))
        };
        let mut found: Vec<u32> = self
            .loose
            .iter()
            .copied()
            .filter(|&s| overlaps(s))
            .collect();
        // A piece's box grown by the margin the node boxes have: a piece may miss its
        // source's edge by a cut's rounding.
        let margin = Vec3A::splat(self.tolerance as f32);
        let mut stack: TraversalStack<u32> = TraversalStack::new();
        if self
            .nodes
            .first()
            .is_some_and(|n| n.bounds.intersects_aabb(aabb))
        {
            stack.push(0);
        }
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            for piece in &self.pieces[node.range()] {
                let piece_box = Aabb::from_points(piece.vertices).expanded(margin);
                if piece_box.intersects_aabb(aabb) && overlaps(piece.source) {
                    found.push(piece.source);
                }
            }
            for child in [node.front, node.back] {
                if child != NONE && self.nodes[child as usize].bounds.intersects_aabb(aabb) {
                    stack.push(child);
                }
            }
        }
        found.sort_unstable();
        found.dedup();
        found.into_iter().for_each(&mut visit);
    }
}
