//! What the trees did this frame, as a resource and as Bevy diagnostics.

use crate::index::{AutomaticIndexStats, BvhIndexStats, IndexChoice};
use bevy::diagnostic::{Diagnostic, DiagnosticPath, RegisterDiagnostic};
use bevy::prelude::*;
use core::time::Duration;
use spatial_accel::query::{IndexStats, UpkeepReport};

/// Counts and timings of the last sync, updated every frame the plugin runs (not while the
/// trees stand aside: see [`AccelTrees::stepped_aside`](crate::AccelTrees::stepped_aside)).
/// Also published as Bevy diagnostics (the constants below) by
/// [`AccelDiagnosticsPlugin`](crate::AccelDiagnosticsPlugin).
#[derive(Resource, Clone, Debug, Default)]
pub struct AccelStats {
    /// Entities inserted into a tree this frame.
    pub inserted: usize,
    /// Entities whose box was updated this frame.
    pub updated: usize,
    /// Entities removed from a tree this frame.
    pub removed: usize,
    /// Dynamic entities whose box the sync wrote this frame, whether or not a structure
    /// changed (a move inside a fat leaf or a loose cell counts here, not in `updated`), and
    /// the busy movers whose moves it left unwritten
    /// ([`busy_moves_skipped`](Self::busy_moves_skipped)).
    pub moved: usize,
    /// Of [`moved`](Self::moved), the busy movers' moves: written to their flat list, not
    /// to the dynamic index.
    pub busy_moved: usize,
    /// Of [`busy_moved`](Self::busy_moved), the moves left unwritten because no view or
    /// reader would read them
    /// ([`AccelSettings::skip_unread_mover_upkeep`](crate::AccelSettings::skip_unread_mover_upkeep)).
    pub busy_moves_skipped: usize,
    /// Entities currently left out for a bad transform or box.
    pub rejected: usize,
    /// True when a new static tree was swapped in this frame (built in the frame or off it).
    pub static_rebuilt: bool,
    /// Static entities waiting in the dynamic index for the static tree being built off the
    /// frame (or the next one).
    pub static_waiting: usize,
    /// Whether a static tree is being built off the frame.
    pub static_build_in_flight: bool,
    /// Time spent applying inserts, updates and removals.
    pub sync_time: Duration,
    /// Time spent refitting, optimising and (maybe) rebuilding the dynamic tree.
    pub maintain_time: Duration,
    /// Rays cast through the trees per frame (those counted by
    /// `AccelRayCast`, the picking backends and the preview), averaged over about ten
    /// frames: what the ray snapshot and picking's slot mesh table are kept for.
    pub rays_per_frame: f32,
    /// Dynamic entities: those in the dynamic index and the busy movers.
    pub dynamic_entities: usize,
    /// Busy movers: dynamic entities kept in a flat list while they move frame after frame
    /// ([`BusyMoverSettings`](crate::BusyMoverSettings)).
    pub busy_movers: usize,
    /// Entities in the static tree.
    pub static_entities: usize,
    /// The structure holding the moving entities (never
    /// [`IndexChoice::Automatic`]: the structure it chose).
    pub index: IndexChoice,
    /// Shape and cost of the dynamic index (nodes, depth, memory, quality against a fresh
    /// build where the structure tracks it), read in O(1).
    pub dynamic_index: IndexStats,
    /// What the dynamic index's last upkeep did.
    pub last_upkeep: UpkeepReport,
    /// The BVH backend's own figures, while it is the index.
    pub bvh: Option<BvhIndexStats>,
    /// What [`IndexChoice::Automatic`] saw and recommends, while it is the choice.
    pub automatic: Option<AutomaticIndexStats>,
}

impl AccelStats {
    /// Sync time, in milliseconds.
    pub const SYNC_TIME: DiagnosticPath = DiagnosticPath::const_new("bevy_accel/sync_time_ms");
    /// Maintenance time, in milliseconds.
    pub const MAINTAIN_TIME: DiagnosticPath =
        DiagnosticPath::const_new("bevy_accel/maintain_time_ms");
    /// Tracked entities.
    pub const ENTITIES: DiagnosticPath = DiagnosticPath::const_new("bevy_accel/entities");
    /// Depth of the dynamic index.
    pub const DEPTH: DiagnosticPath = DiagnosticPath::const_new("bevy_accel/dynamic_depth");
    /// Query cost of the dynamic index relative to a fresh build (the BVH's SAH ratio); not
    /// measured for indexes that do not track it.
    pub const QUALITY_RATIO: DiagnosticPath =
        DiagnosticPath::const_new("bevy_accel/dynamic_quality_ratio");

    pub(crate) fn register(app: &mut App) {
        for path in [
            Self::SYNC_TIME,
            Self::MAINTAIN_TIME,
            Self::ENTITIES,
            Self::DEPTH,
            Self::QUALITY_RATIO,
        ] {
            app.register_diagnostic(Diagnostic::new(path));
        }
    }
}
