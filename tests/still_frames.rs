//! A frame in which nothing moves leaves `AccelTrees` unchanged, so readers that key on its
//! change tick (the culling keeps a view's walk while neither the frustum nor the trees
//! change) skip their work. Background work of the trees must not break that.

use bevy::camera::primitives::Aabb;
use bevy::prelude::*;
use bevy_accel::prelude::*;

/// Per frame, whether `AccelTrees` was marked changed and whether a ray snapshot of the
/// dynamic tree was being built on another thread.
#[derive(Resource, Default)]
struct Frames(Vec<(bool, bool)>);

fn record(trees: Res<AccelTrees>, mut frames: ResMut<Frames>) {
    let pending = trees
        .query()
        .bvh_pair()
        .is_some_and(|pair| pair.dynamic_ray_snapshot_pending());
    frames.0.push((trees.is_changed(), pending));
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
    let side = 40;
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
    let pending_frames = log.iter().filter(|(_, pending)| *pending).count();
    assert!(
        pending_frames >= 2,
        "the build should span frames for this test to mean anything ({pending_frames})"
    );
    // The frames of the spawn, of the build's start and of its landing; none while it ran.
    let changed_while_pending = log
        .windows(2)
        .filter(|w| w[0].1 && w[1].1 && w[1].0)
        .count();
    assert_eq!(changed_while_pending, 0, "frames: {log:?}");
    let changed = log.iter().filter(|(changed, _)| *changed).count();
    assert!(changed <= 4, "{changed} changed frames: {log:?}");
}
