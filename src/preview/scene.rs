//! The entity trees as the preview's scene: the trees find the entities a ray reaches, and
//! each entity's mesh BVH (from the picking plugin's cache) finds the triangle.

use crate::AccelTrees;
use crate::picking::CachedMesh;
use bevy::math::{Affine3A, Mat3A};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use spatial_accel::mesh::{CountedHit, TraversalCost};
use spatial_accel::preview::{MeshSurface, PreviewScene, SurfaceHit};
use spatial_accel::{Backfaces, Ray, SpatialQuery};
use std::sync::Arc;

/// One mesh's BVH and the vertex data shading reads.
pub(super) struct PreviewMesh {
    pub(super) cached: Arc<CachedMesh>,
    pub(super) surface: MeshSurface,
}

impl PreviewMesh {
    pub(super) fn new(cached: Arc<CachedMesh>) -> Self {
        let mut surface = MeshSurface::new(cached.positions.clone(), cached.indices.clone());
        surface.uvs = cached.uvs.clone();
        surface = match &cached.normals {
            Some(normals) => MeshSurface {
                normals: Some(normals.clone()),
                ..surface
            },
            // Bevy shades a mesh without normals flat; smooth normals are closer to what
            // the artist meant than the facets.
            None => surface.with_smooth_normals(),
        };
        Self { cached, surface }
    }
}

/// An entity the preview can hit: its mesh, where it is, and what it is made of.
pub(super) struct PreviewObject {
    pub(super) mesh: Arc<PreviewMesh>,
    pub(super) world_from_local: Affine3A,
    pub(super) local_from_world: Affine3A,
    pub(super) normal_to_world: Mat3A,
    pub(super) material: u32,
}

impl PreviewObject {
    /// The object for an entity at `world_from_local`, or `None` for a transform that
    /// cannot be inverted (the trees reject those entities anyway).
    pub(super) fn new(
        mesh: Arc<PreviewMesh>,
        world_from_local: Affine3A,
        material: u32,
    ) -> Option<Self> {
        let det = world_from_local.matrix3.determinant();
        if !det.is_finite() || det == 0.0 {
            return None;
        }
        Some(Self {
            mesh,
            world_from_local,
            local_from_world: world_from_local.inverse(),
            // As the core's instanced scene computes it, so that normals agree to the bit.
            normal_to_world: world_from_local.inverse().matrix3.transpose(),
            material,
        })
    }
}

/// The preview's objects by tree slot, and the meshes they share.
#[derive(Default)]
pub(super) struct PreviewObjects {
    pub(super) by_slot: Vec<Option<PreviewObject>>,
    pub(super) meshes: HashMap<AssetId<Mesh>, Arc<PreviewMesh>>,
}

/// The scene the tracer sees: the trees over the objects.
pub(super) struct EntityPreviewScene<'a> {
    pub(super) trees: &'a AccelTrees,
    pub(super) objects: &'a PreviewObjects,
}

impl EntityPreviewScene<'_> {
    fn object(&self, slot: u32) -> Option<&PreviewObject> {
        self.objects.by_slot.get(slot as usize)?.as_ref()
    }
}

impl PreviewScene for EntityPreviewScene<'_> {
    fn closest(&self, ray: &Ray) -> Option<SurfaceHit> {
        let mut best = None;
        let hit = self.trees.query().cast_ray(ray, |slot, r| {
            let object = self.object(slot)?;
            r.intersect_aabb(&self.trees.world_bounds(slot))?;
            // The local ray keeps the world ray's parameter: its direction is not normalised.
            let local = r.transformed(&object.local_from_world);
            let hit = object
                .mesh
                .cached
                .bvh
                .cast_ray(&local, Backfaces::Include)?;
            best = Some((slot, hit));
            Some(hit.t)
        })?;
        // The walk may settle a tie on another entity than the last one the closure saw:
        // then the winner's hit is found again.
        let (slot, mut mesh_hit) = match best {
            Some((slot, h)) if slot == hit.primitive => (slot, h),
            _ => {
                let object = self.object(hit.primitive)?;
                let local = ray.transformed(&object.local_from_world);
                let h = object
                    .mesh
                    .cached
                    .bvh
                    .cast_ray(&local, Backfaces::Include)?;
                (hit.primitive, h)
            }
        };
        let object = self.object(slot)?;
        mesh_hit.geometric_normal = (object.normal_to_world * mesh_hit.geometric_normal)
            .try_normalize()
            .unwrap_or(Vec3A::Y);
        Some(object.mesh.surface.surface_hit(
            ray,
            slot,
            object.material,
            &object.world_from_local,
            &object.normal_to_world,
            &mesh_hit,
        ))
    }

    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let ray = ray.with_t_max(ray.t_max.min(t_max));
        self.trees
            .query()
            .cast_ray_any(&ray, |slot, r| {
                let Some(object) = self.object(slot) else {
                    return false;
                };
                if r.intersect_aabb(&self.trees.world_bounds(slot)).is_none() {
                    return false;
                }
                let local = r.transformed(&object.local_from_world);
                object
                    .mesh
                    .cached
                    .bvh
                    .cast_ray_any(&local, Backfaces::Include)
            })
            .is_some()
    }

    /// The entity trees' walk does not count its nodes: the cost here is each entity whose
    /// box the ray reached (one node each) plus each mesh walk's own nodes and triangles,
    /// and the leaf depth is the mesh BVH's.
    fn closest_counted(&self, ray: &Ray) -> CountedHit<SurfaceHit> {
        let mut cost = TraversalCost::default();
        let mut best = None;
        let hit = self.trees.query().cast_ray(ray, |slot, r| {
            let object = self.object(slot)?;
            cost.nodes += 1;
            r.intersect_aabb(&self.trees.world_bounds(slot))?;
            let local = r.transformed(&object.local_from_world);
            let counted = object
                .mesh
                .cached
                .bvh
                .cast_ray_counted(&local, Backfaces::Include);
            cost.nodes += counted.cost.nodes;
            cost.triangles += counted.cost.triangles;
            let hit = counted.hit?;
            best = Some((slot, counted.leaf_depth));
            Some(hit.t)
        });
        let leaf_depth = hit.and_then(|h| {
            best.filter(|(slot, _)| *slot == h.primitive)
                .and_then(|(_, d)| d)
        });
        CountedHit {
            hit: hit.and_then(|_| self.closest(ray)),
            cost,
            leaf_depth,
        }
    }
}
