//! The sync: entities placed in the trees, moved in them and taken out, so that the trees
//! hold exactly the tracked entities with their current world boxes.
//!
//! Lifecycle changes (an `Aabb` added or removed, a marker added or removed, a despawn) are
//! caught by observers as they happen and queued (`membership`); motion is caught by a
//! `Changed` query over dynamic entities only. So a frame in which nothing was spawned,
//! despawned or moved scans no static entity and touches no tree.

use super::choose_index::IndexSwitchReport;
use super::membership::{MembershipQuery, PendingMembership, RejectedEntities};
use super::prefetched::for_each_prefetched_in_two_stages;
use crate::components::{AccelIgnore, AccelStatic, AccelTracked};
use crate::pool_batches::uneven_work_batches;
use crate::settings::AccelSettings;
use crate::stats::AccelStats;
use crate::trees::{AccelTrees, Placed, placement};
use bevy::camera::primitives::Aabb as BevyAabb;
use bevy::prelude::*;
use bevy::tasks::ComputeTaskPool;
use bevy::utils::Parallel;
use spatial_accel::prefetch::prefetch_all;
use std::time::Instant;

type MovedQuery<'w, 's, StaticFilter> = Query<
    'w,
    's,
    (
        Entity,
        &'static BevyAabb,
        &'static GlobalTransform,
        Has<AccelTracked>,
    ),
    (
        Or<(Changed<GlobalTransform>, Changed<BevyAabb>)>,
        StaticFilter,
        Without<AccelIgnore>,
    ),
>;

/// From this many busy movers, with more than one compute thread, their moves are written
/// from every thread of the pool (see [`move_busy_movers_in_parallel`]): below, the pass's
/// start costs more than it saves.
const PARALLEL_BUSY_FROM: usize = 8_192;

/// From this many dynamic entities, with more than one compute thread, the `Changed` scan
/// itself is split across the pool even when few of them move: it reads every dynamic
/// entity's change ticks, a serial cost that grows with the world, not with its movers.
const PARALLEL_SCAN_FROM: usize = 32_768;

/// The parallel scan leaves to one thread the movers that are not busy movers (they are
/// edits of the dynamic index): it is taken only while last frame had at most this many.
const PARALLEL_SCAN_MAX_LEFT: usize = 1_024;

/// One thread's share of a parallel pass over the moved entities. Aligned to two cache lines
/// so that the threads' shares, which `Parallel` keeps side by side, never share one: the
/// count is bumped per mover (see `FlatTally`).
#[derive(Default)]
#[repr(align(128))]
pub(crate) struct MovesBatch {
    /// Busy movers whose box changed.
    busy_moved: usize,
    /// Busy movers whose move was left unwritten.
    busy_skipped: usize,
    /// Entities the pass left for the one-thread placement: not busy movers, or with a
    /// transform the placement refuses.
    left: Vec<Entity>,
}

/// Inserts, moves and removes entities so the trees hold exactly the tracked entities with
/// their current world boxes; puts busy movers that went quiet back into the dynamic index.
// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sync_trees(
    settings: Res<AccelSettings>,
    mut trees: ResMut<AccelTrees>,
    mut pending: ResMut<PendingMembership>,
    mut rejected: ResMut<RejectedEntities>,
    mut stats: ResMut<AccelStats>,
    mut switch: ResMut<IndexSwitchReport>,
    membership: MembershipQuery,
    moved: MovedQuery<Without<AccelStatic>>,
    moved_static: MovedQuery<With<AccelStatic>>,
    mut batches: Local<Parallel<MovesBatch>>,
) {
    let start = Instant::now();
    let switch = core::mem::take(&mut *switch);
    let mut counts = SyncCounts {
        // Every dynamic entity moved to a new index that landed this frame: as many updates,
        // for the readers.
        updated: switch.moved,
        removed: switch.refused,
        ..default()
    };
    let wanted = |tracked_marker: bool| tracked_marker || !settings.require_marker;
    // `AccelTrees` is marked changed below only if the trees changed, so that readers can
    // skip work in still frames (the culling keeps a view's walk while neither its frustum
    // nor the trees change).
    let tree_state = trees.bypass_change_detection();
    tree_state.clear_assigned_slots();
    let busy = &settings.busy_movers;
    let busy_on = busy.wanted(tree_state.busy_enabled(), stats.moved, stats.rays_per_frame);
    tree_state.begin_busy_frame(busy_on, busy.transfers_per_frame);
    // Why skip: see `trees::unread_movers`. The last frame's culling read no busy mover's box.
    let skip_busy = tree_state
        .unread_movers
        .take_skip(settings.skip_unread_mover_upkeep && !tree_state.step_aside.has_readers());

    for entity in pending.0.drain() {
        let desired =
            membership
                .get(entity)
                .ok()
                .and_then(|(aabb, gt, is_static, ignored, marked)| {
                    (!ignored && wanted(marked)).then_some((aabb?, gt?, is_static))
                });
        match desired {
            Some((aabb, gt, is_static)) => place_checked(
                tree_state,
                &mut rejected,
                entity,
                aabb,
                gt,
                is_static,
                &mut counts,
            ),
            None => {
                rejected.0.remove(&entity);
                counts.removed += tree_state.remove(entity) as usize;
            }
        }
    }
    // Where a tracked entity is now, for the busy movers written after frames left unwritten
    // and for those that go back into the index once quiet.
    let placement_now = |entity| {
        let Ok((Some(aabb), Some(gt), ..)) = membership.get(entity) else {
            return Err("it has no Aabb or GlobalTransform");
        };
        placement(aabb, gt)
    };
    // After the membership changes, so that the busy movers left are live and tracked.
    if !skip_busy && tree_state.unread_movers.is_stale() {
        let mut dropped = Vec::new();
        let refreshed = tree_state.refresh_busy_movers(
            |entity| placement_now(entity).map(|at| at.world),
            &mut dropped,
        );
        counts.updated += refreshed;
        counts.busy_moved += refreshed;
        for (entity, why) in dropped {
            counts.removed += 1;
            rejected.reject(entity, why);
        }
    }
    tree_state.unread_movers.set_stale(skip_busy);
    // The moved entities are scattered through their tables (only some moved): each one's
    // `GlobalTransform` and `Aabb` rows are asked for well ahead, and once those are on their
    // way, its slot and tree leaf (found through the entity) a few entities ahead.
    type Moved<'a> = (Entity, &'a BevyAabb, &'a GlobalTransform, bool);
    type State<'a> = (
        &'a mut AccelTrees,
        &'a mut RejectedEntities,
        &'a mut SyncCounts,
    );
    let rows_ahead = |state: &State, &(entity, aabb, gt, _): &Moved| {
        prefetch_all(gt);
        prefetch_all(aabb);
        state.0.prefetch_record(entity);
    };
    let slot_ahead = |state: &State, &(entity, ..): &Moved| {
        state.0.prefetch_placement(entity);
    };
    let place_moved = |is_static: bool| {
        move |(trees, rejected, counts): &mut State, (entity, aabb, gt, marked): Moved| {
            if !wanted(marked) {
                return;
            }
            if skip_busy && !is_static && trees.is_busy_mover(entity) {
                counts.busy_skipped += 1;
                return;
            }
            place_checked(trees, rejected, entity, aabb, gt, is_static, counts);
        }
    };
    let dynamic_entities = tree_state.index().dynamic_len() + tree_state.busy_len();
    let left_last_frame = stats.moved.saturating_sub(stats.busy_moved);
    let parallel = (tree_state.busy_len() >= PARALLEL_BUSY_FROM
        || (dynamic_entities >= PARALLEL_SCAN_FROM && left_last_frame <= PARALLEL_SCAN_MAX_LEFT))
        && ComputeTaskPool::try_get().is_some_and(|pool| pool.thread_num() > 1);
    if parallel {
        let left = move_busy_movers_in_parallel(
            tree_state,
            dynamic_entities,
            &moved,
            settings.require_marker,
            skip_busy,
            &mut batches,
            &mut counts,
        );
        let place = place_moved(false);
        let mut state = (&mut *tree_state, &mut *rejected, &mut counts);
        for item in left.into_iter().filter_map(|entity| moved.get(entity).ok()) {
            place(&mut state, item);
        }
    } else if busy_on {
        // With the busy movers' list in use, nearly every mover is a busy mover: its rows come
        // in table order and its entry is the next one written, so there is nothing scattered
        // to ask for ahead, and the stages' lookups cost more than they hide (BENCHMARKS.md,
        // Plugin sync).
        let mut state = (&mut *tree_state, &mut *rejected, &mut counts);
        let place = place_moved(false);
        moved.iter().for_each(|item| place(&mut state, item));
    } else {
        let mut state = (&mut *tree_state, &mut *rejected, &mut counts);
        for_each_prefetched_in_two_stages(
            moved.iter(),
            &mut state,
            rows_ahead,
            slot_ahead,
            place_moved(false),
        );
    }
    let mut state = (&mut *tree_state, &mut *rejected, &mut counts);
    if settings.watch_static_motion {
        // A static entity that moved anyway (an editor, a level change) gets its new box in a
        // rebuilt static tree rather than a stale one.
        for_each_prefetched_in_two_stages(
            moved_static.iter(),
            &mut state,
            rows_ahead,
            slot_ahead,
            place_moved(true),
        );
    }
    // Unwritten moves leave the stamps that tell quiet busy movers old, and the runs'
    // bounds as they were: both wait for the frame that writes them.
    if !skip_busy {
        let mut dropped = Vec::new();
        counts.updated += tree_state.settle_quiet_busy_movers(
            busy,
            |entity| {
                let at = placement_now(entity).ok()?;
                Some((at.world, at.frame()))
            },
            &mut dropped,
        );
        for entity in dropped {
            counts.removed += 1;
            rejected.reject(entity, "the dynamic index refused it back");
        }
        tree_state.tighten_busy_chunk_bounds();
    }
    // The index switch's own edits were marked by its system.
    let index_edits = counts.inserted + counts.removed + counts.updated
        - counts.busy_moved
        - switch.moved
        - switch.refused;
    if index_edits > 0 {
        tree_state.note_index_changed();
    }
    if counts.inserted + counts.updated + counts.removed > 0 {
        trees.set_changed();
    }

    stats.inserted = counts.inserted;
    stats.updated = counts.updated;
    stats.removed = counts.removed;
    // Unwritten moves count as moves: the busy movers' list and the choice of index follow
    // how many entities move, not how many were written.
    stats.moved = counts.moved + counts.busy_skipped;
    stats.busy_moved = counts.busy_moved + counts.busy_skipped;
    stats.busy_moves_skipped = counts.busy_skipped;
    stats.rejected = rejected.0.len();
    stats.sync_time = switch.time + start.elapsed();
    trees.step_aside.costs().add_trees(stats.sync_time);
}

/// Writes the new boxes of the moved busy movers from every thread of the compute pool, and
/// returns the moved entities it left for [`place_checked`] (in entity order, so that their
/// slots do not depend on the threads' timing). With `skip_busy`, the busy movers' moves are
/// counted and left unwritten (see `trees::unread_movers`).
///
/// Why: at a million entities the sync's moves are most of its time, and a busy mover's move
/// (its rows read, its world box computed, one list entry written) touches nothing another
/// mover's does; Bevy's own per-entity passes use the pool the same way. In a large world
/// with few movers, the `Changed` scan that finds them (every dynamic entity's ticks) is
/// the sync's time, and it splits the same way. `dynamic_entities` (what the scan goes
/// through) sizes its batches.
fn move_busy_movers_in_parallel(
    trees: &mut AccelTrees,
    dynamic_entities: usize,
    moved: &MovedQuery<Without<AccelStatic>>,
    require_marker: bool,
    skip_busy: bool,
    batches: &mut Parallel<MovesBatch>,
    counts: &mut SyncCounts,
) -> Vec<Entity> {
    let batches_ref = &*batches;
    // The thread's batch is found once per batch of the query, not once per entity (a
    // thread-local lookup each).
    let batch_of_thread = || batches_ref.borrow_local_mut();
    let batching = uneven_work_batches(dynamic_entities);
    if skip_busy {
        let trees = &*trees;
        moved.par_iter().batching_strategy(batching).for_each_init(
            batch_of_thread,
            |batch, (entity, _, _, marked)| {
                if require_marker && !marked {
                    return;
                }
                if trees.is_busy_mover(entity) {
                    batch.busy_skipped += 1;
                } else {
                    batch.left.push(entity);
                }
            },
        );
        return gather_batches(batches, counts);
    }
    let moves = trees.concurrent_busy_moves();
    moved.par_iter().batching_strategy(batching).for_each_init(
        batch_of_thread,
        |batch, (entity, aabb, gt, marked)| {
            if require_marker && !marked {
                return;
            }
            let placed = match placement(aabb, gt) {
                // SAFETY: the query yields each entity once in this pass, and `moves` lives
                // only for it.
                Ok(at) => unsafe { moves.move_busy(entity, at.world) },
                Err(_) => None,
            };
            match placed {
                Some(Placed::Moved) => batch.busy_moved += 1,
                Some(_) => {}
                None => batch.left.push(entity),
            }
        },
    );
    gather_batches(batches, counts)
}

/// Adds the threads' batches into `counts`, and returns the entities they left for
/// [`place_checked`], in entity order.
fn gather_batches(batches: &mut Parallel<MovesBatch>, counts: &mut SyncCounts) -> Vec<Entity> {
    let mut left = Vec::new();
    for batch in batches.iter_mut() {
        counts.busy_moved += batch.busy_moved;
        counts.updated += batch.busy_moved;
        counts.moved += batch.busy_moved;
        counts.busy_skipped += batch.busy_skipped;
        batch.busy_moved = 0;
        batch.busy_skipped = 0;
        left.append(&mut batch.left);
    }
    left.sort_unstable_by_key(|e| e.index());
    left
}

#[derive(Default)]
struct SyncCounts {
    inserted: usize,
    updated: usize,
    removed: usize,
    moved: usize,
    busy_moved: usize,
    /// Busy movers that moved, their moves left unwritten (see `trees::unread_movers`).
    busy_skipped: usize,
}

fn place_checked(
    trees: &mut AccelTrees,
    rejected: &mut RejectedEntities,
    entity: Entity,
    aabb: &BevyAabb,
    gt: &GlobalTransform,
    is_static: bool,
    counts: &mut SyncCounts,
) {
    let at = match placement(aabb, gt) {
        Ok(at) => at,
        Err(why) => {
            counts.removed += trees.remove(entity) as usize;
            rejected.reject(entity, why);
            return;
        }
    };
    // A busy mover needs only its box: its own space is not kept (see `trees::busy_movers`).
    let busy = if is_static {
        None
    } else {
        trees.move_busy(entity, at.world)
    };
    counts.busy_moved += usize::from(busy == Some(Placed::Moved));
    match busy.unwrap_or_else(|| trees.place(entity, at.world, at.frame(), is_static)) {
        // Reported like a bad transform: once, until the entity fits again.
        Placed::Refused(why) => rejected.reject(entity, why),
        Placed::Evicted(why) => {
            counts.removed += 1;
            rejected.reject(entity, why);
        }
        placed => {
            // The set is almost always empty: skip hashing every moved entity into it.
            if !rejected.0.is_empty() && rejected.0.remove(&entity) {
                info!("bevy_accel: entity {entity} is valid again and back in the trees");
            }
            match placed {
                Placed::Inserted => counts.inserted += 1,
                Placed::Moved => counts.updated += 1,
                Placed::Unchanged | Placed::Same | Placed::Refused(_) | Placed::Evicted(_) => {}
            }
            if !is_static && matches!(placed, Placed::Moved | Placed::Unchanged) {
                counts.moved += 1;
            }
        }
    }
}
