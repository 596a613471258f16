//! The movers' index chosen and switched at run time: the automatic choice against the
//! workload it sees, and a switch filled off the frame, the trees checked against the ECS
//! after every frame.

use bevy::prelude::*;
use bevy_accel::TreeSlot;
use bevy_accel::prelude::*;

mod common;
use accel_testkit::Rng;
use common::{check_consistency, trees_app_with_cubes, unit_aabb};

/// An app choosing its index automatically (deciding within 3 frames), with `busy` movers'
/// settings, over 1,000 entities; `moving_for` frames half of them move, then all stand
/// still. Returns the app and the indexes it went through, in order.
fn automatic_choice_over_movers(
    busy: BusyMoverSettings,
    moving_for: usize,
) -> (App, Vec<IndexChoice>) {
    let settings = AccelSettings {
        index: IndexChoice::Automatic,
        automatic: AutomaticIndexSettings {
            min_entities: 100,
            hold_frames: 3,
            frames_between_switches: 0,
            ..default()
        },
        busy_movers: busy,
        ..default()
    };
    let (mut app, entities, mut rng) = trees_app_with_cubes(settings, 1_000, 11);
    let mut seen = Vec::new();
    // The choice reads each frame's figures at the end of its maintenance; the next frame
    // switches to what it recommends.
    let mut recommended = IndexChoice::Bvh;
    for frame in 0..2 * moving_for {
        if frame < moving_for {
            for &e in entities.iter().step_by(2) {
                let world = app.world_mut();
                world.get_mut::<Transform>(e).unwrap().translation += rng.vec3(-1.0, 1.0);
            }
        }
        app.update();
        check_consistency(&mut app);
        let stats = app.world().resource::<AccelStats>();
        let automatic = stats.automatic.expect("figures while automatic");
        assert_eq!(stats.index, recommended, "frame {frame}");
        recommended = automatic.recommended;
        if seen.last() != Some(&stats.index) {
            seen.push(stats.index);
        }
    }
    (app, seen)
}

#[test]
fn the_automatic_choice_takes_the_grid_for_many_movers_and_the_bvh_back_when_calm() {
    // Every mover through the index (no busy movers' list).
    let off = BusyMoverSettings {
        mode: BusyMovers::Off,
        ..default()
    };
    let (mut app, seen) = automatic_choice_over_movers(off, 40);
    assert_eq!(
        seen,
        [IndexChoice::Bvh, IndexChoice::Grid, IndexChoice::Bvh]
    );
    // A fixed choice clears the automatic figures and is kept whatever moves.
    app.world_mut().resource_mut::<AccelSettings>().index = IndexChoice::Octree;
    app.update();
    let stats = app.world().resource::<AccelStats>();
    assert_eq!((stats.index, stats.automatic), (IndexChoice::Octree, None));
}

#[test]
fn the_automatic_choice_keeps_the_bvh_when_the_busy_list_takes_every_mover() {
    // The movers' first frame goes through the index (the list starts the frame after), and
    // joining the list counts as a move: neither is the index's lasting work, so the grid is
    // never chosen for an index left with still entities only.
    let (app, seen) = automatic_choice_over_movers(default(), 40);
    assert_eq!(seen, [IndexChoice::Bvh]);
    assert_eq!(app.world().resource::<AccelTrees>().busy_len(), 0);
    // Nor while the list fills over several frames, its movers moving through the index
    // until their turn to join comes.
    let slow_fill = BusyMoverSettings {
        transfers_per_frame: 60,
        ..default()
    };
    let (_, seen) = automatic_choice_over_movers(slow_fill, 40);
    assert_eq!(seen, [IndexChoice::Bvh]);
}

#[test]
fn a_large_index_switch_is_filled_off_the_frame_and_lands_up_to_date() {
    let mut settings = AccelSettings {
        index_switch_in_frame_up_to: 100,
        static_rebuild_in_frame_up_to: 0,
        ..default()
    };
    // Every mover through the index being switched (the busy movers' list would keep them
    // out of it).
    settings.busy_movers.mode = BusyMovers::Off;
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin { settings }));
    let mut rng = Rng::from_state(5);
    let mut live: Vec<Entity> = Vec::new();
    let spawn = |app: &mut App, rng: &mut Rng, is_static: bool| {
        let t = Transform::from_translation(rng.vec3(-80.0, 80.0));
        let mut e = app.world_mut().spawn((t, unit_aabb()));
        if is_static {
            e.insert(AccelStatic);
        }
        e.id()
    };
    for i in 0..3_000 {
        live.push(spawn(&mut app, &mut rng, i % 10 == 0));
    }
    app.update();
    for target in [IndexChoice::Grid, IndexChoice::Octree, IndexChoice::Bvh] {
        app.world_mut().resource_mut::<AccelSettings>().index = target;
        let mut frames_in_flight = 0;
        for frame in 0..200 {
            // Motion, arrivals (some static, which wait in the dynamic index while the
            // static tree is rebuilt off the frame) and departures while the fill runs.
            for _ in 0..300 {
                let e = live[rng.below(live.len())];
                // Static entities promise not to move (and are not watched here).
                if app.world().get::<AccelStatic>(e).is_some() {
                    continue;
                }
                if let Some(mut t) = app.world_mut().get_mut::<Transform>(e) {
                    t.translation += rng.vec3(-3.0, 3.0);
                }
            }
            for i in 0..20 {
                live.push(spawn(&mut app, &mut rng, i % 4 == 0));
            }
            for _ in 0..10 {
                let e = live.swap_remove(rng.below(live.len()));
                app.world_mut().despawn(e);
            }
            app.update();
            check_consistency(&mut app);
            let trees = app.world().resource::<AccelTrees>();
            let in_dynamic = trees
                .iter()
                .filter(|(e, _)| trees.location(*e).unwrap().1 != TreeSlot::Static)
                .count();
            assert_eq!(trees.query().dynamic_len(), in_dynamic, "{target:?}");
            if trees.index_switch_in_flight() {
                frames_in_flight += 1;
            } else if app.world().resource::<AccelStats>().index == target && frame > 0 {
                break;
            }
        }
        let stats = app.world().resource::<AccelStats>();
        assert_eq!(stats.index, target);
        // The first frame starts the fill; the old index served at least that frame.
        assert!(frames_in_flight >= 1, "{target:?} switched in the frame");
    }
}
