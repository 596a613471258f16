//! What the picking backend did in the last frame, as a resource and as Bevy diagnostics.

use bevy::diagnostic::{Diagnostic, DiagnosticPath, Diagnostics, RegisterDiagnostic};
use bevy::prelude::*;
use core::time::Duration;

/// Counts and time of the backend's last run ([`update_hits`](super::update_hits)).
#[derive(Resource, Clone, Debug, Default)]
pub struct AccelPickingStats {
    /// Pointer rays cast.
    pub rays: usize,
    /// Entities hit, over every ray.
    pub hits: usize,
    /// Skinned entities' posed triangle trees built or refit for rays since the backend's
    /// last run (by it or by any other [`AccelRayCast`](super::AccelRayCast)).
    pub posed_refits: usize,
    /// Time spent casting them.
    pub time: Duration,
}

impl AccelPickingStats {
    /// Backend time, in milliseconds.
    pub const TIME: DiagnosticPath = DiagnosticPath::const_new("bevy_accel/picking_time_ms");

    pub(crate) fn register(app: &mut App) {
        app.register_diagnostic(Diagnostic::new(Self::TIME));
    }
}

/// Adds the backend's time to Bevy's diagnostics (called by `AccelDiagnosticsPlugin`'s one
/// system, in `Last`); a frame with no ray measures zero, so the plot shows idle frames as
/// idle.
pub(crate) fn add_picking_measurements(stats: &AccelPickingStats, diagnostics: &mut Diagnostics) {
    diagnostics.add_measurement(&AccelPickingStats::TIME, || stats.time.as_secs_f64() * 1e3);
}
