//! The services' switches, the index of the movers and the static tree's builder.

use crate::{AccelSettings, BusyMovers, IndexChoice, StaticTreeBuild};
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy_egui::egui;

/// The settings resources the panel switches, where the app has them.
#[derive(SystemParam)]
pub(super) struct ServiceControls<'w> {
    settings: Option<ResMut<'w, AccelSettings>>,
    #[cfg(feature = "culling")]
    culling: Option<ResMut<'w, crate::AccelCullingSettings>>,
    #[cfg(feature = "picking")]
    picking: Option<ResMut<'w, crate::picking::AccelPickingSettings>>,
    #[cfg(feature = "preview")]
    preview: Option<ResMut<'w, crate::preview::AccelPreviewSettings>>,
    #[cfg(feature = "preview")]
    preview_stats: Option<Res<'w, crate::preview::AccelPreviewStats>>,
    stats: Option<Res<'w, crate::AccelStats>>,
}

/// Writes `edited` back only when the panel changed it: a resource written every frame would
/// look changed to every system that watches it (the sync reads a changed index choice as a
/// switch of structure).
fn write_if_changed<T: PartialEq>(target: &mut impl core::ops::DerefMut<Target = T>, edited: T) {
    if **target != edited {
        **target = edited;
    }
}

impl ServiceControls<'_> {
    pub(super) fn ui(&mut self, ui: &mut egui::Ui) {
        let Some(settings) = self.settings.as_mut() else {
            ui.label("AccelPlugin is not in the app.");
            return;
        };
        let mut edited = settings.clone();
        ui.checkbox(&mut edited.enabled, "Trees follow the entities");
        #[cfg(feature = "culling")]
        if let Some(culling) = self.culling.as_mut() {
            let mut use_trees = culling.use_trees;
            ui.checkbox(&mut use_trees, "Cull on the trees (off: Bevy's pass)");
            if use_trees != culling.use_trees {
                culling.use_trees = use_trees;
            }
        }
        #[cfg(feature = "picking")]
        if let Some(picking) = self.picking.as_mut() {
            let mut enabled = picking.enabled;
            ui.checkbox(&mut enabled, "Picking backend");
            if enabled != picking.enabled {
                picking.enabled = enabled;
            }
        }
        egui::ComboBox::from_label("Movers' index")
            .selected_text(format!("{:?}", edited.index))
            .show_ui(ui, |ui| {
                for choice in IndexChoice::ALL {
                    ui.selectable_value(&mut edited.index, choice, format!("{choice:?}"));
                }
            });
        egui::ComboBox::from_label("Busy movers")
            .selected_text(format!("{:?}", edited.busy_movers.mode))
            .show_ui(ui, |ui| {
                for mode in [BusyMovers::Automatic, BusyMovers::On, BusyMovers::Off] {
                    ui.selectable_value(&mut edited.busy_movers.mode, mode, format!("{mode:?}"));
                }
            });
        egui::ComboBox::from_label("Static build")
            .selected_text(format!("{:?}", edited.static_build))
            .show_ui(ui, |ui| {
                for build in StaticTreeBuild::ALL {
                    ui.selectable_value(&mut edited.static_build, build, format!("{build:?}"));
                }
            });
        ui.add(
            egui::Slider::new(&mut edited.upkeep_budget_micros, 0..=5_000)
                .text("upkeep budget (µs)"),
        );
        if let Some(a) = self.stats.as_ref().and_then(|s| s.automatic) {
            ui.label(format!(
                "automatic: {:?} (moved {:.1}%, {:.0} rays a frame)",
                a.recommended,
                a.moved_share * 100.0,
                a.rays_per_frame,
            ));
        }
        if matches!(edited.index, IndexChoice::Bvh | IndexChoice::Automatic) {
            ui.checkbox(&mut edited.bvh.background_rebuild, "Rebuild off the frame");
            ui.add(
                egui::Slider::new(&mut edited.bvh.rebuild_threshold, 1.0..=4.0)
                    .text("rebuild at SAH ratio"),
            );
        }
        write_if_changed(settings, edited);
        #[cfg(feature = "preview")]
        self.preview_ui(ui);
    }

    #[cfg(feature = "preview")]
    fn preview_ui(&mut self, ui: &mut egui::Ui) {
        use crate::preview::{AccelPreviewMode, PreviewPlacement};
        let Some(preview) = self.preview.as_mut() else {
            return;
        };
        let mut edited = (**preview).clone();
        ui.separator();
        ui.checkbox(&mut edited.enabled, "Ray-traced preview (F2)");
        if edited.enabled {
            egui::ComboBox::from_label("Preview view")
                .selected_text(edited.mode.name())
                .show_ui(ui, |ui| {
                    for mode in AccelPreviewMode::ALL {
                        ui.selectable_value(&mut edited.mode, mode, mode.name());
                    }
                });
            ui.horizontal(|ui| {
                ui.radio_value(
                    &mut edited.placement,
                    PreviewPlacement::Overlay,
                    "over the view",
                );
                ui.radio_value(
                    &mut edited.placement,
                    PreviewPlacement::Corner,
                    "in a corner",
                );
            });
            ui.add(egui::Slider::new(&mut edited.resolution_scale, 0.1..=1.0).text("resolution"));
            ui.add(egui::Slider::new(&mut edited.frame_budget_ms, 1.0..=50.0).text("budget (ms)"));
            ui.add(egui::Slider::new(&mut edited.max_samples, 1..=1024).text("max samples"));
            if let Some(stats) = &self.preview_stats {
                ui.label(format!(
                    "{}x{}, {} samples a pixel",
                    stats.size.x, stats.size.y, stats.samples
                ));
            }
        }
        write_if_changed(preview, edited);
    }
}
