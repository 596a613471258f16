//! The BVH with spheres as node bounds: the textbook's other bounding volume.

use super::Bvh;
use crate::query::BoundingTree;
use crate::{Aabb, Sphere};
use glam::Vec3A;

/// A binary BVH whose nodes are bounded by spheres instead of boxes.
///
/// It shares the topology of a [`Bvh`] (so the split choices are the box tree's) and replaces
/// each node box by a sphere: the smaller of the sphere around the node's box and the merge of
/// its children's spheres. Spheres are rotation-invariant and cheap to test against a frustum
/// (one dot product per plane), but enclose boxes loosely: rays and views cost more than in the
/// box tree (BENCHMARKS.md, Shared walks).
///
/// A primitive whose box has an infinite bound (or one so large that its circumscribed
/// radius overflows) is held, as the box tree holds it, under spheres of infinite radius:
/// queries still offer it to the exact test, and its finite siblings stay reachable.
///
/// ```
/// use spatial_accel::{Aabb, BuildConfig, Bvh, Ray, SpatialQuery};
/// use spatial_accel::bvh::SphereBvh;
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
            // `merge` passes over invalid spheres (a primitive the build left out has none),
            // and `from_aabb` gives a box with an infinite bound an infinite radius rather
            // than the NaN centre of `(-inf + inf) / 2`, which emptied whole subtrees.
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
            spheres[i] = grown_for_rounding(match merged {
                Some(m)
                    if m.is_valid() && (m.radius < around_box.radius || !around_box.is_valid()) =>
                {
                    m
                }
                _ => around_box,
            });
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
}

/// The sphere with its radius grown by a few ulps of its size and place.
///
/// Why: a merged sphere's centre is rounded, and so is a box's circumscribed radius; without
/// the slack a point at the edge of a child (a zero-size box, a corner) can test outside its
/// ancestors by an ulp, and a walk pruned on them misses it. The conformance suite found such
/// a point box that a containment query lost.
fn grown_for_rounding(sphere: Sphere) -> Sphere {
    if !sphere.is_valid() {
        return sphere;
    }
    // Each term apart: their sum overflows for spheres near the end of the float range.
    let slack = 8.0 * f32::EPSILON;
    let grown = sphere.radius + slack * sphere.center.abs().max_element() + slack * sphere.radius;
    Sphere::new(sphere.center, grown)
}

impl BoundingTree for SphereBvh {
    type Volume = Sphere;
    type Children<'a>
        = [u32; 2]
    where
        Self: 'a;

    #[inline]
    fn root(&self) -> Option<u32> {
        (!self.spheres.is_empty()).then_some(0)
    }

    #[inline]
    fn node_bounds(&self, node: u32) -> Sphere {
        self.spheres[node as usize]
    }

    #[inline]
    fn node_children(&self, node: u32) -> Option<[u32; 2]> {
        let first = self.first[node as usize];
        (self.count[node as usize] == 0).then_some([first, first + 1])
    }

    #[inline]
    fn node_primitives(&self, node: u32) -> &[u32] {
        match self.count[node as usize] as usize {
            0 => &[],
            count => {
                let first = self.first[node as usize] as usize;
                &self.primitive_indices[first..first + count]
            }
        }
    }
}

crate::impl_spatial_query_for_tree!(SphereBvh);
