//! The BVH with spheres as node bounds: the textbook's other bounding volume.

use super::Bvh;
use crate::query::RayWalk;
use crate::query::TraversalStack;
use crate::query::views::{ViewClassification, ViewMasks};
use crate::{Aabb, Containment, Frustum, Ray, SpatialQuery, Sphere};
use core::ops::ControlFlow;
use glam::Vec3A;

/// A binary BVH whose nodes are bounded by spheres instead of boxes.
///
/// It shares the topology of a [`Bvh`] (so the split choices are the box tree's) and replaces
/// each node box by a sphere: the smaller of the sphere around the node's box and the merge of
/// its children's spheres. Spheres are rotation-invariant and cheap to test against a frustum
/// (one dot product per plane), but enclose boxes loosely; `BENCHMARKS.md` compares the two on
/// rays and culling.
///
/// ```
/// use accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
/// use accel::bvh::SphereBvh;
/// use glam::Vec3A;
/// let boxes: Vec<Aabb> = (0..64).map(|i| Aabb::new(Vec3A::splat(i as f32), Vec3A::splat(i as f32 + 0.5))).collect();
/// let tree = SphereBvh::from_bvh(&Bvh::build(&boxes, &BuildConfig::default()), &boxes);
/// let ray = Ray::new(Vec3A::splat(-1.0), Vec3A::ONE);
/// assert_eq!(tree.cast_ray(&ray, |i, r| r.intersect_aabb(&boxes[i as usize])).unwrap().primitive, 0);
/// ```
#[derive(Clone, Debug, Default)]
pub struct SphereBvh {
    spheres: Vec<Sphere>,
    /// Interior: index of the left child (right = left + 1); leaf: first primitive slot.
    first: Vec<u32>,
    /// Primitive count; 0 for interior nodes.
    count: Vec<u32>,
    primitive_indices: Vec<u32>,
}

impl SphereBvh {
    /// Takes the topology of `bvh` and bounds each node by a sphere, given the primitive boxes
    /// the tree was built from.
    pub fn from_bvh(bvh: &Bvh, bounds: &[Aabb]) -> Self {
        let n = bvh.nodes.len();
        let mut spheres = vec![Sphere::new(Vec3A::ZERO, -1.0); n];
        // Children follow parents, so a reverse sweep sees children first.
        for i in (0..n).rev() {
            let node = bvh.nodes[i];
            let around_box = Sphere::from_aabb(&node.aabb());
            let merged = if node.is_leaf() {
                let first = node.first as usize;
                bvh.primitive_indices[first..first + node.count as usize]
                    .iter()
                    .map(|&p| Sphere::from_aabb(&bounds[p as usize]))
                    .reduce(|a, b| a.merge(&b))
            } else {
                let l = node.first as usize;
                Some(spheres[l].merge(&spheres[l + 1]))
            };
            spheres[i] = match merged {
                Some(m) if m.is_valid() && m.radius < around_box.radius => m,
                _ => around_box,
            };
        }
        Self {
            spheres,
            first: bvh.nodes.iter().map(|n| n.first).collect(),
            count: bvh.nodes.iter().map(|n| n.count).collect(),
            primitive_indices: bvh.primitive_indices.clone(),
        }
    }

    /// The node spheres; node 0 is the root.
    pub fn spheres(&self) -> &[Sphere] {
        &self.spheres
    }

    /// Memory held, in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.spheres.len() * (core::mem::size_of::<Sphere>() + 8) + self.primitive_indices.len() * 4
    }

    fn leaf(&self, node: usize) -> Option<&[u32]> {
        let c = self.count[node] as usize;
        (c > 0).then(|| {
            &self.primitive_indices[self.first[node] as usize..self.first[node] as usize + c]
        })
    }

    /// Depth-first walk: `enter(sphere)` says whether to descend.
    fn walk<P, F>(&self, mut enter: P, mut visit: F)
    where
        P: FnMut(&Sphere) -> bool,
        F: FnMut(u32) -> ControlFlow<()>,
    {
        if self.spheres.is_empty() {
            return;
        }
        let mut stack: TraversalStack<u32> = TraversalStack::new();
        stack.push(0);
        while let Some(n) = stack.pop() {
            if !enter(&self.spheres[n as usize]) {
                continue;
            }
            match self.leaf(n as usize) {
                Some(prims) => {
                    for &p in prims {
                        if visit(p).is_break() {
                            return;
                        }
                    }
                }
                None => {
                    stack.push(self.first[n as usize] + 1);
                    stack.push(self.first[n as usize]);
                }
            }
        }
    }
}

impl RayWalk for SphereBvh {
    /// Nearest-first ray walk with pruning by the ray's (shrinking) range.
    fn walk_ray<F>(&self, ray: &mut Ray, mut visit: F)
    where
        F: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        let Some(t0) = self.spheres.first().and_then(|s| ray.intersect_sphere(s)) else {
            return;
        };
        let mut stack: TraversalStack<(u32, f32)> = TraversalStack::new();
        stack.push((0, t0));
        while let Some((n, t)) = stack.pop() {
            if t > ray.t_max {
                continue;
            }
            if let Some(prims) = self.leaf(n as usize) {
                for &p in prims {
                    if visit(p, ray).is_break() {
                        return;
                    }
                }
                continue;
            }
            let l = self.first[n as usize];
            let tl = ray.intersect_sphere(&self.spheres[l as usize]);
            let tr = ray.intersect_sphere(&self.spheres[l as usize + 1]);
            match (tl, tr) {
                (Some(a), Some(b)) if a <= b => {
                    stack.push((l + 1, b));
                    stack.push((l, a));
                }
                (Some(a), Some(b)) => {
                    stack.push((l, a));
                    stack.push((l + 1, b));
                }
                (Some(a), None) => stack.push((l, a)),
                (None, Some(b)) => stack.push((l + 1, b)),
                (None, None) => {}
            }
        }
    }
}

impl SpatialQuery for SphereBvh {
    fn for_each_overlapping_aabb<F>(&self, aabb: &Aabb, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        self.walk(|s| s.intersects_aabb(aabb), visit);
    }

    fn for_each_overlapping_sphere<F>(&self, sphere: &Sphere, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        self.walk(|s| s.intersects_sphere(sphere), visit);
    }

    fn for_each_containing_point<F>(&self, point: Vec3A, visit: F)
    where
        F: FnMut(u32) -> ControlFlow<()>,
    {
        self.walk(|s| s.contains_point(point), visit);
    }

    fn for_each_in_frustum<F>(&self, frustum: &Frustum, mut visit: F)
    where
        F: FnMut(u32, Containment),
    {
        if self.spheres.is_empty() {
            return;
        }
        let mut stack: TraversalStack<(u32, bool)> = TraversalStack::new();
        stack.push((0, false));
        while let Some((n, accepted)) = stack.pop() {
            let c = if accepted {
                Containment::Inside
            } else {
                frustum.classify_sphere(&self.spheres[n as usize])
            };
            if c == Containment::Outside {
                continue;
            }
            match self.leaf(n as usize) {
                Some(prims) => prims.iter().for_each(|&p| visit(p, c)),
                None => {
                    let inside = c == Containment::Inside;
                    stack.push((self.first[n as usize] + 1, inside));
                    stack.push((self.first[n as usize], inside));
                }
            }
        }
    }

    /// A node's bounds here are the box around its sphere.
    fn for_each_in_views<C, F>(&self, views: u32, mut classify: C, mut visit: F)
    where
        C: FnMut(&Aabb, u32) -> ViewClassification,
        F: FnMut(u32, ViewMasks),
    {
        if self.spheres.is_empty() || views == 0 {
            return;
        }
        let mut stack: TraversalStack<(u32, ViewMasks)> = TraversalStack::new();
        stack.push((0, ViewMasks::undecided(views)));
        while let Some((n, above)) = stack.pop() {
            let c = if above.crossing == 0 {
                // Every view decided an ancestor: nothing left to ask.
                ViewClassification::default()
            } else {
                let sphere = &self.spheres[n as usize];
                let half = Vec3A::splat(sphere.radius);
                classify(
                    &Aabb::from_center_half_extents(sphere.center, half),
                    above.crossing,
                )
            };
            let Some(masks) = above.below(c) else {
                continue;
            };
            match self.leaf(n as usize) {
                Some(prims) => prims.iter().for_each(|&p| visit(p, masks)),
                None => {
                    stack.push((self.first[n as usize] + 1, masks));
                    stack.push((self.first[n as usize], masks));
                }
            }
        }
    }

    fn nearest_k<F>(&self, point: Vec3A, k: usize, mut distance_squared: F) -> Vec<(u32, f32)>
    where
        F: FnMut(u32) -> f32,
    {
        // Small k and simple bounds: a depth-first walk pruned by the k-th best distance.
        let mut best: Vec<(u32, f32)> = Vec::with_capacity(k + 1);
        if k == 0 {
            return best;
        }
        let bound = |s: &Sphere| {
            let d = (s.center.distance(point) - s.radius).max(0.0);
            d * d
        };
        let mut worst = f32::INFINITY;
        let mut stack: TraversalStack<u32> = TraversalStack::new();
        if !self.spheres.is_empty() {
            stack.push(0);
        }
        while let Some(n) = stack.pop() {
            if best.len() == k && bound(&self.spheres[n as usize]) > worst {
                continue;
            }
            match self.leaf(n as usize) {
                Some(prims) => {
                    for &p in prims {
                        let d = distance_squared(p);
                        if d.is_nan() {
                            continue;
                        }
                        let key = |e: &(u32, f32)| (e.1, e.0);
                        let pos =
                            best.partition_point(|e| key(e).0 < d || (key(e).0 == d && e.0 < p));
                        if pos < k {
                            best.insert(pos, (p, d));
                            best.truncate(k);
                            if best.len() == k {
                                worst = best[k - 1].1;
                            }
                        }
                    }
                }
                None => {
                    stack.push(self.first[n as usize] + 1);
                    stack.push(self.first[n as usize]);
                }
            }
        }
        best
    }
}
