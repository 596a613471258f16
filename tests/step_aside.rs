//! The trees stepping aside in a small world that only culling uses
//! (`AccelSettings::step_aside_below`, `AccelTrees::stepped_aside`): the culling stays Bevy's
//! through the step aside and back, the trees catch up with every spawn, move and despawn
//! made while they stood still, and a reader keeps them current.

use bevy::ecs::system::RunSystemOnce;
use bevy::prelude::*;
use bevy_accel::prelude::*;

mod common;
mod culling_scene;
use accel_testkit::Rng;
use culling_scene::*;

/// Frames a small world waits before stepping aside, and a margin.
const SETTLE: usize = 40;

/// Moves, spawns and despawns of one frame, the same in both apps.
struct Churn {
    moves: Vec<(usize, Vec3)>,
    spawns: Vec<Vec3>,
    despawns: Vec<usize>,
}

fn churn(rng: &mut Rng, live: &[bool]) -> Churn {
    let alive: Vec<usize> = (0..live.len()).filter(|&i| live[i]).collect();
    let pick = |rng: &mut Rng| alive[rng.below(alive.len())];
    Churn {
        moves: (0..20)
            .map(|_| (pick(rng), rng.vec3(-60.0, 60.0)))
            .collect(),
        spawns: (0..3).map(|_| rng.vec3(-60.0, 60.0)).collect(),
        despawns: (0..2).map(|_| pick(rng)).collect(),
    }
}

/// Applies `churn` to one app's entities (spawn order is the same in both apps).
fn apply(app: &mut App, entities: &mut Vec<Entity>, live: &mut Vec<bool>, churn: &Churn) {
    let world = app.world_mut();
    for &(i, to) in &churn.moves {
        if live[i] {
            world.get_mut::<Transform>(entities[i]).unwrap().translation = to;
        }
    }
    let class = drawable_class();
    for &at in &churn.spawns {
        entities.push(spawn_drawable(world, &class, at, 0.7).id());
        live.push(true);
    }
    for &i in &churn.despawns {
        if live[i] {
            world.despawn(entities[i]);
            live[i] = false;
        }
    }
}

/// Bevy's app and ours over the same grid, with a camera looking into it.
fn apps(step_aside_below: usize) -> ((App, Vec<Entity>), (App, Vec<Entity>)) {
    let make = |ours: bool| {
        let mut app = app(ours);
        app.init_resource::<ChangedVisibility>()
            .add_systems(Last, record_changed_visibility);
        if ours {
            app.world_mut()
                .resource_mut::<AccelSettings>()
                .step_aside_below = step_aside_below;
        }
        let world = app.world_mut();
        let entities = spawn_grid(world, 8, 0.7, |_, _| {});
        world.spawn((
            Camera::default(),
            Transform::default(),
            frustum(Vec3::new(-30.0, 10.0, -30.0), Vec3::ZERO, 0.9),
            ViewIndex(0),
        ));
        app.update();
        (app, entities)
    };
    (make(false), make(true))
}

/// The trees hold exactly the live entities, each with its current world box.
fn assert_trees_hold(app: &mut App, entities: &[Entity], live: &[bool]) {
    let world = app.world_mut();
    let trees = world.resource::<AccelTrees>();
    let held: usize = entities.iter().filter(|&&e| trees.contains(e)).count();
    let expected = live.iter().filter(|&&l| l).count();
    assert_eq!(held, expected, "entities held");
    assert_eq!(trees.len(), expected, "tracked count");
    for (&e, &l) in entities.iter().zip(live) {
        assert_eq!(trees.contains(e), l, "{e} held");
    }
    common::check_consistency(app);
}

#[test]
fn a_small_world_steps_aside_culls_as_bevy_and_catches_up() {
    let ((mut bevy, mut a), (mut accel, mut b)) = apps(5_000);
    let mut live = vec![true; a.len()];
    let mut live_b = live.clone();
    let mut rng = Rng::from_state(0x57e9_a51d);
    let mut stepped_aside_frames = 0;
    for frame in 0..SETTLE + 60 {
        let c = churn(&mut rng, &live);
        apply(&mut bevy, &mut a, &mut live, &c);
        apply(&mut accel, &mut b, &mut live_b, &c);
        bevy.update();
        accel.update();
        assert_culled_alike((&mut bevy, &a), (&mut accel, &b), frame);
        stepped_aside_frames += accel.world().resource::<AccelTrees>().stepped_aside() as usize;
    }
    assert!(
        stepped_aside_frames >= 60,
        "stood aside {stepped_aside_frames} frames"
    );
    // A reader appears: the trees wake in its first frame and hold the world as it is now.
    accel
        .world_mut()
        .run_system_once(|q: AccelSpatialQuery| q.trees().stepped_aside())
        .unwrap();
    accel.update();
    let trees = accel.world().resource::<AccelTrees>();
    assert!(!trees.stepped_aside());
    assert_trees_hold(&mut accel, &b, &live_b);
    for frame in 0..SETTLE + 10 {
        let c = churn(&mut rng, &live);
        apply(&mut bevy, &mut a, &mut live, &c);
        apply(&mut accel, &mut b, &mut live_b, &c);
        bevy.update();
        accel.update();
        assert_culled_alike((&mut bevy, &a), (&mut accel, &b), frame);
        assert!(!accel.world().resource::<AccelTrees>().stepped_aside());
    }
    assert_trees_hold(&mut accel, &b, &live_b);
}

#[test]
fn a_world_that_grows_past_the_threshold_wakes_the_trees() {
    let ((mut bevy, mut a), (mut accel, mut b)) = apps(600);
    let mut live = vec![true; a.len()];
    let mut live_b = live.clone();
    let mut rng = Rng::from_state(0x9a0_77e5);
    for _ in 0..SETTLE {
        bevy.update();
        accel.update();
    }
    assert!(accel.world().resource::<AccelTrees>().stepped_aside());
    // 512 entities and 3 a frame: past 600 within 30 frames.
    let mut woke_at = None;
    for frame in 0..40 {
        let c = churn(&mut rng, &live);
        apply(&mut bevy, &mut a, &mut live, &c);
        apply(&mut accel, &mut b, &mut live_b, &c);
        bevy.update();
        accel.update();
        assert_culled_alike((&mut bevy, &a), (&mut accel, &b), frame);
        let aside = accel.world().resource::<AccelTrees>().stepped_aside();
        if !aside && woke_at.is_none() {
            woke_at = Some(frame);
        }
        if woke_at.is_some() {
            assert!(
                !aside,
                "frame {frame}: stepped aside again above the threshold"
            );
        }
    }
    assert!(woke_at.is_some(), "never woke");
    assert_trees_hold(&mut accel, &b, &live_b);
}

#[test]
fn zero_keeps_the_trees_current() {
    let (_, (mut accel, _)) = apps(0);
    for _ in 0..SETTLE * 2 {
        accel.update();
        assert!(!accel.world().resource::<AccelTrees>().stepped_aside());
    }
}

#[test]
fn a_reading_plugin_keeps_the_trees_current() {
    let mut app = common::headless_app();
    app.add_plugins((bevy_accel::AccelCullingPlugin, AccelPickingPlugin));
    app.finish();
    app.world_mut()
        .resource_mut::<AccelSettings>()
        .step_aside_below = 5_000;
    spawn_grid(app.world_mut(), 4, 0.5, |_, _| {});
    for _ in 0..SETTLE * 2 {
        app.update();
        assert!(!app.world().resource::<AccelTrees>().stepped_aside());
    }
}

/// A system that reads `Res<AccelTrees>` itself cannot be seen: its first read while aside
/// wakes the trees for good (with one warning).
#[test]
fn a_direct_read_wakes_the_trees_for_good() {
    let (_, (mut accel, b)) = apps(5_000);
    for _ in 0..SETTLE {
        accel.update();
    }
    assert!(accel.world().resource::<AccelTrees>().stepped_aside());
    let moved = b[0];
    accel
        .world_mut()
        .get_mut::<Transform>(moved)
        .unwrap()
        .translation = Vec3::splat(500.0);
    accel.update();
    // The read: stale (the move is not in the trees yet).
    let trees = accel.world().resource::<AccelTrees>();
    let stale = trees
        .location(moved)
        .map(|(slot, _)| trees.world_bounds(slot));
    assert!(stale.is_some_and(|b| b.max.x < 100.0));
    accel.update();
    let trees = accel.world().resource::<AccelTrees>();
    assert!(!trees.stepped_aside());
    let (slot, _) = trees.location(moved).unwrap();
    assert!(trees.world_bounds(slot).min.x > 400.0);
    for _ in 0..SETTLE * 2 {
        accel.update();
        assert!(!accel.world().resource::<AccelTrees>().stepped_aside());
    }
}
