//! Deciding the entities a walk proved inside a view: no frustum test, and spread over the
//! compute task pool when they are many.

use super::class_lists::ClassLists;
use super::system::ViewFilter;
use super::tree_pass::{DecideFilter, DecideItem, TOUCH_BATCH, touch_rows};
use bevy::camera::visibility::SetViewVisibility;
use bevy::ecs::entity::Entities;
use bevy::prelude::*;
use bevy::tasks::ComputeTaskPool;

/// Below this many entities one thread decides them all: a task's start costs more than it
/// saves.
const PARALLEL_FROM: usize = 8_192;

/// The fewest entities a part is given.
const MIN_PART: usize = 2_048;

/// Decides `inside` (entities a tree proved inside the view, each at most once, in slot
/// order) by Bevy's rules without a frustum test, setting `ViewVisibility` and filling `lists`
/// in slot order. Returns how many were visible, and whether they were decided in parts.
///
/// From [`PARALLEL_FROM`] entities, and when Bevy's compute task pool exists, the list is
/// decided in contiguous parts on the pool, and each part's visible entities are appended to
/// `lists` in part order, so the lists come out as from one thread. Why: the decisions wait on
/// memory (a location record, then rows, for each entity), and how many misses a core keeps
/// in flight is bounded by its fill buffers; two cores keep twice as many, as Bevy's own
/// culling loop uses the pool. At 1M entities with 5% in view this took the still view from
/// 3.4-4.0 ms to 1.9-2.6 ms on a 2-core machine (BENCHMARKS.md).
///
/// `part_lists` holds one list set per part between calls, so that their memory is reused.
pub(crate) fn decide_inside(
    deciding: &mut Query<DecideItem, DecideFilter>,
    filter: ViewFilter<'_>,
    inside: &[Entity],
    entities: &Entities,
    lists: &mut ClassLists,
    part_lists: &mut Vec<ClassLists>,
) -> (usize, bool) {
    let query = &*deciding;
    let pool = ComputeTaskPool::try_get();
    // The calling thread works on the scope's tasks too. A few parts per worker, so that a
    // thread that starts late (woken from sleep, or busy elsewhere) leaves its share to the
    // others instead of holding up the view.
    let parts = pool.map_or(1, |pool| {
        (4 * (pool.thread_num() + 1)).min(inside.len() / MIN_PART)
    });
    let (Some(pool), true) = (pool, inside.len() >= PARALLEL_FROM && parts >= 2) else {
        return (decide_part(query, filter, inside, entities, lists), false);
    };
    let part_len = inside.len().div_ceil(parts);
    if part_lists.len() < parts {
        part_lists.resize_with(parts, ClassLists::default);
    }
    let counts: Vec<usize> = pool.scope(|scope| {
        for (part, part_lists) in inside.chunks(part_len).zip(part_lists.iter_mut()) {
            scope.spawn(async move { decide_part(query, filter, part, entities, part_lists) });
        }
    });
    for part in part_lists.iter_mut() {
        lists.append_from(part);
    }
    (counts.into_iter().sum(), true)
}

/// One part: each batch's rows are requested while the batch before it is decided, so the
/// prefetches have a batch's worth of work to arrive in; one query iterator per batch sets
/// up the fetch once, where a `get` per entity sets it up each time.
fn decide_part(
    query: &Query<DecideItem, DecideFilter>,
    filter: ViewFilter<'_>,
    part: &[Entity],
    entities: &Entities,
    lists: &mut ClassLists,
) -> usize {
    let mut visible = 0;
    let touch = |batch: &[Entity]| touch_rows(query, batch, entities);
    let mut batches = part.chunks(TOUCH_BATCH).peekable();
    if let Some(first) = batches.peek() {
        touch(first);
    }
    while let Some(batch) = batches.next() {
        if let Some(next) = batches.peek() {
            touch(next);
        }
        // SAFETY: every entity of `inside` is distinct (one per tree slot) and the parts do
        // not overlap, so no two live items alias; the query's access was registered by the
        // system that owns it, which runs no other use of it meanwhile.
        let mut items = unsafe { query.iter_many_unsafe(batch) };
        while let Some((entity, inherited, mut view_visibility, class, layers, has_range)) =
            items.fetch_next()
        {
            if !filter.admits(entity, inherited, layers, has_range) {
                continue;
            }
            visible += 1;
            view_visibility.set_visible();
            if let Some(class) = class {
                lists.push(class, entity);
            }
        }
    }
    visible
}
