//! The camera culling system: trees for the entities they hold, Bevy's tests for the rest.

use super::flat_pass::{CandidateItem, FlatTally, decide_like_bevy, flat_pass};
use super::found_pass::{FreshFinds, decide_found};
use super::table_rows::SlotRows;
use super::tree_verdicts::TreeVerdicts;
use super::view_pass::{BoundsItem, DecideFilter, DecideItem, ViewPass};
use super::view_walk::{ViewWalk, WalkForm, WalkStill};
use crate::culling::bevy_rounding::{FoundIn, WalkedLayers, tree_plane, walk_frustum_for_bevy};
use crate::culling::bevy_rules::ViewFilter;
use crate::culling::class_lists::{ClassLists, sort_visible};
use crate::culling::slot_order::{FoundSlots, KeyRuns};
use crate::culling::stats::CullingStats;
use crate::culling::untracked::UntrackedEntities;
use crate::trees::AccelTrees;
use bevy::camera::primitives::Frustum;
use bevy::camera::visibility::{NoCpuCulling, RenderLayers, VisibleEntities, VisibleEntityRanges};
use bevy::ecs::entity::{Entities, EntityHashMap};
use bevy::ecs::system::SystemParam;
use bevy::math::Vec4;
use bevy::prelude::*;
use bevy::utils::Parallel;
use spatial_accel::{Containment, Frustum as AccelFrustum};
use std::time::Instant;

/// Above this fraction of entities visible (in the view's previous frame), a flat
/// pass over all entities beats the tree: a tree hit costs an entity lookup, about twice
/// what the linear scan spends per entity, so the crossover lies between a fifth and a half
/// of the world in view (`accel-bench culling`; BENCHMARKS.md, Culling); the lower end is
/// kept, where both cost about the same.
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

/// The view frustum's planes as the trees test them. Bevy culls against the near plane but
/// never the far one, so the far half-space is replaced by one containing all space.
fn tree_planes(frustum: &Frustum) -> [Vec4; 6] {
    let mut planes = frustum.half_spaces.map(|h| tree_plane(h.normal_d()));
    planes[AccelFrustum::FAR] = Vec4::new(0.0, 0.0, 0.0, 1.0);
    planes
}

/// What the camera culling reads besides the views and the candidates.
#[derive(SystemParam)]
pub(crate) struct CullingInputs<'w, 's> {
    trees: Res<'w, AccelTrees>,
    ranges: Option<Res<'w, VisibleEntityRanges>>,
    untracked: UntrackedEntities<'w, 's>,
    entities: &'w Entities,
    bounds: Query<'w, 's, BoundsItem, Without<NoCpuCulling>>,
}

/// What the camera culling keeps from frame to frame: per view, its last walk and the share
/// of the world it saw; and buffers reused across frames.
#[derive(Default)]
pub(crate) struct CullingMemory {
    tallies: Parallel<FlatTally>,
    visible_fraction: EntityHashMap<f32>,
    /// A fresh walk's finds in the static tree and the dynamic index.
    found: FoundSlots,
    /// A fresh walk's finds among the busy movers.
    found_busy: FoundSlots,
    walks: EntityHashMap<ViewWalk>,
    class_lists: ClassLists,
    part_lists: Vec<ClassLists>,
    slot_rows: SlotRows,
    /// [`AccelTrees::index_generation`] at the last frame.
    index_generation: Option<u64>,
}

/// Sets `ViewVisibility` and fills `VisibleEntities` for every active view.
pub(crate) fn cull_views_with_trees(
    inputs: CullingInputs,
    mut views: Query<ViewItem>,
    mut candidates: CandidateQueries,
    mut stats: ResMut<CullingStats>,
    mut memory: Local<CullingMemory>,
) {
    let CullingInputs {
        trees,
        ranges,
        untracked,
        entities,
        bounds,
    } = inputs;
    let CullingMemory {
        tallies,
        visible_fraction,
        found,
        found_busy,
        walks,
        class_lists,
        part_lists,
        slot_rows,
        index_generation,
    } = &mut *memory;
    let start = Instant::now();
    let mut s = CullingStats::default();
    let ranges = ranges.as_deref();
    let tracked = trees.tracked_len().max(1) as f32;
    // While the busy movers' boxes are out of date no view walks the trees; a view that
    // would have says so, and the next sync writes them (see `trees::unread_movers`).
    let busy_stale = trees.unread_movers.is_stale();
    let mut busy_read = false;
    let trees_changed = trees.is_changed();
    // Busy movers change the trees every frame without touching the index: the flat
    // pass's verdicts over the index hold through such frames (see `TreeVerdicts`).
    let index_changed = *index_generation != Some(trees.index_generation());
    *index_generation = Some(trees.index_generation());
    if index_changed {
        walks.values_mut().for_each(ViewWalk::forget);
    } else if trees_changed {
        walks.values_mut().for_each(ViewWalk::forget_busy_movers);
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
        let walks_trees = untracked.trees_current()
            && !visible_fraction
                .get(&view)
                .is_some_and(|f| *f > FLAT_PASS_ABOVE);
        busy_read |= walks_trees;
        if !walks_trees || busy_stale {
            s.flat_views += 1;
            // Fresh trees settle most entities' frustum tests (see `TreeVerdicts`), but only
            // over an index that held still this frame (busy movers aside, which Bevy's test
            // decides): a walk of trees that changed (movers) for a view that sees most of
            // the world cost more than the tests it saved, so such a view takes Bevy's own
            // pass (BENCHMARKS.md, Whole frame).
            let use_trees = untracked.trees_current() && !no_cpu_culling_view && !index_changed;
            let verdicts = use_trees.then(|| {
                let planes = tree_planes(frustum);
                let walk = walks.entry(view).or_default();
                if walk.still(&planes, WalkForm::Bits) == WalkStill::Holds {
                    s.reused_walks += 1;
                } else {
                    walk.restart(planes, WalkForm::Bits);
                    // Bevy's test decides the busy movers on this pass (see
                    // `TreeVerdicts`): the walk leaves them out.
                    walk_frustum_for_bevy(
                        &trees,
                        &AccelFrustum::from_planes(planes),
                        WalkedLayers::TreesOnly,
                        |_, slot, containment| match containment {
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
            let population = candidates.p0().iter().len();
            let (visible, tested, accepted) = flat_pass(
                &mut candidates.p0(),
                population,
                tallies,
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
            lists: class_lists,
            stats: &mut s,
        };
        if no_cpu_culling_view {
            // The camera opted out of culling: everything passes, so the trees have nothing
            // to skip. Decide what they hold, without frustum tests.
            for (entity, _) in trees.culling_iter() {
                pass.decide_exact(entity);
            }
        } else {
            let planes = tree_planes(frustum);
            let walk = walks.entry(view).or_default();
            let still = walk.still(&planes, WalkForm::Lists);
            let fresh = if still == WalkStill::Holds {
                pass.stats.reused_walks += 1;
                None
            } else {
                // The tree finds entities in spatial order, which is random in the ECS
                // tables; they are decided in slot order instead (see `FoundSlots`).
                let layers = if still == WalkStill::HoldsInTrees {
                    pass.stats.kept_tree_walks += 1;
                    WalkedLayers::BusyMoversOnly
                } else {
                    walk.restart(planes, WalkForm::Lists);
                    WalkedLayers::All
                };
                found.clear();
                found_busy.clear();
                walk_frustum_for_bevy(
                    &trees,
                    &AccelFrustum::from_planes(planes),
                    layers,
                    |layer, slot, containment| {
                        let exact = containment != Containment::Inside;
                        match layer {
                            FoundIn::Trees => found.push(slot, exact),
                            FoundIn::BusyMovers => found_busy.push(slot, exact),
                        }
                    },
                );
                let slots = trees.slot_entities().len();
                let keys = KeyRuns {
                    first: found.sorted_keys(slots),
                    second: found_busy.sorted_keys(slots),
                };
                // A fresh walk fills the view's list from the start; one that kept the
                // trees' finds refills only the busy movers' tail after them.
                let from = if layers == WalkedLayers::All {
                    walk.found_in_trees = keys.first.len();
                    0
                } else {
                    walk.found_in_trees
                };
                walk.busy_movers_walked();
                Some(FreshFinds {
                    keys,
                    from,
                    slot_entities: trees.slot_entities(),
                    slot_rows,
                })
            };
            if decide_found(&mut pass, &mut walk.found, fresh, entities, part_lists) > 0 {
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
    trees.unread_movers.report_cameras(busy_read);
    visible_fraction.retain(|view, _| views.contains(*view));
    walks.retain(|view, _| views.contains(*view));
    s.time = start.elapsed();
    trees.step_aside.costs().add_trees(s.time);
    *stats = s;
}
