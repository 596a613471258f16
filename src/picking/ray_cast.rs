//! [`AccelRayCast`]: Bevy's `MeshRayCast`, answered through the trees and per-mesh BVHs.

use super::posed_pass::{SkinnedTargets, posed_hit};
use crate::meshes::{
    AccelMeshCache, CachedMesh, MeshShape, Posing, SlotMeshLookup, SlotMeshTable, ray_cast_mesh,
};
use crate::trees::{TreeReaderPin, placement};
use crate::{AccelTrees, LocalFrame};
use bevy::camera::primitives::Aabb as BevyAabb;
use bevy::camera::visibility::{InheritedVisibility, ViewVisibility};
use bevy::ecs::entity::Entities;
use bevy::ecs::system::SystemParam;
use bevy::ecs::system::lifetimeless::Read;
use bevy::math::{Ray3d, Vec3A};
use bevy::mesh::{Mesh2d, Mesh3d};
use bevy::picking::mesh_picking::ray_cast::{
    MeshRayCastSettings, RayCastBackfaces, RayCastVisibility, RayMeshHit, SimplifiedMesh,
};
use bevy::prelude::*;
use spatial_accel::query::ray_walk::closest_hit_announcing;
use spatial_accel::{Backfaces, Ray};
use std::borrow::Cow;

/// The entities Bevy's `MeshRayCast` can hit: those with a mesh.
type MeshFilter = Or<(With<Mesh3d>, With<Mesh2d>, With<SimplifiedMesh>)>;

/// What a mesh ray cast reads of a candidate that passed the oriented-box test (which reads
/// the slot's [`LocalFrame`](crate::LocalFrame) instead of the ECS: a third of the candidates
/// stop there). With the `Aabb` and the transform in the frame, the same components as
/// `MeshRayCast`.
///
/// No `GlobalTransform`: a hit's world data comes from the frame's inverse (see
/// [`LocalFrame::world_from_local`](crate::LocalFrame::world_from_local)): waiting for that
/// row was a large share of a candidate's test (BENCHMARKS.md, Picking).
type MeshTargetData = (
    Read<InheritedVisibility>,
    Read<ViewVisibility>,
    Option<Read<Mesh2d>>,
    Option<Read<Mesh3d>>,
    Option<Read<SimplifiedMesh>>,
    Has<RayCastBackfaces>,
);

/// What a mesh ray cast reads of a candidate whose mesh the [`SlotMeshTable`] gave, once
/// the ray has hit that mesh: whether it counts. Not read at all when the visibility setting
/// is `Any` and the table knows the entity has both rows (see
/// [`SlotMeshLookup::Mesh`]'s `visibility_rows`).
type MeshHitData = (Read<InheritedVisibility>, Read<ViewVisibility>);

/// What a bounds-only ray cast reads: any tracked entity, visible unless its visibility
/// components say otherwise (its box and transform are in its slot's frame).
type BoundsTargetData = (
    Option<Read<InheritedVisibility>>,
    Option<Read<ViewVisibility>>,
);

/// A hit found during traversal, before the blocking cut and the sort.
pub(super) struct PendingHit {
    pub(super) entity: Entity,
    /// Entry distance into the entity's box (its oriented box for mesh hits): orders
    /// equal-distance hits as Bevy's candidate list, sorted by that distance, does.
    pub(super) entry: f32,
    pub(super) hit: RayMeshHit,
}

/// What a ray is tested against.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Target {
    /// Mesh triangles (entities with `Mesh3d`, `Mesh2d` or `SimplifiedMesh`).
    Meshes,
    /// Every tracked entity's oriented `Aabb`.
    Bounds,
}

/// Casts rays into the world through the [`AccelTrees`] and each mesh's BVH: a drop-in for
/// Bevy's `MeshRayCast` (same `cast_ray` signature, settings and results), so switching is a
/// change of type. Overlap and nearest queries on the entities' boxes are
/// [`AccelSpatialQuery`](crate::AccelSpatialQuery)'s.
///
/// ```
/// # use bevy::prelude::*;
/// # use bevy::picking::mesh_picking::ray_cast::MeshRayCastSettings;
/// # use bevy_accel::prelude::*;
/// fn pick(mut ray_cast: AccelRayCast) {
///     let ray = Ray3d::new(Vec3::ZERO, Dir3::NEG_Z);
///     if let Some((entity, hit)) = ray_cast.cast_ray(ray, &MeshRayCastSettings::default()).first() {
///         info!("{entity} at {}", hit.distance);
///     }
/// }
/// ```
///
/// Semantics are `MeshRayCast`'s: the hits are every hit of an entity that passes the
/// visibility setting and the filter, no farther than the nearest hit of an entity for which
/// `early_exit_test` is true, nearest first. Candidates come from the trees, so only entities
/// the trees hold are hit (not those with [`AccelIgnore`](crate::AccelIgnore), nor, with
/// [`AccelSettings::require_marker`](crate::AccelSettings), those without
/// [`AccelTracked`](crate::AccelTracked)). Triangles are tested with the watertight test, in
/// the mesh's space, through a BVH per mesh asset cached in [`AccelMeshCache`]. Meshes that
/// cannot be read (not a triangle list, render-world only, an index count that is not a
/// multiple of three) are hit on their `Aabb` instead of being skipped, with one warning per
/// asset; triangles naming a vertex the mesh lacks are skipped, as Bevy skips them.
///
/// Where results can differ from `MeshRayCast`, by design:
/// - entities are where the sync last placed them (see [`AccelTrees`]): a transform written
///   after `AccelSystems::Sync`, a static entity moved while
///   [`AccelSettings::watch_static_motion`](crate::AccelSettings) is off, or any motion while
///   [`AccelSettings::enabled`](crate::AccelSettings) is off, is seen only once synced;
/// - a mesh asset edited or removed this frame is seen from the next (see [`AccelMeshCache`]);
/// - while the [`SlotMeshTable`] is on (many rays per frame), an entity's mesh handle,
///   `SimplifiedMesh` or `RayCastBackfaces` changed after `AccelSystems::Sync` is seen from
///   the next frame, as its transform is;
/// - the watertight triangle test has no epsilon: triangles too small or thin for Bevy's
///   Möller-Trumbore test (determinant below `f32::EPSILON`) are hit, and rays through a
///   shared edge never fall between its triangles; where two triangles tie, the one reported
///   may differ (same distance and point);
/// - a hit's point is the world ray at the hit's distance, and its normal and triangle are
///   mapped to world space by the inverse of the entity's
///   [`LocalFrame`](crate::LocalFrame), not by its `GlobalTransform` row: they agree with
///   Bevy's to within rounding.
///
/// Requires [`AccelPlugin`](crate::AccelPlugin) and
/// [`AccelPickingPlugin`](super::AccelPickingPlugin).
#[derive(SystemParam)]
pub struct AccelRayCast<'w, 's> {
    trees: Res<'w, AccelTrees>,
    /// Registers the system as a reader: the trees it reads never step aside (see
    /// [`AccelTrees::stepped_aside`]).
    _reader: Local<'s, TreeReaderPin>,
    locations: &'w Entities,
    meshes: Res<'w, Assets<Mesh>>,
    cache: Res<'w, AccelMeshCache>,
    slot_meshes: Res<'w, SlotMeshTable>,
    mesh_targets: Query<'w, 's, MeshTargetData, MeshFilter>,
    mesh_hits: Query<'w, 's, MeshHitData, MeshFilter>,
    bounds_targets: Query<'w, 's, BoundsTargetData>,
    /// Busy movers' rows: their own space is not kept in the trees (see
    /// [`AccelTrees::local_frame`]).
    busy_rows: Query<'w, 's, (Read<BevyAabb>, Read<GlobalTransform>)>,
    skinned: SkinnedTargets<'w, 's>,
    hits: Local<'s, Vec<PendingHit>>,
    output: Local<'s, Vec<(Entity, RayMeshHit)>>,
    batch_output: Local<'s, Vec<(usize, Entity, RayMeshHit)>>,
}

impl<'w, 's> AccelRayCast<'w, 's> {
    /// Casts the `ray` against meshes and returns the hits, nearest first (as
    /// `MeshRayCast::cast_ray`).
    pub fn cast_ray(
        &mut self,
        ray: Ray3d,
        settings: &MeshRayCastSettings,
    ) -> &[(Entity, RayMeshHit)] {
        self.cast_ray_within(ray, f32::INFINITY, settings)
    }

    /// [`AccelRayCast::cast_ray`] limited to hits at most `max_distance` from the origin; the
    /// trees skip everything farther, so short rays are cheap in large worlds.
    pub fn cast_ray_within(
        &mut self,
        ray: Ray3d,
        max_distance: f32,
        settings: &MeshRayCastSettings,
    ) -> &[(Entity, RayMeshHit)] {
        self.collect(ray, max_distance, Target::Meshes, settings);
        self.output.clear();
        self.output
            .extend(self.hits.drain(..).map(|h| (h.entity, h.hit)));
        &self.output
    }

    /// Casts the `ray` against the oriented `Aabb` of every tracked entity, mesh or not.
    /// Hits carry a point, the box face's normal and the distance; no triangle data. The
    /// settings apply as in [`AccelRayCast::cast_ray`]; an entity without visibility
    /// components counts as visible.
    pub fn cast_ray_bounds(
        &mut self,
        ray: Ray3d,
        max_distance: f32,
        settings: &MeshRayCastSettings,
    ) -> &[(Entity, RayMeshHit)] {
        self.collect(ray, max_distance, Target::Bounds, settings);
        self.output.clear();
        self.output
            .extend(self.hits.drain(..).map(|h| (h.entity, h.hit)));
        &self.output
    }

    /// Casts many rays against meshes: `(ray index, entity, hit)`, by ray, each ray's hits
    /// nearest first. Buffers are shared across the batch.
    pub fn cast_rays(
        &mut self,
        rays: &[Ray3d],
        max_distance: f32,
        settings: &MeshRayCastSettings,
    ) -> &[(usize, Entity, RayMeshHit)] {
        self.batch_output.clear();
        for (i, &ray) in rays.iter().enumerate() {
            self.collect(ray, max_distance, Target::Meshes, settings);
            self.batch_output
                .extend(self.hits.drain(..).map(|h| (i, h.entity, h.hit)));
        }
        &self.batch_output
    }

    /// Skinned entities' posed trees built or refit since the last call (see
    /// [`AccelPosedMeshes`](crate::meshes::AccelPosedMeshes)).
    pub fn take_posed_refits(&self) -> usize {
        self.skinned.posed.as_ref().map_or(0, |p| p.take_refits())
    }

    /// The trees the queries run on.
    pub fn trees(&self) -> &AccelTrees {
        &self.trees
    }

    /// Fills `hits` with the ray's hits, cut at the nearest blocking hit and sorted.
    fn collect(
        &mut self,
        ray: Ray3d,
        max_distance: f32,
        target: Target,
        settings: &MeshRayCastSettings,
    ) {
        let Self {
            trees,
            locations,
            meshes,
            cache,
            slot_meshes,
            mesh_targets,
            mesh_hits,
            bounds_targets,
            busy_rows,
            skinned,
            hits,
            ..
        } = self;
        // A slot's own space: kept by the trees, or for a busy mover taken from its rows as
        // the sync placed it.
        let frame_of = |slot: u32, entity: Entity| match trees.local_frame(slot) {
            Some(frame) => Some(Cow::Borrowed(frame)),
            None => {
                let (aabb, gt) = busy_rows.get(entity).ok()?;
                placement(aabb, gt).ok().map(|at| Cow::Owned(at.frame()))
            }
        };
        hits.clear();
        trees.count_rays(1);
        // A NaN or negative `max_distance` gives an empty range: the ray hits nothing.
        let world_ray = Ray::with_range(ray.origin, *ray.direction, 0.0, max_distance);
        // The traversal's range shrinks only at blocking hits (the callback returns their
        // distance); other hits are kept without shrinking it, as Bevy keeps collecting past
        // hits whose entity does not pass `early_exit_test`.
        // Where a wide node holds several candidates in range, their slot records (and slot
        // mesh table entries) are asked for together: each candidate's test starts with a miss
        // on its record, and those misses then overlap instead of following one another.
        let announce = |slot| {
            trees.prefetch_candidate(slot);
            slot_meshes.prefetch(slot);
        };
        // Whether a candidate passes the visibility setting and the filter.
        let counts = |entity, inherited, view| {
            visible(settings.visibility, inherited, view) && (settings.filter)(entity)
        };
        // Skinned meshes first, at their posed vertices (they are skipped in the walk below):
        // their nearest blocking hit then bounds the walk.
        let mut tested = core::mem::take(&mut *skinned.tested);
        let mut posed = match (target, &skinned.posed) {
            (Target::Meshes, Some(posed)) if !skinned.targets.is_empty() => Some(posed.lock()),
            _ => None,
        };
        let mut world_ray = world_ray;
        if let Some(state) = posed.as_deref_mut() {
            skinned.first_pass(state, meshes, &mut world_ray, settings, (hits, &mut tested));
        }
        let mut posed = posed.as_deref_mut();
        let skin_inputs = skinned.inputs(meshes);
        let skinned_cut = world_ray.t_max;
        let blocking = closest_hit_announcing(trees.query(), &world_ray, announce, |slot, r| {
            let (entity, entry, hit) = match target {
                Target::Meshes => {
                    let entity = trees.entity(slot)?;
                    if let Some(state) = posed.as_deref_mut() {
                        if tested.contains(&entity) {
                            return None;
                        }
                        // A skinned entity the trees found by Bevy's posed box: posed now.
                        if let Ok((_, Some(skin), morph, mesh3d, _, inherited, view, two_sided, _)) =
                            skinned.targets.get(entity)
                            && state.update_pose(
                                entity,
                                mesh3d.id(),
                                Posing::Skin(skin),
                                morph,
                                &skin_inputs,
                            )
                        {
                            if !counts(entity, Some(inherited), Some(view)) {
                                return None;
                            }
                            let (entry, hit) = posed_hit(state, entity, r, two_sided)?;
                            let distance = hit.distance;
                            hits.push(PendingHit { entity, entry, hit });
                            return (settings.early_exit_test)(entity).then_some(distance);
                        }
                    }
                    // With the table on, the ECS is read only for the meshes a ray hits.
                    let known = slot_meshes.lookup(slot, entity);
                    match known {
                        Some(SlotMeshLookup::NoMesh) => return None,
                        // The entity's location record, asked for now and read by the lookup
                        // below: its miss then overlaps the oriented-box test, instead of
                        // following it.
                        None => {
                            core::hint::black_box(locations.get(entity).ok().flatten());
                        }
                        Some(SlotMeshLookup::Mesh { .. }) => {}
                    }
                    // Bevy only tests meshes whose oriented box the ray meets. Tested before
                    // any component read: a third of the candidates stop here. No test of the
                    // exact world box first: the oriented box lies inside it, and the static
                    // trees' boxes are those boxes already.
                    let frame = &*frame_of(slot, entity)?;
                    let local = r.transformed(&frame.local_from_world);
                    let entry = local.intersect_aabb(&frame.local_bounds)?;
                    let hit = if let Some(SlotMeshLookup::Mesh {
                        cell,
                        two_sided,
                        visibility_rows,
                    }) = known
                    {
                        let shape = cell.shape(cache, meshes)?;
                        let hit = shape_hit(shape, frame, r, &local, two_sided)?;
                        if visibility_rows && matches!(settings.visibility, RayCastVisibility::Any)
                        {
                            counts(entity, None, None).then_some(hit)?
                        } else {
                            let (inherited, view) = mesh_hits.get(entity).ok()?;
                            counts(entity, Some(inherited), Some(view)).then_some(hit)?
                        }
                    } else {
                        let (inherited, view, mesh2d, mesh3d, simplified, both) =
                            mesh_targets.get(entity).ok()?;
                        if !counts(entity, Some(inherited), Some(view)) {
                            return None;
                        }
                        let (handle, two_sided) = ray_cast_mesh(mesh3d, mesh2d, simplified, both)?;
                        let shape = cache.get_or_build(handle.id(), meshes)?;
                        shape_hit(&shape, frame, r, &local, two_sided)?
                    };
                    (entity, entry, hit)
                }
                Target::Bounds => {
                    // The exact box first: most candidates of a leaf fail it, and they then
                    // cost no entity lookup.
                    let entry = r.intersect_aabb(&trees.world_bounds(slot))?;
                    let entity = trees.entity(slot)?;
                    let (inherited, view) = bounds_targets.get(entity).ok()?;
                    if !counts(entity, inherited, view) {
                        return None;
                    }
                    let frame = &*frame_of(slot, entity)?;
                    let local = r.transformed(&frame.local_from_world);
                    let hit = box_hit(frame, r, &local)?;
                    (entity, entry, hit)
                }
            };
            let distance = hit.distance;
            hits.push(PendingHit { entity, entry, hit });
            (settings.early_exit_test)(entity).then_some(distance)
        });
        let cut = blocking.map_or(skinned_cut, |b| b.t.min(skinned_cut));
        *skinned.tested = tested;
        hits.retain(|h| h.hit.distance <= cut);
        hits.sort_by(|a, b| {
            a.hit
                .distance
                .total_cmp(&b.hit.distance)
                .then(a.entry.total_cmp(&b.entry))
        });
    }
}

/// Whether an entity passes the visibility setting (missing components count as visible).
pub(super) fn visible(
    mode: RayCastVisibility,
    inherited: Option<&InheritedVisibility>,
    view: Option<&ViewVisibility>,
) -> bool {
    match mode {
        RayCastVisibility::Any => true,
        RayCastVisibility::Visible => inherited.is_none_or(|v| v.get()),
        RayCastVisibility::VisibleInView => view.is_none_or(|v| v.get()),
    }
}

/// The hit on a mesh's shape (its triangles, or its box where the mesh cannot be read);
/// `two_sided` counts back faces.
fn shape_hit(
    shape: &MeshShape,
    frame: &LocalFrame,
    world: &Ray,
    local: &Ray,
    two_sided: bool,
) -> Option<RayMeshHit> {
    match shape {
        MeshShape::Triangles(mesh) => {
            let backfaces = if two_sided {
                Backfaces::Include
            } else {
                Backfaces::Cull
            };
            triangle_hit(mesh, frame, world, local, backfaces)
        }
        MeshShape::Bounds => box_hit(frame, world, local),
    }
}

/// The nearest triangle hit, in Bevy's conventions: world point, normal in world space but
/// not renormalised (the interpolated vertex normal, or the unit geometric normal when the
/// mesh has none, transformed as a vector), barycentrics `(w, u, v)` of the index-order
/// corners, world triangle. `local` is `world` in the frame's space; both have the same
/// parameter (an affine map keeps it), so the world point is `world` at the hit's distance.
fn triangle_hit(
    mesh: &CachedMesh,
    frame: &LocalFrame,
    world: &Ray,
    local: &Ray,
    backfaces: Backfaces,
) -> Option<RayMeshHit> {
    let hit = mesh.bvh.cast_ray(local, backfaces)?;
    let affine = frame.world_from_local();
    let [ia, ib, ic] = mesh.triangle_indices(hit.triangle).map(|i| i as usize);
    let [w, u, v] = hit.barycentrics;
    let normal = mesh
        .normals
        .as_ref()
        .and_then(|n| Some(*n.get(ib)? * u + *n.get(ic)? * v + *n.get(ia)? * w))
        .unwrap_or(Vec3::from(hit.geometric_normal));
    let uv = mesh
        .uvs
        .as_ref()
        .and_then(|uv| Some(*uv.get(ia)? * w + *uv.get(ib)? * u + *uv.get(ic)? * v));
    let corners = [ia, ib, ic].map(|i| affine.transform_point3(mesh.positions[i]));
    Some(RayMeshHit {
        point: world.at(hit.t).into(),
        normal: affine.transform_vector3(normal),
        barycentric_coords: Vec3::new(w, u, v),
        distance: hit.t,
        triangle: Some(corners),
        uv,
        triangle_index: Some(hit.triangle as usize),
    })
}

/// The entry hit on the frame's local box (distance 0 from inside it), with the entered
/// face's normal (the reversed ray direction from inside), in world space. `local` is
/// `world` in the frame's space (see [`triangle_hit`]).
fn box_hit(frame: &LocalFrame, world: &Ray, local: &Ray) -> Option<RayMeshHit> {
    let local_box = &frame.local_bounds;
    let (near, far) = local.slab_interval(local_box.min, local_box.max);
    if near > far {
        return None;
    }
    let negative = local.inv_direction.cmplt(Vec3A::ZERO);
    let entry_plane = Vec3A::select(negative, local_box.max, local_box.min);
    let entry = (entry_plane - local.origin) * local.inv_direction;
    // NaN (an axis-parallel ray on a slab plane) never names the entered face.
    let entry = Vec3A::select(entry.is_nan_mask(), Vec3A::NEG_INFINITY, entry);
    let axis = if entry.x >= entry.y && entry.x >= entry.z {
        0
    } else if entry.y >= entry.z {
        1
    } else {
        2
    };
    let local_normal = if entry[axis] > 0.0 {
        let mut n = Vec3::ZERO;
        n[axis] = -local.direction[axis].signum();
        n
    } else {
        -Vec3::from(local.direction).normalize_or_zero()
    };
    Some(RayMeshHit {
        point: world.at(near).into(),
        normal: frame.world_from_local().transform_vector3(local_normal),
        barycentric_coords: Vec3::ZERO,
        distance: near,
        triangle: None,
        uv: None,
        triangle_index: None,
    })
}
