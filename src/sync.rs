//! The systems that keep the trees in step with the entities.
//!
//! Lifecycle changes (an `Aabb` added or removed, a marker added or removed, a despawn) are
//! caught by observers as they happen and queued; motion is caught by a `Changed` query over
//! dynamic entities only. So a frame in which nothing was spawned, despawned or moved scans
//! no static entity and touches no tree.

use crate::components::{AccelIgnore, AccelStatic, AccelTracked};
use crate::index::{AutomaticIndex, BusyMoverSettings};
use crate::prefetch::{for_each_prefetched_in_two_stages, prefetch_all};
use crate::settings::AccelSettings;
use crate::stats::AccelStats;
use crate::trees::{AccelTrees, LocalFrame, Placed};
use bevy::camera::primitives::Aabb as BevyAabb;
use bevy::ecs::entity::EntityHashSet;
use bevy::math::Affine3A;
use bevy::prelude::*;
use std::time::Instant;

/// Entities whose tree membership may have changed since the last sync.
#[derive(Resource, Default)]
pub(crate) struct PendingMembership(EntityHashSet);

/// Entities left out for a bad transform or box, each warned about once.
#[derive(Resource, Default)]
pub(crate) struct RejectedEntities(EntityHashSet);

impl RejectedEntities {
    /// The entities currently left out (culling tests them one by one, outside the trees).
    #[cfg_attr(not(feature = "culling"), allow(dead_code))]
    pub(crate) fn iter(&self) -> impl Iterator<Item = Entity> + '_ {
        self.0.iter().copied()
    }
}

/// The components whose arrival or departure can change an entity's tree membership.
type MembershipComponents = (
    BevyAabb,
    GlobalTransform,
    AccelStatic,
    AccelIgnore,
    AccelTracked,
);

/// Queues the entity of a lifecycle event for a membership check at the next sync.
fn queue_membership_check<E: EntityEvent>(
    event: On<E, MembershipComponents>,
    mut pending: ResMut<PendingMembership>,
) {
    pending.0.insert(event.event_target());
}

/// Registers the observers that feed [`PendingMembership`]: one for insertions (first or
/// repeated: re-inserting `AccelStatic` re-reads a static box) and one for
/// removals (a despawn removes every component, so it is caught too).
pub(crate) fn add_membership_observers(app: &mut App) {
    app.add_observer(queue_membership_check::<Insert>)
        .add_observer(queue_membership_check::<Remove>);
}

/// Where an entity is: its world box, and what its own space is taken from.
pub(crate) struct Placement {
    /// The entity's `Aabb` in world space.
    pub(crate) world: spatial_accel::Aabb,
    affine: Affine3A,
    local: spatial_accel::Aabb,
}

impl Placement {
    /// The entity's own space. Taken on demand: a busy mover's sync needs only the box.
    pub(crate) fn frame(&self) -> LocalFrame {
        // Inverted as Bevy's `MeshRayCast` does for each ray, so local rays match its own.
        LocalFrame {
            local_from_world: self.affine.inverse(),
            local_bounds: self.local,
        }
    }
}

/// The world box and own space of an entity, or why it has none. Non-finite or singular
/// transforms would put NaN or infinities into the tree (a NaN box hides its whole subtree
/// from every query), so they are refused here and the entity stays out until its transform
/// is valid again.
pub(crate) fn placement(
    aabb: &BevyAabb,
    transform: &GlobalTransform,
) -> Result<Placement, &'static str> {
    let affine = transform.affine();
    let det = affine.matrix3.determinant();
    if !det.is_finite() || !affine.translation.is_finite() {
        return Err("its GlobalTransform is not finite");
    }
    if det == 0.0 {
        return Err("its GlobalTransform has a zero scale");
    }
    let local = spatial_accel::Aabb::from_center_half_extents(aabb.center, aabb.half_extents);
    if !local.is_finite() {
        return Err("its Aabb is not finite");
    }
    let world = local.transformed(&affine);
    if !world.is_finite() {
        return Err("its world bounds overflow");
    }
    Ok(Placement {
        world,
        affine,
        local,
    })
}

type MembershipQuery<'w, 's> = Query<
    'w,
    's,
    (
        Option<&'static BevyAabb>,
        Option<&'static GlobalTransform>,
        Has<AccelStatic>,
        Has<AccelIgnore>,
        Has<AccelTracked>,
    ),
>;

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

/// Inserts, moves and removes entities so the trees hold exactly the tracked entities with
/// their current world boxes.
// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sync_trees(
    settings: Res<AccelSettings>,
    mut trees: ResMut<AccelTrees>,
    mut pending: ResMut<PendingMembership>,
    mut rejected: ResMut<RejectedEntities>,
    mut stats: ResMut<AccelStats>,
    automatic: Res<AutomaticIndex>,
    membership: MembershipQuery,
    moved: MovedQuery<Without<AccelStatic>>,
    moved_static: MovedQuery<With<AccelStatic>>,
) {
    let start = Instant::now();
    let mut counts = SyncCounts::default();
    let wanted = |tracked_marker: bool| tracked_marker || !settings.require_marker;
    // `AccelTrees` is marked changed below only if the trees changed, so that readers can
    // skip work in still frames (the culling keeps a view's walk while neither its frustum
    // nor the trees change).
    let tree_state = trees.bypass_change_detection();
    tree_state.clear_assigned_slots();
    let busy = &settings.busy_movers;
    let busy_on = busy.wanted(tree_state.busy_enabled(), stats.moved, stats.rays_per_frame);
    tree_state.begin_busy_frame(busy_on, busy.transfers_per_frame);
    let target = automatic.resolve(settings.index);
    let landed = tree_state.advance_index_switch(target, settings.index_switch_in_frame_up_to);
    let switched = landed.is_some();
    if let Some(landed) = landed {
        // Every dynamic entity moved to the new index: as many updates, for the readers.
        for (entity, why) in landed.refused.iter().copied() {
            reject(&mut rejected, entity, why);
        }
        counts.updated += landed.moved;
        counts.removed += landed.refused.len();
    }

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
            if wanted(marked) {
                place_checked(trees, rejected, entity, aabb, gt, is_static, counts);
            }
        }
    };
    let mut state = (&mut *tree_state, &mut *rejected, &mut counts);
    for_each_prefetched_in_two_stages(
        moved.iter(),
        &mut state,
        rows_ahead,
        slot_ahead,
        place_moved(false),
    );
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
    settle_quiet_busy_movers(tree_state, &mut rejected, &membership, busy, &mut counts);
    let static_rebuilt = tree_state.advance_static(
        settings.static_rebuild_in_frame_up_to,
        settings.static_build,
    );
    let index_edits = counts.inserted + counts.removed + counts.updated - counts.busy_moved;
    if index_edits > 0 || static_rebuilt || switched {
        tree_state.note_index_changed();
    }
    if counts.inserted + counts.updated + counts.removed > 0 || static_rebuilt || switched {
        trees.set_changed();
    }

    stats.inserted = counts.inserted;
    stats.updated = counts.updated;
    stats.removed = counts.removed;
    stats.moved = counts.moved;
    stats.busy_moved = counts.busy_moved;
    stats.rejected = rejected.0.len();
    stats.static_rebuilt = static_rebuilt;
    stats.sync_time = start.elapsed();
}

#[derive(Default)]
struct SyncCounts {
    inserted: usize,
    updated: usize,
    removed: usize,
    moved: usize,
    busy_moved: usize,
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
            reject(rejected, entity, why);
            return;
        }
    };
    // A busy mover needs only its box: its own space is not kept (see `trees_busy`).
    let busy = if is_static {
        None
    } else {
        trees.move_busy(entity, at.world)
    };
    counts.busy_moved += usize::from(busy == Some(Placed::Moved));
    match busy.unwrap_or_else(|| trees.place(entity, at.world, at.frame(), is_static)) {
        // Reported like a bad transform: once, until the entity fits again.
        Placed::Refused(why) => reject(rejected, entity, why),
        Placed::Evicted(why) => {
            counts.removed += 1;
            reject(rejected, entity, why);
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

/// Puts the busy movers that stopped moving back into the dynamic index, a sweep's worth a
/// frame (all of them, over frames, once movers may not be busy).
fn settle_quiet_busy_movers(
    trees: &mut AccelTrees,
    rejected: &mut RejectedEntities,
    membership: &MembershipQuery,
    busy: &BusyMoverSettings,
    counts: &mut SyncCounts,
) {
    let mut quiet = Vec::new();
    trees.quiet_busy_movers(busy.quiet_frames, busy.checks(trees.busy_len()), &mut quiet);
    for entity in quiet {
        let now = membership
            .get(entity)
            .ok()
            .and_then(|(aabb, gt, ..)| Some((aabb?, gt?)));
        let settled = match now.map(|(aabb, gt)| placement(aabb, gt)) {
            Some(Ok(at)) => trees.settle_busy(entity, at.world, at.frame()),
            // Gone or invalid since its last move: its membership check or its next move
            // says so too; out it goes.
            _ => {
                trees.remove(entity);
                false
            }
        };
        if settled {
            counts.updated += 1;
        } else {
            counts.removed += 1;
            reject(rejected, entity, "the dynamic index refused it back");
        }
    }
}

/// Adds an entity to the rejected set, warning the first time.
fn reject(rejected: &mut RejectedEntities, entity: Entity, why: &str) {
    if rejected.0.insert(entity) {
        warn!("bevy_accel: entity {entity} is left out of the trees: {why}");
    }
}
