//! Each service's time per frame, from Bevy's diagnostics, as small plots.

use crate::AccelStats;
use bevy::diagnostic::{DiagnosticPath, DiagnosticsStore, FrameTimeDiagnosticsPlugin};
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy_egui::egui;
use egui_plot::{Line, Plot, PlotPoints};

/// The plotted diagnostics, in order: the frame, then each service.
fn plotted() -> Vec<(&'static str, DiagnosticPath)> {
    // Grown below by each service compiled in.
    #[cfg_attr(
        not(any(feature = "culling", feature = "picking", feature = "preview")),
        allow(unused_mut)
    )]
    let mut paths = vec![
        ("frame", FrameTimeDiagnosticsPlugin::FRAME_TIME),
        ("sync", AccelStats::SYNC_TIME),
        ("maintenance", AccelStats::MAINTAIN_TIME),
    ];
    #[cfg(feature = "culling")]
    paths.extend([
        ("culling", crate::culling::CullingStats::TIME),
        ("light culling", crate::culling::CullingStats::LIGHT_TIME),
    ]);
    #[cfg(feature = "picking")]
    paths.push(("picking", crate::picking::AccelPickingStats::TIME));
    #[cfg(feature = "preview")]
    paths.push(("preview", crate::preview::AccelPreviewStats::TIME));
    paths
}

/// Bevy's diagnostics store, where the app has one.
#[derive(SystemParam)]
pub(super) struct TimePlots<'w> {
    store: Option<Res<'w, DiagnosticsStore>>,
}

impl TimePlots<'_> {
    pub(super) fn ui(&self, ui: &mut egui::Ui) {
        let Some(store) = &self.store else {
            ui.label("No diagnostics (add DiagnosticsPlugin).");
            return;
        };
        for (name, path) in plotted() {
            // A service that is not in the app has no diagnostic, or one never measured.
            let Some(diagnostic) = store.get(&path).filter(|d| d.history_len() > 0) else {
                continue;
            };
            let values: Vec<[f64; 2]> = diagnostic
                .values()
                .enumerate()
                .map(|(i, v)| [i as f64, *v])
                .collect();
            let latest = diagnostic.smoothed().unwrap_or_default();
            ui.label(format!("{name}: {latest:.3} ms"));
            Plot::new(("accel_time_plot", name))
                .height(36.0)
                .show_axes([false, true])
                .show_grid(false)
                .allow_drag(false)
                .allow_zoom(false)
                .allow_scroll(false)
                .allow_boxed_zoom(false)
                .include_y(0.0)
                .show(ui, |plot| {
                    plot.line(Line::new(name, PlotPoints::from(values)))
                });
        }
    }
}
