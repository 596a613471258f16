//! The pointers' picking rays, their hits, and the tree nodes they pass through.

use super::budget::LineBudget;
use super::{AccelGizmos, AccelOverlaySettings, level_color};
use crate::{AccelRayCast, AccelTrees};
use bevy::picking::backend::ray::RayMap;
use bevy::picking::mesh_picking::ray_cast::MeshRayCastSettings;
use bevy::prelude::*;
use core::ops::ControlFlow;
use spatial_accel::Ray;
use spatial_accel::query::{NodeView, visit_tree_nodes};

const RAY: Color = Color::WHITE;
const HIT: Color = Color::srgb(1.0, 0.2, 0.9);

/// Casts each pointer's ray of `RayMap` through [`AccelRayCast`] (what the picking backend
/// casts), and draws the ray up to its first hit, the hit point with its normal, and the
/// nodes of both trees the ray passes through before the hit, shallowest first: the walk a
/// ray can take. Seen from the camera that casts it a ray is a point, so look from another.
pub(crate) fn draw_picking_rays(
    settings: Res<AccelOverlaySettings>,
    rays: Option<Res<RayMap>>,
    mut ray_cast: AccelRayCast,
    trees: Res<AccelTrees>,
    mut budget: ResMut<LineBudget>,
    mut gizmos: Gizmos<AccelGizmos>,
) {
    let Some(rays) = rays else {
        return;
    };
    let depths = settings.min_depth..=settings.max_depth;
    for ray in rays.iter().map(|(_, ray)| *ray) {
        let hit = ray_cast
            .cast_ray(ray, &MeshRayCastSettings::default())
            .first()
            .map(|(_, hit)| (hit.point, hit.normal, hit.distance));
        if !budget.take(1) {
            return;
        }
        budget.stats.rays += 1;
        let reach = hit.map_or(100.0, |(.., distance)| distance);
        gizmos.line(ray.origin, ray.get_point(reach), RAY);
        if let Some((point, normal, distance)) = hit
            && budget.take(8)
        {
            let size = (distance * 0.02).max(0.05);
            gizmos.arrow(point, point + normal * size * 5.0, HIT);
            gizmos.cross(Isometry3d::from_translation(point), size, HIT);
        }
        let walked = Ray::new(ray.origin, *ray.direction).with_t_max(reach);
        let _ = trees.query().visit_dynamic_nodes(
            depths.clone(),
            &mut passed_nodes(&mut budget, &mut gizmos, walked, false),
        );
        let _ = visit_tree_nodes(
            trees.static_tree(),
            depths.clone(),
            passed_nodes(&mut budget, &mut gizmos, walked, true),
        );
    }
}

/// A node visitor drawing the nodes `ray` passes through, until the budget ends.
fn passed_nodes<'a>(
    budget: &'a mut LineBudget,
    gizmos: &'a mut Gizmos<'_, '_, AccelGizmos>,
    ray: Ray,
    is_static: bool,
) -> impl FnMut(NodeView) -> ControlFlow<()> + 'a {
    move |node: NodeView| {
        if !node.bounds.is_valid() || ray.intersect_aabb(&node.bounds).is_none() {
            return ControlFlow::Continue(());
        }
        let color = level_color(node.depth, is_static);
        if !budget.draw_box(gizmos, &node.bounds, color) {
            return ControlFlow::Break(());
        }
        budget.stats.nodes += 1;
        ControlFlow::Continue(())
    }
}
