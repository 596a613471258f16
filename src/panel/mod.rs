//! A bevy_egui panel over the plugin (cargo feature `egui`): a switch for every service and
//! overlay, the index and static build choices, live statistics with small time plots, and
//! what the pointer is over.
//!
//! - `services`: the switches and choices (trees, culling, picking, index, static build).
//! - `overlay_controls`: the overlays' toggles (cargo feature `overlays`).
//! - `tree_figures`: entities, nodes, depth, quality, visible counts.
//! - `time_plots`: per-service times from Bevy's diagnostics, plotted.
//! - `pointer_hit`: the entity under the pointer, its triangle and distance.

mod overlay_controls;
mod pointer_hit;
mod services;
mod time_plots;
mod tree_figures;

use bevy::prelude::*;
use bevy_egui::{EguiContexts, EguiPlugin, EguiPrimaryContextPass, egui};

pub use bevy_egui;

/// Runtime settings of the panel.
#[derive(Resource, Reflect, Clone, Debug, PartialEq)]
#[reflect(Resource, Default)]
pub struct AccelPanelSettings {
    /// Whether the panel is shown. Closed, its drawing system does not run.
    pub open: bool,
    /// The key that opens and closes it (`F1` by default; `None`: no key).
    pub toggle_key: Option<KeyCode>,
}

impl Default for AccelPanelSettings {
    fn default() -> Self {
        Self {
            open: true,
            toggle_key: Some(KeyCode::F1),
        }
    }
}

/// The panel's systems: the key in `Update`, the drawing in bevy_egui's
/// `EguiPrimaryContextPass`.
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct AccelPanelSystems;

/// Adds the panel, and bevy_egui's `EguiPlugin` unless the app has it. Needs a window and a
/// camera (bevy_egui draws on the first camera's window); reads whatever of the plugin's
/// resources exist, so it works with any subset of the services.
///
/// ```no_run
/// use bevy::prelude::*;
/// use bevy_accel::prelude::*;
/// App::new()
///     .add_plugins((DefaultPlugins, AccelPlugin::default(), AccelPanelPlugin))
///     .run();
/// ```
///
/// Pointer input over the panel does not reach the scene through picking: bevy_egui's
/// picking integration reports the panel as the topmost hit. Systems that cast their own
/// pointer rays should run `.run_if(not(egui_wants_any_pointer_input))`
/// ([`bevy_egui::input::egui_wants_any_pointer_input`]).
#[derive(Default)]
pub struct AccelPanelPlugin;

impl Plugin for AccelPanelPlugin {
    fn build(&self, app: &mut App) {
        if !app.is_plugin_added::<EguiPlugin>() {
            app.add_plugins(EguiPlugin::default());
        }
        // The time plots read the plugins' diagnostics (a second copy of the plugin is a
        // no-op, so this holds beside `AccelPlugins` or a game's own).
        app.add_plugins(crate::AccelDiagnosticsPlugin);
        app.init_resource::<AccelPanelSettings>()
            .register_type::<AccelPanelSettings>()
            .add_systems(Update, toggle_panel.in_set(AccelPanelSystems))
            .add_systems(
                EguiPrimaryContextPass,
                draw_panel
                    .in_set(AccelPanelSystems)
                    .run_if(|s: Res<AccelPanelSettings>| s.open),
            );
    }

    fn finish(&self, app: &mut App) {
        crate::trees::step_aside::register_reader_plugin(app);
    }
}

fn toggle_panel(keys: Option<Res<ButtonInput<KeyCode>>>, mut settings: ResMut<AccelPanelSettings>) {
    let pressed = match (keys, settings.toggle_key) {
        (Some(keys), Some(key)) => keys.just_pressed(key),
        _ => false,
    };
    if pressed {
        settings.open = !settings.open;
    }
}

fn draw_panel(
    mut contexts: EguiContexts,
    mut services: services::ServiceControls,
    mut overlays: overlay_controls::OverlayControls,
    figures: tree_figures::TreeFigures,
    plots: time_plots::TimePlots,
    pointer: pointer_hit::PointerHit,
) -> Result {
    let ctx = contexts.ctx_mut()?;
    egui::Window::new("bevy_accel")
        .default_pos([8.0, 8.0])
        .default_width(280.0)
        .default_height(690.0)
        .resizable(true)
        .show(ctx, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| {
                egui::CollapsingHeader::new("Services")
                    .default_open(true)
                    .show(ui, |ui| services.ui(ui));
                overlays.ui(ui);
                egui::CollapsingHeader::new("Trees")
                    .default_open(true)
                    .show(ui, |ui| figures.ui(ui));
                egui::CollapsingHeader::new("Times")
                    .default_open(true)
                    .show(ui, |ui| plots.ui(ui));
                egui::CollapsingHeader::new("Pointer")
                    .default_open(true)
                    .show(ui, |ui| pointer.ui(ui));
            });
        });
    Ok(())
}
