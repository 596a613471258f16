//! What the culling passes did, as a resource and as Bevy diagnostics: the camera and the
//! light passes both write it.

use bevy::diagnostic::{Diagnostic, DiagnosticPath, Diagnostics, RegisterDiagnostic};
use bevy::prelude::*;
use core::time::Duration;

/// What the last culling pass did, summed over views. Also published as Bevy diagnostics
/// ([`CullingStats::TIME`], [`CullingStats::LIGHT_TIME`], [`CullingStats::VISIBLE`]) by
/// [`AccelDiagnosticsPlugin`](crate::AccelDiagnosticsPlugin).
#[derive(Resource, Clone, Debug, Default)]
pub struct CullingStats {
    /// Views culled.
    pub views: usize,
    /// Entities reported visible (per view, summed).
    pub visible: usize,
    /// Entities accepted whole, inside a subtree fully in view, with no per-entity test (on
    /// the tree path, and on the flat pass when the trees settled their tests).
    pub accepted_by_subtree: usize,
    /// Entities given Bevy's frustum test one by one (leaves crossing a plane, and entities
    /// not in the trees; on a flat pass without the trees' word, every entity admitted).
    pub tested: usize,
    /// Views culled with the flat parallel pass instead of the trees (most of the world was
    /// in view last frame).
    pub flat_views: usize,
    /// Of the flat views, those whose frustum tests the trees settled wherever they could
    /// (the trees were current): only entities crossing a plane, or outside the trees, got
    /// Bevy's test.
    pub flat_views_on_trees: usize,
    /// Views whose tree walk was reused from the last frame, because neither their frustum
    /// nor the trees had changed (the entities found are still decided one by one).
    pub reused_walks: usize,
    /// Views whose walk of the static tree and the dynamic index was kept from the last
    /// frame because only busy movers had moved since: the busy movers alone were tested
    /// again.
    pub kept_tree_walks: usize,
    /// Views on the tree path whose entities proved inside were many enough to be decided in
    /// parts on the compute task pool.
    pub views_decided_in_parts: usize,
    /// Time spent in the camera culling system.
    pub time: Duration,
    /// Shadow views of lights culled on the trees (point light cube faces, spot light
    /// frusta, directional light cascades per camera); cargo feature `light_culling`.
    pub light_views: usize,
    /// Entities decided one by one for those views on the tree path: what their walks found,
    /// plus the entities no walk finds (views on the flat pass are not counted).
    pub light_candidates: usize,
    /// Light views decided by the flat parallel pass over every caster (their walk found
    /// most of the world, or the trees were stale).
    pub flat_light_views: usize,
    /// Of the flat light views, those whose caster tests the trees settled wherever they
    /// could (the trees were current): a caster no list of the view reached is dropped
    /// untested, one inside a list's frustum and the light's range goes into that list
    /// untested, and only lists crossing its leaf get Bevy's tests.
    pub flat_light_views_on_trees: usize,
    /// Light views whose walk was kept from the last frame (neither the view nor the trees
    /// changed); their entities are still decided one by one.
    pub reused_light_walks: usize,
    /// Time spent culling light views.
    pub light_time: Duration,
}

impl CullingStats {
    /// Camera culling time, in milliseconds.
    pub const TIME: DiagnosticPath = DiagnosticPath::const_new("bevy_accel/culling_time_ms");
    /// Light-view culling time, in milliseconds (cargo feature `light_culling`).
    pub const LIGHT_TIME: DiagnosticPath =
        DiagnosticPath::const_new("bevy_accel/light_culling_time_ms");
    /// Entities visible in the camera views, summed over views.
    pub const VISIBLE: DiagnosticPath = DiagnosticPath::const_new("bevy_accel/culling_visible");

    pub(crate) fn register(app: &mut App) {
        for path in [Self::TIME, Self::LIGHT_TIME, Self::VISIBLE] {
            app.register_diagnostic(Diagnostic::new(path));
        }
    }
}

/// Adds the last frame's culling figures to Bevy's diagnostics (called by
/// `AccelDiagnosticsPlugin`'s one system, in `Last`, after the camera and light passes).
pub(crate) fn add_culling_measurements(s: &CullingStats, diagnostics: &mut Diagnostics) {
    diagnostics.add_measurement(&CullingStats::TIME, || s.time.as_secs_f64() * 1e3);
    diagnostics.add_measurement(&CullingStats::LIGHT_TIME, || {
        s.light_time.as_secs_f64() * 1e3
    });
    diagnostics.add_measurement(&CullingStats::VISIBLE, || s.visible as f64);
}
