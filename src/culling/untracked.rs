//! The entities a view's tree walk cannot find, which every culling pass decides one by one.

use super::AccelCullingSettings;
use crate::components::{AccelIgnore, AccelTracked};
use crate::settings::AccelSettings;
use crate::systems::RejectedEntities;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::{NoCpuCulling, NoFrustumCulling};
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;

/// Entities no tree holds, or that no walk should be trusted to find.
type NeverWalked = (
    With<ViewVisibility>,
    Without<NoCpuCulling>,
    Or<(
        Without<Aabb>,
        Without<GlobalTransform>,
        With<AccelIgnore>,
        With<NoFrustumCulling>,
    )>,
);

/// Entities the trees would hold but for a missing [`AccelTracked`] (it matters only with
/// [`AccelSettings::require_marker`]); disjoint from [`NeverWalked`].
type Unmarked = (
    With<ViewVisibility>,
    Without<NoCpuCulling>,
    With<Aabb>,
    With<GlobalTransform>,
    Without<AccelIgnore>,
    Without<NoFrustumCulling>,
    Without<AccelTracked>,
);

/// Entities that can be seen but that a tree walk would not report for a view:
/// - no `Aabb` or no `GlobalTransform` (never in a tree; Bevy never culls them);
/// - kept out with `AccelIgnore`, or, when [`AccelSettings::require_marker`] is on, not
///   marked [`AccelTracked`];
/// - marked `NoFrustumCulling` (the trees may hold them, but they are visible wherever they
///   are, and a walk finds only what is in view);
/// - left out for a bad transform ([`RejectedEntities`]).
///
/// Why one parameter: the camera and light passes must agree on this set, and each entity
/// must come out of it once (a rejected entity can also be `NoFrustumCulling`).
#[derive(SystemParam)]
pub(crate) struct UntrackedEntities<'w, 's> {
    settings: Res<'w, AccelSettings>,
    culling: Option<Res<'w, AccelCullingSettings>>,
    rejected: Res<'w, RejectedEntities>,
    never_walked: Query<'w, 's, Entity, NeverWalked>,
    unmarked: Query<'w, 's, Entity, Unmarked>,
    no_frustum_culling: Query<'w, 's, (), With<NoFrustumCulling>>,
}

impl UntrackedEntities<'_, '_> {
    /// Whether culling may walk the trees this frame. When the plugin is switched off
    /// ([`AccelSettings::enabled`]) they keep a stale state, and culling must not trust them;
    /// with [`AccelCullingSettings::use_trees`] off, Bevy's per-entity pass runs instead.
    pub(crate) fn trees_current(&self) -> bool {
        self.settings.enabled && self.culling.as_ref().is_none_or(|c| c.use_trees)
    }

    /// Each entity of the set once.
    pub(crate) fn iter(&self) -> impl Iterator<Item = Entity> + '_ {
        let unmarked = self
            .settings
            .require_marker
            .then(|| self.unmarked.iter())
            .into_iter()
            .flatten();
        let rejected = self
            .rejected
            .iter()
            .filter(|&e| !self.no_frustum_culling.contains(e));
        self.never_walked.iter().chain(unmarked).chain(rejected)
    }
}
