//! [`AccelDiagnosticsPlugin`]: the plugins' figures as Bevy diagnostics, for whoever reads
//! Bevy's `DiagnosticsStore` (`LogDiagnosticsPlugin`, the panel's time plots).

use crate::stats::AccelStats;
use bevy::diagnostic::Diagnostics;
use bevy::prelude::*;

/// Publishes the figures of the trees ([`AccelStats`]), the culling
/// ([`CullingStats`](crate::CullingStats)) and the picking
/// ([`AccelPickingStats`](crate::AccelPickingStats)) as Bevy diagnostics, each frame in
/// `Last`, under `bevy_accel/…` (the paths are the stats types' constants). Opt-in, as Bevy's
/// own `FrameTimeDiagnosticsPlugin` is: the resources hold the same figures for a game's own
/// systems, and a system a frame costs a small world the executor's hand-off
/// (BENCHMARKS.md, Whole frame). [`AccelPlugins`](crate::AccelPlugins) has it, and
/// [`AccelPanelPlugin`](crate::AccelPanelPlugin) adds it for its time plots. Add it after the
/// plugins whose figures it publishes, or anywhere: it looks for them in [`Plugin::finish`].
/// Added more than once (by the panel and by hand), it publishes once.
///
/// ```
/// use bevy::diagnostic::DiagnosticsStore;
/// use bevy::prelude::*;
/// use bevy_accel::prelude::*;
///
/// let mut app = App::new();
/// app.add_plugins((MinimalPlugins, TransformPlugin))
///     .add_plugins((AccelPlugin::default(), AccelDiagnosticsPlugin));
/// app.finish();
/// app.update();
/// let store = app.world().resource::<DiagnosticsStore>();
/// assert!(store.get_measurement(&AccelStats::SYNC_TIME).is_some());
/// ```
#[derive(Default)]
pub struct AccelDiagnosticsPlugin;

/// Marks an app whose diagnostics system is added.
#[derive(Resource)]
struct DiagnosticsPublished;

impl Plugin for AccelDiagnosticsPlugin {
    fn build(&self, app: &mut App) {
        if app.world().contains_resource::<DiagnosticsPublished>() {
            return;
        }
        app.insert_resource(DiagnosticsPublished).add_systems(
            Last,
            publish_diagnostics.run_if(crate::systems::trees_awake),
        );
    }

    // The panel adds it whatever the game added: a second copy is a no-op (see `build`).
    fn is_unique(&self) -> bool {
        false
    }

    fn finish(&self, app: &mut App) {
        AccelStats::register(app);
        #[cfg(feature = "culling")]
        if app
            .world()
            .contains_resource::<crate::culling::CullingStats>()
        {
            crate::culling::CullingStats::register(app);
        }
        #[cfg(feature = "picking")]
        if app
            .world()
            .contains_resource::<crate::picking::AccelPickingStats>()
        {
            crate::picking::AccelPickingStats::register(app);
        }
    }
}

/// Adds the frame's figures of the trees, the culling and the picking to Bevy's diagnostics,
/// in `Last` (after the culling's passes, whichever ran). One system for every plugin: each
/// system a frame costs Bevy's executor a task and a thread wake-up, which a small world
/// notices.
fn publish_diagnostics(
    stats: Res<AccelStats>,
    #[cfg(feature = "culling")] culling: Option<Res<crate::culling::CullingStats>>,
    #[cfg(feature = "picking")] picking: Option<Res<crate::picking::AccelPickingStats>>,
    mut diagnostics: Diagnostics,
) {
    let s = &*stats;
    diagnostics.add_measurement(&AccelStats::SYNC_TIME, || s.sync_time.as_secs_f64() * 1e3);
    diagnostics.add_measurement(&AccelStats::MAINTAIN_TIME, || {
        s.maintain_time.as_secs_f64() * 1e3
    });
    diagnostics.add_measurement(&AccelStats::ENTITIES, || {
        (s.dynamic_entities + s.static_entities) as f64
    });
    diagnostics.add_measurement(&AccelStats::DEPTH, || s.dynamic_index.depth as f64);
    if let Some(ratio) = s.dynamic_index.quality_ratio {
        diagnostics.add_measurement(&AccelStats::QUALITY_RATIO, || ratio as f64);
    }
    #[cfg(feature = "culling")]
    if let Some(culling) = culling {
        crate::culling::add_culling_measurements(&culling, &mut diagnostics);
    }
    #[cfg(feature = "picking")]
    if let Some(picking) = picking {
        crate::picking::add_picking_measurements(&picking, &mut diagnostics);
    }
}
