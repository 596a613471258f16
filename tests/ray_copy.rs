//! The wide ray copy of a still dynamic tree, through the plugin: made once the world holds
//! still, dropped when anything moves.

use bevy::ecs::system::RunSystemOnce;
use bevy::picking::mesh_picking::ray_cast::{MeshRayCastSettings, RayCastVisibility};
use bevy::prelude::*;
use bevy_accel::prelude::*;

mod common;
use common::app;

/// The entity a ray from `origin` down -z hits first, through `AccelRayCast`.
fn first_hit_down_z(app: &mut App, origin: Vec3) -> Option<Entity> {
    app.world_mut()
        .run_system_once(move |mut ray_cast: AccelRayCast| {
            let ray = Ray3d::new(origin, Dir3::NEG_Z);
            // No camera here, so nothing is visible in a view: any visibility counts.
            let settings = MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
            ray_cast.cast_ray(ray, &settings).first().map(|(e, _)| *e)
        })
        .unwrap()
}

/// The wide copy of a still dynamic tree is dropped when an entity moves: rays then find it
/// where it went, not where it was when the copy was made.
#[test]
fn rays_follow_an_entity_that_moves_after_the_dynamic_tree_was_copied() {
    let mut app = app();
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(1.0, 1.0, 1.0));
    let mover = app
        .world_mut()
        .spawn((Transform::default(), Mesh3d(cube.clone())))
        .id();
    for i in 0..50 {
        let x = 20.0 + 3.0 * i as f32;
        app.world_mut()
            .spawn((Transform::from_xyz(x, 0.0, 0.0), Mesh3d(cube.clone())));
    }
    let wait = AccelSettings::default().ray_snapshot_after_still_frames;
    for _ in 0..wait.expect("on by default") + 2 {
        app.update();
    }
    let copied = |app: &App| {
        app.world()
            .resource::<AccelTrees>()
            .query()
            .has_dynamic_ray_snapshot()
    };
    assert!(copied(&app));
    assert_eq!(
        first_hit_down_z(&mut app, Vec3::new(0.0, 0.0, 5.0)),
        Some(mover)
    );

    app.world_mut()
        .entity_mut(mover)
        .insert(Transform::from_xyz(0.0, 10.0, 0.0));
    app.update();
    assert!(!copied(&app));
    assert_eq!(first_hit_down_z(&mut app, Vec3::new(0.0, 0.0, 5.0)), None);
    assert_eq!(
        first_hit_down_z(&mut app, Vec3::new(0.0, 10.0, 5.0)),
        Some(mover)
    );
}
