//! The sync on a compute pool of several threads: busy movers' moves written from every
//! thread, the other moved entities placed after, checked against the ECS every frame. A
//! process of its own, so that its pool has the threads it asks for.

use bevy::camera::primitives::Aabb;
use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, TaskPoolBuilder};
use bevy_accel::prelude::*;

mod common;
use accel_testkit::Rng;
use common::check_consistency;

/// An app with the plugin on a compute pool of four threads.
fn app_on_four_threads(settings: AccelSettings) -> App {
    // Made before the app, which then keeps it (Bevy makes its pools once per process).
    let pool = ComputeTaskPool::get_or_init(|| TaskPoolBuilder::new().num_threads(4).build());
    assert_eq!(pool.thread_num(), 4);
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin))
        .add_plugins(AccelPlugin { settings });
    app
}

/// A unit box within `half` of the origin.
fn spawn_box(world: &mut World, rng: &mut Rng, half: f32) -> Entity {
    let unit = Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5));
    let t = Transform::from_translation(rng.vec3(-half, half));
    world.spawn((t, unit)).id()
}

/// Despawns `count` of `entities` at random and spawns as many boxes in their place.
fn replace_some(
    world: &mut World,
    entities: &mut Vec<Entity>,
    rng: &mut Rng,
    count: usize,
    half: f32,
) {
    for _ in 0..count {
        let i = rng.below(entities.len());
        world.despawn(entities.swap_remove(i));
    }
    for _ in 0..count {
        entities.push(spawn_box(world, rng, half));
    }
}

#[test]
fn busy_movers_move_from_every_thread_beside_the_rest_of_the_sync() {
    let mut app = app_on_four_threads(AccelSettings {
        busy_movers: BusyMoverSettings {
            mode: BusyMovers::On,
            ..default()
        },
        ..default()
    });
    let mut rng = Rng::from_state(21);
    let mut movers: Vec<Entity> = (0..12_000)
        .map(|_| spawn_box(app.world_mut(), &mut rng, 200.0))
        .collect();
    let mut most_busy = 0;
    let mut busy_moves = 0;
    for frame in 0..40 {
        let world = app.world_mut();
        // Most move every frame; some hold still (their box unchanged), a few get a bad
        // transform for a while, some leave and newcomers arrive.
        for (i, &e) in movers.iter().enumerate() {
            let mut t = world.get_mut::<Transform>(e).unwrap();
            match i % 100 {
                0 if frame % 10 == 3 => t.scale = Vec3::ZERO,
                0 if frame % 10 == 6 => t.scale = Vec3::ONE,
                1 => t.set_changed(),
                _ => t.translation += Vec3::from(rng.vec3a(-1.0, 1.0)),
            }
        }
        if frame % 5 == 4 {
            replace_some(world, &mut movers, &mut rng, 200, 200.0);
        }
        app.update();
        check_consistency(&mut app);
        let stats = app.world().resource::<AccelStats>();
        most_busy = most_busy.max(stats.busy_movers);
        busy_moves += stats.busy_moved;
    }
    // Enough busy movers for the threads to take their moves, for most of the run.
    assert!(most_busy > 10_000, "{most_busy} busy movers at most");
    assert!(busy_moves > 300_000, "{busy_moves} busy moves");
}

#[test]
fn a_large_world_with_few_movers_is_scanned_from_every_thread() {
    let mut app = app_on_four_threads(AccelSettings::default());
    let mut rng = Rng::from_state(34);
    // Past the size from which the change scan alone is split across the pool, with far
    // fewer movers than would make the busy movers' pass parallel by themselves.
    let mut entities: Vec<Entity> = (0..40_000)
        .map(|_| spawn_box(app.world_mut(), &mut rng, 400.0))
        .collect();
    app.update();
    let mut busy_moves = 0;
    let mut index_moves = 0;
    for frame in 0..30 {
        let world = app.world_mut();
        // A few hundred move every frame, a different few join each frame (first moves are
        // the dynamic index's: left for the one-thread placement), some get a bad transform
        // for a while, and some leave while others arrive.
        for i in 0..400 {
            let e = entities[(i * 97) % entities.len()];
            let mut t = world.get_mut::<Transform>(e).unwrap();
            t.translation += Vec3::from(rng.vec3a(-1.0, 1.0));
        }
        for i in 0..100 {
            let e = entities[(frame * 1_000 + i * 13 + 5) % entities.len()];
            let mut t = world.get_mut::<Transform>(e).unwrap();
            t.translation += Vec3::from(rng.vec3a(-30.0, 30.0));
            match frame % 6 {
                2 if i < 10 => t.scale = Vec3::ZERO,
                4 if i < 10 => t.scale = Vec3::ONE,
                _ => {}
            }
        }
        if frame % 5 == 4 {
            replace_some(world, &mut entities, &mut rng, 50, 400.0);
        }
        app.update();
        check_consistency(&mut app);
        let stats = app.world().resource::<AccelStats>();
        assert!(
            stats.dynamic_entities > 32_768,
            "{}",
            stats.dynamic_entities
        );
        busy_moves += stats.busy_moved;
        index_moves += stats.moved - stats.busy_moved;
    }
    // Both kinds of move went through the pass: busy movers from the threads, the rest left
    // to the placement after it.
    assert!(busy_moves > 5_000, "{busy_moves} busy moves");
    assert!(index_moves > 1_000, "{index_moves} moves in the index");
}
