//! The entity trees as the preview's scene: the trees find the entities a ray reaches, and
//! each entity's mesh BVH (from the picking plugin's cache) finds the triangle.

use crate::AccelTrees;
use crate::picking::CachedMesh;
use bevy::math::{Affine3A, Mat3A, Vec3A};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use spatial_accel::mesh::{CountedHit, MeshBvh, MeshHit, TraversalCost};
use spatial_accel::preview::{MeshSurface, PreviewScene, SurfaceHit};
use spatial_accel::{Aabb, Backfaces, Ray, SpatialQuery};
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

/// A skinned or morphed entity, posed as Bevy draws it: its triangles in world space, a
/// copy of its posed tree taken when the trace started, and the box around them.
pub(super) struct PosedPreviewObject {
    /// The entity's tree slot: hits name their object by slot, as the others' do.
    pub(super) slot: u32,
    pub(super) bvh: MeshBvh,
    pub(super) surface: MeshSurface,
    pub(super) bounds: Aabb,
    pub(super) material: u32,
}

impl PosedPreviewObject {
    fn hit(&self, ray: &Ray) -> Option<MeshHit> {
        ray.intersect_aabb(&self.bounds)?;
        self.bvh.cast_ray(ray, Backfaces::Include)
    }

    fn surface_hit(&self, ray: &Ray, hit: &MeshHit) -> SurfaceHit {
        let mut hit = *hit;
        hit.geometric_normal = hit.geometric_normal.try_normalize().unwrap_or(Vec3A::Y);
        self.surface.surface_hit(
            ray,
            self.slot,
            self.material,
            &Affine3A::IDENTITY,
            &Mat3A::IDENTITY,
            &hit,
        )
    }
}

/// The preview's objects by tree slot, the meshes they share, and the posed objects (which
/// the trees' walk skips: their tree boxes are Bevy's, which a pose can leave).
#[derive(Default)]
pub(super) struct PreviewObjects {
    pub(super) by_slot: Vec<Option<PreviewObject>>,
    pub(super) meshes: HashMap<AssetId<Mesh>, Arc<PreviewMesh>>,
    pub(super) posed: Vec<PosedPreviewObject>,
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
        // The posed objects first: their nearest hit bounds the trees' walk.
        let mut posed_best: Option<(&PosedPreviewObject, MeshHit)> = None;
        let mut ray = *ray;
        for object in &self.objects.posed {
            if let Some(hit) = object.hit(&ray) {
                ray.t_max = hit.t;
                posed_best = Some((object, hit));
            }
        }
        let ray = &ray;
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
        });
        let Some(hit) = hit else {
            return posed_best.map(|(object, hit)| object.surface_hit(ray, &hit));
        };
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
        let posed_blocks = self.objects.posed.iter().any(|object| {
            ray.intersect_aabb(&object.bounds).is_some()
                && object.bvh.cast_ray_any(&ray, Backfaces::Include)
        });
        posed_blocks
            || self
                .trees
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
