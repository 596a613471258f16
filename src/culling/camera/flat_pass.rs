//! The flat pass: every cullable entity once, in table order and in parallel, as Bevy's own
//! `check_visibility_cpu_culling` goes, for views that see most of the world.

use super::tree_verdicts::TreeVerdicts;
use crate::culling::bevy_rules::{ViewFilter, bevy_frustum_test};
use crate::culling::class_lists::{ClassLists, sort_visible};
use crate::pool_batches::uneven_work_batches;
use bevy::camera::primitives::{Aabb, Frustum, Sphere};
use bevy::camera::visibility::{
    NoCpuCulling, NoFrustumCulling, RenderLayers, SetViewVisibility, VisibilityClass,
    VisibilityRange, VisibleEntities,
};
use bevy::prelude::*;
use bevy::utils::Parallel;

/// What the flat pass reads and writes of each entity: Bevy's own query.
pub(crate) type CandidateItem = (
    Entity,
    &'static InheritedVisibility,
    &'static mut ViewVisibility,
    Option<&'static VisibilityClass>,
    Option<&'static RenderLayers>,
    Option<&'static Aabb>,
    Option<&'static Sphere>,
    &'static GlobalTransform,
    Has<NoFrustumCulling>,
    Has<VisibilityRange>,
);

/// One thread's share of a flat pass. Each thread counts and gathers into its own: a shared
/// atomic counter would bounce its cache line between cores on every visible entity, and a
/// hash-map entry per entity and class (Bevy's way) costs more than a search of the world's
/// few classes. Aligned to two cache lines: `Parallel` keeps the threads' shares side by side,
/// and counters bumped per entity on a shared line would bounce it all the same (false
/// sharing; two lines, as the adjacent-line prefetcher pairs them).
#[derive(Default)]
#[repr(align(128))]
pub(crate) struct FlatTally {
    lists: ClassLists,
    /// Entities made visible.
    visible: usize,
    /// Entities given Bevy's frustum test.
    tested: usize,
    /// Entities made visible on a tree's word, with no frustum test.
    accepted: usize,
}

impl FlatTally {
    /// Moves the gathered entities into the view's lists (unsorted) and hands back the
    /// counts as `(visible, tested, accepted)`, leaving the tally empty for the next view.
    pub(crate) fn flush_into(
        &mut self,
        visible_entities: &mut VisibleEntities,
    ) -> (usize, usize, usize) {
        self.lists.flush_into(visible_entities);
        (
            core::mem::take(&mut self.visible),
            core::mem::take(&mut self.tested),
            core::mem::take(&mut self.accepted),
        )
    }
}

/// Runs the flat pass for one view: Bevy's rules for every entity, its frustum test where
/// `verdicts` (when given) cannot settle it. `population` is how many entities `candidates`
/// holds (it sizes the batches). Returns the summed tallies' counts as
/// `(visible, tested, accepted)`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn flat_pass(
    candidates: &mut Query<CandidateItem, Without<NoCpuCulling>>,
    population: usize,
    tallies: &mut Parallel<FlatTally>,
    visible_entities: &mut VisibleEntities,
    filter: ViewFilter<'_>,
    frustum: &Frustum,
    no_cpu_culling_view: bool,
    verdicts: Option<TreeVerdicts<'_>>,
) -> (usize, usize, usize) {
    candidates
        .par_iter_mut()
        .batching_strategy(uneven_work_batches(population))
        .for_each_init(
            || tallies.borrow_local_mut(),
            |tally, item| {
                let known = |entity| verdicts.and_then(|v| v.frustum_test(entity));
                decide_like_bevy(item, filter, frustum, no_cpu_culling_view, known, tally);
            },
        );
    let (mut visible, mut tested, mut accepted) = (0, 0, 0);
    for tally in tallies.iter_mut() {
        let (v, t, a) = tally.flush_into(visible_entities);
        (visible, tested, accepted) = (visible + v, tested + t, accepted + a);
    }
    for list in visible_entities.entities.values_mut() {
        sort_visible(list);
    }
    (visible, tested, accepted)
}

/// Decides one entity as Bevy's `check_visibility_cpu_culling` does: its rules, then its
/// frustum test unless the entity or the view opted out. The test's outcome is taken from
/// `known` when it has one. Counts into `tally`, and gathers into its lists.
#[inline]
pub(crate) fn decide_like_bevy(
    (
        entity,
        inherited,
        mut view_visibility,
        class,
        layers,
        aabb,
        sphere,
        transform,
        no_frustum_culling,
        has_range,
    ): <CandidateItem as bevy::ecs::query::QueryData>::Item<'_, '_>,
    filter: ViewFilter<'_>,
    frustum: &Frustum,
    no_cpu_culling_view: bool,
    known: impl FnOnce(Entity) -> Option<bool>,
    tally: &mut FlatTally,
) {
    // The trees' word first: an entity they put outside is hidden whatever Bevy's rules say,
    // and asking them reads one bit where the rules read the entity's rows.
    let known = (!no_frustum_culling && !no_cpu_culling_view).then(|| known(entity));
    if known == Some(Some(false)) || !filter.admits(entity, inherited, layers, has_range) {
        return;
    }
    match known {
        None | Some(Some(false)) => {}
        Some(Some(true)) => tally.accepted += 1,
        Some(None) => {
            tally.tested += 1;
            if !bevy_frustum_test(frustum, aabb, sphere, transform) {
                return;
            }
        }
    }
    view_visibility.set_visible();
    tally.visible += 1;
    if let Some(class) = class {
        tally.lists.push(class, entity);
    }
}
