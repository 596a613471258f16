//! Shadow views of lights on the trees: the replacements for bevy_light's
//! `check_point_light_mesh_visibility` and `check_dir_light_mesh_visibility`.
//!
//! Bevy tests every shadow caster in the world against every shadow-mapped light each frame:
//! six cube faces per point light, one frustum per spot light, one per cascade and camera per
//! directional light. Here each light view walks the trees first, and Bevy's own per-entity
//! tests run only on what the walk found. The walks ([`super::light_walks`]) drop only what
//! Bevy's tests would drop, so the results are Bevy's.

use super::light_walks::{
    LightCandidates, light_planes, light_sphere_may_reach, walk_shape, walk_where,
};
use super::system::{CullingStats, ViewFilter};
use super::untracked::UntrackedEntities;
use crate::trees::AccelTrees;
use accel::{Containment, Frustum as AccelFrustum, SpatialQuery};
use bevy::camera::primitives::{Aabb, CascadesFrusta, CubemapFrusta, Frustum, Sphere};
use bevy::camera::visibility::{
    CascadesVisibleEntities, CubemapVisibleEntities, NoCpuCulling, NoFrustumCulling, RenderLayers,
    SetViewVisibility, VisibilityRange, VisibleEntities, VisibleEntityRanges, VisibleMeshEntities,
};
use bevy::camera::{RenderTarget, ShadowLodOrigin};
use bevy::ecs::entity::EntityHashSet;
use bevy::light::cluster::ClusterVisibilityClass;
use bevy::light::{
    DirectionalLight, NotShadowCaster, PointLight, SpotLight, get_shadow_lod_origin,
};
use bevy::math::{Affine3A, Vec3A, Vec4};
use bevy::mesh::Mesh3d;
use bevy::prelude::*;
use core::any::TypeId;
use std::time::Instant;

/// What deciding a shadow caster reads and writes: the item of Bevy's own query.
pub(super) type CasterItem = (
    Entity,
    &'static InheritedVisibility,
    &'static mut ViewVisibility,
    Option<&'static RenderLayers>,
    Option<&'static Aabb>,
    Option<&'static GlobalTransform>,
    Has<VisibilityRange>,
    Has<NoFrustumCulling>,
);

/// Bevy's filter for shadow casters.
pub(super) type CasterFilter = (
    Without<NotShadowCaster>,
    Without<DirectionalLight>,
    Without<NoCpuCulling>,
    With<Mesh3d>,
);

pub(super) type Casters<'w, 's> = Query<'w, 's, CasterItem, CasterFilter>;

type PointLightItem = (
    &'static PointLight,
    &'static GlobalTransform,
    &'static CubemapFrusta,
    &'static mut CubemapVisibleEntities,
    Option<&'static RenderLayers>,
);

type SpotLightItem = (
    &'static SpotLight,
    &'static GlobalTransform,
    &'static Frustum,
    &'static mut VisibleMeshEntities,
    Option<&'static RenderLayers>,
);

/// The lights `get_shadow_lod_origin` falls back on.
type PointOrSpotLight = Or<(With<PointLight>, With<SpotLight>)>;

type DirectionalLightItem = (
    Entity,
    &'static DirectionalLight,
    &'static CascadesFrusta,
    &'static mut CascadesVisibleEntities,
    Option<&'static RenderLayers>,
    &'static ViewVisibility,
);

/// Calls `decide` for each candidate that passes Bevy's rules before any bounds test
/// (hierarchy, layers, range), with its visibility, bounds and whether it has
/// `NoFrustumCulling`. A walked `NoFrustumCulling` entity is passed over: it comes again among
/// the entities no walk finds.
fn for_each_admitted(
    candidates: &LightCandidates,
    casters: &mut Casters,
    filter: &ViewFilter,
    mut decide: impl FnMut(Entity, Mut<ViewVisibility>, Option<&Aabb>, Option<&GlobalTransform>, bool),
) {
    for (entity, walked) in candidates.iter() {
        let Ok((entity, inherited, view_visibility, layers, aabb, transform, has_range, nfc)) =
            casters.get_mut(entity)
        else {
            continue;
        };
        if (walked && nfc) || !filter.admits(entity, inherited, layers, has_range) {
            continue;
        }
        decide(entity, view_visibility, aabb, transform, nfc);
    }
}

/// Decides the candidates of a point light (six faces) or a spot light (one) exactly as
/// `check_point_light_mesh_visibility` does; fills `lists` (one per face, sorted).
fn decide_point_or_spot(
    candidates: &LightCandidates,
    casters: &mut Casters,
    filter: &ViewFilter,
    light_sphere: &Sphere,
    frusta: &[Frustum],
    lists: &mut [Vec<Entity>],
) {
    for list in lists.iter_mut() {
        list.clear();
    }
    for_each_admitted(
        candidates,
        casters,
        filter,
        |entity, mut view_visibility, aabb, transform, nfc| {
            if let (Some(aabb), Some(transform)) = (aabb, transform) {
                let model_to_world = transform.affine();
                if !nfc && !light_sphere.intersects_obb(aabb, &model_to_world) {
                    return;
                }
                for (frustum, list) in frusta.iter().zip(lists.iter_mut()) {
                    if nfc || frustum.intersects_obb(aabb, &model_to_world, true, true) {
                        view_visibility.set_visible();
                        list.push(entity);
                    }
                }
            } else {
                view_visibility.set_visible();
                for list in lists.iter_mut() {
                    list.push(entity);
                }
            }
        },
    );
    for list in lists.iter_mut() {
        list.sort_unstable();
    }
}

/// Replaces `check_point_light_mesh_visibility`: the shadow casters of every point and spot
/// light that a camera's clusters hold, found through the trees.
#[allow(clippy::too_many_arguments)]
pub(crate) fn cull_point_and_spot_lights(
    trees: Res<AccelTrees>,
    untracked: UntrackedEntities,
    ranges: Option<Res<VisibleEntityRanges>>,
    views: Query<&VisibleEntities>,
    mut point_lights: Query<PointLightItem>,
    mut spot_lights: Query<SpotLightItem>,
    mut casters: Casters,
    mut camera_query: Query<(Entity, &RenderTarget), With<Camera>>,
    mut shadow_lod_origin_query: Query<Entity, With<ShadowLodOrigin>>,
    mut point_and_spot_light_query: Query<Entity, PointOrSpotLight>,
    mut checked_lights: Local<EntityHashSet>,
    mut candidates: Local<LightCandidates>,
    mut shape: Local<Vec<u32>>,
    mut face_lists: Local<[Vec<Entity>; 6]>,
    mut stats: ResMut<CullingStats>,
) {
    let start = Instant::now();
    checked_lights.clear();
    candidates.start_frame(trees.is_changed());
    let range_view = get_shadow_lod_origin(
        camera_query.transmute_lens_filtered(),
        shadow_lod_origin_query.transmute_lens_filtered(),
        point_and_spot_light_query.transmute_lens_filtered(),
    );
    let ranges = ranges.as_deref();
    for visible in &views {
        for &light in visible.get(TypeId::of::<ClusterVisibilityClass>()) {
            if !checked_lights.insert(light) {
                continue;
            }
            if let Ok((point_light, transform, frusta, mut visible_entities, layers)) =
                point_lights.get_mut(light)
            {
                if !point_light.shadow_maps_enabled {
                    continue;
                }
                let sphere = Sphere {
                    center: Vec3A::from(transform.translation()),
                    radius: point_light.range,
                };
                // The six faces together cover nearly all space (Bevy bounds them with one far
                // plane), so the light sphere alone is walked; faces are tested per entity.
                walk_shape(Some(&sphere), &[], &mut shape);
                let view = (light, light);
                candidates.gather(view, &shape, &trees, &untracked, &casters, |pair, found| {
                    walk_where(pair, found, |b| light_sphere_may_reach(&sphere, b));
                });
                let filter = ViewFilter {
                    view: range_view,
                    mask: layers.unwrap_or_default(),
                    ranges,
                };
                // The faces' lists are swapped into scratch lists and back (capacity kept both
                // ways), so that the decisions get one slice of lists for cube and spot alike.
                for (face, list) in visible_entities.iter_mut().zip(face_lists.iter_mut()) {
                    core::mem::swap(&mut face.entities, list);
                }
                decide_point_or_spot(
                    &candidates,
                    &mut casters,
                    &filter,
                    &sphere,
                    &frusta.frusta,
                    &mut face_lists[..],
                );
                for (face, list) in visible_entities.iter_mut().zip(face_lists.iter_mut()) {
                    core::mem::swap(&mut face.entities, list);
                    face.shrink();
                }
                stats.light_views += 6;
                stats.light_candidates += candidates.len();
            }
            if let Ok((spot_light, transform, frustum, mut visible_entities, layers)) =
                spot_lights.get_mut(light)
            {
                if !spot_light.shadow_maps_enabled {
                    continue;
                }
                let sphere = Sphere {
                    center: Vec3A::from(transform.translation()),
                    radius: spot_light.range,
                };
                let spot_planes = light_planes(frustum, true);
                walk_shape(Some(&sphere), &[spot_planes], &mut shape);
                let planes = AccelFrustum::from_planes(spot_planes);
                let view = (light, light);
                candidates.gather(view, &shape, &trees, &untracked, &casters, |pair, found| {
                    walk_where(pair, found, |b| {
                        light_sphere_may_reach(&sphere, b)
                            && planes.classify_aabb(b) != Containment::Outside
                    });
                });
                let filter = ViewFilter {
                    view: range_view,
                    mask: layers.unwrap_or_default(),
                    ranges,
                };
                decide_point_or_spot(
                    &candidates,
                    &mut casters,
                    &filter,
                    &sphere,
                    core::slice::from_ref(frustum),
                    core::slice::from_mut(&mut visible_entities.entities),
                );
                visible_entities.shrink();
                stats.light_views += 1;
                stats.light_candidates += candidates.len();
            }
        }
    }
    candidates.end_frame();
    stats.reused_light_walks += candidates.reused;
    stats.light_time += start.elapsed();
}

/// Replaces `check_dir_light_mesh_visibility`: the shadow casters of every cascade of every
/// directional light, found through the trees.
#[allow(clippy::too_many_arguments)]
pub(crate) fn cull_directional_lights(
    trees: Res<AccelTrees>,
    untracked: UntrackedEntities,
    ranges: Option<Res<VisibleEntityRanges>>,
    mut lights: Query<DirectionalLightItem, Without<SpotLight>>,
    mut casters: Casters,
    mut candidates: Local<LightCandidates>,
    mut scratch: Local<(Vec<u32>, Vec<[Vec4; 6]>)>,
    mut stats: ResMut<CullingStats>,
) {
    let start = Instant::now();
    let ranges = ranges.as_deref();
    candidates.start_frame(trees.is_changed());
    let (shape, cascade_planes) = &mut *scratch;
    for (light_entity, light, frusta, mut visible_entities, layers, light_visibility) in &mut lights
    {
        // The same bookkeeping as Bevy: one list per cascade of every view the light has
        // frusta for, and none for views it no longer has.
        let visible_entities = &mut visible_entities.entities;
        visible_entities.retain(|view, _| frusta.frusta.contains_key(view));
        for (view, view_frusta) in &frusta.frusta {
            visible_entities
                .entry(*view)
                .or_default()
                .resize(view_frusta.len(), VisibleMeshEntities::default());
        }
        if !light.shadow_maps_enabled || !light_visibility.get() {
            visible_entities.clear();
            continue;
        }
        let mask = layers.unwrap_or_default();
        for (view, view_frusta) in &frusta.frusta {
            let filter = ViewFilter {
                view: Some(*view),
                mask,
                ranges,
            };
            let lists = visible_entities
                .get_mut(view)
                .expect("made for every view above");
            for list in lists.iter_mut() {
                list.entities.clear();
            }
            cascade_planes.clear();
            cascade_planes.extend(view_frusta.iter().map(|f| light_planes(f, false)));
            walk_shape(None, cascade_planes, shape);
            let key = (light_entity, *view);
            candidates.gather(key, shape, &trees, &untracked, &casters, |pair, found| {
                for planes in cascade_planes.iter() {
                    let planes = AccelFrustum::from_planes(*planes);
                    pair.for_each_in_frustum(&planes, |slot, _| found.push(slot, true));
                }
            });
            decide_cascades(&candidates, &mut casters, &filter, view_frusta, lists);
            for list in lists.iter_mut() {
                list.shrink();
                list.entities.sort_unstable();
            }
            stats.light_views += view_frusta.len();
            stats.light_candidates += candidates.len();
        }
    }
    candidates.end_frame();
    stats.reused_light_walks += candidates.reused;
    stats.light_time += start.elapsed();
}

/// Decides a view's cascades exactly as `check_dir_light_mesh_visibility` does (no near
/// plane, no light sphere).
fn decide_cascades(
    candidates: &LightCandidates,
    casters: &mut Casters,
    filter: &ViewFilter,
    view_frusta: &[Frustum],
    lists: &mut [VisibleMeshEntities],
) {
    for_each_admitted(
        candidates,
        casters,
        filter,
        |entity, mut view_visibility, aabb, transform, nfc| {
            let Some((aabb, transform)) = aabb.zip(transform) else {
                view_visibility.set_visible();
                for list in lists.iter_mut() {
                    list.entities.push(entity);
                }
                return;
            };
            let affine: Affine3A = transform.affine();
            let mut visible = false;
            for (frustum, list) in view_frusta.iter().zip(lists.iter_mut()) {
                if nfc || frustum.intersects_obb(aabb, &affine, false, true) {
                    visible = true;
                    list.entities.push(entity);
                }
            }
            if visible {
                view_visibility.set_visible();
            }
        },
    );
}
