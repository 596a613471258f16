//! What the shared walks ask of a node's bounding volume.

use crate::{Aabb, Containment, Frustum, Ray, Sphere};
use glam::Vec3A;

/// A bounding volume that a tree's nodes carry: a box for the BVHs (and the coming octree),
/// a sphere for [`SphereBvh`](crate::bvh::SphereBvh).
///
/// Every test is conservative in the same direction: it may say "reached" for a volume the
/// query only grazes, never "missed" for one it reaches, so a walk that prunes on it loses
/// nothing.
pub trait NodeVolume: Copy {
    /// Where the ray enters the volume within its range, or `None` when it misses.
    fn ray_entry(&self, ray: &Ray) -> Option<f32>;

    /// Whether the volume overlaps the box.
    fn overlaps_aabb(&self, aabb: &Aabb) -> bool;

    /// Whether the volume overlaps the sphere.
    fn overlaps_sphere(&self, sphere: &Sphere) -> bool;

    /// Whether the volume contains the point.
    fn contains_point(&self, point: Vec3A) -> bool;

    /// How the volume stands with the frustum.
    fn classify_frustum(&self, frustum: &Frustum) -> Containment;

    /// The squared distance from the point to the volume (zero inside): a lower bound on the
    /// distance of anything below the node.
    fn distance_squared_to_point(&self, point: Vec3A) -> f32;

    /// A box around the volume, for tests written for boxes only (the view classifiers of
    /// [`SpatialQuery::for_each_in_views`](super::SpatialQuery::for_each_in_views)).
    fn bounding_box(&self) -> Aabb;
}

impl NodeVolume for Aabb {
    #[inline]
    fn ray_entry(&self, ray: &Ray) -> Option<f32> {
        ray.intersect_aabb(self)
    }

    #[inline]
    fn overlaps_aabb(&self, aabb: &Aabb) -> bool {
        self.intersects_aabb(aabb)
    }

    #[inline]
    fn overlaps_sphere(&self, sphere: &Sphere) -> bool {
        sphere.intersects_aabb(self)
    }

    #[inline]
    fn contains_point(&self, point: Vec3A) -> bool {
        Aabb::contains_point(self, point)
    }

    #[inline]
    fn classify_frustum(&self, frustum: &Frustum) -> Containment {
        frustum.classify_aabb(self)
    }

    #[inline]
    fn distance_squared_to_point(&self, point: Vec3A) -> f32 {
        Aabb::distance_squared_to_point(self, point)
    }

    #[inline]
    fn bounding_box(&self) -> Aabb {
        *self
    }
}

impl NodeVolume for Sphere {
    #[inline]
    fn ray_entry(&self, ray: &Ray) -> Option<f32> {
        ray.intersect_sphere(self)
    }

    #[inline]
    fn overlaps_aabb(&self, aabb: &Aabb) -> bool {
        self.intersects_aabb(aabb)
    }

    #[inline]
    fn overlaps_sphere(&self, sphere: &Sphere) -> bool {
        self.intersects_sphere(sphere)
    }

    #[inline]
    fn contains_point(&self, point: Vec3A) -> bool {
        Sphere::contains_point(self, point)
    }

    #[inline]
    fn classify_frustum(&self, frustum: &Frustum) -> Containment {
        frustum.classify_sphere(self)
    }

    #[inline]
    fn distance_squared_to_point(&self, point: Vec3A) -> f32 {
        let d = (self.center.distance(point) - self.radius).max(0.0);
        d * d
    }

    #[inline]
    fn bounding_box(&self) -> Aabb {
        Aabb::from_center_half_extents(self.center, Vec3A::splat(self.radius))
    }
}
