//! The plugin's systems, in `PostUpdate`, in the order a frame runs them (each set after the
//! one before, all after transform propagation and bounds calculation, and before Bevy's
//! visibility checks, so that culling sees this frame's trees):
//!
//! 1. [`AccelSystems::ChooseIndex`] (`choose_index`, only while a switch is due): a switch
//!    of the movers' index starts, or lands when its fill is done.
//! 2. [`AccelSystems::Sync`] (`sync`, with `membership` and `prefetched`): entities that
//!    appeared, changed membership, moved or left are placed in the trees or taken out; busy
//!    movers that went quiet go back into the index.
//! 3. [`AccelSystems::Maintain`] (`maintain`, `bvh_upkeep`): the static tree's builds land
//!    or start; the dynamic index is refit and improved within its budget; the frame's
//!    [`AccelStats`](crate::AccelStats) are published (`publish_stats`) and the automatic
//!    choice of index reads them.
//! 4. [`AccelSystems::Stats`]: none of the plugin's own; the point after which the trees and
//!    [`AccelStats`](crate::AccelStats) hold the whole frame's state.
//!
//! With [`AccelDiagnosticsPlugin`](crate::AccelDiagnosticsPlugin), one system in `Last` adds
//! the trees', the culling's and the picking's figures to Bevy's diagnostics.

mod bvh_upkeep;
mod choose_index;
mod maintain;
mod membership;
mod prefetched;
mod publish_stats;
pub(crate) mod step_aside;
mod sync;

#[cfg(feature = "culling")]
pub(crate) use membership::RejectedEntities;
pub(crate) use step_aside::trees_awake;

use crate::settings::AccelSettings;
use bevy::camera::visibility::VisibilitySystems;
use bevy::prelude::*;
use bevy::transform::TransformSystems;

/// The plugin's system sets, in `PostUpdate`, in this order, after transform propagation and
/// bounds calculation and before visibility checks (so culling sees this frame's trees).
/// Read [`AccelTrees`](crate::AccelTrees) after [`AccelSystems::Sync`] (or after
/// [`AccelSystems::Stats`] for the whole frame's state).
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AccelSystems {
    /// A switch of the movers' index to the one the settings or the automatic choice ask for
    /// started or landed (its system runs only while a switch is due).
    ChooseIndex,
    /// Entities inserted, moved and removed.
    Sync,
    /// The static tree's builds landed; the dynamic index refit, optimised, and rebuilt when
    /// its quality decays.
    Maintain,
    /// After it, [`AccelStats`](crate::AccelStats) and the trees hold the frame's state
    /// (published at the end of the maintenance, which saves the executor a system a frame;
    /// the diagnostics, with [`AccelDiagnosticsPlugin`](crate::AccelDiagnosticsPlugin),
    /// follow in `Last`).
    Stats,
}

/// Adds the systems, their sets and the resources they keep to `app`.
pub(crate) fn add_tree_systems(app: &mut App) {
    app.init_resource::<choose_index::AutomaticIndex>()
        .init_resource::<choose_index::IndexSwitchReport>()
        .init_resource::<membership::PendingMembership>()
        .init_resource::<membership::RejectedEntities>()
        .configure_sets(
            PostUpdate,
            (
                AccelSystems::ChooseIndex,
                AccelSystems::Sync,
                AccelSystems::Maintain,
                AccelSystems::Stats,
            )
                .chain()
                .after(TransformSystems::Propagate)
                .after(VisibilitySystems::CalculateBounds)
                .before(VisibilitySystems::CheckVisibility)
                .run_if(|s: Res<AccelSettings>| s.enabled),
        )
        // The frame's step-aside decision first (the chain's first set), then every set
        // reads it.
        .configure_sets(
            PostUpdate,
            AccelSystems::ChooseIndex.run_if(step_aside::decide_step_aside),
        )
        .configure_sets(
            PostUpdate,
            (
                AccelSystems::Sync,
                AccelSystems::Maintain,
                AccelSystems::Stats,
            )
                .run_if(trees_awake),
        )
        .add_systems(
            PostUpdate,
            (
                choose_index::choose_index
                    .in_set(AccelSystems::ChooseIndex)
                    .run_if(choose_index::index_switch_due),
                sync::sync_trees.in_set(AccelSystems::Sync),
                maintain::maintain_trees.in_set(AccelSystems::Maintain),
            ),
        );
    membership::add_membership_observers(app);
}
