//! The debug overlays draw what the trees hold and what the culling view decided, within the
//! line budget, and nothing when they are off.

use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::{VisibilityClass, VisibleEntities};
use bevy::gizmos::GizmoPlugin;
use bevy::math::primitives::ViewFrustum;
use bevy::picking::backend::ray::{RayId, RayMap};
use bevy::picking::pointer::PointerId;
use bevy::prelude::*;
use bevy_accel::AccelCullingPlugin;
use bevy_accel::overlays::{AccelOverlaySettings, AccelOverlayStats, AccelOverlaysPlugin};
use bevy_accel::prelude::*;
use std::any::TypeId;

mod common;
use common::{grid_point, headless_app};

#[derive(Component, Default)]
struct Drawable;

/// 512 unit boxes on an 8x8x8 lattice 4 apart, a camera at one corner looking along +x (it
/// sees part of them), and the overlays with the given settings.
fn scene(settings: AccelOverlaySettings) -> (App, Entity) {
    let mut app = headless_app();
    app.add_plugins((
        GizmoPlugin,
        AccelCullingPlugin,
        AccelPickingPlugin,
        AccelOverlaysPlugin,
    ))
    .insert_resource(settings);
    app.finish();
    let mut class = VisibilityClass::default();
    class.push(TypeId::of::<Drawable>());
    let world = app.world_mut();
    for i in 0..512 {
        world.spawn((
            Transform::from_translation(grid_point(i, 8)),
            Visibility::Visible,
            class.clone(),
            Drawable,
            Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
        ));
    }
    let eye = Vec3::new(-10.0, 2.0, 2.0);
    let transform = Transform::from_translation(eye).looking_at(eye + Vec3::X, Vec3::Y);
    let proj = Mat4::perspective_infinite_reverse_rh(0.5, 1.5, 0.1);
    let frustum = Frustum(ViewFrustum::from_clip_from_world(
        &(proj * transform.to_matrix().inverse()),
    ));
    let camera = world.spawn((Camera::default(), transform, frustum)).id();
    app.update();
    app.update();
    (app, camera)
}

fn stats(app: &App) -> AccelOverlayStats {
    app.world().resource::<AccelOverlayStats>().clone()
}

#[test]
fn boxes_show_the_culling_views_verdicts() {
    let (mut app, camera) = scene(AccelOverlaySettings {
        entity_bounds: true,
        frustum: true,
        ..default()
    });
    let seen = app
        .world()
        .get::<VisibleEntities>(camera)
        .unwrap()
        .get(TypeId::of::<Drawable>())
        .len();
    assert!(
        seen > 0 && seen < 512,
        "the view sees part of the lattice: {seen}"
    );
    let s = stats(&app);
    assert_eq!(s.entity_boxes, 512);
    assert_eq!(s.visible_boxes, seen);
    assert_eq!(s.lines, 512 * 12 + 12, "boxes and the frustum");
    assert!(!s.truncated);
    // A budget of the frustum and 100 boxes draws the 100 nearest and says it left some out.
    app.world_mut()
        .resource_mut::<AccelOverlaySettings>()
        .line_budget = 12 + 1200;
    app.update();
    let s = stats(&app);
    assert_eq!((s.entity_boxes, s.lines), (100, 1212));
    assert!(s.truncated);
}

#[test]
fn tree_nodes_are_drawn_by_depth_within_the_budget() {
    for index in IndexChoice::ALL {
        let (mut app, _) = scene(AccelOverlaySettings {
            dynamic_nodes: true,
            static_nodes: true,
            ..default()
        });
        app.world_mut().resource_mut::<AccelSettings>().index = index;
        app.update();
        app.update();
        let s = stats(&app);
        assert!(s.nodes > 0, "{index:?}: no node drawn");
        assert_eq!(s.lines, s.nodes * 12, "{index:?}");
        // Only the roots: one box for the trees and the flat list; every occupied cell for
        // the grid, whose cells are all at depth 0 here (no oversize boxes).
        app.world_mut()
            .resource_mut::<AccelOverlaySettings>()
            .max_depth = 0;
        app.update();
        let roots = stats(&app).nodes;
        match index {
            IndexChoice::Grid => assert_eq!(roots, s.nodes),
            IndexChoice::BruteForce => assert_eq!((roots, s.nodes), (1, 1)),
            _ => assert!(
                roots == 1 && roots < s.nodes,
                "{index:?}: {roots} of {}",
                s.nodes
            ),
        }
        app.world_mut()
            .resource_mut::<AccelOverlaySettings>()
            .max_depth = 8;
        app.world_mut()
            .resource_mut::<AccelOverlaySettings>()
            .line_budget = 120;
        app.update();
        let all_nodes = s.nodes;
        let s = stats(&app);
        assert!(s.lines <= 120, "{index:?}: {s:?}");
        assert_eq!(s.truncated, all_nodes * 12 > 120, "{index:?}: {s:?}");
    }
}

#[test]
fn picking_rays_draw_their_hit_and_the_nodes_they_pass() {
    let (mut app, camera) = scene(AccelOverlaySettings {
        picking_rays: true,
        ..default()
    });
    // A mesh in view in front of the lattice, and a pointer ray from the camera through it.
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::from_length(1.0));
    app.world_mut().spawn((
        Mesh3d(cube),
        Transform::from_xyz(-5.0, 2.0, 2.0),
        Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
    ));
    app.update();
    let mut rays = RayMap::default();
    rays.map.insert(
        RayId::new(camera, PointerId::Mouse),
        Ray3d::new(Vec3::new(-10.0, 2.0, 2.0), Dir3::X),
    );
    app.insert_resource(rays);
    app.update();
    let s = stats(&app);
    assert_eq!(s.rays, 1);
    assert!(s.nodes > 0, "the ray passes through the trees' nodes");
    assert_eq!(s.lines, 1 + 8 + s.nodes * 12, "ray, hit marks, nodes");
}

#[test]
fn overlays_that_are_off_draw_nothing() {
    let (mut app, _) = scene(AccelOverlaySettings::all());
    assert!(stats(&app).lines > 0);
    *app.world_mut().resource_mut::<AccelOverlaySettings>() = AccelOverlaySettings::default();
    app.update();
    assert_eq!(stats(&app), AccelOverlayStats::default());
}
