//! A frame in which nothing moves leaves `AccelTrees` unchanged, so readers that key on its
//! change tick (the culling keeps a view's walk while neither the frustum nor the trees
//! change) skip their work. Background work of the trees must not break that.

use bevy::camera::primitives::Aabb;
use bevy::prelude::*;
use bevy_accel::prelude::*;

/// Per frame, whether `AccelTrees` was marked changed, whether a ray snapshot of the
/// dynamic tree was being built on another thread, and how many rebuilds the dynamic tree
/// has installed.
#[derive(Resource, Default)]
struct Frames(Vec<(bool, bool, u64)>);

fn record(trees: Res<AccelTrees>, mut frames: ResMut<Frames>) {
    let pending = trees
        .query()
        .bvh_pair()
        .is_some_and(|pair| pair.dynamic_ray_snapshot_pending());
    let rebuilds = trees.dynamic_bvh().map_or(0, |d| d.rebuild_count());
    frames.0.push((trees.is_changed(), pending, rebuilds));
}

#[test]
fn a_background_ray_snapshot_marks_the_trees_changed_only_when_it_lands() {
    let mut settings = AccelSettings::default();
    // Built off the frame, and soon: the build over this many leaves spans frames.
    settings.bvh.ray_snapshot_in_frame_max_entities = 100;
    settings.bvh.ray_snapshot_after_stable_frames = Some(3);
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin { settings }))
        .init_resource::<Frames>()
        .add_systems(Last, record);
    spawn_lattice(&mut app, 40);
    let snapshot_held = |app: &App| {
        app.world()
            .resource::<AccelStats>()
            .bvh
            .as_ref()
            .is_some_and(|b| b.ray_snapshot)
    };
    let mut frames = 0;
    while !snapshot_held(&app) {
        app.update();
        frames += 1;
        assert!(frames < 20_000, "the ray snapshot was never installed");
    }
    let log = &app.world().resource::<Frames>().0;
    let pending_frames = log.iter().filter(|(_, pending, _)| *pending).count();
    assert!(
        pending_frames >= 2,
        "the build should span frames for this test to mean anything ({pending_frames})"
    );
    // The frames of the spawn, of the build's start and of its landing, and of the dynamic
    // tree's own rebuild landing; none other while the snapshot was built.
    let changed_while_pending = log
        .windows(2)
        .filter(|w| w[0].1 && w[1].1 && w[1].0 && w[0].2 == w[1].2)
        .count();
    assert_eq!(changed_while_pending, 0, "frames: {log:?}");
    let changed = log.iter().filter(|(changed, ..)| *changed).count();
    assert!(changed <= 5, "{changed} changed frames: {log:?}");
}

/// A field of `side`³ unit boxes 3 units apart, none marked static.
fn spawn_lattice(app: &mut App, side: usize) {
    for i in 0..side * side * side {
        let p = Vec3::new(
            (i % side) as f32,
            (i / side % side) as f32,
            (i / side / side) as f32,
        ) * 3.0;
        app.world_mut().spawn((
            Transform::from_translation(p),
            Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
        ));
    }
}

#[test]
fn a_world_that_holds_still_after_a_spawn_gets_the_rebuilt_tree() {
    let mut settings = AccelSettings::default();
    // No ray snapshot: only the dynamic tree's own rebuild is at stake here.
    settings.bvh.ray_snapshot_after_stable_frames = None;
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin { settings }))
        .init_resource::<Frames>()
        .add_systems(Last, record);
    spawn_lattice(&mut app, 30);
    app.update();
    let tree = |app: &App| {
        let trees = app.world().resource::<AccelTrees>();
        let d = trees.dynamic_bvh().expect("the BVH backend");
        (d.len(), d.rebuild_count(), d.rebuild_in_flight())
    };
    assert_eq!(tree(&app).0, 27_000);
    let started = tree(&app).1 > 0 || tree(&app).2;
    assert!(
        started,
        "the spawn should start a rebuild for this test to mean anything"
    );
    // Nothing moves or spawns from here on: the rebuild must land all the same.
    let mut frames = 0;
    while tree(&app).1 == 0 {
        std::thread::sleep(std::time::Duration::from_millis(2));
        app.update();
        frames += 1;
        assert!(frames < 5_000, "the rebuild never landed: {:?}", tree(&app));
    }
    assert_eq!(tree(&app), (27_000, 1, false));
    // Once landed, still frames leave the trees unchanged again.
    let landed = app.world().resource::<Frames>().0.len();
    for _ in 0..5 {
        app.update();
    }
    let log = &app.world().resource::<Frames>().0;
    assert!(
        log[landed..].iter().all(|(changed, ..)| !changed),
        "{log:?}"
    );
    // And the landing started no further rebuild: a still world keeps no core busy.
    assert_eq!(tree(&app), (27_000, 1, false));
}
