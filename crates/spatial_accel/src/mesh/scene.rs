//! The top level: instances of shared meshes under affine transforms.

use super::scene_update::TopLevelUpkeep;
use super::{MeshBvh, MeshHit};
use crate::bvh::wide::Bvh8;
use crate::{Aabb, Backfaces, BuildConfig, Bvh, Ray, SpatialQuery};
use glam::{Affine3A, Vec3A};
use std::sync::Arc;

/// One placement of a mesh in the world.
#[derive(Clone, Debug)]
pub struct Instance {
    /// The mesh (shared: one mesh BVH serves every instance of it).
    pub mesh: Arc<MeshBvh>,
    /// Local-to-world transform.
    pub world_from_local: Affine3A,
}

/// A hit in an [`InstancedScene`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InstanceHit {
    /// Index of the instance in the scene.
    pub instance: u32,
    /// The mesh-level hit. `t` is in units of the world ray (instance space keeps `t`);
    /// `geometric_normal` is in world space, unit length; `front_face` refers to the mesh's own
    /// winding.
    pub hit: MeshHit,
}

#[derive(Clone, Debug)]
pub(super) struct PlacedInstance {
    pub(super) mesh: Arc<MeshBvh>,
    pub(super) local_from_world: Affine3A,
    /// Inverse-transpose of the linear part: how normals go from local to world.
    normal_to_world: glam::Mat3A,
}

impl PlacedInstance {
    /// The instance ready for rays, and its world box; `None` for a transform that is not
    /// invertible or not finite.
    pub(super) fn place(instance: Instance) -> Option<(Self, Aabb)> {
        let m = instance.world_from_local;
        if !is_placeable(&m) {
            return None;
        }
        let world_box = instance_world_box(&instance.mesh.bounds(), &m);
        let local_from_world = m.inverse();
        // A finite transform can still overflow the world box (a scale near f32::MAX) or
        // have an inverse that does: such an instance could never be found through the top
        // level, so it is rejected and reported, not silently unreachable.
        if !(world_box.is_valid() && world_box.is_finite() && local_from_world.is_finite()) {
            return None;
        }
        Some((
            Self {
                normal_to_world: local_from_world.matrix3.transpose(),
                local_from_world,
                mesh: instance.mesh,
            },
            world_box,
        ))
    }
}

/// The world box of a mesh's `local` box under `world_from_local`, grown by a few ulps of its
/// magnitude. `Aabb::transformed` rounds to nearest, so the exact image of a triangle can
/// poke out of it by an ulp; a ray meeting the triangle there would miss the box and the hit
/// (the stress suite found one, from `-f32::MAX`). Near `f32::MAX` the growth overflows, and
/// the instance is rejected rather than found by some rays only.
pub(crate) fn instance_world_box(local: &Aabb, world_from_local: &Affine3A) -> Aabb {
    let world = local.transformed(world_from_local);
    let magnitude = world.min.abs().max(world.max.abs()) + world.extent().abs();
    world.expanded(magnitude * (4.0 * f32::EPSILON))
}

/// Whether an instance can be placed under `world_from_local`: the transform must be finite
/// and invertible, or rays could not be taken into its space. Shared with the preview's
/// brute-force scene, which must leave out exactly the instances the tree leaves out.
pub(crate) fn is_placeable(world_from_local: &Affine3A) -> bool {
    let det = world_from_local.matrix3.determinant();
    det.is_finite() && det != 0.0 && world_from_local.translation.is_finite()
}

/// A two-level scene: a top-level BVH over instance boxes, each instance a mesh BVH under a
/// transform.
///
/// Rays are taken into each instance's space rather than vertices into world space: far from
/// the origin, moving a ray loses no more precision than the ray already has, while moving a
/// mesh would re-round every vertex (robustness notes; pbrt does the same). `t` is preserved
/// by the transform, so hits in different instances compare directly.
///
/// Instances whose transform is not invertible or not finite are left out of the tree and
/// reported by [`InstancedScene::rejected_instances`].
///
/// Instances move, or change meshes, through [`InstancedScene::update_instances`], which
/// refits the top level along the changed instances' paths and rebuilds it once refits have
/// made it loose.
///
/// ```
/// use spatial_accel::{Backfaces, Ray};
/// use spatial_accel::mesh::{Instance, InstancedScene, MeshBvh};
/// use glam::{Affine3A, Vec3, Vec3A};
/// use std::sync::Arc;
/// let quad = Arc::new(MeshBvh::new(
///     &[Vec3::new(-1., -1., 0.), Vec3::new(1., -1., 0.), Vec3::new(1., 1., 0.), Vec3::new(-1., 1., 0.)],
///     &[0, 1, 2, 0, 2, 3],
/// ).unwrap());
/// let scene = InstancedScene::new(vec![
///     Instance { mesh: quad.clone(), world_from_local: Affine3A::from_translation(Vec3::new(0., 0., -10.)) },
///     Instance { mesh: quad, world_from_local: Affine3A::from_translation(Vec3::new(0., 0., -5.)) },
/// ]);
/// let hit = scene.cast_ray(&Ray::new(Vec3A::ZERO, Vec3A::NEG_Z), Backfaces::Include).unwrap();
/// assert_eq!((hit.instance, hit.hit.t), (1, 5.0));
/// ```
#[derive(Clone, Debug)]
pub struct InstancedScene {
    pub(super) top: Bvh8,
    pub(super) instances: Vec<Option<PlacedInstance>>,
    /// Each instance's world box; [`Aabb::EMPTY`] for a rejected one.
    pub(super) boxes: Vec<Aabb>,
    pub(super) rejected: Vec<u32>,
    /// What keeps the top level up to date as instances change.
    pub(super) upkeep: TopLevelUpkeep,
}

impl InstancedScene {
    /// Builds the top level over the instances' world boxes.
    pub fn new(instances: Vec<Instance>) -> Self {
        let mut rejected = Vec::new();
        let mut boxes = Vec::with_capacity(instances.len());
        let placed = instances
            .into_iter()
            .enumerate()
            .map(|(i, instance)| {
                let placed = PlacedInstance::place(instance);
                if placed.is_none() {
                    rejected.push(i as u32);
                }
                boxes.push(placed.as_ref().map_or(Aabb::EMPTY, |(_, b)| *b));
                placed.map(|(p, _)| p)
            })
            .collect();
        let top = top_level_over(&boxes);
        Self {
            upkeep: TopLevelUpkeep::new(&top),
            top,
            instances: placed,
            boxes,
            rejected,
        }
    }

    /// Instances left out for a non-invertible or non-finite transform.
    pub fn rejected_instances(&self) -> &[u32] {
        &self.rejected
    }

    /// The top-level tree (primitive ids are instance indices).
    pub fn top_level(&self) -> &Bvh8 {
        &self.top
    }

    pub(super) fn instance(&self, i: u32) -> &PlacedInstance {
        self.instances[i as usize]
            .as_ref()
            .expect("the top level holds only accepted instances")
    }

    pub(super) fn to_world(&self, instance: u32, mut hit: MeshHit) -> InstanceHit {
        let n = self.instance(instance).normal_to_world * hit.geometric_normal;
        hit.geometric_normal = n.normalize_or_zero();
        InstanceHit { instance, hit }
    }

    /// The closest hit over all instances.
    pub fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<InstanceHit> {
        let mut best: Option<(u32, MeshHit)> = None;
        self.top.cast_ray(ray, |i, r| {
            let inst = self.instance(i);
            let h = inst
                .mesh
                .cast_ray(&r.transformed(&inst.local_from_world), backfaces)?;
            if best.is_none_or(|(_, b)| h.t < b.t) {
                best = Some((i, h));
            }
            Some(h.t)
        })?;
        best.map(|(i, h)| self.to_world(i, h))
    }

    /// True when anything blocks the ray.
    pub fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool {
        self.top
            .cast_ray_any(ray, |i, r| {
                let inst = self.instance(i);
                inst.mesh
                    .cast_ray_any(&r.transformed(&inst.local_from_world), backfaces)
            })
            .is_some()
    }

    /// Every hit over all instances, nearest first (ties by instance, then triangle).
    pub fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<InstanceHit>) {
        let start = out.len();
        let mut mesh_hits = Vec::new();
        self.top.cast_ray_any(ray, |i, r| {
            let inst = self.instance(i);
            mesh_hits.clear();
            inst.mesh.cast_ray_all(
                &r.transformed(&inst.local_from_world),
                backfaces,
                &mut mesh_hits,
            );
            out.extend(mesh_hits.iter().map(|h| self.to_world(i, *h)));
            false
        });
        out[start..].sort_unstable_by(|a, b| {
            a.hit
                .t
                .total_cmp(&b.hit.t)
                .then(a.instance.cmp(&b.instance))
                .then(a.hit.triangle.cmp(&b.hit.triangle))
        });
    }

    /// The point of a hit in world space.
    pub fn hit_point(ray: &Ray, hit: &InstanceHit) -> Vec3A {
        ray.at(hit.hit.t)
    }
}

/// The top level over the instances' world boxes (rejected instances' empty boxes are left
/// out by the build).
pub(super) fn top_level_over(boxes: &[Aabb]) -> Bvh8 {
    // One instance a leaf. Why: the walk calls back for every primitive of a leaf whose box
    // it hits, with no test of the primitive's own box, and here a call means moving the ray
    // into the instance and walking its mesh. On the benchmark scene split into overlapping
    // instances, leaves of up to eight instances (the default) make a ray enter many more
    // instances than one instance a leaf does, and every kind of ray is slower
    // (BENCHMARKS.md, Rays on meshes).
    let config = BuildConfig {
        max_leaf_size: 1,
        ..BuildConfig::default()
    };
    Bvh8::from_bvh(&Bvh::build(boxes, &config))
}
