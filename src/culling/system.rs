//! The culling system: trees for the entities they hold, Bevy's tests for the rest.

use super::bevy_rounding::walk_frustum_for_bevy;
use super::class_lists::{ClassLists, sort_visible};
use super::flat_pass::{CandidateItem, FlatTally, TreeVerdicts, decide_like_bevy, flat_pass};
use super::found_pass::{FreshFinds, decide_found};
use super::slot_order::FoundSlots;
use super::table_rows::SlotRows;
use super::tree_pass::{BoundsItem, DecideFilter, DecideItem, ViewPass};
use super::untracked::UntrackedEntities;
use super::view_walk::{ViewWalk, WalkForm};
use crate::trees::AccelTrees;
use accel::{Containment, Frustum as AccelFrustum};
use bevy::camera::primitives::{Aabb, Frustum, Sphere};
use bevy::camera::visibility::{NoCpuCulling, RenderLayers, VisibleEntities, VisibleEntityRanges};
use bevy::diagnostic::{Diagnostic, DiagnosticPath, Diagnostics, RegisterDiagnostic};
use bevy::ecs::entity::{Entities, EntityHashMap};
use bevy::math::Vec4;
use bevy::prelude::*;
use bevy::utils::Parallel;
use core::time::Duration;
use std::time::Instant;

/// What the last culling pass did, summed over views. Also published as Bevy diagnostics
/// ([`CullingStats::TIME`], [`CullingStats::LIGHT_TIME`], [`CullingStats::VISIBLE`]).
#[derive(Resource, Clone, Debug, Default)]
pub struct CullingStats {
    /// Views culled.
    pub views: usize,
    /// Entities reported visible (per view, summed).
    pub visible: usize,
    /// Entities accepted whole, inside a subtree fully in view, with no per-entity test (on
    /// the tree path, and on the flat pass when the trees settled their tests).
    pub accepted_by_subtree: usize,
    /// Entities given Bevy's frustum test one by one (leaves crossing a plane, and entities
    /// not in the trees; on a flat pass without the trees' word, every entity admitted).
    pub tested: usize,
    /// Views culled with the flat parallel pass instead of the trees (most of the world was
    /// in view last frame).
    pub flat_views: usize,
    /// Of the flat views, those whose frustum tests the trees settled wherever they could
    /// (the trees were current): only entities crossing a plane, or outside the trees, got
    /// Bevy's test.
    pub flat_views_on_trees: usize,
    /// Views whose tree walk was reused from the last frame, because neither their frustum
    /// nor the trees had changed (the entities found are still decided one by one).
    pub reused_walks: usize,
    /// Views on the tree path whose entities proved inside were many enough to be decided in
    /// parts on the compute task pool.
    pub views_decided_in_parts: usize,
    /// Time spent in the camera culling system.
    pub time: Duration,
    /// Shadow views of lights culled on the trees (point light cube faces, spot light
    /// frusta, directional light cascades per camera); cargo feature `light_culling`.
    pub light_views: usize,
    /// Entities decided one by one for those views on the tree path: what their walks found,
    /// plus the entities no walk finds (views on the flat pass are not counted).
    pub light_candidates: usize,
    /// Light views decided by the flat parallel pass over every caster (their walk found
    /// most of the world, or the trees were stale).
    pub flat_light_views: usize,
    /// Of the flat light views, those whose caster tests the trees settled wherever they
    /// could (the trees were current): a caster no list of the view reached is dropped
    /// untested, one inside a list's frustum and the light's range goes into that list
    /// untested, and only lists crossing its leaf get Bevy's tests.
    pub flat_light_views_on_trees: usize,
    /// Light views whose walk was kept from the last frame (neither the view nor the trees
    /// changed); their entities are still decided one by one.
    pub reused_light_walks: usize,
    /// Time spent culling light views.
    pub light_time: Duration,
}

impl CullingStats {
    /// Camera culling time, in milliseconds.
    pub const TIME: DiagnosticPath = DiagnosticPath::const_new("bevy_accel/culling_time_ms");
    /// Light-view culling time, in milliseconds (cargo feature `light_culling`).
    pub const LIGHT_TIME: DiagnosticPath =
        DiagnosticPath::const_new("bevy_accel/light_culling_time_ms");
    /// Entities visible in the camera views, summed over views.
    pub const VISIBLE: DiagnosticPath = DiagnosticPath::const_new("bevy_accel/culling_visible");

    pub(crate) fn register(app: &mut App) {
        for path in [Self::TIME, Self::LIGHT_TIME, Self::VISIBLE] {
            app.register_diagnostic(Diagnostic::new(path));
        }
    }
}

/// Copies the last frame's culling figures into Bevy's diagnostics.
pub(crate) fn publish_culling_stats(stats: Res<CullingStats>, mut diagnostics: Diagnostics) {
    let s = &*stats;
    diagnostics.add_measurement(&CullingStats::TIME, || s.time.as_secs_f64() * 1e3);
    diagnostics.add_measurement(&CullingStats::LIGHT_TIME, || {
        s.light_time.as_secs_f64() * 1e3
    });
    diagnostics.add_measurement(&CullingStats::VISIBLE, || s.visible as f64);
}

/// Above this fraction of entities visible (in the view's previous frame), a flat
/// pass over all entities beats the tree: a tree hit costs an entity lookup, about 2x (at
/// first 2.5x) what the linear scan spends per entity, so the crossover sits near 20-50%
/// (measured in `benches/culling.rs`; the lower end is kept, where both cost about the same).
const FLAT_PASS_ABOVE: f32 = 0.2;

type ViewItem = (
    Entity,
    &'static mut VisibleEntities,
    &'static Frustum,
    Option<&'static RenderLayers>,
    &'static Camera,
    Has<NoCpuCulling>,
);

/// Every cullable entity: the flat pass's full query, and the tree path's narrow one (they
/// share `ViewVisibility` mutably, so one at a time). The inner lifetimes are `'static`, as
/// `ParamSet` hands out its members with its own.
type CandidateQueries<'w, 's> = ParamSet<
    'w,
    's,
    (
        Query<'static, 'static, CandidateItem, Without<NoCpuCulling>>,
        Query<'static, 'static, DecideItem, DecideFilter>,
    ),
>;

/// A half-space of a Bevy frustum as the trees must test it to keep every entity Bevy's
/// oriented-box test keeps. Bevy calls a box outside when `normal_d . (center, 1) + r <= 0`:
/// - with a zero normal (an unset `Frustum`, before a camera's first update) `r` is 0, so
///   every box is outside unless `d > 0`; the trees' plane type would keep everything;
/// - with a NaN or infinite normal the comparison is false or undefined: nothing may be
///   dropped, so such a half-space holds all space.
pub(crate) fn tree_plane(v: Vec4) -> Vec4 {
    const ALL_SPACE: Vec4 = Vec4::new(0.0, 0.0, 0.0, 1.0);
    const NO_SPACE: Vec4 = Vec4::new(0.0, 0.0, 0.0, -1.0);
    let normal = v.truncate();
    if !normal.is_finite() || v.w.is_nan() {
        ALL_SPACE
    } else if normal == bevy::math::Vec3::ZERO {
        if v.w > 0.0 { ALL_SPACE } else { NO_SPACE }
    } else {
        v
    }
}

/// The view frustum's planes as the trees test them. Bevy culls against the near plane but
/// never the far one, so the far half-space is replaced by one containing all space.
fn tree_planes(frustum: &Frustum) -> [Vec4; 6] {
    let mut planes = frustum.half_spaces.map(|h| tree_plane(h.normal_d()));
    planes[AccelFrustum::FAR] = Vec4::new(0.0, 0.0, 0.0, 1.0);
    planes
}

/// Sets `ViewVisibility` and fills `VisibleEntities` for every active view.
#[allow(clippy::too_many_arguments)]
pub(crate) fn cull_views_with_trees(
    trees: Res<AccelTrees>,
    ranges: Option<Res<VisibleEntityRanges>>,
    mut views: Query<ViewItem>,
    mut candidates: CandidateQueries,
    untracked: UntrackedEntities,
    mut stats: ResMut<CullingStats>,
    mut tallies: Local<Parallel<FlatTally>>,
    mut visible_fraction: Local<EntityHashMap<f32>>,
    mut found: Local<FoundSlots>,
    mut walks: Local<EntityHashMap<ViewWalk>>,
    mut class_lists: Local<ClassLists>,
    mut part_lists: Local<Vec<ClassLists>>,
    mut slot_rows: Local<SlotRows>,
    entities: &Entities,
    bounds: Query<BoundsItem, Without<NoCpuCulling>>,
) {
    let start = Instant::now();
    let mut s = CullingStats::default();
    let ranges = ranges.as_deref();
    let tracked = trees.len().max(1) as f32;
    if trees.is_changed() {
        walks.values_mut().for_each(ViewWalk::forget);
    }
    for (view, mut visible_entities, frustum, view_layers, camera, no_cpu_culling_view) in
        &mut views
    {
        if !camera.is_active {
            continue;
        }
        s.views += 1;
        visible_entities.clear_all();
        let view_mask = view_layers.cloned().unwrap_or_default();
        // Stale trees (the plugin is switched off) cannot be walked: Bevy's pass then.
        if !untracked.trees_current()
            || visible_fraction
                .get(&view)
                .is_some_and(|f| *f > FLAT_PASS_ABOVE)
        {
            s.flat_views += 1;
            // Fresh trees settle most entities' frustum tests (see `TreeVerdicts`).
            let verdicts = (untracked.trees_current() && !no_cpu_culling_view).then(|| {
                let planes = tree_planes(frustum);
                let walk = walks.entry(view).or_default();
                if walk.walked(&planes, WalkForm::Bits) {
                    s.reused_walks += 1;
                } else {
                    walk.restart(planes, WalkForm::Bits);
                    walk_frustum_for_bevy(
                        &trees,
                        &AccelFrustum::from_planes(planes),
                        |slot, containment| match containment {
                            Containment::Inside => walk.inside_bits.insert(slot),
                            _ => walk.crossing_bits.insert(slot),
                        },
                    );
                }
                s.flat_views_on_trees += 1;
                TreeVerdicts {
                    walk,
                    trees: &trees,
                }
            });
            let (visible, tested, accepted) = flat_pass(
                &mut candidates.p0(),
                &mut tallies,
                &mut visible_entities,
                ViewFilter {
                    view: Some(view),
                    mask: &view_mask,
                    ranges,
                },
                frustum,
                no_cpu_culling_view,
                verdicts,
            );
            let population = candidates.p0().iter().len();
            s.visible += visible;
            s.tested += tested;
            s.accepted_by_subtree += accepted;
            visible_fraction.insert(view, visible as f32 / population.max(1) as f32);
            continue;
        }
        let visible_before = s.visible;
        let filter = ViewFilter {
            view: Some(view),
            mask: &view_mask,
            ranges,
        };
        // Decisions read the visibility components through a narrow query, and the bounds
        // through their own query only where a frustum test is needed. Both are read as table
        // columns at remembered rows (see `table_rows`); the per-entity lookups that remain
        // (a camera without culling, a query that cannot be read as columns) pay for each
        // component of the query they go through, and most finds are accepted whole.
        let mut deciding = candidates.p1();
        let mut pass = ViewPass {
            filter,
            frustum,
            no_cpu_culling_view,
            deciding: &mut deciding,
            bounds: &bounds,
            lists: &mut class_lists,
            stats: &mut s,
        };
        if no_cpu_culling_view {
            // The camera opted out of culling: everything passes, so the trees have nothing
            // to skip. Decide what they hold, without frustum tests.
            for (entity, _) in trees.iter() {
                pass.decide_exact(entity);
            }
        } else {
            let planes = tree_planes(frustum);
            let walk = walks.entry(view).or_default();
            let fresh = if walk.walked(&planes, WalkForm::Lists) {
                pass.stats.reused_walks += 1;
                None
            } else {
                // The tree finds entities in spatial order, which is random in the ECS
                // tables; they are decided in slot order instead (see `FoundSlots`).
                walk.restart(planes, WalkForm::Lists);
                found.clear();
                walk_frustum_for_bevy(
                    &trees,
                    &AccelFrustum::from_planes(planes),
                    |slot, containment| found.push(slot, containment != Containment::Inside),
                );
                Some(FreshFinds {
                    keys: found.sorted_keys(trees.slot_entities().len()),
                    slot_entities: trees.slot_entities(),
                    slot_rows: &slot_rows,
                })
            };
            if decide_found(&mut pass, &mut walk.found, fresh, entities, &mut part_lists) > 0 {
                slot_rows.remember(&walk.found);
            }
        }
        // The fraction that chooses the pass counts only what the walk found: entities outside
        // the trees cost the same either way (`NoFrustumCulling` ones are always visible).
        visible_fraction.insert(view, (s.visible - visible_before) as f32 / tracked);
        let mut all = candidates.p0();
        let mut tally = FlatTally::default();
        for entity in untracked.iter() {
            let Ok(item) = all.get_mut(entity) else {
                continue;
            };
            decide_like_bevy(
                item,
                filter,
                frustum,
                no_cpu_culling_view,
                |_| None,
                &mut tally,
            );
        }
        let (visible, tested, _) = tally.flush_into(&mut visible_entities);
        s.visible += visible;
        s.tested += tested;
        class_lists.flush_into(&mut visible_entities);
        // Bevy diffs these lists in O(n) and needs them sorted (they are a few sorted runs
        // already; see `sort_visible`).
        for list in visible_entities.entities.values_mut() {
            sort_visible(list);
        }
    }
    visible_fraction.retain(|view, _| views.contains(*view));
    walks.retain(|view, _| views.contains(*view));
    s.time = start.elapsed();
    *stats = s;
}

/// The per-entity rules Bevy applies before any frustum test: the entity is visible in the
/// hierarchy, shares a render layer with the view, and is within its visibility range. Every
/// culling path (flat, tree, light views) asks it, so they cannot drift apart.
#[derive(Clone, Copy)]
pub(crate) struct ViewFilter<'a> {
    /// The view whose distance decides visibility ranges. `None` hides every entity that has
    /// a range, as Bevy's point and spot light pass does when no view can be the shadow LOD
    /// origin.
    pub(crate) view: Option<Entity>,
    pub(crate) mask: &'a RenderLayers,
    pub(crate) ranges: Option<&'a VisibleEntityRanges>,
}

impl ViewFilter<'_> {
    #[inline]
    pub(crate) fn admits(
        &self,
        entity: Entity,
        inherited: &InheritedVisibility,
        layers: Option<&RenderLayers>,
        has_range: bool,
    ) -> bool {
        inherited.get() && self.admits_in_layers(entity, self.in_layers(layers), has_range)
    }

    /// Whether the view sees `layers` (an entity without `RenderLayers` is on layer 0).
    #[inline]
    pub(crate) fn in_layers(&self, layers: Option<&RenderLayers>) -> bool {
        self.mask.intersects(layers.unwrap_or_default())
    }

    /// [`Self::admits`] for an entity visible in the hierarchy, with [`Self::in_layers`]
    /// already answered (it is the same for every entity of a table without `RenderLayers`).
    #[inline]
    pub(crate) fn admits_in_layers(
        &self,
        entity: Entity,
        in_layers: bool,
        has_range: bool,
    ) -> bool {
        in_layers
            && !(has_range
                && self.ranges.is_some_and(|r| {
                    self.view
                        .is_none_or(|view| !r.entity_is_in_range_of_view(entity, view))
                }))
    }
}

/// Bevy's own per-entity test: a bounding sphere first, then the oriented box, near plane
/// included and far plane excluded; entities with neither `Aabb` nor `Sphere` pass.
pub(crate) fn bevy_frustum_test(
    frustum: &Frustum,
    aabb: Option<&Aabb>,
    sphere: Option<&Sphere>,
    transform: &GlobalTransform,
) -> bool {
    if let Some(aabb) = aabb {
        let world_from_local = transform.affine();
        let model_sphere = Sphere {
            center: world_from_local.transform_point3a(aabb.center),
            radius: transform.radius_vec3a(aabb.half_extents),
        };
        frustum.intersects_sphere(&model_sphere, false)
            && frustum.intersects_obb(aabb, &world_from_local, true, false)
    } else if let Some(sphere) = sphere {
        frustum.intersects_sphere(sphere, false)
    } else {
        true
    }
}
