//! The brute-force scene: every triangle of every instance tested for every ray, the oracle
//! the tree-traced images are compared with.

use super::scene::{InstanceShading, PreviewInstance, PreviewScene, SurfaceHit};
use crate::mesh::{CountedHit, MeshHit, TraversalCost, is_placeable};
use crate::query::{BruteForceMesh, TriangleQuery};
use crate::{Backfaces, Ray};
use glam::Affine3A;
use std::sync::Arc;

/// One instance as the brute-force scene tests it.
#[derive(Clone, Debug)]
struct Placed {
    object: u32,
    triangles: Arc<BruteForceMesh>,
    local_from_world: Affine3A,
    shading: InstanceShading,
}

/// A [`PreviewScene`] with no acceleration structure: each ray is taken into each instance's
/// space, as [`InstancedScene`](crate::mesh::InstancedScene) does, and tested against every
/// triangle there with [`BruteForceMesh`] (the same watertight test). Hits, normals and
/// shading records are therefore the tree scene's to the bit, and an image traced through
/// either is the same image; only ties (two surfaces at exactly one distance) may resolve to
/// a different object, here always the lower instance index.
///
/// For tests and for checking a new scene implementation, not for real time: every ray
/// costs the whole scene's triangle count.
#[derive(Clone, Debug)]
pub struct BruteForcePreviewScene {
    placed: Vec<Placed>,
    triangle_count: u32,
}

impl BruteForcePreviewScene {
    /// The scene of `instances` (read from each instance's surface, not its BVH); instance
    /// `i` reports object id `i`. Instances the tree scene rejects (a transform not finite or
    /// not invertible) are left out here too.
    pub fn new(instances: &[PreviewInstance]) -> Self {
        // One triangle list per distinct surface, shared as the BVHs are.
        let mut lists: Vec<(*const super::MeshSurface, Arc<BruteForceMesh>)> = Vec::new();
        let mut placed = Vec::new();
        for (object, instance) in (0u32..).zip(instances) {
            if !is_placeable(&instance.world_from_local) {
                continue;
            }
            let key = Arc::as_ptr(&instance.surface);
            let triangles = match lists.iter().find(|(k, _)| *k == key) {
                Some((_, list)) => list.clone(),
                None => {
                    let s = &instance.surface;
                    // Bad indices make an empty list: such a surface has no BVH either.
                    let list =
                        Arc::new(BruteForceMesh::new(&s.positions, &s.indices).unwrap_or_default());
                    lists.push((key, list.clone()));
                    list
                }
            };
            placed.push(Placed {
                object,
                triangles,
                local_from_world: instance.world_from_local.inverse(),
                shading: InstanceShading::of(instance),
            });
        }
        let triangle_count = placed
            .iter()
            .map(|p| p.triangles.triangle_count() as u32)
            .fold(0u32, u32::saturating_add);
        Self {
            placed,
            triangle_count,
        }
    }

    /// The closest hit, in instance order, with the instance it was on.
    fn closest_hit(&self, ray: &Ray) -> Option<(&Placed, MeshHit)> {
        let mut best: Option<(&Placed, MeshHit)> = None;
        for p in &self.placed {
            let range = best.map_or(ray.t_max, |(_, b)| b.t);
            let local = ray.with_t_max(range).transformed(&p.local_from_world);
            if let Some(mut hit) = p.triangles.cast_ray(&local, Backfaces::Include)
                && best.is_none_or(|(_, b)| hit.t < b.t)
            {
                // World space, as `InstancedScene` takes it there.
                hit.geometric_normal =
                    (p.shading.normal_to_world * hit.geometric_normal).normalize_or_zero();
                best = Some((p, hit));
            }
        }
        best
    }
}

impl PreviewScene for BruteForcePreviewScene {
    fn closest(&self, ray: &Ray) -> Option<SurfaceHit> {
        let (p, hit) = self.closest_hit(ray)?;
        Some(p.shading.surface_hit(ray, p.object, &hit))
    }

    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let ray = ray.with_t_max(t_max);
        self.placed.iter().any(|p| {
            p.triangles
                .cast_ray_any(&ray.transformed(&p.local_from_world), Backfaces::Include)
        })
    }

    fn closest_counted(&self, ray: &Ray) -> CountedHit<SurfaceHit> {
        let hit = self
            .closest_hit(ray)
            .map(|(p, hit)| p.shading.surface_hit(ray, p.object, &hit));
        CountedHit {
            hit,
            // No nodes: every triangle of every instance is tested.
            cost: TraversalCost {
                nodes: 0,
                triangles: self.triangle_count,
            },
            leaf_depth: None,
        }
    }
}
