//! # bevy_accel
//!
//! Acceleration structures over a Bevy world's entities. Add [`AccelPlugin`] and every entity
//! with an `Aabb` and a `GlobalTransform` is kept in the trees (a BVH, or a uniform grid while
//! many entities move: [`IndexChoice`]; entities that move every frame in a flat list beside
//! them: [`BusyMoverSettings`]), in step with its transform, every frame, at no cost in frames
//! where nothing changed. Query them through [`AccelTrees`].
//!
//! The geometry lives in the engine-independent crate [`spatial_accel`] (re-exported); this crate only
//! connects it to the ECS.
//!
//! ```
//! use bevy::prelude::*;
//! use bevy::camera::primitives::Aabb;
//! use bevy_accel::prelude::*;
//! use bevy_accel::spatial_accel::{Ray, SpatialQuery};
//! use bevy::math::Vec3A;
//!
//! let mut app = App::new();
//! app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin::default()));
//! let cube = app
//!     .world_mut()
//!     .spawn((Transform::from_xyz(0.0, 0.0, -5.0), Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5))))
//!     .id();
//! app.update();
//!
//! let trees = app.world().resource::<AccelTrees>();
//! let ray = Ray::new(Vec3A::ZERO, Vec3A::NEG_Z);
//! let hit = trees.query().cast_ray(&ray, |slot, r| r.intersect_aabb(&trees.world_bounds(slot))).unwrap();
//! assert_eq!(trees.entity(hit.primitive), Some(cube));
//! assert!((hit.t - 4.5).abs() < 1e-5);
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
#![warn(missing_docs)]

mod components;
#[cfg(feature = "culling")]
pub mod culling;
pub mod index;
mod local_frame;
#[cfg(feature = "picking")]
mod meshes;
#[cfg(feature = "overlays")]
pub mod overlays;
#[cfg(feature = "egui")]
pub mod panel;
#[cfg(feature = "picking")]
pub mod picking;
mod prefetch;
#[cfg(feature = "preview")]
pub mod preview;
mod scenery;
mod settings;
mod stats;
mod sync;
mod trees;

pub use components::{AccelIgnore, AccelStatic, AccelTracked};
#[cfg(feature = "culling")]
pub use culling::{AccelCullingPlugin, AccelCullingSettings};
pub use index::{
    AutomaticIndexSettings, AutomaticIndexStats, BusyMoverSettings, BusyMovers, EntityIndex,
    IndexChoice,
};
#[cfg(feature = "sprite_picking")]
pub use picking::AccelSpritePickingPlugin;
#[cfg(feature = "picking")]
pub use picking::{AccelPickingPlugin, AccelRayCast};
pub use settings::{AccelSettings, StaticTreeBuild};
pub use spatial_accel;
pub use stats::AccelStats;
pub use trees::{AccelTrees, LocalFrame, TreeSlot};

use bevy::camera::visibility::VisibilitySystems;
use bevy::prelude::*;
use bevy::transform::TransformSystems;

/// The most used items.
pub mod prelude {
    pub use crate::index::{
        AutomaticIndexSettings, BusyMoverSettings, BusyMovers, BvhIndexSettings, IndexChoice,
    };
    pub use crate::{
        AccelIgnore, AccelPlugin, AccelSettings, AccelStatic, AccelStats, AccelSystems,
        AccelTracked, AccelTrees, StaticTreeBuild,
    };
    #[cfg(feature = "picking")]
    pub use crate::{AccelPickingPlugin, AccelRayCast};
}

/// The plugin's system sets, in `PostUpdate`, in this order, after transform propagation and
/// bounds calculation and before visibility checks (so culling sees this frame's trees).
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AccelSystems {
    /// Entities inserted, updated and removed.
    Sync,
    /// The dynamic tree refit, optimised, and rebuilt when its quality decays.
    Maintain,
    /// Statistics and diagnostics published.
    Stats,
}

/// Keeps acceleration trees over the world's entities; see the [crate docs](crate).
#[derive(Default)]
pub struct AccelPlugin {
    /// Initial settings (the [`AccelSettings`] resource can be changed at runtime).
    pub settings: AccelSettings,
}

impl Plugin for AccelPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(self.settings.clone())
            .register_type::<AccelSettings>()
            .register_type::<index::IndexChoice>()
            .register_type::<StaticTreeBuild>()
            .register_type::<index::BvhIndexSettings>()
            .register_type::<index::AutomaticIndexSettings>()
            .register_type::<index::BusyMoverSettings>()
            .register_type::<index::BusyMovers>()
            .register_type::<AccelIgnore>()
            .register_type::<AccelStatic>()
            .register_type::<AccelTracked>()
            .init_resource::<AccelTrees>()
            .init_resource::<AccelStats>()
            .init_resource::<index::AutomaticIndex>()
            .init_resource::<sync::PendingMembership>()
            .init_resource::<sync::RejectedEntities>()
            .configure_sets(
                PostUpdate,
                (
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
            .add_systems(
                PostUpdate,
                (
                    (index::advise_index, sync::sync_trees)
                        .chain()
                        .in_set(AccelSystems::Sync),
                    index::maintain_index.in_set(AccelSystems::Maintain),
                    stats::publish_stats.in_set(AccelSystems::Stats),
                ),
            );
        sync::add_membership_observers(app);
        AccelStats::register(app);
    }
}
