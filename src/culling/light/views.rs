//! Shadow views of lights on the trees: the replacements for bevy_light's
//! `check_point_light_mesh_visibility` and `check_dir_light_mesh_visibility`.
//!
//! Bevy tests every shadow caster in the world against every shadow-mapped light each frame:
//! six cube faces per point light, one frustum per spot light, one per cascade and camera per
//! directional light. Here each light view walks the trees first, and Bevy's own per-entity
//! tests run only on what the walk found, and only where the walk could not settle them
//! ([`super::verdicts`]). The walks ([`super::walks`]) drop only what Bevy's
//! tests would drop, and settle only what they would pass, so the results are Bevy's.

use super::verdicts::{CasterVerdicts, LightLists, MAX_SETTLED_LISTS, unpack};
use super::walks::{LightCandidates, ViewKey, light_planes};
use crate::culling::bevy_rules::ViewFilter;
use crate::culling::class_lists::sort_visible;
use crate::culling::stats::CullingStats;
use crate::culling::untracked::UntrackedEntities;
use crate::trees::AccelTrees;
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
use bevy::utils::Parallel;
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

/// Bevy's bounds tests for one light view: which of its lists (cube faces, the spot frustum,
/// cascades) an admitted caster goes into.
pub(super) struct CasterTest<'a> {
    /// The light's sphere, tested first (point and spot lights; `None` for cascades).
    pub(super) sphere: Option<&'a Sphere>,
    /// One frustum per list.
    pub(super) frusta: &'a [Frustum],
    /// Whether the near plane is tested (not for cascades: a caster may stand before it).
    pub(super) near: bool,
}

impl CasterTest<'_> {
    /// Pushes `entity` into the lists whose frustum keeps it, as bevy_light does; returns
    /// whether any did (the caster is then visible). Casters without bounds go everywhere.
    fn place(
        &self,
        entity: Entity,
        aabb: Option<&Aabb>,
        transform: Option<&GlobalTransform>,
        nfc: bool,
        lists: &mut [Vec<Entity>],
    ) -> bool {
        let (Some(aabb), Some(transform)) = (aabb, transform) else {
            lists.iter_mut().for_each(|list| list.push(entity));
            return true;
        };
        let model_to_world: Affine3A = transform.affine();
        if !nfc
            && self
                .sphere
                .is_some_and(|sphere| !sphere.intersects_obb(aabb, &model_to_world))
        {
            return false;
        }
        let mut visible = false;
        for (frustum, list) in self.frusta.iter().zip(lists.iter_mut()) {
            if nfc || frustum.intersects_obb(aabb, &model_to_world, self.near, true) {
                visible = true;
                list.push(entity);
            }
        }
        visible
    }
}

/// What the directional pass reuses from frame to frame: the cascades' planes and lists.
type CascadeScratch = (Vec<[Vec4; 6]>, Vec<Vec<Entity>>);

/// Per-thread lists of the flat pass, and how many casters each thread placed.
type ThreadLists = Parallel<ThreadShare>;

/// One thread's lists and count. Aligned to two cache lines so that the threads' shares,
/// which `Parallel` keeps side by side, never share one: the count is bumped per caster
/// (false sharing; see the camera pass's `FlatTally`).
#[derive(Default)]
#[repr(align(128))]
pub(crate) struct ThreadShare(Vec<Vec<Entity>>, usize);

/// Decides one light view into `lists` (sorted, as Bevy leaves them): its candidates one by
/// one (with their walk's masks), or, when [`LightCandidates::flat`], every caster in a
/// parallel loop as Bevy's, where `verdicts` (when given) settle the tests of the casters the
/// trees hold. Returns how many
/// entities the view found: those its walk found, or, on the flat pass, those it placed.
#[allow(clippy::too_many_arguments)]
fn decide_lists(
    candidates: &LightCandidates,
    flat: bool,
    verdicts: Option<CasterVerdicts>,
    casters: &mut Casters,
    filter: &ViewFilter,
    test: &CasterTest,
    lists: &mut [Vec<Entity>],
    threads: &mut ThreadLists,
) -> usize {
    lists.iter_mut().for_each(Vec::clear);
    if flat {
        let n = lists.len();
        casters.par_iter_mut().for_each_init(
            || threads.borrow_local_mut(),
            |local, (entity, inherited, mut view_visibility, layers, aabb, transform, range, nfc)| {
                let settled = verdicts.and_then(|v| {
                    v.lists(entity, nfc, aabb.is_some() && transform.is_some())
                });
                // The trees' word first: a caster no list reached is dropped after one read.
                if settled == Some((0, 0)) || !filter.admits(entity, inherited, layers, range) {
                    return;
                }
                let ThreadShare(parts, placed) = &mut **local;
                if parts.len() < n {
                    parts.resize_with(n, Vec::new);
                }
                let taken = match (settled, aabb, transform) {
                    (Some(settled), Some(aabb), Some(transform)) => {
                        test.place_settled(entity, aabb, transform, settled, &mut parts[..n])
                    }
                    _ => test.place(entity, aabb, transform, nfc, &mut parts[..n]),
                };
                if taken {
                    view_visibility.set_visible();
                    *placed += 1;
                }
            },
        );
        let mut found = 0;
        for ThreadShare(parts, placed) in threads.iter_mut() {
            for (list, part) in lists.iter_mut().zip(parts.iter_mut()) {
                list.append(part);
            }
            found += core::mem::take(placed);
        }
        lists.iter_mut().for_each(|list| sort_visible(list));
        found
    } else {
        // The walk's masks settle the tests where they can (see `verdicts`); a view with
        // more lists than they hold is tested caster by caster.
        let settle = lists.len() <= MAX_SETTLED_LISTS;
        for (entity, walked) in candidates.iter() {
            let Ok((entity, inherited, mut view_visibility, layers, aabb, transform, range, nfc)) =
                casters.get_mut(entity)
            else {
                continue;
            };
            // A walked `NoFrustumCulling` entity comes again among those no walk finds.
            if (walked.is_some() && nfc) || !filter.admits(entity, inherited, layers, range) {
                continue;
            }
            let taken = match (walked.filter(|_| settle), aabb, transform) {
                (Some(masks), Some(aabb), Some(transform)) => {
                    test.place_settled(entity, aabb, transform, unpack(masks), lists)
                }
                _ => test.place(entity, aabb, transform, nfc, lists),
            };
            if taken {
                view_visibility.set_visible();
            }
        }
        lists.iter_mut().for_each(|list| sort_visible(list));
        candidates.walked_len()
    }
}

/// Decides light view `view` into `lists` (see [`decide_lists`]), on the flat pass when
/// [`LightCandidates::flat`] says so, records what it found for the next frame's choice, and
/// counts it in `stats`. `walked` describes the view's lists as the trees are walked for them.
#[allow(clippy::too_many_arguments)]
fn decide_view(
    view: ViewKey,
    candidates: &mut LightCandidates,
    casters: &mut Casters,
    filter: &ViewFilter,
    test: &CasterTest,
    walked: &LightLists,
    lists: &mut [Vec<Entity>],
    threads: &mut ThreadLists,
    stats: &mut CullingStats,
    trees: &AccelTrees,
) {
    let tracked = trees.tracked_len();
    let flat = candidates.flat(tracked);
    // A flat view still takes the trees' word where they can give it (see `verdicts`).
    let settled = flat && candidates.trees_current() && lists.len() <= MAX_SETTLED_LISTS;
    if settled {
        if candidates.verdicts.walk(view, trees, walked) {
            stats.reused_light_walks += 1;
        }
        stats.flat_light_views_on_trees += 1;
    }
    let verdicts = settled
        .then(|| candidates.verdicts.masks(view))
        .flatten()
        .map(|masks| CasterVerdicts { masks, trees });
    let found = decide_lists(
        candidates, flat, verdicts, casters, filter, test, lists, threads,
    );
    candidates.record(view, found, tracked);
    stats.light_views += lists.len();
    if flat {
        stats.flat_light_views += 1;
    } else {
        stats.light_candidates += candidates.len();
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
    mut face_lists: Local<[Vec<Entity>; 6]>,
    mut threads: Local<ThreadLists>,
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
                // One walk over the six faces within the light's range (see `verdicts`).
                let face_planes = frusta.frusta.each_ref().map(|f| light_planes(f, true));
                let walked = LightLists {
                    sphere: Some(&sphere),
                    planes: &face_planes,
                    cover_every_direction: true,
                };
                let view = (light, light);
                candidates.gather(view, &walked, &trees, &untracked);
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
                let test = CasterTest {
                    sphere: Some(&sphere),
                    frusta: &frusta.frusta,
                    near: true,
                };
                decide_view(
                    view,
                    &mut candidates,
                    &mut casters,
                    &filter,
                    &test,
                    &walked,
                    &mut face_lists[..],
                    &mut threads,
                    &mut stats,
                    &trees,
                );
                for (face, list) in visible_entities.iter_mut().zip(face_lists.iter_mut()) {
                    core::mem::swap(&mut face.entities, list);
                    face.shrink();
                }
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
                let spot_planes = [light_planes(frustum, true)];
                let walked = LightLists {
                    sphere: Some(&sphere),
                    planes: &spot_planes,
                    cover_every_direction: false,
                };
                let view = (light, light);
                candidates.gather(view, &walked, &trees, &untracked);
                let filter = ViewFilter {
                    view: range_view,
                    mask: layers.unwrap_or_default(),
                    ranges,
                };
                let test = CasterTest {
                    sphere: Some(&sphere),
                    frusta: core::slice::from_ref(frustum),
                    near: true,
                };
                decide_view(
                    view,
                    &mut candidates,
                    &mut casters,
                    &filter,
                    &test,
                    &walked,
                    core::slice::from_mut(&mut visible_entities.entities),
                    &mut threads,
                    &mut stats,
                    &trees,
                );
                visible_entities.shrink();
            }
        }
    }
    candidates.end_frame();
    stats.reused_light_walks += candidates.reused;
    let time = start.elapsed();
    stats.light_time += time;
    trees.step_aside.costs().add_trees(time);
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
    mut scratch: Local<CascadeScratch>,
    mut threads: Local<ThreadLists>,
    mut stats: ResMut<CullingStats>,
) {
    let start = Instant::now();
    let ranges = ranges.as_deref();
    candidates.start_frame(trees.is_changed());
    let (cascade_planes, cascade_lists) = &mut *scratch;
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
            let Some(cascades) = visible_entities.get_mut(view) else {
                continue;
            };
            cascade_planes.clear();
            cascade_planes.extend(view_frusta.iter().map(|f| light_planes(f, false)));
            let walked = LightLists {
                sphere: None,
                planes: cascade_planes,
                cover_every_direction: false,
            };
            let key = (light_entity, *view);
            candidates.gather(key, &walked, &trees, &untracked);
            // As for cube faces: the cascades' lists go through scratch lists and back.
            cascade_lists.resize_with(cascades.len(), Vec::new);
            for (cascade, list) in cascades.iter_mut().zip(cascade_lists.iter_mut()) {
                core::mem::swap(&mut cascade.entities, list);
            }
            decide_view(
                key,
                &mut candidates,
                &mut casters,
                &filter,
                &CasterTest {
                    sphere: None,
                    frusta: view_frusta,
                    near: false,
                },
                &walked,
                &mut cascade_lists[..cascades.len()],
                &mut threads,
                &mut stats,
                &trees,
            );
            for (cascade, list) in cascades.iter_mut().zip(cascade_lists.iter_mut()) {
                core::mem::swap(&mut cascade.entities, list);
                cascade.shrink();
            }
        }
    }
    candidates.end_frame();
    stats.reused_light_walks += candidates.reused;
    let time = start.elapsed();
    stats.light_time += time;
    trees.step_aside.costs().add_trees(time);
}
