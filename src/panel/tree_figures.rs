//! The trees' figures: entities, nodes, depth, memory, quality, what culling saw, and the
//! picking rays (with the skinned meshes' posed trees they refit).

use crate::AccelStats;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy_egui::egui;

/// The stats resources the panel reads, where the app has them.
#[derive(SystemParam)]
pub(super) struct TreeFigures<'w> {
    stats: Option<Res<'w, AccelStats>>,
    #[cfg(feature = "culling")]
    culling: Option<Res<'w, crate::culling::CullingStats>>,
    #[cfg(feature = "picking")]
    picking: Option<Res<'w, crate::picking::AccelPickingStats>>,
}

fn row(ui: &mut egui::Ui, name: &str, value: String) {
    ui.label(name);
    ui.label(value);
    ui.end_row();
}

impl TreeFigures<'_> {
    pub(super) fn ui(&self, ui: &mut egui::Ui) {
        egui::Grid::new("accel_tree_figures")
            .num_columns(2)
            .striped(true)
            .show(ui, |ui| {
                if let Some(s) = &self.stats {
                    let tracked = s.dynamic_entities + s.static_entities;
                    row(ui, "entities", format!("{tracked}"));
                    row(
                        ui,
                        "  moving / static",
                        format!("{} / {}", s.dynamic_entities, s.static_entities),
                    );
                    if s.busy_movers > 0 {
                        // Moving frame after frame: in the flat list, not the index.
                        row(ui, "  busy movers", format!("{}", s.busy_movers));
                    }
                    if s.static_waiting > 0 || s.static_build_in_flight {
                        row(
                            ui,
                            "  static waiting",
                            format!(
                                "{}{}",
                                s.static_waiting,
                                if s.static_build_in_flight {
                                    " (building)"
                                } else {
                                    ""
                                }
                            ),
                        );
                    }
                    row(ui, "index", format!("{:?}", s.index));
                    let d = &s.dynamic_index;
                    row(ui, "  nodes", format!("{}", d.nodes));
                    row(ui, "  depth", format!("{}", d.depth));
                    row(
                        ui,
                        "  memory",
                        format!("{:.1} MiB", d.memory_bytes as f64 / (1024.0 * 1024.0)),
                    );
                    row(
                        ui,
                        "  quality",
                        d.quality_ratio.map_or("not tracked".into(), |q| {
                            format!("{q:.2}x a fresh build's SAH")
                        }),
                    );
                    row(
                        ui,
                        "this frame",
                        format!(
                            "+{} ~{} -{}{}",
                            s.inserted,
                            s.updated,
                            s.removed,
                            if s.rejected > 0 {
                                format!(", {} rejected", s.rejected)
                            } else {
                                String::new()
                            }
                        ),
                    );
                }
                #[cfg(feature = "culling")]
                if let Some(c) = &self.culling {
                    let tracked = self
                        .stats
                        .as_ref()
                        .map_or(0, |s| s.dynamic_entities + s.static_entities);
                    row(ui, "camera views", format!("{}", c.views));
                    row(
                        ui,
                        "  visible / culled",
                        format!(
                            "{} / {}",
                            c.visible,
                            (tracked * c.views).saturating_sub(c.visible)
                        ),
                    );
                    row(
                        ui,
                        "  accepted whole / tested",
                        format!("{} / {}", c.accepted_by_subtree, c.tested),
                    );
                    row(ui, "shadow views", format!("{}", c.light_views));
                }
                #[cfg(feature = "picking")]
                if let Some(p) = &self.picking {
                    row(
                        ui,
                        "picking rays / hits",
                        format!("{} / {}", p.rays, p.hits),
                    );
                    // Skinned meshes hit at their posed vertices: how many posed triangle
                    // trees the rays refit this frame (none while no ray reaches a mover).
                    row(ui, "  posed meshes refit", format!("{}", p.posed_refits));
                }
            });
    }
}
