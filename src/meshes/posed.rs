//! Skinned meshes as Bevy draws them: each skinned entity's triangles at their posed
//! positions, in a BVH of its own, refit only when a ray reaches the entity and its pose
//! changed since the last refit.
//!
//! Bevy draws a skinned mesh at posed vertices (each blended from up to four joints, joint
//! `GlobalTransform` times inverse bindpose) but its `MeshRayCast` tests the bind pose, so a
//! bent arm is missed and the air where it was is hit (bevy issues 23378 and 25605). Baking a
//! posed `Mesh` per cast (bevy PR 23583) rebuilds everything per ray; three-mesh-bvh's
//! `SkinnedMeshBVH` refits a per-mesh tree from the posed vertices instead, which is what is
//! done here, lazily: a frame in which no ray comes near a skinned entity costs nothing for
//! it.
//!
//! The broad phase cannot use the entity's `Aabb`: without `DynamicSkinnedMeshBounds` Bevy
//! keeps the bind pose's box, which a raised arm leaves. So skinned entities are left out of
//! the trees' mesh candidates, and tested on a box that holds every posed vertex whatever the
//! weights ([`SkinBounds`]), made from the joints alone at the first ray of a system's run.
//! Culling keeps Bevy's `Aabb`, as Bevy's own culling does.

use bevy::asset::AssetId;
use bevy::ecs::change_detection::Tick;
use bevy::ecs::entity::EntityHashMap;
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use spatial_accel::Aabb;
use spatial_accel::mesh::{PosedMeshBvh, SkinBounds, SkinnedVertices, joint_matrices};
use std::sync::{Arc, Mutex, PoisonError};

/// One skinned mesh asset's vertex data, read once and shared by every entity that uses it.
#[derive(Debug)]
pub struct SkinnedShape {
    /// Bind-pose positions, as in the asset.
    pub positions: Vec<Vec3>,
    /// Four joint indices per vertex (`ATTRIBUTE_JOINT_INDEX`).
    pub joint_indices: Vec<[u16; 4]>,
    /// Four weights per vertex (`ATTRIBUTE_JOINT_WEIGHT`), as stored.
    pub joint_weights: Vec<[f32; 4]>,
    /// The triangle list's vertex indices, shared with every posed copy.
    pub topology: Arc<[u32]>,
    /// Vertex normals, when the asset has `Float32x3` ones (bind pose: a hit's normal is
    /// the geometric one of the posed triangle).
    pub uvs: Option<Vec<Vec2>>,
    /// The box of any pose, from the joints' matrices alone.
    pub bounds: SkinBounds,
}

impl SkinnedShape {
    /// Reads a skinned mesh asset; `Err` says why it cannot be posed (rays then test its
    /// bind pose, as Bevy's do).
    pub fn from_mesh(mesh: &Mesh) -> Result<Self, String> {
        if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
            return Err("is not a triangle list".into());
        }
        let attribute = |id| mesh.try_attribute_option(id).ok().flatten();
        let positions: Vec<Vec3> = attribute(Mesh::ATTRIBUTE_POSITION)
            .and_then(VertexAttributeValues::as_float3)
            .ok_or("has no Float32x3 positions in the main world")?
            .iter()
            .copied()
            .map(Vec3::from)
            .collect();
        let joint_indices = match attribute(Mesh::ATTRIBUTE_JOINT_INDEX) {
            Some(VertexAttributeValues::Uint16x4(j)) => j.clone(),
            _ => return Err("has no Uint16x4 joint indices".into()),
        };
        let joint_weights = match attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT) {
            Some(VertexAttributeValues::Float32x4(w)) => w.clone(),
            _ => return Err("has no Float32x4 joint weights".into()),
        };
        let indices: Vec<u32> = match mesh.try_indices_option() {
            Err(_) => return Err("has its indices in the render world only".into()),
            Ok(Some(Indices::U16(i))) => i.iter().map(|&i| u32::from(i)).collect(),
            Ok(Some(Indices::U32(i))) => i.clone(),
            Ok(None) => (0..(positions.len() / 3 * 3) as u32).collect(),
        };
        if !indices.len().is_multiple_of(3)
            || indices.iter().any(|&i| i as usize >= positions.len())
        {
            return Err("has triangles naming vertices it does not have".into());
        }
        let vertices = SkinnedVertices {
            positions: &positions,
            joint_indices: &joint_indices,
            joint_weights: &joint_weights,
        };
        let bounds = SkinBounds::new(&vertices, &[], 0).map_err(|e| e.to_string())?;
        let uvs = match attribute(Mesh::ATTRIBUTE_UV_0) {
            Some(VertexAttributeValues::Float32x2(uvs)) => {
                Some(uvs.iter().copied().map(Vec2::from).collect())
            }
            _ => None,
        };
        Ok(Self {
            topology: indices.into(),
            positions,
            joint_indices,
            joint_weights,
            uvs,
            bounds,
        })
    }

    /// The asset's skinning attributes, as the core's skinning reads them.
    pub fn vertices(&self) -> SkinnedVertices<'_> {
        SkinnedVertices {
            positions: &self.positions,
            joint_indices: &self.joint_indices,
            joint_weights: &self.joint_weights,
        }
    }

    /// The vertex indices of triangle `triangle`.
    pub fn triangle_indices(&self, triangle: u32) -> [u32; 3] {
        let i = 3 * triangle as usize;
        [self.topology[i], self.topology[i + 1], self.topology[i + 2]]
    }
}

/// One skinned entity's pose as rays see it.
pub(crate) struct PosedEntity {
    pub(crate) shape: Arc<SkinnedShape>,
    /// The joints' skinning matrices (read at the first ray of each run of a system that
    /// casts rays: the joints cannot move while it runs).
    pub(crate) joints: Vec<Mat4>,
    /// A box around the posed surface of `joints`' pose.
    pub(crate) bound: Aabb,
    /// The posed tree, built at the first ray that reaches the entity.
    pub(crate) bvh: Option<PosedMeshBvh>,
    /// The matrices `bvh` was posed with.
    posed_with: Vec<Mat4>,
    /// The system run whose joints `joints` holds.
    read_at: Tick,
}

impl PosedEntity {
    /// The posed tree for this frame's joints: built, or refit if the pose changed since.
    /// `None` when the pose cannot be skinned (logged once by the caller).
    pub(crate) fn posed_bvh(&mut self, refits: &mut usize) -> Option<&PosedMeshBvh> {
        if self.bvh.is_none() {
            let mut posed = Vec::new();
            spatial_accel::mesh::skin_positions(
                &self.shape.vertices(),
                &self.joints,
                None,
                &mut posed,
            )
            .ok()?;
            self.bvh = PosedMeshBvh::new(self.shape.topology.clone(), posed).ok();
            self.posed_with.clone_from(&self.joints);
            *refits += 1;
        } else if self.posed_with != self.joints {
            let bvh = self.bvh.as_mut()?;
            bvh.skin(&self.shape.vertices(), &self.joints, None).ok()?;
            self.posed_with.clone_from(&self.joints);
            *refits += 1;
        }
        self.bvh.as_ref()
    }
}

/// What the posed meshes keep between rays: per mesh asset its shape, per entity its pose.
#[derive(Default)]
pub(crate) struct PosedState {
    shapes: HashMap<AssetId<Mesh>, Result<Arc<SkinnedShape>, ()>>,
    pub(crate) entities: EntityHashMap<PosedEntity>,
    /// Entities whose skin could not be read this frame, so they are tested on their bind
    /// pose: warned about once each.
    warned: EntityHashMap<()>,
    /// Posed trees built or refit since the stats last took the count.
    pub(crate) refits: usize,
}

/// The posed trees of skinned entities behind [`AccelRayCast`](crate::picking::AccelRayCast)
/// and the picking backend. Behind a lock, as [`AccelMeshCache`](super::AccelMeshCache), so
/// that ray casts from a shared `Res` can build and refit them. An entity's entry goes with
/// its `SkinnedMesh`.
#[derive(Resource, Default)]
pub struct AccelPosedMeshes {
    pub(crate) state: Mutex<PosedState>,
}

impl AccelPosedMeshes {
    /// Skinned entities with a pose read since their `SkinnedMesh` came.
    pub fn len(&self) -> usize {
        self.lock().entities.len()
    }

    /// True when no skinned entity has a pose.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Posed trees built or refit since the last call (the picking stats take it each frame).
    pub fn take_refits(&self) -> usize {
        core::mem::take(&mut self.lock().refits)
    }

    pub(crate) fn lock(&self) -> std::sync::MutexGuard<'_, PosedState> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// What reading a skinned entity's pose needs.
pub(crate) struct SkinInputs<'a> {
    pub(crate) meshes: &'a Assets<Mesh>,
    pub(crate) bindposes: Option<&'a Assets<SkinnedMeshInverseBindposes>>,
    pub(crate) joints: &'a Query<'a, 'a, &'static GlobalTransform>,
    /// The casting system's run.
    pub(crate) this_run: Tick,
}

impl PosedState {
    /// Brings `entity`'s pose to this frame: its joints' matrices and the box around them.
    /// `false` when the entity cannot be posed (its mesh or skin is missing or malformed;
    /// one warning per entity): rays then test it as an unskinned mesh, on its bind pose.
    pub(crate) fn update_pose(
        &mut self,
        entity: Entity,
        mesh: AssetId<Mesh>,
        skin: &SkinnedMesh,
        inputs: &SkinInputs,
    ) -> bool {
        if let Some(posed) = self.entities.get(&entity)
            && posed.read_at == inputs.this_run
        {
            return true;
        }
        match self.read_pose(entity, mesh, skin, inputs) {
            Ok(()) => true,
            Err(reason) => {
                self.entities.remove(&entity);
                if self.warned.insert(entity, ()).is_none() {
                    warn!(
                        "bevy_accel picking: skinned entity {entity} {reason}; rays test its \
                         bind pose, as Bevy's do"
                    );
                }
                false
            }
        }
    }

    fn read_pose(
        &mut self,
        entity: Entity,
        mesh: AssetId<Mesh>,
        skin: &SkinnedMesh,
        inputs: &SkinInputs,
    ) -> Result<(), String> {
        let shape = match self.shapes.get(&mesh) {
            Some(shape) => shape.clone(),
            None => {
                let asset = inputs.meshes.get(mesh).ok_or("has no mesh asset yet")?;
                let shape = SkinnedShape::from_mesh(asset)
                    .map(Arc::new)
                    .map_err(|reason| {
                        warn!("bevy_accel picking: skinned mesh {mesh:?} {reason}");
                    });
                self.shapes.insert(mesh, shape.clone());
                shape
            }
        }
        .map_err(|()| "has a mesh that cannot be posed".to_string())?;
        let bindposes = inputs
            .bindposes
            .and_then(|assets| assets.get(&skin.inverse_bindposes))
            .ok_or("has no inverse bindposes asset")?;
        // Bevy's skin extraction: a joint without a transform or a bindpose is the identity.
        let globals: Vec<Mat4> = skin
            .joints
            .iter()
            .map(|&joint| {
                inputs
                    .joints
                    .get(joint)
                    .map_or(Mat4::IDENTITY, |g| Mat4::from(g.affine()))
            })
            .collect();
        let posed = self.entities.entry(entity).or_insert_with(|| PosedEntity {
            shape: shape.clone(),
            joints: Vec::new(),
            bound: Aabb::EMPTY,
            bvh: None,
            posed_with: Vec::new(),
            read_at: Tick::new(inputs.this_run.get().wrapping_sub(1)),
        });
        if !Arc::ptr_eq(&posed.shape, &shape) {
            // A new mesh asset: its tree is built again at the next ray.
            posed.shape = shape;
            posed.bvh = None;
        }
        let mut matrices = core::mem::take(&mut posed.joints);
        joint_matrices(&globals, bindposes, &mut matrices);
        posed.joints = matrices;
        posed.read_at = inputs.this_run;
        posed.bound = posed
            .shape
            .bounds
            .bound(&posed.joints, &[])
            .map_err(|e| format!("cannot be posed: {e}"))?;
        self.warned.remove(&entity);
        Ok(())
    }

    /// Forgets shapes of mesh assets that changed, and their entities' trees.
    pub(crate) fn forget_mesh(&mut self, mesh: AssetId<Mesh>) {
        if let Some(Ok(shape)) = self.shapes.remove(&mesh) {
            self.entities
                .retain(|_, posed| !Arc::ptr_eq(&posed.shape, &shape));
        }
    }
}

/// Gives back an entity's posed tree when its `SkinnedMesh` goes (or the entity does).
pub(crate) fn forget_unskinned(remove: On<Remove, SkinnedMesh>, posed: Res<AccelPosedMeshes>) {
    let mut state = posed.lock();
    state.entities.remove(&remove.entity);
    state.warned.remove(&remove.entity);
}
