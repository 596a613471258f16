//! The posed entities' part of a ray cast: which skinned and morphed entities a ray tests
//! itself (the first pass) and which it leaves to the trees, and a ray's hit on a pose.

use super::ray_cast::{PendingHit, visible};
use crate::meshes::{AccelPosedMeshes, PosedState, Posing, SkinInputs};
use bevy::camera::visibility::{DynamicSkinnedMeshBounds, InheritedVisibility, ViewVisibility};
use bevy::ecs::entity::EntityHashSet;
use bevy::ecs::system::lifetimeless::Read;
use bevy::ecs::system::{SystemChangeTick, SystemParam};
use bevy::mesh::Mesh3d;
use bevy::mesh::morph::{MeshMorphWeights, MorphWeights};
use bevy::mesh::skinning::{SkinnedMesh, SkinnedMeshInverseBindposes};
use bevy::picking::mesh_picking::ray_cast::{MeshRayCastSettings, RayCastBackfaces, RayMeshHit};
use bevy::prelude::*;
use core::sync::atomic::Ordering;
use spatial_accel::{Backfaces, Ray};

/// What a posed candidate is read for (see [`crate::meshes::AccelPosedMeshes`]).
pub(super) type PosedTargetData = (
    Entity,
    Option<Read<SkinnedMesh>>,
    Option<Read<MeshMorphWeights>>,
    Read<Mesh3d>,
    Read<GlobalTransform>,
    Read<InheritedVisibility>,
    Read<ViewVisibility>,
    Has<RayCastBackfaces>,
    Has<DynamicSkinnedMeshBounds>,
);

/// The entities Bevy poses before drawing: skinned, or with morph weights.
pub(super) type PosedFilter = Or<(With<SkinnedMesh>, With<MeshMorphWeights>)>;

/// Skinned and morphed meshes, tested at their posed vertices beside the trees' candidates.
#[derive(SystemParam)]
pub(crate) struct SkinnedTargets<'w, 's> {
    pub(super) posed: Option<Res<'w, AccelPosedMeshes>>,
    pub(super) targets: Query<'w, 's, PosedTargetData, PosedFilter>,
    pub(super) joints: Query<'w, 's, &'static GlobalTransform>,
    pub(super) morph_weights: Query<'w, 's, &'static MorphWeights>,
    pub(super) bindposes: Option<Res<'w, Assets<SkinnedMeshInverseBindposes>>>,
    pub(super) ticks: SystemChangeTick,
    /// The posed entities this ray's first pass tested (the walk skips them).
    pub(super) tested: Local<'s, EntityHashSet>,
}

impl SkinnedTargets<'_, '_> {
    /// The inputs a pose is read from.
    pub(super) fn inputs<'a>(&'a self, meshes: &'a Assets<Mesh>) -> SkinInputs<'a> {
        SkinInputs {
            meshes,
            bindposes: self.bindposes.as_deref(),
            joints: &self.joints,
            morph_weights: &self.morph_weights,
            this_run: self.ticks.this_run(),
        }
    }

    /// The first pass of a ray: poses and tests the posed entities that the trees cannot find
    /// by their pose (see [`SkinnedTargets::list_first_pass`]), before the walk, so that their nearest
    /// blocking hit bounds it. Fills `tested` with those it posed (the walk skips them).
    pub(super) fn first_pass(
        &self,
        state: &mut PosedState,
        meshes: &Assets<Mesh>,
        world_ray: &mut Ray,
        settings: &MeshRayCastSettings,
        (hits, tested): (&mut Vec<PendingHit>, &mut EntityHashSet),
    ) {
        tested.clear();
        if let Some(posed) = &self.posed
            && !posed.first_pass_listed.load(Ordering::Acquire)
        {
            let settled = self.list_first_pass(state, meshes);
            posed.first_pass_listed.store(settled, Ordering::Release);
        }
        let first_pass = core::mem::take(&mut state.first_pass);
        let inputs = self.inputs(meshes);
        for &entity in &first_pass {
            let Ok((_, skin, morph, mesh3d, transform, inherited, view, two_sided, _)) =
                self.targets.get(entity)
            else {
                continue;
            };
            let posing = skin.map_or(Posing::MorphOnly(transform), Posing::Skin);
            // One that cannot be posed is left to the walk, which tests it unposed.
            if !state.update_pose(entity, mesh3d.id(), posing, morph, &inputs) {
                continue;
            }
            tested.insert(entity);
            if !(visible(settings.visibility, Some(inherited), Some(view))
                && (settings.filter)(entity))
            {
                continue;
            }
            let Some((entry, hit)) = posed_hit(state, entity, world_ray, two_sided) else {
                continue;
            };
            let distance = hit.distance;
            hits.push(PendingHit { entity, entry, hit });
            if (settings.early_exit_test)(entity) && distance < world_ray.t_max {
                world_ray.t_max = distance;
            }
        }
        state.first_pass = first_pass;
    }

    /// Lists the posed entities of the first pass: all but the skinned ones whose Bevy box the
    /// trees hold and that box provably holds the pose (see
    /// [`SkinnedShape::bevy_bounds_hold`](crate::meshes::SkinnedShape::bevy_bounds_hold)).
    /// Kept until a posed entity, its mesh or its bounds change: deciding it each ray read
    /// every posed entity's mesh, whatever the ray.
    /// False while a mesh is still loading: the list is made again at the next ray.
    fn list_first_pass(&self, state: &mut PosedState, meshes: &Assets<Mesh>) -> bool {
        state.first_pass.clear();
        // A mesh still loading cannot be judged: judge again at the next ray.
        let mut loading = false;
        for (entity, skin, _, mesh3d, _, _, _, _, bevy_bounds) in &self.targets {
            loading |= !meshes.contains(mesh3d.id());
            if bevy_bounds && skin.is_some() && state.bevy_bounds_hold(mesh3d.id(), meshes) {
                continue;
            }
            state.first_pass.push(entity);
        }
        !loading
    }
}

/// Lists the first pass again when an entity's skin, morph weights or Bevy's posed bounds
/// come or go (an entity despawned removes them too). Components that few entities carry:
/// an observer of every mesh entity's `Mesh3d` would add to the spawn of each (see
/// [`watch_posed_meshes`] for those).
pub(crate) fn first_pass_changed(
    _: On<Insert, (SkinnedMesh, MeshMorphWeights, DynamicSkinnedMeshBounds)>,
    posed: Res<AccelPosedMeshes>,
) {
    posed.first_pass_listed.store(false, Ordering::Release);
}

/// See [`first_pass_changed`].
pub(crate) fn first_pass_lost(
    _: On<Remove, (SkinnedMesh, MeshMorphWeights, DynamicSkinnedMeshBounds)>,
    posed: Res<AccelPosedMeshes>,
) {
    posed.first_pass_listed.store(false, Ordering::Release);
}

/// Lists the first pass again when a posed entity's mesh handle changed: a check of each
/// posed entity's change tick a frame, where an observer of `Mesh3d` would run at every mesh
/// entity's spawn. Rays cast before it in the frame of the change see it from the next.
pub(crate) fn watch_posed_meshes(
    changed: Query<(), (PosedFilter, Changed<Mesh3d>)>,
    posed: Res<AccelPosedMeshes>,
) {
    if !changed.is_empty() {
        posed.first_pass_listed.store(false, Ordering::Release);
    }
}

/// The nearest hit on a posed entity's triangles, with the entry distance into its posed
/// box; only the pieces of the mesh the ray reaches are skinned. In world space:
/// the normal is the posed triangle's unit geometric normal (the vertex normals are the
/// bind pose's), the triangle its posed corners.
pub(super) fn posed_hit(
    state: &mut PosedState,
    entity: Entity,
    world: &Ray,
    two_sided: bool,
) -> Option<(f32, RayMeshHit)> {
    let PosedState {
        entities,
        refits,
        scratch,
        ..
    } = state;
    let posed = entities.get(&entity)?;
    let entry = world.intersect_aabb(&posed.bound)?;
    let backfaces = if two_sided {
        Backfaces::Include
    } else {
        Backfaces::Cull
    };
    *refits += 1;
    let (hit, corners) = posed.cast_ray(world, backfaces, scratch)?;
    let shape = &posed.shape;
    let [ia, ib, ic] = shape.triangle_indices(hit.triangle).map(|i| i as usize);
    let [w, u, v] = hit.barycentrics;
    let uv = shape
        .uvs
        .as_ref()
        .and_then(|uv| Some(*uv.get(ia)? * w + *uv.get(ib)? * u + *uv.get(ic)? * v));
    Some((
        entry,
        RayMeshHit {
            point: world.at(hit.t).into(),
            normal: Vec3::from(hit.geometric_normal),
            barycentric_coords: Vec3::new(w, u, v),
            distance: hit.t,
            triangle: Some(corners),
            uv,
            triangle_index: Some(hit.triangle as usize),
        },
    ))
}
