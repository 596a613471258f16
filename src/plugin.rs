//! [`AccelPlugin`], the trees over the world's entities, and [`AccelPlugins`], every service
//! of the crate in one group.

use crate::components::{AccelIgnore, AccelStatic, AccelTracked};
use crate::index::{AutomaticIndexSettings, BvhIndexSettings, IndexChoice};
use crate::settings::{AccelSettings, StaticTreeBuild};
use crate::stats::AccelStats;
use crate::trees::{AccelTrees, BusyMoverSettings, BusyMovers};
use bevy::app::PluginGroupBuilder;
use bevy::prelude::*;

/// Keeps acceleration trees over the world's entities: every entity with an `Aabb` and a
/// `GlobalTransform` is in them, in step with its transform, every frame
/// ([`AccelSystems`](crate::AccelSystems)), at no cost in a frame where nothing changed.
/// Read them through [`AccelSpatialQuery`](crate::AccelSpatialQuery) or the
/// [`AccelTrees`] resource; the other plugins of [`AccelPlugins`] (culling, picking, the
/// preview, overlays, the panel) are built on them.
///
/// ```
/// use bevy::prelude::*;
/// use bevy_accel::prelude::*;
///
/// let mut app = App::new();
/// app.add_plugins((MinimalPlugins, TransformPlugin))
///     .add_plugins(AccelPlugin {
///         settings: AccelSettings { index: IndexChoice::Grid, ..default() },
///     });
/// app.update();
/// assert_eq!(app.world().resource::<AccelStats>().index, IndexChoice::Grid);
/// ```
#[derive(Default)]
pub struct AccelPlugin {
    /// Initial settings (the [`AccelSettings`] resource can be changed at runtime).
    pub settings: AccelSettings,
}

impl Plugin for AccelPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(self.settings.clone())
            .register_type::<AccelSettings>()
            .register_type::<IndexChoice>()
            .register_type::<StaticTreeBuild>()
            .register_type::<BvhIndexSettings>()
            .register_type::<AutomaticIndexSettings>()
            .register_type::<BusyMoverSettings>()
            .register_type::<BusyMovers>()
            .register_type::<AccelIgnore>()
            .register_type::<AccelStatic>()
            .register_type::<AccelTracked>()
            .init_resource::<AccelTrees>()
            .init_resource::<AccelStats>();
        crate::systems::add_tree_systems(app);
    }
}

/// Every plugin of the crate that its cargo features compiled in, [`AccelPlugin`] first,
/// then [`AccelDiagnosticsPlugin`](crate::AccelDiagnosticsPlugin):
/// [`AccelCullingPlugin`](crate::AccelCullingPlugin) (`culling`),
/// [`AccelPickingPlugin`](crate::AccelPickingPlugin) (`picking`),
/// [`AccelSpritePickingPlugin`](crate::AccelSpritePickingPlugin) (`sprite_picking`),
/// [`AccelSelectionPlugin`](crate::AccelSelectionPlugin) (`selection`),
/// [`AccelOverlaysPlugin`](crate::AccelOverlaysPlugin) (`overlays`, each overlay off until
/// its setting turns it on), [`AccelPreviewPlugin`](crate::AccelPreviewPlugin) (`preview`,
/// off until `F2` or its setting) and [`AccelPanelPlugin`](crate::AccelPanelPlugin) (`egui`,
/// open, `F1` to close). Add it after Bevy's `DefaultPlugins`; take out what a game does not
/// want with `.disable::<P>()`, or turn its cargo feature off; set a plugin's starting
/// settings with `.set(P { .. })`.
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_accel::prelude::*;
///
/// App::new()
///     .add_plugins(DefaultPlugins)
///     .add_plugins(
///         AccelPlugins
///             .build()
///             .disable::<AccelPanelPlugin>()
///             .set(AccelPlugin {
///                 settings: AccelSettings { index: IndexChoice::Bvh, ..default() },
///             }),
///     )
///     .run();
/// ```
pub struct AccelPlugins;

impl PluginGroup for AccelPlugins {
    fn build(self) -> PluginGroupBuilder {
        let group = PluginGroupBuilder::start::<Self>()
            .add(AccelPlugin::default())
            .add(crate::AccelDiagnosticsPlugin);
        #[cfg(feature = "culling")]
        let group = group.add(crate::AccelCullingPlugin);
        #[cfg(feature = "picking")]
        let group = group.add(crate::AccelPickingPlugin);
        #[cfg(feature = "sprite_picking")]
        let group = group.add(crate::AccelSpritePickingPlugin);
        #[cfg(feature = "selection")]
        let group = group.add(crate::AccelSelectionPlugin);
        #[cfg(feature = "overlays")]
        let group = group.add(crate::AccelOverlaysPlugin);
        #[cfg(feature = "preview")]
        let group = group.add(crate::AccelPreviewPlugin);
        #[cfg(feature = "egui")]
        let group = group.add(crate::AccelPanelPlugin);
        group
    }
}
