//! The tracked entities' world boxes, coloured by a view's culling verdict.

use super::budget::LineBudget;
use super::{AccelGizmos, AccelOverlaySettings, culling_view};
use crate::AccelTrees;
use bevy::camera::visibility::VisibleEntities;
use bevy::ecs::entity::EntityHashMap;
use bevy::prelude::*;
use spatial_accel::SpatialQuery;

/// Seen by the culling view.
const VISIBLE: Color = Color::srgb(0.2, 0.95, 0.3);
/// Culled from the culling view.
const CULLED: Color = Color::srgb(0.95, 0.25, 0.2);

/// Draws the world boxes of the tracked entities nearest the culling view's camera, as many
/// as the line budget allows (found through the trees' own k-nearest query, so the cost
/// follows what is drawn, not the world), green where the view's `VisibleEntities` lists the
/// entity and red where it was culled.
///
/// Why the view's lists rather than `ViewVisibility`: an entity is visible if any view sees
/// it (a shadow view, a second camera), and the overlay answers for one view.
pub(crate) fn draw_entity_bounds(
    settings: Res<AccelOverlaySettings>,
    trees: Res<AccelTrees>,
    cameras: Query<(Entity, &Camera, &GlobalTransform, Option<&VisibleEntities>)>,
    mut budget: ResMut<LineBudget>,
    mut gizmos: Gizmos<AccelGizmos>,
) {
    let Some(view) = culling_view(&settings, cameras.iter().map(|(e, c, ..)| (e, c))) else {
        return;
    };
    let Ok((_, _, transform, visible)) = cameras.get(view) else {
        return;
    };
    let eye = transform.translation_vec3a();
    let k = budget.remaining() / 12;
    let nearest = trees.query().nearest_k(eye, k, |slot| {
        trees.world_bounds(slot).distance_squared_to_point(eye)
    });
    // The drawn entities, each with whether the view sees it: one pass over the view's lists.
    let mut drawn: EntityHashMap<(u32, bool)> = nearest
        .iter()
        .filter_map(|&(slot, _)| Some((trees.entity(slot)?, (slot, false))))
        .collect();
    if let Some(visible) = visible {
        for entity in visible.entities.values().flatten() {
            if let Some((_, seen)) = drawn.get_mut(entity) {
                *seen = true;
            }
        }
    }
    if trees.len() > drawn.len() {
        budget.stats.truncated = true;
    }
    for &(slot, seen) in drawn.values() {
        let color = if seen { VISIBLE } else { CULLED };
        if budget.draw_box(&mut gizmos, &trees.world_bounds(slot), color) {
            budget.stats.entity_boxes += 1;
            budget.stats.visible_boxes += usize::from(seen);
        }
    }
}
