//! Deciding the entities a view's tree walk found: straight from Bevy's table columns, and
//! spread over the compute task pool when they are many.

use super::table_rows::{
    BoundsColumns, DecideColumns, DecideTally, ExactTest, FoundEntity, SlotRows,
};
use super::view_pass::ViewPass;
use crate::culling::bevy_rules::ViewFilter;
use crate::culling::class_lists::ClassLists;
use crate::culling::slot_order::{KeyRuns, LOOKUP_AHEAD, prefetch_entry};
use bevy::camera::visibility::SetViewVisibility;
use bevy::ecs::entity::Entities;
use bevy::prelude::*;
use bevy::tasks::ComputeTaskPool;

/// Below this many entities one thread decides them all: a task's start costs more than it
/// saves. With one compute thread the parts only overlap with the calling thread.
const PARALLEL_FROM: usize = 8_192;

/// [`PARALLEL_FROM`] where the pool has threads of its own to give the parts: a view's
/// decisions then shrink with threads as Bevy's loop does (issue 72).
const PARALLEL_FROM_SEVERAL_THREADS: usize = 2_048;

/// The fewest entities a part is given.
const MIN_PART: usize = 1_024;

/// How many entities ahead of its decision an entity's rows are prefetched: enough
/// decisions to cover a memory latency.
const ROWS_AHEAD: usize = 16;

/// A fresh walk's finds, to be turned into the view's list of [`FoundEntity`] as they are
/// decided: the whole list, or its tail after the finds kept from the last frame.
#[derive(Clone, Copy)]
pub(crate) struct FreshFinds<'a> {
    /// The walk's finds, each run in slot order
    /// ([`FoundSlots::sorted_keys`](crate::culling::slot_order::FoundSlots::sorted_keys)).
    pub(crate) keys: KeyRuns<'a>,
    /// Where in the view's list they go: the entries before are kept.
    pub(crate) from: usize,
    /// [`AccelTrees::slot_entities`](crate::AccelTrees::slot_entities).
    pub(crate) slot_entities: &'a [Option<Entity>],
    pub(crate) slot_rows: &'a SlotRows,
}

impl<'a> FreshFinds<'a> {
    /// The finds that go into `range` of the view's list, with where in the range they
    /// start; `None` if the range is all kept entries.
    fn within(&self, range: core::ops::Range<usize>) -> Option<(usize, FreshFinds<'a>)> {
        let start = range.start.max(self.from);
        let end = range.end.min(self.from + self.keys.len());
        (start < end).then(|| {
            let keys = self.keys.slice(start - self.from..end - self.from);
            (start - range.start, FreshFinds { keys, ..*self })
        })
    }
}

/// Decides what a view's walk found, by Bevy's rules: the entities a tree proved inside
/// without a frustum test, those whose leaf crosses a plane with it. Sets `ViewVisibility`,
/// fills the pass's lists in `found`'s order and counts into its stats.
///
/// With `fresh` finds, `found` is first rebuilt from them from `fresh.from` on (in the same
/// parallel parts as the decisions: why, see [`decide_list`]); the entries before, and the
/// whole list without, are those kept from the last frame, decided again. Row hints in
/// `found` that no longer held are replaced; returns how many.
///
/// `part_lists` holds one list set per part between calls, so that their memory is reused.
pub(crate) fn decide_found(
    pass: &mut ViewPass<'_, '_, '_>,
    found: &mut Vec<FoundEntity>,
    fresh: Option<FreshFinds<'_>>,
    entities: &Entities,
    part_lists: &mut Vec<ClassLists>,
) -> usize {
    if let Some(fresh) = &fresh {
        // Sized without clearing: every entry is overwritten by the fill, so only a longer
        // list than last frame's writes its new tail twice.
        found.resize(fresh.from + fresh.keys.len(), FoundEntity::VACANT);
    }
    let bounds = BoundsColumns::gather(pass.bounds, entities);
    let (Some(columns), Some(bounds)) = (
        DecideColumns::gather(pass.deciding, entities, pass.filter),
        &bounds,
    ) else {
        if let Some(fresh) = &fresh {
            fill_from_keys(&mut found[fresh.from..], fresh);
        }
        decide_by_lookup(pass, found);
        return 0;
    };
    let decider = Decider {
        columns: &columns,
        filter: pass.filter,
        exact: ExactTest {
            frustum: pass.frustum,
            bounds,
        },
        entities,
    };
    let (tally, in_parts) = decide_list(decider, found, fresh.as_ref(), pass.lists, part_lists);
    let stats = &mut *pass.stats;
    stats.accepted_by_subtree += tally.accepted;
    stats.visible += tally.visible;
    stats.tested += tally.tested;
    stats.views_decided_in_parts += usize::from(in_parts);
    tally.refreshed
}

/// What every decision of one view reads: the columns, the view's rules, Bevy's frustum test
/// for the entities crossing a plane, and the entity records for rows that moved.
#[derive(Clone, Copy)]
struct Decider<'a, 'q> {
    columns: &'a DecideColumns<'q>,
    filter: ViewFilter<'a>,
    exact: ExactTest<'a, 'q>,
    entities: &'a Entities,
}

/// Decides `list` (entities a walk found, each at most once, in runs of slot order), filling
/// `lists` in list order. With `fresh` finds (as many as `list` holds from `fresh.from` on),
/// each part first fills its share of that tail from its share of the keys.
///
/// From [`PARALLEL_FROM`] entities, and when Bevy's compute task pool exists, the list is
/// decided in contiguous parts on the pool, and each part's visible entities are appended to
/// `lists` in part order, so the lists come out as from one thread. Why: the decisions wait on
/// memory (rows of a few columns for each entity, and for fresh finds each slot's entity and
/// row hint), and how many misses a core keeps in flight is bounded by its fill buffers; two
/// cores keep twice as many, as Bevy's own culling loop uses the pool (BENCHMARKS.md,
/// Culling).
fn decide_list(
    decider: Decider<'_, '_>,
    list: &mut [FoundEntity],
    fresh: Option<&FreshFinds<'_>>,
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
    let from = if pool.is_some_and(|pool| pool.thread_num() > 1) {
        PARALLEL_FROM_SEVERAL_THREADS
    } else {
        PARALLEL_FROM
    };
    let (Some(pool), true) = (pool, list.len() >= from && parts >= 2) else {
        let fresh = fresh.and_then(|f| f.within(0..list.len()));
        let tally = decide_part(decider, list, fresh, lists);
        return (tally, false);
    };
    let part_len = list.len().div_ceil(parts);
    if part_lists.len() < parts {
        part_lists.resize_with(parts, ClassLists::default);
    }
    let tallies: Vec<DecideTally> = pool.scope(|scope| {
        for (i, (part, part_lists)) in list
            .chunks_mut(part_len)
            .zip(part_lists.iter_mut())
            .enumerate()
        {
            // The same boundaries over the keys as over the list.
            let start = i * part_len;
            let fresh = fresh.and_then(|f| f.within(start..start + part.len()));
            scope.spawn(async move { decide_part(decider, part, fresh, part_lists) });
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

/// One part, in order, each entity's rows prefetched [`ROWS_AHEAD`] entities earlier; with
/// `fresh` finds (and where in the part they start), the part is first filled from them.
fn decide_part(
    decider: Decider<'_, '_>,
    part: &mut [FoundEntity],
    fresh: Option<(usize, FreshFinds<'_>)>,
    lists: &mut ClassLists,
) -> DecideTally {
    let Decider {
        columns,
        filter,
        exact,
        entities,
    } = decider;
    if let Some((at, fresh)) = fresh {
        fill_from_keys(&mut part[at..], &fresh);
    }
    let mut tally = DecideTally::default();
    for i in 0..part.len() {
        if let Some(ahead) = part.get(i + ROWS_AHEAD) {
            columns.prefetch_row(ahead.hint);
            if ahead.exact {
                exact.bounds.prefetch_row(ahead.hint);
            }
        }
        columns.decide(&mut part[i], filter, exact, entities, lists, &mut tally);
    }
    tally
}

/// Fills `part` from `fresh.keys` (as many), each slot's entity and row hint prefetched
/// [`LOOKUP_AHEAD`] keys earlier. Why: ascending slots are still scattered through a large
/// world's slot arrays (a view's slab of a grid is a few slots of every row), too far apart
/// for the hardware prefetcher; waiting on each lookup was most of the ordering's time.
fn fill_from_keys(part: &mut [FoundEntity], fresh: &FreshFinds<'_>) {
    for (i, (item, key)) in part.iter_mut().zip(fresh.keys.iter()).enumerate() {
        if let Some(ahead) = fresh.keys.get(i + LOOKUP_AHEAD) {
            prefetch_entry(fresh.slot_entities, ahead.slot());
            fresh.slot_rows.prefetch(ahead.slot());
        }
        *item = FoundEntity::of_slot(
            key.slot(),
            key.exact(),
            fresh.slot_entities,
            fresh.slot_rows,
        );
    }
}

/// The same decisions through the queries, one lookup per entity: for queries that cannot be
/// read as table columns (never expected; see [`DecideColumns::gather`]).
fn decide_by_lookup(pass: &mut ViewPass<'_, '_, '_>, found: &[FoundEntity]) {
    for item in found {
        if item.exact {
            pass.decide_exact(item.entity);
            continue;
        }
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
}
