//! The exact queries: closest, any and all ray hits with the watertight triangle test, and
//! the triangles near a box; [`TriangleQuery`] on top of them.

use super::KdTree;
use super::node::KdNodeKind;
use crate::mesh::MeshHit;
use crate::query::{TraversalStack, TriangleQuery};
use crate::{Aabb, Backfaces, Ray, TriangleHit, WatertightRay};
use core::ops::ControlFlow;

impl KdTree {
    /// The hit record of reference `r`.
    fn record(&self, r: usize, hit: TriangleHit) -> MeshHit {
        let [a, b, c] = self.corners[r];
        MeshHit {
            t: hit.t,
            triangle: self.references[r],
            barycentrics: hit.barycentrics(),
            geometric_normal: (b - a).cross(c - a).normalize_or_zero(),
            front_face: hit.front_face,
        }
    }

    /// The closest hit along the ray, or `None`: the same `t`, to the bit, as testing every
    /// triangle ([`crate::query::BruteForceMesh`]), since it runs the same watertight test.
    pub fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<MeshHit> {
        let mut wt = WatertightRay::new(ray);
        let mut best: Option<(usize, TriangleHit)> = None;
        self.walk_ray(ray, |run| {
            for r in run {
                let [a, b, c] = self.corners[r];
                // Ties go to the lower index, as in a loop over every triangle in order: so
                // the record is the brute-force one, to the bit, even where several
                // triangles meet the ray at one distance (a shared edge, or `0.0` and `-0.0`
                // at the origin). A triangle met again in a later leaf gives the same bits
                // and changes nothing.
                if let Some(h) = wt.intersect_vertices(a, b, c, backfaces)
                    && best.is_none_or(|(r_best, b)| {
                        h.t < b.t || (h.t == b.t && self.references[r] < self.references[r_best])
                    })
                {
                    wt.set_t_max(h.t);
                    best = Some((r, h));
                }
            }
            ControlFlow::Continue(wt.t_max())
        });
        best.map(|(r, h)| self.record(r, h))
    }

    /// True when anything blocks the ray (shadow rays: stops at the first hit found).
    pub fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool {
        let wt = WatertightRay::new(ray);
        let mut found = false;
        self.walk_ray(ray, |run| {
            for r in run {
                let [a, b, c] = self.corners[r];
                if wt.intersect_vertices(a, b, c, backfaces).is_some() {
                    found = true;
                    return ControlFlow::Break(());
                }
            }
            ControlFlow::Continue(ray.t_max)
        });
        found
    }

    /// Every hit along the ray, nearest first (ties by triangle index), each triangle once
    /// (one that crosses several leaves the ray visits is hit in each, with the same bits),
    /// appended to `out`.
    pub fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<MeshHit>) {
        let wt = WatertightRay::new(ray);
        let start = out.len();
        self.walk_ray(ray, |run| {
            for r in run {
                let [a, b, c] = self.corners[r];
                if let Some(h) = wt.intersect_vertices(a, b, c, backfaces) {
                    out.push(self.record(r, h));
                }
            }
            ControlFlow::Continue(ray.t_max)
        });
        out[start..].sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
        // Copies of one triangle's hit have the same `t` and index, so they sit together.
        let mut kept = start;
        for i in start..out.len() {
            if kept == start || out[kept - 1].triangle != out[i].triangle {
                out.swap(kept, i);
                kept += 1;
            }
        }
        out.truncate(kept);
    }

    /// Calls `visit(triangle index)` once for each triangle whose box overlaps `aabb` and
    /// that sits in a leaf whose region does: every triangle that touches `aabb` (the point
    /// where it does lies in a leaf that holds it), and only those whose box overlaps it. A
    /// NaN box visits nothing.
    pub fn for_each_triangle_overlapping(&self, aabb: &Aabb, visit: impl FnMut(u32)) {
        let mut found = Vec::new();
        let mut stack: TraversalStack<u32> = TraversalStack::new();
        if self.bounds.intersects_aabb(aabb) {
            stack.push(0);
        }
        while let Some(node) = stack.pop() {
            match self.nodes[node as usize].kind() {
                KdNodeKind::Interior {
                    axis,
                    position,
                    above,
                } => {
                    if aabb.max[axis] >= position {
                        stack.push(above);
                    }
                    if aabb.min[axis] <= position {
                        stack.push(node + 1);
                    }
                }
                KdNodeKind::Leaf { first, count } => {
                    for r in first as usize..(first + count) as usize {
                        if Aabb::from_points(self.corners[r]).intersects_aabb(aabb) {
                            found.push(self.references[r]);
                        }
                    }
                }
            }
        }
        // A triangle in several leaves the box reaches: visited once.
        found.sort_unstable();
        found.dedup();
        found.into_iter().for_each(visit);
    }
}

impl TriangleQuery for KdTree {
    fn triangle_count(&self) -> usize {
        KdTree::triangle_count(self)
    }

    fn bounds(&self) -> Aabb {
        KdTree::bounds(self)
    }

    fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<MeshHit> {
        KdTree::cast_ray(self, ray, backfaces)
    }

    fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool {
        KdTree::cast_ray_any(self, ray, backfaces)
    }

    fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<MeshHit>) {
        KdTree::cast_ray_all(self, ray, backfaces, out)
    }

    fn for_each_triangle_overlapping<F: FnMut(u32)>(&self, aabb: &Aabb, visit: F) {
        KdTree::for_each_triangle_overlapping(self, aabb, visit)
    }
}
