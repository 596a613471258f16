//! The `bevy_picking` backend system.

use super::ray_cast::AccelRayCast;
use super::{AccelPickingCamera, AccelPickingSettings, AccelPickingStats};
use bevy::camera::visibility::RenderLayers;
use bevy::picking::Pickable;
use bevy::picking::backend::ray::RayMap;
use bevy::picking::backend::{HitData, PointerHits};
use bevy::picking::mesh_picking::ray_cast::MeshRayCastSettings;
use bevy::prelude::*;

/// The extra data of each [`HitData`] the backend writes; read it with
/// `hit.extra_as::<AccelHitExtra>()`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AccelHitExtra {
    /// The index of the triangle hit (triangle `i` is indices `3i..3i + 3` of the mesh), or
    /// `None` for a mesh hit on its bounds (see [`AccelRayCast`]).
    pub triangle_index: Option<usize>,
    /// Barycentric weights of the triangle's corners in index order (zero for bounds hits).
    pub barycentric_coords: Vec3,
    /// The interpolated first texture coordinate, when the mesh has one.
    pub uv: Option<Vec2>,
}

/// Casts each pointer's ray through the trees and writes its [`PointerHits`]: Bevy's mesh
/// backend (`update_hits`), with [`AccelRayCast`] in place of `MeshRayCast`.
// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
pub fn update_hits(
    settings: Res<AccelPickingSettings>,
    ray_map: Res<RayMap>,
    cameras: Query<(&Camera, Has<AccelPickingCamera>, Option<&RenderLayers>)>,
    pickables: Query<&Pickable>,
    layers: Query<&RenderLayers>,
    mut ray_cast: AccelRayCast,
    mut writer: MessageWriter<PointerHits>,
    mut stats: ResMut<AccelPickingStats>,
) {
    let start = std::time::Instant::now();
    *stats = AccelPickingStats::default();
    if !settings.enabled {
        return;
    }
    for (&ray_id, &ray) in ray_map.iter() {
        let Ok((camera, marked_camera, camera_layers)) = cameras.get(ray_id.camera) else {
            continue;
        };
        if settings.require_markers && !marked_camera {
            continue;
        }
        let camera_layers = camera_layers.cloned().unwrap_or_default();
        let filter = |entity| {
            let marked = !settings.require_markers || pickables.contains(entity);
            // Entities without render layers are on layer 0, as Bevy's backend assumes.
            let in_layers = layers.get(entity).map_or_else(
                |_| camera_layers.intersects(&RenderLayers::default()),
                |l| camera_layers.intersects(l),
            );
            let hoverable = pickables.get(entity).ok().is_none_or(|p| p.is_hoverable);
            marked && in_layers && hoverable
        };
        // Only a `Pickable` that blocks stops the ray (none means keep collecting), as Bevy.
        let blocks = |entity| pickables.get(entity).is_ok_and(|p| p.should_block_lower);
        let cast_settings = MeshRayCastSettings::default()
            .with_visibility(settings.ray_cast_visibility)
            .with_filter(&filter)
            .with_early_exit_test(&blocks);
        let picks: Vec<(Entity, HitData)> = ray_cast
            .cast_ray(ray, &cast_settings)
            .iter()
            .map(|(entity, hit)| {
                let extra = AccelHitExtra {
                    triangle_index: hit.triangle_index,
                    barycentric_coords: hit.barycentric_coords,
                    uv: hit.uv,
                };
                let data = HitData::new_with_extra(
                    ray_id.camera,
                    hit.distance,
                    Some(hit.point),
                    Some(hit.normal),
                    extra,
                );
                (*entity, data)
            })
            .collect();
        stats.rays += 1;
        stats.hits += picks.len();
        if !picks.is_empty() {
            writer.write(PointerHits::new(ray_id.pointer, picks, camera.order as f32));
        }
    }
    stats.posed_refits = ray_cast.take_posed_refits();
    stats.time = start.elapsed();
}
