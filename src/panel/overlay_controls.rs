//! The overlays' toggles, when the `overlays` feature and its plugin are in.

use bevy::ecs::system::SystemParam;
use bevy_egui::egui;

#[cfg(feature = "overlays")]
use crate::overlays::{AccelOverlaySettings, AccelOverlayStats};
#[cfg(feature = "overlays")]
use bevy::prelude::*;

/// The overlay settings and counts, where the app has them.
#[derive(SystemParam)]
pub(super) struct OverlayControls<'w, 's> {
    #[cfg(feature = "overlays")]
    settings: Option<ResMut<'w, AccelOverlaySettings>>,
    #[cfg(feature = "overlays")]
    stats: Option<Res<'w, AccelOverlayStats>>,
    #[cfg(feature = "overlays")]
    cameras: Query<'w, 's, (Entity, Option<&'static Name>), With<Camera>>,
    #[cfg(not(feature = "overlays"))]
    _unused: core::marker::PhantomData<(&'w (), &'s ())>,
}

impl OverlayControls<'_, '_> {
    /// Draws the section; nothing when the overlays are not in the app.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui) {
        #[cfg(feature = "overlays")]
        {
            let Some(settings) = self.settings.as_mut() else {
                return;
            };
            egui::CollapsingHeader::new("Overlays")
                .default_open(false)
                .show(ui, |ui| {
                    let mut edited = (**settings).clone();
                    ui.checkbox(&mut edited.dynamic_nodes, "Dynamic index nodes");
                    ui.checkbox(&mut edited.static_nodes, "Static tree nodes");
                    ui.add(egui::Slider::new(&mut edited.min_depth, 0..=32).text("from depth"));
                    ui.add(egui::Slider::new(&mut edited.max_depth, 0..=32).text("to depth"));
                    edited.max_depth = edited.max_depth.max(edited.min_depth);
                    ui.checkbox(
                        &mut edited.entity_bounds,
                        "Entity boxes (green seen, red culled)",
                    );
                    ui.checkbox(&mut edited.frustum, "View frustum");
                    ui.checkbox(&mut edited.picking_rays, "Picking rays");
                    let name = |e: Option<Entity>| match e {
                        None => "first active camera".to_string(),
                        Some(e) => self
                            .cameras
                            .get(e)
                            .ok()
                            .and_then(|(_, n)| n.map(|n| n.to_string()))
                            .unwrap_or_else(|| format!("{e}")),
                    };
                    egui::ComboBox::from_label("Culling view")
                        .selected_text(name(edited.culling_view))
                        .show_ui(ui, |ui| {
                            ui.selectable_value(&mut edited.culling_view, None, name(None));
                            for (camera, _) in &self.cameras {
                                ui.selectable_value(
                                    &mut edited.culling_view,
                                    Some(camera),
                                    name(Some(camera)),
                                );
                            }
                        });
                    ui.add(
                        egui::Slider::new(&mut edited.line_budget, 1_000..=200_000)
                            .logarithmic(true)
                            .text("line budget"),
                    );
                    if let Some(stats) = &self.stats {
                        ui.label(format!(
                            "{} lines: {} nodes, {} boxes ({} seen), {} rays{}",
                            stats.lines,
                            stats.nodes,
                            stats.entity_boxes,
                            stats.visible_boxes,
                            stats.rays,
                            if stats.truncated {
                                ", budget reached"
                            } else {
                                ""
                            }
                        ));
                    }
                    if **settings != edited {
                        **settings = edited;
                    }
                });
        }
        #[cfg(not(feature = "overlays"))]
        let _ = ui;
    }
}
