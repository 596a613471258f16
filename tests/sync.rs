//! The trees follow the entities: spawns, motion, despawns, reparenting and bad transforms,
//! frame after frame, checked against the ECS after every frame.

use bevy::prelude::*;
use bevy_accel::prelude::*;
use bevy_accel::spatial_accel::SpatialQuery;

mod common;
use accel_testkit::Rng;
use common::{bvh, check_consistency, trees_app_with_cubes, unit_aabb};

fn app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin::default()));
    app
}

/// The scenario below moves static entities too, so it asks the plugin to watch them.
/// `static_rebuild_in_frame_up_to` 0 sends every static rebuild but the first off the frame.
fn app_watching_statics(
    index: IndexChoice,
    static_rebuild_in_frame_up_to: usize,
    busy: BusyMovers,
) -> App {
    let mut app = App::new();
    let settings = AccelSettings {
        watch_static_motion: true,
        index,
        static_rebuild_in_frame_up_to,
        busy_movers: BusyMoverSettings {
            mode: busy,
            // Short, so that entities leave the list within the scenario too.
            quiet_frames: 3,
            ..default()
        },
        ..Default::default()
    };
    app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin { settings }));
    app
}

#[test]
fn plugin_builds_and_runs_on_an_empty_world() {
    let mut app = app();
    app.update();
    app.update();
    assert!(app.world().resource::<AccelTrees>().is_empty());
}

#[test]
fn thousands_of_entities_spawned_moved_reparented_and_despawned() {
    // Every index, and the index switched to the next choice every 25 frames.
    for index in IndexChoice::ALL {
        churn(index, false, 4_096, BusyMovers::Off);
    }
    churn(IndexChoice::Bvh, true, 4_096, BusyMovers::Off);
}

#[test]
fn busy_movers_join_and_leave_the_flat_list_through_churn() {
    // Busy movers beside each index, and the index switched under them.
    for index in [IndexChoice::Bvh, IndexChoice::Grid, IndexChoice::Octree] {
        churn(index, false, 4_096, BusyMovers::On);
    }
    churn(IndexChoice::Bvh, true, 0, BusyMovers::On);
}

#[test]
fn busy_movers_go_back_to_the_index_when_quiet_or_switched_off() {
    let settings = AccelSettings {
        busy_movers: BusyMoverSettings {
            mode: BusyMovers::On,
            quiet_frames: 4,
            transfers_per_frame: 50,
            checks_per_frame: 1_000,
            ..default()
        },
        ..default()
    };
    let (mut app, entities, mut rng) = trees_app_with_cubes(settings, 400, 5);
    let busy_len = |app: &App| app.world().resource::<AccelTrees>().busy_len();
    let step = |app: &mut App, movers: &[Entity], rng: &mut Rng| {
        for &e in movers {
            let world = app.world_mut();
            world.get_mut::<Transform>(e).unwrap().translation += rng.vec3(-1.0, 1.0);
        }
        app.update();
        check_consistency(app);
    };
    app.update();
    assert_eq!(busy_len(&app), 0, "nothing moved yet");
    // 300 movers join 50 a frame (the transfer budget), the rest stay in the index.
    let movers = &entities[..300];
    for frame in 1..=8 {
        step(&mut app, movers, &mut rng);
        assert_eq!(busy_len(&app), (50 * frame).min(300), "frame {frame}");
    }
    // A third stop: they leave after the quiet frames, the others stay.
    for _ in 0..12 {
        step(&mut app, &movers[100..], &mut rng);
    }
    assert_eq!(busy_len(&app), 200);
    let stats = app.world().resource::<AccelStats>();
    assert_eq!(stats.busy_movers, 200);
    assert_eq!(stats.dynamic_entities, 400);
    // Switched off, the list empties at the transfer budget though everything moves.
    app.world_mut()
        .resource_mut::<AccelSettings>()
        .busy_movers
        .mode = BusyMovers::Off;
    for frame in 1..=4 {
        step(&mut app, movers, &mut rng);
        assert_eq!(busy_len(&app), 200 - (50 * frame).min(200), "frame {frame}");
    }
}

#[test]
fn static_scenery_streams_in_and_out_through_builds_off_the_frame() {
    // Static newcomers wait in the dynamic index and leavers' slots stay cleared while the
    // static tree is rebuilt on the async compute pool; queries see the same entities.
    churn(IndexChoice::Bvh, false, 0, BusyMovers::Off);
    churn(IndexChoice::Grid, true, 0, BusyMovers::Off);
}

fn churn(index: IndexChoice, switch: bool, static_rebuild_in_frame_up_to: usize, busy: BusyMovers) {
    let mut app = app_watching_statics(index, static_rebuild_in_frame_up_to, busy);
    let mut rng = Rng::from_state(7);
    let mut parents = Vec::new();
    for _ in 0..20 {
        parents.push(
            app.world_mut()
                .spawn(Transform::from_translation(rng.vec3(-50.0, 50.0)))
                .id(),
        );
    }
    let mut live: Vec<Entity> = Vec::new();
    let mut built_off_the_frame = 0;
    let mut busy_seen = 0;
    for frame in 0..120 {
        let world = app.world_mut();
        // Spawn: some free, some children of a moving parent, some static, some ignored.
        for i in 0..60 {
            let t = Transform::from_translation(rng.vec3(-60.0, 60.0))
                .with_scale(Vec3::splat(rng.range(0.2, 3.0)));
            let mut e = world.spawn((t, unit_aabb()));
            match i % 6 {
                0 => {
                    e.insert(ChildOf(parents[(rng.next_u32() % 20) as usize]));
                }
                1 => {
                    e.insert(AccelStatic);
                }
                2 if frame % 3 == 0 => {
                    e.insert(AccelIgnore);
                }
                _ => {}
            }
            live.push(e.id());
        }
        // Move parents and some entities.
        for &p in &parents {
            world.get_mut::<Transform>(p).unwrap().translation += rng.vec3(-2.0, 2.0);
        }
        for _ in 0..100 {
            let e = live[(rng.next_u32() as usize) % live.len()];
            if let Some(mut t) = world.get_mut::<Transform>(e) {
                t.translation += rng.vec3(-5.0, 5.0);
            }
        }
        // Reparent a few, toggle markers on a few, despawn some.
        for _ in 0..5 {
            let e = live[(rng.next_u32() as usize) % live.len()];
            let p = parents[(rng.next_u32() % 20) as usize];
            world.entity_mut(e).insert(ChildOf(p));
        }
        for _ in 0..5 {
            let e = live[(rng.next_u32() as usize) % live.len()];
            let mut em = world.entity_mut(e);
            if em.contains::<AccelIgnore>() {
                em.remove::<AccelIgnore>();
            } else if em.contains::<AccelStatic>() {
                em.remove::<AccelStatic>();
            } else {
                em.insert(AccelStatic);
            }
        }
        for _ in 0..40 {
            let i = (rng.next_u32() as usize) % live.len();
            let e = live.swap_remove(i);
            world.despawn(e);
        }
        if frame % 10 == 5 {
            // A moving parent despawned with its children.
            let p = parents.remove(0);
            world.despawn(p);
            live.retain(|&e| world.get_entity(e).is_ok());
            parents.push(
                world
                    .spawn(Transform::from_translation(rng.vec3(-50.0, 50.0)))
                    .id(),
            );
        }
        if busy == BusyMovers::On && frame % 30 == 29 {
            // Off and on again: the list empties into the index, then fills.
            let mut settings = app.world_mut().resource_mut::<AccelSettings>();
            settings.busy_movers.mode = match settings.busy_movers.mode {
                BusyMovers::On => BusyMovers::Off,
                _ => BusyMovers::On,
            };
        }
        if switch && frame % 25 == 24 {
            let mut settings = app.world_mut().resource_mut::<AccelSettings>();
            // Through every choice in turn.
            settings.index = settings.index.next();
        }
        app.update();
        check_consistency(&mut app);
        let wanted = app.world().resource::<AccelSettings>().index;
        let stats = app.world().resource::<AccelStats>();
        match wanted {
            IndexChoice::Automatic => {
                let automatic = stats.automatic.expect("figures while automatic");
                assert_eq!(stats.index, automatic.recommended);
            }
            fixed => assert_eq!(stats.index, fixed),
        }
        built_off_the_frame += usize::from(stats.static_build_in_flight);
        busy_seen = busy_seen.max(stats.busy_movers);
    }
    assert_eq!(
        busy_seen > 0,
        busy == BusyMovers::On,
        "busy movers: {busy_seen}"
    );
    // The first load is built in its frame; later changes go off it only past the setting.
    assert_eq!(built_off_the_frame > 0, static_rebuild_in_frame_up_to == 0);
    assert!(app.world().resource::<AccelTrees>().len() > 2000);
    // A build still in flight lands, and the next one takes in whoever waits.
    for _ in 0..2 {
        app.world_mut()
            .resource_mut::<AccelTrees>()
            .finish_static_build();
        app.update();
    }
    check_consistency(&mut app);
    let trees = app.world().resource::<AccelTrees>();
    assert_eq!(trees.static_waiting_len(), 0);
    assert!(trees.static_len() > 300);
}

#[test]
fn bad_transforms_stay_out_until_valid_again() {
    let mut app = app();
    let good = app
        .world_mut()
        .spawn((Transform::default(), unit_aabb()))
        .id();
    let nan = app
        .world_mut()
        .spawn((Transform::from_xyz(f32::NAN, 0.0, 0.0), unit_aabb()))
        .id();
    let flat = app
        .world_mut()
        .spawn((Transform::from_scale(Vec3::new(1.0, 0.0, 1.0)), unit_aabb()))
        .id();
    app.update();
    {
        let trees = app.world().resource::<AccelTrees>();
        assert!(trees.contains(good) && !trees.contains(nan) && !trees.contains(flat));
        assert_eq!(app.world().resource::<AccelStats>().rejected, 2);
    }
    check_consistency(&mut app);
    // The good one goes bad, the bad ones get fixed.
    app.world_mut()
        .get_mut::<Transform>(good)
        .unwrap()
        .translation
        .y = f32::INFINITY;
    app.world_mut()
        .get_mut::<Transform>(nan)
        .unwrap()
        .translation
        .x = 1.0;
    app.world_mut().get_mut::<Transform>(flat).unwrap().scale = Vec3::ONE;
    app.update();
    let trees = app.world().resource::<AccelTrees>();
    assert!(!trees.contains(good) && trees.contains(nan) && trees.contains(flat));
    check_consistency(&mut app);
}

#[test]
fn bounds_the_tree_cannot_hold_stay_out_until_they_fit_again() {
    // A finite box so close to the float range's end that its fat box overflows: the
    // transform is valid, the dynamic tree refuses the box. The entity is reported like a bad
    // transform (counted once among the rejected, however often it moves) and comes back
    // once its box fits.
    let mut app = app();
    let far = Transform::from_xyz(3.0e38, 0.0, 0.0).with_scale(Vec3::new(7.6e37, 1.0, 1.0));
    let e = app.world_mut().spawn((far, unit_aabb())).id();
    app.update();
    for frame in 0..3 {
        let trees = app.world().resource::<AccelTrees>();
        assert!(!trees.contains(e), "frame {frame}");
        assert_eq!(
            app.world().resource::<AccelStats>().rejected,
            1,
            "frame {frame}"
        );
        app.world_mut()
            .get_mut::<Transform>(e)
            .unwrap()
            .translation
            .y += 1.0;
        app.update();
    }
    *app.world_mut().get_mut::<Transform>(e).unwrap() = Transform::from_xyz(1.0, 2.0, 3.0);
    app.update();
    assert!(app.world().resource::<AccelTrees>().contains(e));
    assert_eq!(app.world().resource::<AccelStats>().rejected, 0);
    check_consistency(&mut app);
    // A tracked entity moving out of range is taken out, counted as removed and rejected.
    *app.world_mut().get_mut::<Transform>(e).unwrap() = far;
    app.update();
    assert!(!app.world().resource::<AccelTrees>().contains(e));
    let stats = app.world().resource::<AccelStats>();
    assert_eq!((stats.removed, stats.rejected), (1, 1));
    bvh(app.world().resource::<AccelTrees>())
        .validate()
        .unwrap();
}

#[test]
fn a_frame_with_no_changes_does_no_tree_work() {
    let mut app = app();
    for i in 0..1000 {
        let mut e = app
            .world_mut()
            .spawn((Transform::from_xyz(i as f32, 0.0, 0.0), unit_aabb()));
        if i % 2 == 0 {
            e.insert(AccelStatic);
        }
    }
    app.update();
    app.update();
    let stats = app.world().resource::<AccelStats>().clone();
    assert_eq!((stats.inserted, stats.updated, stats.removed), (0, 0, 0));
    assert!(!stats.static_rebuilt);
    assert_eq!(stats.dynamic_entities + stats.static_entities, 1000);
    assert!(!bvh(app.world().resource::<AccelTrees>()).needs_refit());
}

#[test]
fn rays_find_entities_through_both_trees() {
    let mut app = app();
    let near = app
        .world_mut()
        .spawn((Transform::from_xyz(0.0, 0.0, -5.0), unit_aabb()))
        .id();
    let far = app
        .world_mut()
        .spawn((
            Transform::from_xyz(0.0, 0.0, -9.0),
            unit_aabb(),
            AccelStatic,
        ))
        .id();
    app.update();
    let trees = app.world().resource::<AccelTrees>();
    let ray = bevy_accel::spatial_accel::Ray::new(Vec3A::ZERO, Vec3A::NEG_Z);
    let mut hits = Vec::new();
    trees.query().cast_ray_all(
        &ray,
        |s, r| r.intersect_aabb(&trees.world_bounds(s)),
        &mut hits,
    );
    let order: Vec<Entity> = hits
        .iter()
        .map(|h| trees.entity(h.primitive).unwrap())
        .collect();
    assert_eq!(order, vec![near, far]);
}

#[test]
fn unwatched_static_entities_keep_their_box_until_remarked() {
    let mut app = app();
    let e = app
        .world_mut()
        .spawn((Transform::default(), unit_aabb(), AccelStatic))
        .id();
    app.update();
    let before = app
        .world()
        .resource::<AccelTrees>()
        .location(e)
        .map(|(s, _)| s)
        .unwrap();
    let box_before = app.world().resource::<AccelTrees>().world_bounds(before);
    app.world_mut()
        .get_mut::<Transform>(e)
        .unwrap()
        .translation
        .x = 10.0;
    app.update();
    assert_eq!(
        app.world().resource::<AccelTrees>().world_bounds(before),
        box_before
    );
    // Re-inserting the marker re-reads the box.
    app.world_mut().entity_mut(e).insert(AccelStatic);
    app.update();
    check_consistency(&mut app);
}

#[test]
fn a_new_static_build_strategy_rebuilds_the_static_tree_once() {
    let mut app = App::new();
    let settings = AccelSettings {
        static_rebuild_in_frame_up_to: usize::MAX,
        ..Default::default()
    };
    app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin { settings }));
    let mut rng = Rng::new(41);
    for _ in 0..500 {
        app.world_mut().spawn((
            Transform::from_translation(rng.vec3(-50.0, 50.0)),
            unit_aabb(),
            AccelStatic,
        ));
    }
    app.update();
    let hits = |app: &App| {
        let trees = app.world().resource::<AccelTrees>();
        let mut out = Vec::new();
        for k in 0..50 {
            let ray = bevy_accel::spatial_accel::Ray::new(
                Vec3A::new(k as f32 * 2.0 - 50.0, -60.0, 0.0),
                Vec3A::new(0.01, 1.0, 0.02),
            );
            let mut hits = Vec::new();
            trees.query().cast_ray_all(
                &ray,
                |s, r| r.intersect_aabb(&trees.world_bounds(s)),
                &mut hits,
            );
            out.extend(hits.iter().map(|h| trees.entity(h.primitive).unwrap()));
        }
        out
    };
    let before = hits(&app);
    assert!(!before.is_empty());
    app.update();
    assert!(!app.world().resource::<AccelStats>().static_rebuilt);
    for build in StaticTreeBuild::ALL.into_iter().skip(1) {
        app.world_mut().resource_mut::<AccelSettings>().static_build = build;
        app.update();
        assert!(
            app.world().resource::<AccelStats>().static_rebuilt,
            "{build:?} rebuilt the tree"
        );
        app.update();
        assert!(!app.world().resource::<AccelStats>().static_rebuilt);
        assert_eq!(hits(&app), before, "{build:?} finds the same entities");
        check_consistency(&mut app);
    }
}
