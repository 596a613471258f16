//! What the tracer asks of a scene, the hit record it gets back, and the implementation over
//! the crate's two-level [`InstancedScene`].

use crate::mesh::{CountedHit, InstancedScene, MeshBvh, MeshError, MeshHit};
use crate::{Backfaces, Ray};
use glam::{Affine3A, Mat3A, Vec2, Vec3, Vec3A};
use std::sync::Arc;

/// A surface point a ray reached, with what shading needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceHit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// The object hit (an instance index, or an entity id in an engine's scene).
    pub object: u32,
    /// The triangle hit, in its mesh's index buffer.
    pub triangle: u32,
    /// The hit point in world space.
    pub position: Vec3A,
    /// Unit world-space normal of the triangle's plane, on the side the ray came from.
    pub geometric_normal: Vec3A,
    /// Unit world-space interpolated vertex normal (the geometric normal where the mesh has
    /// none), on the same side as `geometric_normal`.
    pub shading_normal: Vec3A,
    /// Interpolated texture coordinate, where the mesh has them.
    pub uv: Option<Vec2>,
    /// Index of the material to shade with.
    pub material: u32,
}

/// The scene interface of the preview tracer: closest hits and occlusion, in world space.
///
/// `Sync`, because one scene serves every thread tracing its own rows. The tracer never
/// mutates the scene; an engine rebuilds or updates it between frames.
pub trait PreviewScene: Sync {
    /// The nearest surface along the ray within its range, or `None` (also for a degenerate
    /// ray).
    fn closest(&self, ray: &Ray) -> Option<SurfaceHit>;

    /// True when anything blocks the ray before `t_max` (shadow and occlusion rays: any hit
    /// will do).
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool;

    /// [`closest`](Self::closest) with the work of finding it: the traversal-cost and
    /// leaf-depth views call this, every other view `closest`. A miss has a cost too, which
    /// is why the cost sits beside the hit rather than in it. A structure without nodes (a
    /// brute-force list) reports only its triangle tests and no leaf depth.
    fn closest_counted(&self, ray: &Ray) -> CountedHit<SurfaceHit>;
}

/// The vertex data of one mesh that shading reads: positions and indices (for precise hit
/// points), and optionally normals and texture coordinates, all indexed as the mesh BVH
/// was built (triangle `i` uses `indices[3i..3i + 3]`).
///
/// Attribute arrays of the wrong length, or indices out of range, are not an error: the
/// hit falls back to the geometric normal, the ray's point and no texture coordinate.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshSurface {
    /// Vertex positions, in the mesh's space.
    pub positions: Vec<Vec3>,
    /// Three vertex indices per triangle.
    pub indices: Vec<u32>,
    /// Per-vertex normals, in the mesh's space.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates.
    pub uvs: Option<Vec<Vec2>>,
}

impl MeshSurface {
    /// A surface with positions and indices only.
    pub fn new(positions: Vec<Vec3>, indices: Vec<u32>) -> Self {
        Self {
            positions,
            indices,
            normals: None,
            uvs: None,
        }
    }

    /// The surface with vertex normals made from its triangles: each vertex the sum of its
    /// triangles' unnormalised normals, so larger triangles weigh more (for meshes that come
    /// without normals; a vertex no triangle uses gets zero, which shading skips).
    pub fn with_smooth_normals(mut self) -> Self {
        let mut normals = vec![Vec3::ZERO; self.positions.len()];
        for tri in 0..(self.indices.len() / 3) as u32 {
            let Some(c) = self.corners(tri) else { continue };
            let [a, b, d] = c.map(|i| self.positions[i as usize]);
            let n = (b - a).cross(d - a);
            if n.is_finite() {
                c.iter().for_each(|&i| normals[i as usize] += n);
            }
        }
        normals.iter_mut().for_each(|n| *n = n.normalize_or_zero());
        self.normals = Some(normals);
        self
    }

    /// The mesh BVH over these triangles ([`MeshBvh::new`]).
    pub fn build_bvh(&self) -> Result<MeshBvh, MeshError> {
        MeshBvh::new(&self.positions, &self.indices)
    }

    /// The vertex indices of `triangle`, if they all name vertices.
    fn corners(&self, triangle: u32) -> Option<[u32; 3]> {
        let start = 3 * triangle as usize;
        let tri = self.indices.get(start..start + 3)?;
        let ids = [tri[0], tri[1], tri[2]];
        ids.iter()
            .all(|&i| (i as usize) < self.positions.len())
            .then_some(ids)
    }

    /// The shading record of `hit`, a hit on this mesh by the world ray `ray`, whose
    /// `geometric_normal` is already in world space and unit length (as
    /// [`InstancedScene::cast_ray`] gives it). `world_from_local` places the mesh and
    /// `normal_to_world` is the inverse-transpose of its linear part.
    ///
    /// The point is interpolated from the corners rather than taken as `ray.at(t)`: its
    /// error is then relative to the point's own magnitude, which is what the shadow-ray
    /// offset ([`offset_ray_origin`](super::offset_ray_origin)) is sized for, while the
    /// ray's point also carries the rounding of `t` times the ray's length (Wächter and
    /// Binder 2019, section 6.2).
    pub fn surface_hit(
        &self,
        ray: &Ray,
        object: u32,
        material: u32,
        world_from_local: &Affine3A,
        normal_to_world: &Mat3A,
        hit: &MeshHit,
    ) -> SurfaceHit {
        let faced = |n: Vec3A| if n.dot(ray.direction) > 0.0 { -n } else { n };
        let geometric_normal = faced(hit.geometric_normal);
        let corners = self.corners(hit.triangle);
        let position = corners
            .map(|c| world_from_local.transform_point3a(hit.interpolate(c, &self.positions).into()))
            .filter(|p| p.is_finite())
            .unwrap_or_else(|| ray.at(hit.t));
        let shading_normal = interpolated(hit, corners, &self.normals)
            .and_then(|n: Vec3| (*normal_to_world * Vec3A::from(n)).try_normalize())
            // Onto the side the ray came from, with the geometric normal: a vertex normal
            // may disagree with the winding, and shading must light the side that is seen.
            .map(|n| if n.dot(geometric_normal) < 0.0 { -n } else { n })
            .unwrap_or(geometric_normal);
        SurfaceHit {
            t: hit.t,
            object,
            triangle: hit.triangle,
            position,
            geometric_normal,
            shading_normal,
            uv: interpolated(hit, corners, &self.uvs),
            material,
        }
    }
}

/// A vertex attribute interpolated at the hit; `None` without the attribute, or where it
/// does not cover the triangle's corners.
fn interpolated<T>(hit: &MeshHit, corners: Option<[u32; 3]>, values: &Option<Vec<T>>) -> Option<T>
where
    T: Copy + core::ops::Mul<f32, Output = T> + core::ops::Add<Output = T>,
{
    let (values, corners) = (values.as_ref()?, corners?);
    corners
        .iter()
        .all(|&i| (i as usize) < values.len())
        .then(|| hit.interpolate(corners, values))
}

/// One placed mesh of an [`InstancedPreviewScene`] (or of the brute-force reference).
#[derive(Clone, Debug)]
pub struct PreviewInstance {
    /// The mesh's BVH, built over `surface`'s positions and indices.
    pub mesh: Arc<MeshBvh>,
    /// The mesh's vertex data.
    pub surface: Arc<MeshSurface>,
    /// Local-to-world transform.
    pub world_from_local: Affine3A,
    /// The material index hits on this instance report.
    pub material: u32,
}

/// What shading needs of one instance beyond what the two-level scene keeps.
#[derive(Clone, Debug)]
pub(super) struct InstanceShading {
    pub(super) surface: Arc<MeshSurface>,
    pub(super) world_from_local: Affine3A,
    pub(super) normal_to_world: Mat3A,
    pub(super) material: u32,
}

impl InstanceShading {
    pub(super) fn of(instance: &PreviewInstance) -> Self {
        // As `InstancedScene` computes it, so the two scenes' normals agree to the bit.
        let local_from_world = instance.world_from_local.inverse();
        Self {
            surface: instance.surface.clone(),
            world_from_local: instance.world_from_local,
            normal_to_world: local_from_world.matrix3.transpose(),
            material: instance.material,
        }
    }

    pub(super) fn surface_hit(&self, ray: &Ray, object: u32, hit: &MeshHit) -> SurfaceHit {
        self.surface.surface_hit(
            ray,
            object,
            self.material,
            &self.world_from_local,
            &self.normal_to_world,
            hit,
        )
    }
}

/// A [`PreviewScene`] over [`InstancedScene`]: the two-level BVH for rays, and per instance
/// a material index and the mesh's vertex data for shading. Both sides of every triangle
/// are hit (the preview draws double-sided).
#[derive(Clone, Debug)]
pub struct InstancedPreviewScene {
    scene: InstancedScene,
    shading: Vec<InstanceShading>,
}

impl InstancedPreviewScene {
    /// The scene over `instances`; instance `i` reports object id `i`. Instances whose
    /// transform is not finite or not invertible are left out (see
    /// [`InstancedScene::rejected_instances`]).
    pub fn new(instances: &[PreviewInstance]) -> Self {
        let scene = InstancedScene::new(
            instances
                .iter()
                .map(|i| crate::mesh::Instance {
                    mesh: i.mesh.clone(),
                    world_from_local: i.world_from_local,
                })
                .collect(),
        );
        Self {
            scene,
            shading: instances.iter().map(InstanceShading::of).collect(),
        }
    }

    /// The two-level scene rays are cast through.
    pub fn scene(&self) -> &InstancedScene {
        &self.scene
    }
}

impl PreviewScene for InstancedPreviewScene {
    fn closest(&self, ray: &Ray) -> Option<SurfaceHit> {
        let hit = self.scene.cast_ray(ray, Backfaces::Include)?;
        Some(self.shading[hit.instance as usize].surface_hit(ray, hit.instance, &hit.hit))
    }

    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.scene
            .cast_ray_any(&ray.with_t_max(t_max), Backfaces::Include)
    }

    fn closest_counted(&self, ray: &Ray) -> CountedHit<SurfaceHit> {
        let counted = self.scene.cast_ray_counted(ray, Backfaces::Include);
        CountedHit {
            hit: counted
                .hit
                .map(|h| self.shading[h.instance as usize].surface_hit(ray, h.instance, &h.hit)),
            cost: counted.cost,
            leaf_depth: counted.leaf_depth,
        }
    }
}
