//! Which entities belong in the trees: lifecycle changes caught by observers as they happen,
//! and the entities left out for a bad transform or box.

use crate::components::{AccelIgnore, AccelStatic, AccelTracked};
use bevy::camera::primitives::Aabb as BevyAabb;
use bevy::ecs::entity::EntityHashSet;
use bevy::prelude::*;

/// Entities whose tree membership may have changed since the last sync.
#[derive(Resource, Default)]
pub(crate) struct PendingMembership(pub(super) EntityHashSet);

/// Entities left out for a bad transform or box, each warned about once.
#[derive(Resource, Default)]
pub(crate) struct RejectedEntities(pub(super) EntityHashSet);

impl RejectedEntities {
    /// The entities currently left out (culling tests them one by one, outside the trees).
    #[cfg_attr(not(feature = "culling"), allow(dead_code))]
    pub(crate) fn iter(&self) -> impl Iterator<Item = Entity> + '_ {
        self.0.iter().copied()
    }

    /// Adds an entity to the set, warning the first time.
    pub(super) fn reject(&mut self, entity: Entity, why: &str) {
        if self.0.insert(entity) {
            warn!("bevy_accel: entity {entity} is left out of the trees: {why}");
        }
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

/// What the sync reads of an entity whose membership may have changed.
pub(super) type MembershipQuery<'w, 's> = Query<
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
