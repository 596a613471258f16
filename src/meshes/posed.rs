//! Skinned and morphed meshes as Bevy draws them: each such entity's triangles at their
//! posed positions (morph targets applied, then skinning), in a BVH of its own, refit only
//! when a ray reaches the entity and its pose changed since the last refit.
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
use bevy::mesh::morph::{MeshMorphWeights, MorphWeights};
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use core::sync::atomic::AtomicBool;
use spatial_accel::Aabb;
use spatial_accel::mesh::{
    MeshHit, MorphTargets, PosedMeshBvh, SkinBounds, SkinSegments, SkinnedVertices, joint_matrices,
    skin_positions,
};
use spatial_accel::{Backfaces, Ray};
use std::sync::{Arc, Mutex, PoisonError};

/// One posed mesh asset's vertex data, read once and shared by every entity that uses it.
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
    /// First texture coordinates, when the asset has `Float32x2` ones.
    pub uvs: Option<Vec<Vec2>>,
    /// The morph targets' position displacements, target-major (target `t`'s displacement
    /// of vertex `v` at `t * vertex_count + v`, as Bevy's glTF loader stores them); empty
    /// without targets.
    pub morph_displacements: Vec<Vec3>,
    /// How many morph targets the mesh has.
    pub morph_targets: usize,
    /// The box of any pose, from the joints' matrices and the morph weights alone.
    pub bounds: SkinBounds,
    /// The triangles by joint, for rays that meet a pose once (picking).
    pub segments: SkinSegments,
    /// Whether Bevy's `DynamicSkinnedMeshBounds` box holds every posed vertex: the mesh has
    /// Bevy's skinned bounds, no morph targets (which Bevy's box leaves out), and weights
    /// that are non-negative and sum to one at every vertex (as glTF requires), which make
    /// each posed vertex a blend of its joints' images of it, inside the joints' boxes that
    /// Bevy unites. Such entities are found by the trees like any mesh, and posed only when
    /// a ray reaches them.
    pub bevy_bounds_hold: bool,
}

impl SkinnedShape {
    /// Reads a skinned mesh asset, or with `skinned` false a mesh posed by its morph
    /// targets alone (then every vertex follows one joint, the entity's own transform, with
    /// weight one: the skinning formula then gives Bevy's unskinned vertex). `Err` says why
    /// it cannot be posed (rays then test it unposed, as Bevy's do).
    pub fn from_mesh(mesh: &Mesh, skinned: bool) -> Result<Self, String> {
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
        let (joint_indices, joint_weights) = if skinned {
            let joints = match attribute(Mesh::ATTRIBUTE_JOINT_INDEX) {
                Some(VertexAttributeValues::Uint16x4(j)) => j.clone(),
                _ => return Err("has no Uint16x4 joint indices".into()),
            };
            let weights = match attribute(Mesh::ATTRIBUTE_JOINT_WEIGHT) {
                Some(VertexAttributeValues::Float32x4(w)) => w.clone(),
                _ => return Err("has no Float32x4 joint weights".into()),
            };
            (joints, weights)
        } else {
            let n = positions.len();
            (vec![[0; 4]; n], vec![[1.0, 0.0, 0.0, 0.0]; n])
        };
        let morph_displacements: Vec<Vec3> = mesh
            .morph_targets()
            .map(|targets| targets.iter().map(|t| t.position).collect())
            .unwrap_or_default();
        let morph_targets = morph_displacements.len() / positions.len().max(1);
        if morph_targets * positions.len() != morph_displacements.len() {
            return Err("has morph targets of another vertex count".into());
        }
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
        let bounds = SkinBounds::new(&vertices, &morph_displacements, morph_targets)
            .map_err(|e| e.to_string())?;
        let segments = SkinSegments::new(&vertices, &morph_displacements, morph_targets, &indices)
            .map_err(|e| e.to_string())?;
        let bevy_bounds_hold = skinned
            && morph_targets == 0
            && mesh.skinned_mesh_bounds().is_some()
            && joint_weights.iter().all(|w| {
                w.iter().all(|&w| w >= 0.0) && (w.iter().sum::<f32>() - 1.0).abs() <= 1e-4
            });
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
            morph_displacements,
            morph_targets,
            bounds,
            segments,
            bevy_bounds_hold,
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

    /// The morph targets with `weights` (one per target), if the mesh has any.
    // For the posed trees, which only the preview builds.
    #[cfg_attr(not(feature = "preview"), allow(dead_code))]
    fn morph<'a>(&'a self, weights: &'a [f32]) -> Option<MorphTargets<'a>> {
        (self.morph_targets > 0).then_some(MorphTargets {
            weights,
            displacements: &self.morph_displacements,
        })
    }
}

/// One posed entity's pose as rays see it.
pub(crate) struct PosedEntity {
    pub(crate) shape: Arc<SkinnedShape>,
    /// The joints' skinning matrices (read at the first ray of each run of a system that
    /// casts rays: the joints cannot move while it runs).
    pub(crate) joints: Vec<Mat4>,
    /// The morph targets' weights (one per target of the mesh).
    pub(crate) morph_weights: Vec<f32>,
    /// A box around the posed surface of that pose.
    pub(crate) bound: Aabb,
    /// The posed tree, built at the first ray that reaches the entity.
    pub(crate) bvh: Option<PosedMeshBvh>,
    /// The matrices and morph weights `bvh` was posed with.
    #[cfg_attr(not(feature = "preview"), allow(dead_code))]
    posed_with: (Vec<Mat4>, Vec<f32>),
    /// The system run whose pose `joints` and `morph_weights` hold.
    read_at: Tick,
}

impl PosedEntity {
    /// The nearest hit of `ray` on the pose last read, and the hit triangle's posed corners:
    /// only the pieces the ray reaches are skinned (see [`SkinSegments`]), which is what a
    /// pose met by one ray, a pointer's, should cost. `None` for a miss or a pose that cannot
    /// be skinned.
    pub(crate) fn cast_ray(
        &self,
        ray: &Ray,
        backfaces: Backfaces,
        scratch: &mut Vec<Vec3>,
    ) -> Option<(MeshHit, [Vec3; 3])> {
        let shape = &self.shape;
        let vertices = shape.vertices();
        let hit = shape
            .segments
            .cast_ray(
                ray,
                backfaces,
                &vertices,
                &self.joints,
                &self.morph_weights,
                scratch,
            )
            .ok()??;
        // The hit triangle's corners, posed alone.
        let corners = shape.triangle_indices(hit.triangle).map(|i| i as usize);
        let n = shape.positions.len();
        let positions = corners.map(|v| shape.positions[v]);
        let joints = corners.map(|v| shape.joint_indices[v]);
        let weights = corners.map(|v| shape.joint_weights[v]);
        let morph: Vec<Vec3> = (0..shape.morph_targets)
            .flat_map(|t| corners.map(|v| shape.morph_displacements[t * n + v]))
            .collect();
        let three = SkinnedVertices {
            positions: &positions,
            joint_indices: &joints,
            joint_weights: &weights,
        };
        let morph = (shape.morph_targets > 0).then_some(MorphTargets {
            weights: &self.morph_weights,
            displacements: &morph,
        });
        skin_positions(&three, &self.joints, morph, scratch).ok()?;
        Some((hit, [scratch[0], scratch[1], scratch[2]]))
    }

    /// The posed tree for the pose last read: built, or refit if the pose changed since.
    /// `None` when the pose cannot be skinned.
    // Only the preview traces posed trees (picking skins segments, see `cast_ray`).
    #[cfg_attr(not(feature = "preview"), allow(dead_code))]
    pub(crate) fn posed_bvh(&mut self, refits: &mut usize) -> Option<&PosedMeshBvh> {
        let shape = &self.shape;
        let morph = shape.morph(&self.morph_weights);
        if self.bvh.is_none() {
            let mut posed = Vec::new();
            skin_positions(&shape.vertices(), &self.joints, morph, &mut posed).ok()?;
            self.bvh = PosedMeshBvh::new(shape.topology.clone(), posed).ok();
        } else if self.posed_with.0 != self.joints || self.posed_with.1 != self.morph_weights {
            let bvh = self.bvh.as_mut()?;
            bvh.skin(&shape.vertices(), &self.joints, morph).ok()?;
        } else {
            return self.bvh.as_ref();
        }
        self.posed_with.0.clone_from(&self.joints);
        self.posed_with.1.clone_from(&self.morph_weights);
        *refits += 1;
        self.bvh.as_ref()
    }
}

/// What the posed meshes keep between rays: per mesh asset its shape, per entity its pose.
#[derive(Default)]
pub(crate) struct PosedState {
    /// By mesh asset, and whether it is posed by a skin (a mesh may be both skinned and
    /// used unskinned with morph weights).
    shapes: HashMap<(AssetId<Mesh>, bool), Result<Arc<SkinnedShape>, ()>>,
    pub(crate) entities: EntityHashMap<PosedEntity>,
    /// Entities whose pose could not be read, so they are tested unposed: warned about once
    /// each.
    warned: EntityHashMap<()>,
    /// Posed entities skinned for rays (their reached pieces, or their whole tree
    /// refit) since the stats last took the count.
    pub(crate) refits: usize,
    /// A piece's posed vertices, between rays.
    pub(crate) scratch: Vec<Vec3>,
    /// The joints' global matrices of the pose being read, between reads.
    globals: Vec<Mat4>,
    /// The posed entities a ray poses and tests before the walk, while
    /// [`AccelPosedMeshes::first_pass_listed`] holds.
    pub(crate) first_pass: Vec<Entity>,
}

/// The posed trees of skinned and morphed entities behind
/// [`AccelRayCast`](crate::picking::AccelRayCast) and the picking backend. Behind a lock, as
/// [`AccelMeshCache`](super::AccelMeshCache), so that ray casts from a shared `Res` can build
/// and refit them. An entity's entry goes with its `SkinnedMesh` or `MeshMorphWeights`.
#[derive(Resource, Default)]
pub struct AccelPosedMeshes {
    pub(crate) state: Mutex<PosedState>,
    /// [`PosedState::first_pass`] is up to date: cleared when a posed entity's skin, morph
    /// weights, mesh or bounds come or go, or a mesh asset changes. Outside the lock: the
    /// observers and the per-frame check that clear it take no lock.
    pub(crate) first_pass_listed: AtomicBool,
}

impl AccelPosedMeshes {
    /// Posed entities with a pose read since they were posed.
    pub fn len(&self) -> usize {
        self.lock().entities.len()
    }

    /// True when no entity has a pose.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Posed trees built or refit since the last call (the picking stats take it each frame).
    pub fn take_refits(&self) -> usize {
        core::mem::take(&mut self.lock().refits)
    }

    /// Forgets the shapes of a mesh asset that changed, their entities' poses, and the list of
    /// the first pass (which judged entities by that asset).
    pub(crate) fn forget_mesh(&self, mesh: AssetId<Mesh>) {
        self.lock().forget_mesh(mesh);
        self.first_pass_listed
            .store(false, core::sync::atomic::Ordering::Release);
    }

    pub(crate) fn lock(&self) -> std::sync::MutexGuard<'_, PosedState> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// What reading a posed entity's pose needs.
pub(crate) struct SkinInputs<'a> {
    pub(crate) meshes: &'a Assets<Mesh>,
    pub(crate) bindposes: Option<&'a Assets<SkinnedMeshInverseBindposes>>,
    pub(crate) joints: &'a Query<'a, 'a, &'static GlobalTransform>,
    /// Shared morph weights, for entities whose `MeshMorphWeights` refer to them.
    pub(crate) morph_weights: &'a Query<'a, 'a, &'static MorphWeights>,
    /// The casting system's run.
    pub(crate) this_run: Tick,
}

/// How an entity is posed: by its skin (after its morph targets, if its mesh has them), or
/// by its morph targets alone, on its own transform.
#[derive(Clone, Copy)]
pub(crate) enum Posing<'a> {
    Skin(&'a SkinnedMesh),
    MorphOnly(&'a GlobalTransform),
}

impl PosedState {
    /// Brings `entity`'s pose up to date: its joints' matrices, its morph weights and the box
    /// around them. `false` when the entity cannot be posed (its mesh or skin is missing or
    /// malformed; one warning per entity): rays then test it as an unposed mesh, as Bevy's do.
    pub(crate) fn update_pose(
        &mut self,
        entity: Entity,
        mesh: AssetId<Mesh>,
        posing: Posing,
        morph: Option<&MeshMorphWeights>,
        inputs: &SkinInputs,
    ) -> bool {
        if let Some(posed) = self.entities.get(&entity)
            && posed.read_at == inputs.this_run
        {
            return true;
        }
        match self.read_pose(entity, mesh, posing, morph, inputs) {
            Ok(()) => true,
            Err(reason) => {
                self.entities.remove(&entity);
                if self.warned.insert(entity, ()).is_none() {
                    warn!(
                        "bevy_accel picking: posed entity {entity} {reason}; rays test it \
                         unposed, as Bevy's do"
                    );
                }
                false
            }
        }
    }

    /// Whether a skinned entity of `mesh` carrying `DynamicSkinnedMeshBounds` can be left to
    /// the trees (see [`SkinnedShape::bevy_bounds_hold`]); false while the asset is missing.
    pub(crate) fn bevy_bounds_hold(&mut self, mesh: AssetId<Mesh>, meshes: &Assets<Mesh>) -> bool {
        self.shape(mesh, true, meshes)
            .is_ok_and(|shape| shape.bevy_bounds_hold)
    }

    /// The shape of `mesh`, read on first use (one warning for a mesh that cannot be posed).
    fn shape(
        &mut self,
        mesh: AssetId<Mesh>,
        skinned: bool,
        meshes: &Assets<Mesh>,
    ) -> Result<Arc<SkinnedShape>, String> {
        match self.shapes.get(&(mesh, skinned)) {
            Some(shape) => shape.clone(),
            None => {
                let asset = meshes.get(mesh).ok_or("has no mesh asset yet")?;
                let shape = SkinnedShape::from_mesh(asset, skinned)
                    .map(Arc::new)
                    .map_err(|reason| warn!("bevy_accel picking: mesh {mesh:?} {reason}"));
                self.shapes.insert((mesh, skinned), shape.clone());
                shape
            }
        }
        .map_err(|()| "has a mesh that cannot be posed".to_string())
    }

    fn read_pose(
        &mut self,
        entity: Entity,
        mesh: AssetId<Mesh>,
        posing: Posing,
        morph: Option<&MeshMorphWeights>,
        inputs: &SkinInputs,
    ) -> Result<(), String> {
        let skinned = matches!(posing, Posing::Skin(_));
        let shape = self.shape(mesh, skinned, inputs.meshes)?;
        // Bevy's skin extraction: a joint without a transform or a bindpose is the identity.
        // The joints' globals go through a buffer kept between reads: the first ray of a
        // system run reads every posed entity.
        let mut globals = core::mem::take(&mut self.globals);
        globals.clear();
        let bindposes: &[Mat4] = match posing {
            Posing::Skin(skin) => {
                let bindposes = inputs
                    .bindposes
                    .and_then(|assets| assets.get(&skin.inverse_bindposes))
                    .ok_or("has no inverse bindposes asset")?;
                globals.extend(skin.joints.iter().map(|&joint| {
                    inputs
                        .joints
                        .get(joint)
                        .map_or(Mat4::IDENTITY, |g| Mat4::from(g.affine()))
                }));
                bindposes
            }
            Posing::MorphOnly(transform) => {
                globals.push(Mat4::from(transform.affine()));
                &[Mat4::IDENTITY]
            }
        };
        // Bevy draws the targets that have no weight (none given, or too few) at zero.
        let given = match morph {
            Some(MeshMorphWeights::Value { weights }) => weights.as_slice(),
            Some(MeshMorphWeights::Reference(owner)) => inputs
                .morph_weights
                .get(*owner)
                .map_or(&[][..], MorphWeights::weights),
            None => &[],
        };
        let shape_targets = shape.morph_targets;
        let posed = self.entities.entry(entity).or_insert_with(|| PosedEntity {
            shape: shape.clone(),
            joints: Vec::new(),
            morph_weights: Vec::new(),
            bound: Aabb::EMPTY,
            bvh: None,
            posed_with: (Vec::new(), Vec::new()),
            read_at: Tick::new(inputs.this_run.get().wrapping_sub(1)),
        });
        if !Arc::ptr_eq(&posed.shape, &shape) {
            // Another mesh asset: its tree is built again at the next ray.
            posed.shape = shape;
            posed.bvh = None;
        }
        joint_matrices(&globals, bindposes, &mut posed.joints);
        self.globals = globals;
        posed.morph_weights.clear();
        posed.morph_weights.resize(shape_targets, 0.0);
        for (w, given) in posed.morph_weights.iter_mut().zip(given) {
            *w = *given;
        }
        posed.read_at = inputs.this_run;
        posed.bound = posed
            .shape
            .bounds
            .bound(&posed.joints, &posed.morph_weights)
            .map_err(|e| format!("cannot be posed: {e}"))?;
        self.warned.remove(&entity);
        Ok(())
    }

    /// Forgets the shapes of a mesh asset that changed, and their entities' trees.
    pub(crate) fn forget_mesh(&mut self, mesh: AssetId<Mesh>) {
        for skinned in [false, true] {
            if let Some(Ok(shape)) = self.shapes.remove(&(mesh, skinned)) {
                self.entities
                    .retain(|_, posed| !Arc::ptr_eq(&posed.shape, &shape));
            }
        }
    }
}

/// Gives back an entity's posed tree when its `SkinnedMesh` or `MeshMorphWeights` goes (or
/// the entity does); a ray finds it again as it then is.
pub(crate) fn forget_unposed(
    remove: On<Remove, (SkinnedMesh, MeshMorphWeights)>,
    posed: Res<AccelPosedMeshes>,
) {
    let mut state = posed.lock();
    state.entities.remove(&remove.entity);
    state.warned.remove(&remove.entity);
}
