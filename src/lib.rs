//! # bevy_accel
//!
//! Acceleration structures over a Bevy world's entities, kept in step with them every
//! frame: one set of trees serves frustum culling, ray picking, spatial queries and a
//! ray-traced preview. Add [`AccelPlugins`] after Bevy's `DefaultPlugins`:
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_accel::prelude::*;
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, AccelPlugins))
//!     .run();
//! ```
//!
//! Every entity with an `Aabb` and a `GlobalTransform` (Bevy gives meshes and sprites an
//! `Aabb`) is then in the trees: a static tree for entities marked [`AccelStatic`], a
//! dynamic index for the rest ([`IndexChoice`]: a BVH, or a grid while many entities move),
//! and a flat list for entities that move every frame ([`BusyMoverSettings`]). Culling
//! ([`AccelCullingPlugin`]) and picking ([`AccelPickingPlugin`]) replace Bevy's own passes
//! with walks of the trees and give Bevy's results; systems ask the trees directly:
//!
//! ```
//! use bevy::prelude::*;
//! use bevy::camera::primitives::Aabb;
//! use bevy::math::bounding::BoundingSphere;
//! use bevy::ecs::system::RunSystemOnce;
//! use bevy_accel::prelude::*;
//!
//! let mut app = App::new();
//! app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin::default()));
//! let cube = app
//!     .world_mut()
//!     .spawn((Transform::from_xyz(0.0, 0.0, -5.0), Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5))))
//!     .id();
//! app.update();
//!
//! let found = app
//!     .world_mut()
//!     .run_system_once(|mut query: AccelSpatialQuery| {
//!         query.overlap_sphere(BoundingSphere::new(Vec3::new(0.0, 0.0, -4.0), 1.0)).to_vec()
//!     })
//!     .unwrap();
//! assert_eq!(found, [cube]);
//! ```
//!
//! ## What is tracked
//! Every entity with an `Aabb` (local bounds, as Bevy computes for meshes) and a
//! `GlobalTransform`, unless it has [`AccelIgnore`]; with
//! [`AccelSettings::require_marker`] only those with [`AccelTracked`]. Entities without an
//! `Aabb` (Bevy adds none with `NoFrustumCulling` or `NoAutoAabb`) are not tracked: insert an
//! `Aabb` yourself to track them. Entities marked [`AccelStatic`] go in a static tree that is
//! never refit or watched for motion.
//!
//! An entity whose transform is not finite or has a zero scale is left out, with one warning,
//! until its transform is valid again; [`AccelStats::rejected`] counts them.
//!
//! ## The crate's parts
//! The geometry and every structure live in the engine-independent crate [`spatial_accel`]
//! (re-exported); this crate connects them to the ECS:
//!
//! - `trees`: [`AccelTrees`], the slots of the tracked entities and what each slot holds.
//! - [`index`]: [`EntityIndex`], the structures that hold the slots, queried as one.
//! - `systems`: the frame's sync and upkeep, in the sets of [`AccelSystems`].
//! - `spatial_query`: [`AccelSpatialQuery`], overlap and nearest queries for any system.
//! - `diagnostics`: [`AccelDiagnosticsPlugin`], the plugins' figures as Bevy diagnostics.
//! - [`culling`], [`picking`], [`selection`], [`overlays`], [`panel`], [`preview`]: the
//!   services, each its plugin and cargo feature.
#![warn(missing_docs)]

mod components;
#[cfg(feature = "culling")]
pub mod culling;
mod diagnostics;
pub mod index;
#[cfg(feature = "picking")]
mod meshes;
#[cfg(feature = "overlays")]
pub mod overlays;
#[cfg(feature = "egui")]
pub mod panel;
#[cfg(feature = "picking")]
pub mod picking;
mod plugin;
mod pool_batches;
#[cfg(feature = "preview")]
pub mod preview;
#[cfg(feature = "selection")]
pub mod selection;
mod settings;
mod spatial_query;
mod stats;
mod systems;
mod trees;

pub use components::{AccelIgnore, AccelStatic, AccelTracked};
#[cfg(feature = "culling")]
pub use culling::{AccelCullingPlugin, AccelCullingSettings, AccelCullingSystems, CullingStats};
pub use diagnostics::AccelDiagnosticsPlugin;
pub use index::{
    AutomaticIndexSettings, AutomaticIndexStats, BvhIndexSettings, BvhIndexStats, EntityIndex,
    IndexChoice,
};
#[cfg(feature = "overlays")]
pub use overlays::{
    AccelGizmos, AccelOverlaySettings, AccelOverlayStats, AccelOverlaySystems, AccelOverlaysPlugin,
};
#[cfg(feature = "egui")]
pub use panel::{AccelPanelPlugin, AccelPanelSettings, AccelPanelSystems};
#[cfg(feature = "picking")]
pub use picking::{
    AccelHitExtra, AccelPickingCamera, AccelPickingPlugin, AccelPickingSettings, AccelPickingStats,
    AccelPickingSystems, AccelRayCast, SlotMeshTableMode,
};
#[cfg(feature = "sprite_picking")]
pub use picking::{AccelSpritePickingMode, AccelSpritePickingPlugin, AccelSpritePickingSettings};
pub use plugin::{AccelPlugin, AccelPlugins};
#[cfg(feature = "preview")]
pub use preview::{
    AccelPreviewMode, AccelPreviewPlugin, AccelPreviewSettings, AccelPreviewStats,
    AccelPreviewSystems, PreviewPlacement,
};
#[cfg(feature = "selection")]
pub use selection::{
    AccelSelection, AccelSelectionDrag, AccelSelectionPlugin, AccelSelectionSettings,
    AccelSelectionSystems, Selected, SelectionChanged, SelectionError, SelectionMode,
    SelectionOrder,
};
pub use settings::{AccelSettings, StaticTreeBuild};
pub use spatial_accel;
pub use spatial_query::AccelSpatialQuery;
pub use stats::AccelStats;
pub use systems::AccelSystems;
pub use trees::{AccelTrees, BusyMoverSettings, BusyMovers, LocalFrame, StepAsideProbe, TreeSlot};

/// Everything a game needs to use the crate: `use bevy_accel::prelude::*;`.
pub mod prelude {
    /// The engine-independent core, for its structures and geometry (`spatial_accel::bsp`,
    /// `spatial_accel::Ray`, ...).
    pub use crate::spatial_accel;
    #[cfg(feature = "culling")]
    pub use crate::{AccelCullingPlugin, AccelCullingSettings, AccelCullingSystems, CullingStats};
    pub use crate::{
        AccelDiagnosticsPlugin, AccelIgnore, AccelPlugin, AccelPlugins, AccelSettings,
        AccelSpatialQuery, AccelStatic, AccelStats, AccelSystems, AccelTracked, AccelTrees,
        AutomaticIndexSettings, BusyMoverSettings, BusyMovers, BvhIndexSettings, IndexChoice,
        StaticTreeBuild,
    };
    #[cfg(feature = "overlays")]
    pub use crate::{
        AccelGizmos, AccelOverlaySettings, AccelOverlayStats, AccelOverlaySystems,
        AccelOverlaysPlugin,
    };
    #[cfg(feature = "picking")]
    pub use crate::{
        AccelHitExtra, AccelPickingCamera, AccelPickingPlugin, AccelPickingSettings,
        AccelPickingStats, AccelPickingSystems, AccelRayCast, SlotMeshTableMode,
    };
    #[cfg(feature = "egui")]
    pub use crate::{AccelPanelPlugin, AccelPanelSettings, AccelPanelSystems};
    #[cfg(feature = "preview")]
    pub use crate::{
        AccelPreviewMode, AccelPreviewPlugin, AccelPreviewSettings, AccelPreviewStats,
        AccelPreviewSystems, PreviewPlacement,
    };
    #[cfg(feature = "selection")]
    pub use crate::{
        AccelSelection, AccelSelectionDrag, AccelSelectionPlugin, AccelSelectionSettings,
        AccelSelectionSystems, Selected, SelectionChanged, SelectionError, SelectionMode,
        SelectionOrder,
    };
    #[cfg(feature = "sprite_picking")]
    pub use crate::{AccelSpritePickingMode, AccelSpritePickingPlugin, AccelSpritePickingSettings};
}
