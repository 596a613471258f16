//! A triangle BVH over a skinned or morphed mesh's posed vertices, refit as the pose changes.

use super::skinning::{MorphTargets, SkinnedVertices, SkinningError, SkinningInput};
use super::{MeshBvh, MeshError, MeshHit, skin_positions};
use crate::{Aabb, Backfaces, Ray};
use glam::{Mat4, Vec3};
use std::sync::Arc;

/// A [`MeshBvh`] over a mesh's posed vertices (skinned, morphed, or moved any other way),
/// built once and refit to each new pose, rebuilt only when refits have loosened it too far.
///
/// The index list (the topology) is shared: entities that pose the same mesh asset hold one
/// `Arc` of it between them, and each its own posed vertices and tree.
///
/// The tree is refit in [`PosedMeshBvh::pose`] itself, not on the next query: queries take
/// `&self`, so that many threads can cast rays at once. A caller that poses on demand (when a
/// ray is about to be cast at the mesh) pays for neither skinning nor refit in frames no ray
/// looks at it.
///
/// A pose is all or nothing: the new positions are written to a second buffer and swapped in
/// only when the pose succeeds, so a failed one leaves the mesh, its positions and its tree
/// in the last good pose.
///
/// ```
/// use spatial_accel::mesh::{PosedMeshBvh, SkinnedVertices, joint_matrices};
/// use spatial_accel::{Backfaces, Ray};
/// use glam::{Mat4, Vec3};
/// use std::sync::Arc;
/// // A unit quad in the z = 0 plane facing +z, its left edge on joint 0, its right on joint 1.
/// let positions = [Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(1., 1., 0.), Vec3::new(0., 1., 0.)];
/// let joint_indices = [[0, 0, 0, 0], [1, 0, 0, 0], [1, 0, 0, 0], [0, 0, 0, 0]];
/// let joint_weights = [[1.0, 0.0, 0.0, 0.0]; 4];
/// let skin = SkinnedVertices { positions: &positions, joint_indices: &joint_indices, joint_weights: &joint_weights };
/// let topology: Arc<[u32]> = Arc::from([0, 1, 2, 0, 2, 3]);
/// // Built at the bind pose (the joints where the inverse bindposes undo them).
/// let mut mesh = PosedMeshBvh::new(topology, positions.to_vec()).unwrap();
///
/// // Joint 1 moves two units along x: the quad stretches to x = 3.
/// let mut joints = Vec::new();
/// joint_matrices(&[Mat4::IDENTITY, Mat4::from_translation(Vec3::X * 2.0)], &[Mat4::IDENTITY; 2], &mut joints);
/// mesh.skin(&skin, &joints, None).unwrap();
///
/// let ray = Ray::new(Vec3::new(2.5, 0.1, 5.0), Vec3::NEG_Z);
/// let hit = mesh.cast_ray(&ray, Backfaces::Cull).unwrap();
/// assert_eq!((hit.t, hit.triangle), (5.0, 0));
/// assert_eq!(mesh.refit_count(), 1);
/// ```
#[derive(Clone, Debug)]
pub struct PosedMeshBvh {
    topology: Arc<[u32]>,
    /// The current pose, as the tree holds it.
    positions: Vec<Vec3>,
    /// Where the next pose is written, kept so that posing does not allocate.
    next: Vec<Vec3>,
    bvh: MeshBvh,
    /// The tree's slot area cost when it was last built.
    built_cost: f32,
    rebuild_threshold: f32,
    refits: u64,
    rebuilds: u64,
}

impl PosedMeshBvh {
    /// The default of [`set_rebuild_threshold`](Self::set_rebuild_threshold): a refit tree
    /// is rebuilt once its slot area cost is half again that of its build.
    ///
    /// Laxer than [`InstancedScene::DEFAULT_REBUILD_THRESHOLD`](super::InstancedScene::DEFAULT_REBUILD_THRESHOLD):
    /// a rebuild costs many refits, and a character's animation keeps returning near the pose
    /// the tree was built in, which tightens the refit tree again; only a pose that stays far
    /// off (an arm held raised) should pay for a new tree.
    pub const DEFAULT_REBUILD_THRESHOLD: f32 = 1.5;

    /// The tree over the mesh of `topology` (three vertex indices per triangle) at the pose
    /// `posed`. Errors as [`MeshBvh::new`]: a list that is not of triangles, or an index past
    /// the vertices.
    pub fn new(topology: Arc<[u32]>, posed: Vec<Vec3>) -> Result<Self, MeshError> {
        let bvh = Self::build(&posed, &topology)?;
        Ok(Self {
            built_cost: bvh.tree().slot_area_cost(),
            next: Vec::with_capacity(posed.len()),
            topology,
            positions: posed,
            bvh,
            rebuild_threshold: Self::DEFAULT_REBUILD_THRESHOLD,
            refits: 0,
            rebuilds: 0,
        })
    }

    /// Over whole triangles, not pre-split ones ([`MeshBvh::new`]): the first refit bounds
    /// whole triangles again, so pieces would speed up the first pose only, and the built
    /// cost the rebuild rule compares with would be of tighter boxes than any refit can give,
    /// which would rebuild on every pose.
    fn build(posed: &[Vec3], topology: &[u32]) -> Result<MeshBvh, MeshError> {
        let config = MeshBvh::default_config(topology.len() / 3);
        MeshBvh::with_config(posed, topology, &config)
    }

    /// Poses the mesh: `write` is given the current positions (one per vertex) to overwrite
    /// with the new pose (as [`skin_positions`] or [`morph_positions`](super::morph_positions)
    /// do), and the tree is refit to them, or rebuilt when the refit has loosened it past the
    /// [threshold](Self::set_rebuild_threshold).
    ///
    /// Errors: `write`'s own, or a pose that left a different number of positions
    /// ([`SkinningInput::PosedPositions`]); either way the mesh stays in its last good pose.
    /// A non-finite position is not an error here (the triangles using it cannot be hit);
    /// [`skin_positions`] reports it.
    pub fn pose(
        &mut self,
        write: impl FnOnce(&mut Vec<Vec3>) -> Result<(), SkinningError>,
    ) -> Result<(), SkinningError> {
        self.next.clear();
        self.next.extend_from_slice(&self.positions);
        write(&mut self.next)?;
        let length_error = SkinningError::LengthMismatch {
            input: SkinningInput::PosedPositions,
            expected: self.positions.len(),
            got: self.next.len(),
        };
        if self.next.len() != self.positions.len() {
            return Err(length_error);
        }
        // Only a count that differs from the build fails a refit, ruled out just above.
        self.bvh.refit(&self.next).map_err(|_| length_error)?;
        core::mem::swap(&mut self.positions, &mut self.next);
        self.refits += 1;
        if self.cost_growth() > self.rebuild_threshold {
            // Cannot fail: the topology passed the same checks when the mesh was built.
            if let Ok(bvh) = Self::build(&self.positions, &self.topology) {
                self.built_cost = bvh.tree().slot_area_cost();
                self.bvh = bvh;
                self.rebuilds += 1;
            }
        }
        Ok(())
    }

    /// Skins the mesh ([`skin_positions`] over `vertices`, the mesh asset's attributes, with
    /// the skin's `joint_matrices` and the morph targets, if any) and refits the tree to the
    /// new pose (see [`PosedMeshBvh::pose`]).
    pub fn skin(
        &mut self,
        vertices: &SkinnedVertices<'_>,
        joint_matrices: &[Mat4],
        morph: Option<MorphTargets<'_>>,
    ) -> Result<(), SkinningError> {
        self.pose(|out| skin_positions(vertices, joint_matrices, morph, out))
    }

    /// The posed positions the tree holds.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// The shared index list.
    pub fn topology(&self) -> &Arc<[u32]> {
        &self.topology
    }

    /// The tree.
    pub fn mesh_bvh(&self) -> &MeshBvh {
        &self.bvh
    }

    /// The exact box of the posed mesh: of every finite triangle's corners (the vertices no
    /// triangle uses are left out), as the tree's root holds it after every pose.
    pub fn bounds(&self) -> Aabb {
        self.bvh.bounds()
    }

    /// The closest hit along the ray, or `None` (see [`MeshBvh::cast_ray`]); the ray is in
    /// the space of the posed positions (world space, for a skinned mesh).
    pub fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<MeshHit> {
        self.bvh.cast_ray(ray, backfaces)
    }

    /// True when anything blocks the ray (see [`MeshBvh::cast_ray_any`]).
    pub fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool {
        self.bvh.cast_ray_any(ray, backfaces)
    }

    /// Every hit along the ray, nearest first, appended to `out` (see
    /// [`MeshBvh::cast_ray_all`]).
    pub fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<MeshHit>) {
        self.bvh.cast_ray_all(ray, backfaces, out)
    }

    /// Memory held, in bytes: the tree and both position buffers, not the shared topology
    /// (see [`PosedMeshBvh::topology`]), which is counted once by whoever counts the asset.
    pub fn memory_bytes(&self) -> usize {
        self.bvh.memory_bytes()
            + (self.positions.capacity() + self.next.capacity()) * size_of::<Vec3>()
    }

    /// The number of poses the tree was refit to.
    pub fn refit_count(&self) -> u64 {
        self.refits
    }

    /// The number of poses after which the refit tree was rebuilt.
    pub fn rebuild_count(&self) -> u64 {
        self.rebuilds
    }

    /// The tree's [`slot_area_cost`](crate::bvh::wide::WideBvh::slot_area_cost) over its
    /// cost when it was last built: how much refits have loosened it (1 for a fresh tree).
    pub fn cost_growth(&self) -> f32 {
        let cost = self.bvh.tree().slot_area_cost();
        if self.built_cost > 0.0 {
            cost / self.built_cost
        } else {
            1.0
        }
    }

    /// The [`cost_growth`](Self::cost_growth) past which a pose rebuilds the tree
    /// ([`DEFAULT_REBUILD_THRESHOLD`](Self::DEFAULT_REBUILD_THRESHOLD) unless set);
    /// [`f32::INFINITY`] never rebuilds, 1 or less rebuilds after every pose that loosens it.
    pub fn set_rebuild_threshold(&mut self, cost_growth: f32) {
        self.rebuild_threshold = cost_growth;
    }

    /// See [`set_rebuild_threshold`](Self::set_rebuild_threshold).
    pub fn rebuild_threshold(&self) -> f32 {
        self.rebuild_threshold
    }
}

impl crate::query::TriangleQuery for PosedMeshBvh {
    fn triangle_count(&self) -> usize {
        self.bvh.triangle_count()
    }

    fn bounds(&self) -> Aabb {
        PosedMeshBvh::bounds(self)
    }

    fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<MeshHit> {
        PosedMeshBvh::cast_ray(self, ray, backfaces)
    }

    fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool {
        PosedMeshBvh::cast_ray_any(self, ray, backfaces)
    }

    fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<MeshHit>) {
        PosedMeshBvh::cast_ray_all(self, ray, backfaces, out)
    }

    fn for_each_triangle_overlapping<F: FnMut(u32)>(&self, aabb: &Aabb, visit: F) {
        self.bvh.for_each_triangle_overlapping(aabb, visit)
    }
}
