//! Deciding the entities a view's tree walk found: straight from Bevy's table columns, and
//! spread over the compute task pool when they are many.

use super::class_lists::ClassLists;
use super::system::ViewFilter;
use super::table_rows::{BoundsColumns, DecideColumns, DecideTally, ExactTest, FoundEntity};
use super::tree_pass::ViewPass;
use super::view_walk::ViewWalk;
use bevy::camera::visibility::SetViewVisibility;
use bevy::ecs::entity::Entities;
use bevy::prelude::*;
use bevy::tasks::ComputeTaskPool;

/// Below this many entities one thread decides them all: a task's start costs more than it
/// saves.
const PARALLEL_FROM: usize = 8_192;

/// The fewest entities a part is given.
const MIN_PART: usize = 2_048;

/// How many entities ahead of its decision an entity's rows are prefetched: enough
/// decisions to cover a memory latency.
const ROWS_AHEAD: usize = 16;

/// Decides what `walk` found, by Bevy's rules: the entities a tree proved inside without a
/// frustum test, those whose leaf crosses a plane with it. Sets `ViewVisibility`, fills the
/// pass's lists (each list in slot order, inside entities first) and counts into its stats.
/// Replaces the row hints in `walk` that no longer held, and returns how many it replaced.
///
/// `part_lists` holds one list set per part between calls, so that their memory is reused.
pub(crate) fn decide_found(
    pass: &mut ViewPass<'_, '_, '_>,
    walk: &mut ViewWalk,
    entities: &Entities,
    part_lists: &mut Vec<ClassLists>,
) -> usize {
    let bounds = BoundsColumns::gather(pass.bounds, entities);
    let (Some(columns), Some(bounds)) = (DecideColumns::gather(pass.deciding, entities), &bounds)
    else {
        decide_by_lookup(pass, walk);
        return 0;
    };
    let exact = ExactTest {
        frustum: pass.frustum,
        bounds,
    };
    let (inside, inside_in_parts) = decide_list(
        &columns,
        pass.filter,
        None,
        &mut walk.inside,
        entities,
        pass.lists,
        part_lists,
    );
    let (crossing, crossing_in_parts) = decide_list(
        &columns,
        pass.filter,
        Some(exact),
        &mut walk.crossing,
        entities,
        pass.lists,
        part_lists,
    );
    let stats = &mut *pass.stats;
    stats.accepted_by_subtree += inside.visible;
    stats.visible += inside.visible + crossing.visible;
    stats.tested += crossing.tested;
    stats.views_decided_in_parts += usize::from(inside_in_parts || crossing_in_parts);
    inside.refreshed + crossing.refreshed
}

/// Decides `list` (entities a walk found, each at most once, in slot order), with Bevy's
/// frustum test if `exact` is given, filling `lists` in list order.
///
/// From [`PARALLEL_FROM`] entities, and when Bevy's compute task pool exists, the list is
/// decided in contiguous parts on the pool, and each part's visible entities are appended to
/// `lists` in part order, so the lists come out as from one thread. Why: the decisions wait on
/// memory (rows of a few columns for each entity), and how many misses a core keeps in flight
/// is bounded by its fill buffers; two cores keep twice as many, as Bevy's own culling loop
/// uses the pool. At 1M entities with 5% in view this took the still view from 3.4-4.0 ms to
/// 1.9-2.6 ms on a 2-core machine, when decisions still went through entity lookups
/// (BENCHMARKS.md).
fn decide_list(
    columns: &DecideColumns<'_>,
    filter: ViewFilter<'_>,
    exact: Option<ExactTest<'_, '_>>,
    list: &mut [FoundEntity],
    entities: &Entities,
    lists: &mut ClassLists,
    part_lists: &mut Vec<ClassLists>,
) -> (DecideTally, bool) {
    let pool = ComputeTaskPool::try_get();
    // The calling thread works on the scope's tasks too. A few parts per worker, so that a
    // thread that starts late (woken from sleep, or busy elsewhere) leaves its share to the
    // others instead of holding up the view.
    let parts = pool.map_or(1, |pool| {
        (4 * (pool.thread_num() + 1)).min(list.len() / MIN_PART)
    });
    let (Some(pool), true) = (pool, list.len() >= PARALLEL_FROM && parts >= 2) else {
        return (
            decide_part(columns, filter, exact, list, entities, lists),
            false,
        );
    };
    let part_len = list.len().div_ceil(parts);
    if part_lists.len() < parts {
        part_lists.resize_with(parts, ClassLists::default);
    }
    let tallies: Vec<DecideTally> = pool.scope(|scope| {
        for (part, part_lists) in list.chunks_mut(part_len).zip(part_lists.iter_mut()) {
            scope.spawn(
                async move { decide_part(columns, filter, exact, part, entities, part_lists) },
            );
        }
    });
    for part in part_lists.iter_mut() {
        lists.append_from(part);
    }
    let tally = tallies
        .into_iter()
        .fold(DecideTally::default(), DecideTally::add);
    (tally, true)
}

/// One part, in order, each entity's rows prefetched [`ROWS_AHEAD`] entities earlier.
fn decide_part(
    columns: &DecideColumns<'_>,
    filter: ViewFilter<'_>,
    exact: Option<ExactTest<'_, '_>>,
    part: &mut [FoundEntity],
    entities: &Entities,
    lists: &mut ClassLists,
) -> DecideTally {
    let mut tally = DecideTally::default();
    for i in 0..part.len() {
        if let Some(ahead) = part.get(i + ROWS_AHEAD) {
            columns.prefetch_row(ahead.hint);
            if let Some(exact) = exact {
                exact.bounds.prefetch_row(ahead.hint);
            }
        }
        columns.decide(&mut part[i], filter, exact, entities, lists, &mut tally);
    }
    tally
}

/// The same decisions through the queries, one lookup per entity: for queries that cannot be
/// read as table columns (never expected; see [`DecideColumns::gather`]).
fn decide_by_lookup(pass: &mut ViewPass<'_, '_, '_>, walk: &ViewWalk) {
    for item in &walk.inside {
        let Ok((entity, inherited, mut view_visibility, class, layers, has_range)) =
            pass.deciding.get_mut(item.entity)
        else {
            continue;
        };
        if !pass.filter.admits(entity, inherited, layers, has_range) {
            continue;
        }
        pass.stats.visible += 1;
        pass.stats.accepted_by_subtree += 1;
        view_visibility.set_visible();
        if let Some(class) = class {
            pass.lists.push(class, entity);
        }
    }
    for item in &walk.crossing {
        pass.decide_exact(item.entity);
    }
}
