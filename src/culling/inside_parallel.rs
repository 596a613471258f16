//! Deciding the entities a walk proved inside a view, spread over the compute task pool.

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
/// order) as [`super::tree_pass::ViewPass::decide_inside`] does, in contiguous parts on the
/// compute task pool; each part's visible entities are appended to `lists` in part order, so
/// the lists keep the slot order a single thread gives. Returns how many were visible, or
/// `None` (nothing decided) when the list is too short to split or there is no pool.
///
/// Why: the decisions wait on memory (a location record, then rows, for each entity), and
/// how many misses a core keeps in flight is bounded by its fill buffers; two cores keep
/// twice as many, as Bevy's own culling loop uses the pool. At 1M entities with 5% in view
/// this took the still view from 3.4-4.0 ms to 1.9-2.6 ms on a 2-core machine (BENCHMARKS.md).
///
/// `part_lists` holds one list set per part between calls, so that their memory is reused.
pub(crate) fn decide_inside_in_parts(
    deciding: &mut Query<DecideItem, DecideFilter>,
    filter: ViewFilter<'_>,
    inside: &[Entity],
    entities: &Entities,
    lists: &mut ClassLists,
    part_lists: &mut Vec<ClassLists>,
) -> Option<usize> {
    let pool = ComputeTaskPool::try_get()?;
    // The calling thread works on the scope's tasks too.
    let workers = pool.thread_num() + 1;
    // A few parts per worker, so that a thread that starts late (woken from sleep, or busy
    // elsewhere) leaves its share to the others instead of holding up the view.
    let parts = (4 * workers).min(inside.len() / MIN_PART);
    if inside.len() < PARALLEL_FROM || parts < 2 {
        return None;
    }
    let part_len = inside.len().div_ceil(parts);
    if part_lists.len() < parts {
        part_lists.resize_with(parts, ClassLists::default);
    }
    let query = &*deciding;
    let counts: Vec<usize> = pool.scope(|scope| {
        for (part, part_lists) in inside.chunks(part_len).zip(part_lists.iter_mut()) {
            scope.spawn(async move { decide_part(query, filter, part, entities, part_lists) });
        }
    });
    for part in part_lists.iter_mut() {
        lists.append_from(part);
    }
    Some(counts.into_iter().sum())
}

/// One part: rows fetched a batch ahead, then Bevy's rules (no frustum test).
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
        for &entity in batch {
            // SAFETY: every entity of `inside` is distinct (one per tree slot) and the parts
            // do not overlap, so no two live items alias; the query's access was registered
            // by the system that owns it, which runs no other use of it meanwhile.
            let Ok((entity, inherited, mut view_visibility, class, layers, has_range)) =
                (unsafe { query.get_unchecked(entity) })
            else {
                continue;
            };
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
