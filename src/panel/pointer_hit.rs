//! What the pointer is over: the nearest hit of bevy_picking's hover map.

use bevy::ecs::system::SystemParam;
use bevy::picking::hover::HoverMap;
use bevy::picking::pointer::PointerId;
use bevy::prelude::*;
use bevy_egui::egui;

/// The hover map and the names of what it holds.
#[derive(SystemParam)]
pub(super) struct PointerHit<'w, 's> {
    hovers: Option<Res<'w, HoverMap>>,
    names: Query<'w, 's, &'static Name>,
}

impl PointerHit<'_, '_> {
    pub(super) fn ui(&self, ui: &mut egui::Ui) {
        let nearest = self
            .hovers
            .as_ref()
            .and_then(|h| h.get(&PointerId::Mouse))
            .and_then(|hits| {
                hits.iter()
                    .min_by(|a, b| a.1.depth.total_cmp(&b.1.depth))
                    .map(|(e, hit)| (*e, hit.clone()))
            });
        let Some((entity, hit)) = nearest else {
            ui.label("Nothing under the pointer.");
            return;
        };
        let name = self
            .names
            .get(entity)
            .map_or_else(|_| format!("{entity}"), |n| format!("{n} ({entity})"));
        ui.label(format!("entity: {name}"));
        ui.label(format!("distance: {:.3}", hit.depth));
        #[cfg(feature = "picking")]
        if let Some(extra) = hit.extra_as::<crate::picking::AccelHitExtra>() {
            match extra.triangle_index {
                Some(t) => ui.label(format!("triangle: {t}")),
                None => ui.label("triangle: none (hit on its bounds)"),
            };
        }
        if let Some(p) = hit.position {
            ui.label(format!("at: ({:.2}, {:.2}, {:.2})", p.x, p.y, p.z));
        }
    }
}
