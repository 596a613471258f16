//! The wide ray snapshot of the dynamic tree, through the plugin: made once no entity has
//! entered or left for a while, refit when entities move, dropped when one enters or leaves.

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

/// Frames the world must stay free of spawns (and, without rays, of motion) before the
/// plugin builds the snapshot.
fn snapshot_wait() -> u32 {
    AccelSettings::default()
        .bvh
        .ray_snapshot_after_stable_frames
        .expect("on by default")
}

/// Whether rays walk the dynamic tree's snapshot.
fn has_snapshot(app: &App) -> bool {
    app.world()
        .resource::<AccelTrees>()
        .query()
        .has_dynamic_ray_snapshot()
}

/// A world of unit cubes: a mover at the origin and a row of 50 others far along +x, all
/// dynamic, with `settings`. Returns the app, the mover and the cube mesh.
fn world_with_mover(settings: AccelSettings) -> (App, Entity, Handle<Mesh>) {
    let mut app = app();
    app.insert_resource(settings);
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
    (app, mover, cube)
}

/// The snapshot is refit when an entity moves: rays find it where it went, not where it was
/// when the snapshot was made, through the snapshot. An entity entering drops it.
#[test]
fn rays_follow_an_entity_that_moves_after_the_dynamic_tree_was_copied() {
    // Kept through motion whatever the ray count (the test casts one ray a frame at most).
    let (mut app, mover, cube) = world_with_mover(AccelSettings {
        bvh: BvhIndexSettings {
            ray_snapshot_rays_per_mover: 0.0,
            ..default()
        },
        ..default()
    });
    for _ in 0..snapshot_wait() + 2 {
        app.update();
    }
    assert!(has_snapshot(&app));
    assert_eq!(
        first_hit_down_z(&mut app, Vec3::new(0.0, 0.0, 5.0)),
        Some(mover)
    );

    app.world_mut()
        .entity_mut(mover)
        .insert(Transform::from_xyz(0.0, 10.0, 0.0));
    app.update();
    assert!(has_snapshot(&app), "motion dropped the snapshot");
    assert_eq!(first_hit_down_z(&mut app, Vec3::new(0.0, 0.0, 5.0)), None);
    assert_eq!(
        first_hit_down_z(&mut app, Vec3::new(0.0, 10.0, 5.0)),
        Some(mover)
    );
    // Two small steps: the first refattens the box the jump stretched, the second stays
    // inside the new fat box, where only the snapshot's tight boxes have anything to follow.
    for y in [10.05, 10.1] {
        app.world_mut()
            .entity_mut(mover)
            .insert(Transform::from_xyz(0.0, y, 0.0));
        app.update();
    }
    assert_eq!(
        app.world().resource::<AccelStats>().updated,
        0,
        "the step left the fat box: this no longer tests the snapshot-only refit"
    );
    assert!(has_snapshot(&app));
    // The cube spans 9.6..10.6 in y now (9.55..10.55 before the second step).
    assert_eq!(first_hit_down_z(&mut app, Vec3::new(0.0, 9.57, 5.0)), None);
    assert_eq!(
        first_hit_down_z(&mut app, Vec3::new(0.0, 10.58, 5.0)),
        Some(mover)
    );

    let newcomer = app
        .world_mut()
        .spawn((Transform::from_xyz(0.0, -10.0, 0.0), Mesh3d(cube)))
        .id();
    app.update();
    assert!(
        !has_snapshot(&app),
        "an entity entered and the snapshot stayed"
    );
    assert_eq!(
        first_hit_down_z(&mut app, Vec3::new(0.0, -10.0, 5.0)),
        Some(newcomer)
    );
}

/// By default the snapshot is kept through motion only while rays outnumber the movers: a
/// mover in a world where no ray is cast drops it (rays would save less than its refits
/// cost), and it comes back once the world has held still long enough.
#[test]
fn motion_without_rays_drops_the_snapshot_until_the_world_holds_still() {
    let (mut app, mover, _) = world_with_mover(AccelSettings::default());
    let wait = snapshot_wait();
    for _ in 0..wait + 2 {
        app.update();
    }
    assert!(has_snapshot(&app));
    for frame in 0..5 {
        // Off the spawn point from the first frame: a box that stays put is no move.
        app.world_mut()
            .entity_mut(mover)
            .insert(Transform::from_xyz(0.0, frame as f32 + 0.5, 0.0));
        app.update();
        assert!(!has_snapshot(&app), "frame {frame}: kept for no rays");
    }
    for _ in 0..wait - 1 {
        app.update();
        assert!(
            !has_snapshot(&app),
            "rebuilt before the world held still long enough"
        );
    }
    for _ in 0..2 {
        app.update();
    }
    assert!(has_snapshot(&app));
    assert_eq!(
        first_hit_down_z(&mut app, Vec3::new(0.0, 4.5, 5.0)),
        Some(mover)
    );
}

/// With the default settings, rays cast in volume (here ten a frame against one mover) keep
/// the snapshot through motion, refit each frame, and rays find the mover where it went.
#[test]
fn many_rays_keep_the_snapshot_through_motion() {
    let (mut app, mover, _) = world_with_mover(AccelSettings::default());
    let cast_ten = |app: &mut App, y: f32| {
        (0..10)
            .map(|_| first_hit_down_z(app, Vec3::new(0.0, y, 5.0)))
            .last()
            .flatten()
    };
    for _ in 0..snapshot_wait() + 2 {
        cast_ten(&mut app, 0.0);
        app.update();
    }
    assert!(has_snapshot(&app));
    for frame in 1..20 {
        app.world_mut()
            .entity_mut(mover)
            .insert(Transform::from_xyz(0.0, frame as f32, 0.0));
        app.update();
        assert!(
            has_snapshot(&app),
            "frame {frame}: dropped despite the rays"
        );
        assert_eq!(cast_ten(&mut app, frame as f32), Some(mover));
        assert_eq!(cast_ten(&mut app, frame as f32 - 1.0), None);
    }
}
