//! Components that say which entities the trees hold, and in which tree.

use bevy::prelude::*;

/// Keeps an entity out of every tree, even though it has an `Aabb`.
///
/// Use it for things no query should ever find (sky domes, particles, UI in world space).
/// Removing the component puts the entity back in at the next sync.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Default)]
pub struct AccelIgnore;

/// Puts an entity in the trees when [`AccelSettings::require_marker`] is on.
///
/// By default every entity with an `Aabb` and a `GlobalTransform` is tracked; scenes that want
/// only a few entities in the trees turn the setting on and mark those.
///
/// [`AccelSettings::require_marker`]: crate::AccelSettings::require_marker
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Default)]
pub struct AccelTracked;

/// Marks an entity that never moves: it goes in the static tree.
///
/// The static tree is built once from all static entities and rebuilt only when one is added
/// or removed; it is never refit, and static entities are not watched for motion, which is
/// what makes a frame of a static world cost nothing. To move one, re-insert the marker after
/// moving it (or remove it: the entity then joins the dynamic tree), or turn on
/// [`AccelSettings::watch_static_motion`](crate::AccelSettings::watch_static_motion), which
/// rebuilds the static tree whenever a static entity moves.
#[derive(Component, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Component, Default)]
pub struct AccelStatic;
