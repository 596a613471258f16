//! The interface of a structure over one mesh's triangles: exact ray hits and overlap.

use crate::mesh::MeshHit;
use crate::{Aabb, Backfaces, Ray};

/// Exact queries on the triangles of one mesh, in the mesh's own space.
///
/// [`MeshBvh`](crate::mesh::MeshBvh), [`KdTree`](crate::kdtree::KdTree) and
/// [`BspTree`](crate::bsp::BspTree) (which tests the whole source of each cut piece a ray
/// reaches) implement it, as does [`BruteForceMesh`](super::BruteForceMesh), the oracle they
/// are checked against. Unlike [`SpatialQuery`](super::SpatialQuery), whose callbacks decide,
/// these answers are final: the structure runs the watertight triangle test itself (Woop,
/// Benthin and Wald 2013), so every implementation gives the same hits, to the bit.
///
/// ```
/// use spatial_accel::query::{BruteForceMesh, TriangleQuery};
/// use spatial_accel::mesh::MeshBvh;
/// use spatial_accel::{Backfaces, Ray};
/// use glam::{Vec3, Vec3A};
/// let vertices = [Vec3::ZERO, Vec3::X, Vec3::Y];
/// let meshes: [&dyn Fn(&Ray) -> Option<f32>; 2] = [
///     &|r| MeshBvh::new(&vertices, &[0, 1, 2]).unwrap().cast_ray(r, Backfaces::Include).map(|h| h.t),
///     &|r| BruteForceMesh::new(&vertices, &[0, 1, 2]).unwrap().cast_ray(r, Backfaces::Include).map(|h| h.t),
/// ];
/// let ray = Ray::new(Vec3A::new(0.25, 0.25, 1.0), Vec3A::NEG_Z);
/// assert!(meshes.iter().all(|cast| cast(&ray) == Some(1.0)));
/// ```
pub trait TriangleQuery {
    /// Number of triangles the structure was built over (those with non-finite corners
    /// included; they are never hit).
    fn triangle_count(&self) -> usize;

    /// The box around every finite triangle.
    fn bounds(&self) -> Aabb;

    /// The closest hit along the ray, or `None`.
    fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<MeshHit>;

    /// True when anything blocks the ray (shadow rays: stops at the first hit found).
    fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool;

    /// Every hit along the ray, nearest first (ties by triangle index), each triangle once,
    /// appended to `out`.
    fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<MeshHit>);

    /// Calls `visit(triangle index)` once for each triangle that may touch `aabb`: every
    /// triangle that does, and only triangles whose box overlaps `aabb`.
    fn for_each_triangle_overlapping<F: FnMut(u32)>(&self, aabb: &Aabb, visit: F);
}
