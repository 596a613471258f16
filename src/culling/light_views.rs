//! Shadow views of lights on the trees: the replacements for bevy_light's
//! `check_point_light_mesh_visibility` and `check_dir_light_mesh_visibility`.
//!
//! Bevy tests every shadow caster in the world against every shadow-mapped light each frame:
//! six cube faces per point light, one frustum per spot light, one per cascade and camera per
//! directional light. Here each light view walks the trees first, and Bevy's own per-entity
//! tests run only on what the walk found. A walk drops a subtree only when its box lies wholly
//! behind one of the view's planes; the tree's box holds the entity's oriented box, which is
//! then behind that plane too, and Bevy's test (one plane at a time) rejects it as well. So the
//! walk never loses an entity Bevy would keep, and the results are Bevy's.

use super::slot_order::FoundSlots;
use super::system::{CullingStats, tree_plane};
use super::untracked::UntrackedEntities;
use crate::trees::AccelTrees;
use accel::dynamic::StaticDynamicPair;
use accel::query::binary::for_each_leaf_primitive;
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
use core::ops::ControlFlow;
use std::time::Instant;

/// What deciding a shadow caster reads and writes: the item of Bevy's own query.
type CasterItem = (
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
type CasterFilter = (
    Without<NotShadowCaster>,
    Without<DirectionalLight>,
    Without<NoCpuCulling>,
    With<Mesh3d>,
);

type Casters<'w, 's> = Query<'w, 's, CasterItem, CasterFilter>;

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
    &'static DirectionalLight,
    &'static CascadesFrusta,
    &'static mut CascadesVisibleEntities,
    Option<&'static RenderLayers>,
    &'static ViewVisibility,
);

/// The planes of a light view as the trees test them. Point and spot lights test all six;
/// directional cascades skip the near plane (a caster may stand before it), so it becomes a
/// half-space holding all space.
fn light_planes(frustum: &Frustum, near: bool) -> [Vec4; 6] {
    let mut planes = frustum.half_spaces.map(|h| tree_plane(h.normal_d()));
    if !near {
        planes[AccelFrustum::NEAR] = Vec4::new(0.0, 0.0, 0.0, 1.0);
    }
    planes
}

/// Whether Bevy's light-sphere test (`Sphere::intersects_obb`) can pass for an entity whose
/// box lies in `b`. That test projects the entity's oriented box on one axis only, the line from
/// the light to the box's center, so it passes for long boxes whose every point is out of
/// range: a plain sphere-box overlap would drop entities Bevy keeps. What does hold: the test
/// passes only if the box's center lies within the range plus the box's largest half-extent
/// along that axis, which is at most the half-diagonal of any box holding the entity. Both
/// the center and that box lie in `b`, so `b` can be dropped when it is farther from the light
/// than the range plus its own half-diagonal (with a little slack for rounding).
fn light_sphere_may_reach(sphere: &Sphere, b: &accel::Aabb) -> bool {
    let reach = (sphere.radius + b.half_extents().length()) * (1.0 + 1e-3);
    b.distance_squared_to_point(sphere.center) <= reach * reach
}

/// The entities one light view decides, each once.
#[derive(Default)]
pub(crate) struct LightCandidates {
    found: FoundSlots,
    /// Found by the walks, in slot order. `NoFrustumCulling` ones among them are skipped: they
    /// come again in `others`.
    walked: Vec<Entity>,
    /// Unused: light walks mark every find for the exact test.
    proved_inside: Vec<Entity>,
    /// Everything a walk cannot find (see [`UntrackedEntities`]), or, while the trees are
    /// stale, every caster.
    others: Vec<Entity>,
}

impl LightCandidates {
    /// Gathers the candidates that `walk` finds in the trees (it pushes slots, repeats
    /// allowed), or every caster when the trees are not current.
    fn gather(
        &mut self,
        trees: &AccelTrees,
        untracked: &UntrackedEntities,
        casters: &Casters,
        walk: impl FnOnce(&StaticDynamicPair, &mut FoundSlots),
    ) {
        self.walked.clear();
        self.others.clear();
        if !untracked.trees_current() {
            self.others.extend(casters.iter().map(|item| item.0));
            return;
        }
        self.found.clear();
        walk(trees.query(), &mut self.found);
        // Slot order is table order, so the decisions read the rows nearly in sequence; views
        // made of several frusta find an entity once per frustum, next to each other here.
        self.found.drain_entities(
            trees.slot_entities(),
            &mut self.proved_inside,
            &mut self.walked,
        );
        self.walked.dedup();
        self.others.extend(untracked.iter());
    }

    /// Each candidate with whether a walk found it.
    fn iter(&self) -> impl Iterator<Item = (Entity, bool)> + '_ {
        let walked = self.walked.iter().map(|&e| (e, true));
        walked.chain(self.others.iter().map(|&e| (e, false)))
    }

    fn len(&self) -> usize {
        self.walked.len() + self.others.len()
    }
}

/// Pushes every slot whose tree box passes `accept` (which must fail for every box inside a
/// box it fails).
fn walk_where(
    pair: &StaticDynamicPair,
    found: &mut FoundSlots,
    accept: impl FnMut(&accel::Aabb) -> bool,
) {
    for_each_leaf_primitive(pair, accept, |slot| {
        found.push(slot, true);
        ControlFlow::Continue(())
    });
}

/// Bevy's rules for a shadow caster before any frustum test.
struct CasterRules<'a> {
    mask: &'a RenderLayers,
    ranges: Option<&'a VisibleEntityRanges>,
    /// The view whose distance decides visibility ranges; `None` (point and spot lights with
    /// no shadow LOD origin) hides every entity that has a range, as Bevy does.
    range_view: Option<Entity>,
}

impl CasterRules<'_> {
    fn admits(
        &self,
        entity: Entity,
        inherited: &InheritedVisibility,
        layers: Option<&RenderLayers>,
        has_range: bool,
    ) -> bool {
        inherited.get()
            && self.mask.intersects(layers.unwrap_or_default())
            && !(has_range
                && self.ranges.is_some_and(|r| {
                    self.range_view
                        .is_none_or(|view| !r.entity_is_in_range_of_view(entity, view))
                }))
    }
}

/// Decides the candidates of a point light (six faces) or a spot light (one) exactly as
/// `check_point_light_mesh_visibility` does; fills `lists` (one per face, sorted).
fn decide_point_or_spot(
    candidates: &LightCandidates,
    casters: &mut Casters,
    rules: &CasterRules,
    light_sphere: &Sphere,
    frusta: &[Frustum],
    lists: &mut [&mut Vec<Entity>],
) {
    for list in lists.iter_mut() {
        list.clear();
    }
    for (entity, walked) in candidates.iter() {
        let Ok((entity, inherited, mut view_visibility, layers, aabb, transform, has_range, nfc)) =
            casters.get_mut(entity)
        else {
            continue;
        };
        if (walked && nfc) || !rules.admits(entity, inherited, layers, has_range) {
            continue;
        }
        if let (Some(aabb), Some(transform)) = (aabb, transform) {
            let model_to_world = transform.affine();
            if !nfc && !light_sphere.intersects_obb(aabb, &model_to_world) {
                continue;
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
    }
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
    mut stats: ResMut<CullingStats>,
) {
    let start = Instant::now();
    checked_lights.clear();
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
                candidates.gather(&trees, &untracked, &casters, |pair, found| {
                    walk_where(pair, found, |b| light_sphere_may_reach(&sphere, b));
                });
                let rules = CasterRules {
                    mask: layers.unwrap_or_default(),
                    ranges,
                    range_view,
                };
                let mut lists: Vec<&mut Vec<Entity>> = visible_entities
                    .iter_mut()
                    .map(|v| &mut v.entities)
                    .collect();
                decide_point_or_spot(
                    &candidates,
                    &mut casters,
                    &rules,
                    &sphere,
                    &frusta.frusta,
                    &mut lists,
                );
                for faces in visible_entities.iter_mut() {
                    faces.shrink();
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
                let planes = AccelFrustum::from_planes(light_planes(frustum, true));
                candidates.gather(&trees, &untracked, &casters, |pair, found| {
                    walk_where(pair, found, |b| {
                        light_sphere_may_reach(&sphere, b)
                            && planes.classify_aabb(b) != Containment::Outside
                    });
                });
                let rules = CasterRules {
                    mask: layers.unwrap_or_default(),
                    ranges,
                    range_view,
                };
                decide_point_or_spot(
                    &candidates,
                    &mut casters,
                    &rules,
                    &sphere,
                    core::slice::from_ref(frustum),
                    &mut [&mut visible_entities.entities],
                );
                visible_entities.shrink();
                stats.light_views += 1;
                stats.light_candidates += candidates.len();
            }
        }
    }
    stats.light_time += start.elapsed();
}

/// Replaces `check_dir_light_mesh_visibility`: the shadow casters of every cascade of every
/// directional light, found through the trees.
pub(crate) fn cull_directional_lights(
    trees: Res<AccelTrees>,
    untracked: UntrackedEntities,
    ranges: Option<Res<VisibleEntityRanges>>,
    mut lights: Query<DirectionalLightItem, Without<SpotLight>>,
    mut casters: Casters,
    mut candidates: Local<LightCandidates>,
    mut stats: ResMut<CullingStats>,
) {
    let start = Instant::now();
    let ranges = ranges.as_deref();
    for (light, frusta, mut visible_entities, layers, light_visibility) in &mut lights {
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
            let rules = CasterRules {
                mask,
                ranges,
                range_view: Some(*view),
            };
            let lists = visible_entities
                .get_mut(view)
                .expect("made for every view above");
            for list in lists.iter_mut() {
                list.entities.clear();
            }
            candidates.gather(&trees, &untracked, &casters, |pair, found| {
                for frustum in view_frusta {
                    let planes = AccelFrustum::from_planes(light_planes(frustum, false));
                    pair.for_each_in_frustum(&planes, |slot, _| found.push(slot, true));
                }
            });
            decide_cascades(&candidates, &mut casters, &rules, view_frusta, lists);
            for list in lists.iter_mut() {
                list.shrink();
                list.entities.sort_unstable();
            }
            stats.light_views += view_frusta.len();
            stats.light_candidates += candidates.len();
        }
    }
    stats.light_time += start.elapsed();
}

/// Decides a view's cascades exactly as `check_dir_light_mesh_visibility` does (no near
/// plane, no light sphere).
fn decide_cascades(
    candidates: &LightCandidates,
    casters: &mut Casters,
    rules: &CasterRules,
    view_frusta: &[Frustum],
    lists: &mut [VisibleMeshEntities],
) {
    for (entity, walked) in candidates.iter() {
        let Ok((entity, inherited, mut view_visibility, layers, aabb, transform, has_range, nfc)) =
            casters.get_mut(entity)
        else {
            continue;
        };
        if (walked && nfc) || !rules.admits(entity, inherited, layers, has_range) {
            continue;
        }
        let Some((aabb, transform)) = aabb.zip(transform) else {
            view_visibility.set_visible();
            for list in lists.iter_mut() {
                list.entities.push(entity);
            }
            continue;
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
    }
}
