//! A preview scene whose top level is any [`DynamicIndex`]: the structure an engine keeps over
//! its moving objects (a dynamic BVH, a loose octree, a grid) traced as it is, without a
//! second instance BVH built for the preview.

use super::scene::{InstanceShading, PreviewInstance, PreviewScene, SurfaceHit};
use crate::mesh::{CountedHit, MeshBvh, TraversalCost};
use crate::mesh::{instance_world_box, is_placeable};
use crate::query::{DynamicIndex, IndexError};
use crate::{Backfaces, Ray};
use glam::{Affine3A, Vec3A};
use std::sync::Arc;
use std::time::Duration;

/// One instance as the indexed scene keeps it: its mesh walk, its ray transform and shading.
#[derive(Clone, Debug)]
struct IndexedInstance {
    mesh: Arc<MeshBvh>,
    local_from_world: Affine3A,
    shading: InstanceShading,
}

/// A [`PreviewScene`] over a top-level [`DynamicIndex`] of instance boxes, each instance's
/// [`MeshBvh`] below it: the layout an engine's entity trees give (the `bevy_accel` plugin
/// traces its trees this way), and the one for comparing the index choices on the same
/// image (`accel-bench preview`).
///
/// Instance `i` is entry `i` of the index and reports object id `i`. Its images equal
/// [`InstancedPreviewScene`](super::InstancedPreviewScene)'s for the same instances, whatever
/// the index.
///
/// ```
/// use spatial_accel::preview::{IndexedPreviewScene, MeshSurface, PreviewInstance, PreviewScene};
/// use spatial_accel::{LooseOctree, Ray};
/// use glam::{Affine3A, Vec3, Vec3A};
/// use std::sync::Arc;
/// let surface = MeshSurface::new(
///     vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
///     vec![0, 1, 2],
/// );
/// let mesh = Arc::new(surface.build_bvh().unwrap());
/// let instance = PreviewInstance {
///     mesh,
///     surface: Arc::new(surface),
///     world_from_local: Affine3A::from_translation(Vec3::new(0.0, 0.0, -5.0)),
///     material: 0,
/// };
/// let scene = IndexedPreviewScene::new(LooseOctree::new(), &[instance]).unwrap();
/// let hit = scene.closest(&Ray::new(Vec3A::ZERO, -Vec3A::Z)).unwrap();
/// assert_eq!((hit.object, hit.t), (0, 5.0));
/// ```
#[derive(Clone, Debug)]
pub struct IndexedPreviewScene<I> {
    index: I,
    instances: Vec<Option<IndexedInstance>>,
}

impl<I: DynamicIndex> IndexedPreviewScene<I> {
    /// `instances` inserted into `index` (which should be empty) by their world boxes, the
    /// index then maintained once so that it is ready for rays. Instances whose transform is
    /// not finite or not invertible are left out, as `InstancedScene` leaves them out.
    pub fn new(mut index: I, instances: &[PreviewInstance]) -> Result<Self, IndexError> {
        let mut kept = Vec::with_capacity(instances.len());
        for (i, instance) in instances.iter().enumerate() {
            let m = instance.world_from_local;
            let world = instance_world_box(&instance.mesh.bounds(), &m);
            let local_from_world = m.inverse();
            // The two-level scene's rule: an instance it could not reach is left out here too.
            if !(is_placeable(&m)
                && world.is_valid()
                && world.is_finite()
                && local_from_world.is_finite())
            {
                kept.push(None);
                continue;
            }
            index.insert(i as u32, world)?;
            kept.push(Some(IndexedInstance {
                mesh: instance.mesh.clone(),
                local_from_world,
                shading: InstanceShading::of(instance),
            }));
        }
        index.maintain(Duration::ZERO);
        Ok(Self {
            index,
            instances: kept,
        })
    }

    /// The top-level index rays walk.
    pub fn index(&self) -> &I {
        &self.index
    }

    fn instance(&self, id: u32) -> Option<&IndexedInstance> {
        self.instances.get(id as usize)?.as_ref()
    }

    /// The closest mesh hit along `ray`: the instance and the hit with its normal in world
    /// space.
    fn closest_mesh_hit(&self, ray: &Ray) -> Option<(u32, crate::mesh::MeshHit)> {
        let mut best = None;
        let hit = self.index.cast_ray(ray, |id, r| {
            let instance = self.instance(id)?;
            // The local ray keeps the world ray's parameter: its direction is not normalised.
            let hit = instance.mesh.cast_ray(
                &r.transformed(&instance.local_from_world),
                Backfaces::Include,
            )?;
            best = Some((id, hit));
            Some(hit.t)
        })?;
        // The walk may settle a tie on another instance than the last one the closure saw:
        // then the winner's hit is found again.
        let (id, mut mesh_hit) = match best {
            Some((id, h)) if id == hit.primitive => (id, h),
            _ => {
                let instance = self.instance(hit.primitive)?;
                let local = ray.transformed(&instance.local_from_world);
                (
                    hit.primitive,
                    instance.mesh.cast_ray(&local, Backfaces::Include)?,
                )
            }
        };
        let shading = &self.instance(id)?.shading;
        mesh_hit.geometric_normal = (shading.normal_to_world * mesh_hit.geometric_normal)
            .try_normalize()
            .unwrap_or(Vec3A::Y);
        Some((id, mesh_hit))
    }
}

impl<I: DynamicIndex + Sync> PreviewScene for IndexedPreviewScene<I> {
    fn closest(&self, ray: &Ray) -> Option<SurfaceHit> {
        let (id, hit) = self.closest_mesh_hit(ray)?;
        Some(self.instance(id)?.shading.surface_hit(ray, id, &hit))
    }

    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let ray = ray.with_t_max(ray.t_max.min(t_max));
        self.index
            .cast_ray_any(&ray, |id, r| {
                self.instance(id).is_some_and(|instance| {
                    let local = r.transformed(&instance.local_from_world);
                    instance.mesh.cast_ray_any(&local, Backfaces::Include)
                })
            })
            .is_some()
    }

    /// The top-level walk does not count its nodes: the cost is one node per instance whose
    /// box the ray reached, plus each mesh walk's nodes and triangles; the leaf depth is the
    /// mesh BVH's.
    fn closest_counted(&self, ray: &Ray) -> CountedHit<SurfaceHit> {
        let mut cost = TraversalCost::default();
        let mut best = None;
        let hit = self.index.cast_ray(ray, |id, r| {
            let instance = self.instance(id)?;
            cost.nodes += 1;
            let local = r.transformed(&instance.local_from_world);
            let counted = instance.mesh.cast_ray_counted(&local, Backfaces::Include);
            cost.nodes += counted.cost.nodes;
            cost.triangles += counted.cost.triangles;
            let hit = counted.hit?;
            best = Some((id, counted.leaf_depth));
            Some(hit.t)
        });
        let leaf_depth = hit.and_then(|h| {
            best.filter(|(id, _)| *id == h.primitive)
                .and_then(|(_, d)| d)
        });
        CountedHit {
            hit: hit.and_then(|_| self.closest(ray)),
            cost,
            leaf_depth,
        }
    }
}
