//! Culling on a compute pool of four threads against Bevy's own culling on the same pool:
//! many busy movers (their frustum test split across the pool, beside the trees' walk), a
//! narrow view on the tree path (its finds decided in parts) and a wide one on the flat pass;
//! the movers scattered, or in rows in spawn order (narrow runs of the busy list, which the
//! narrow view skips) with some leaping across the world and back. A process of its own, so
//! that its pool has the threads it asks for.

use bevy::camera::primitives::{Aabb, Frustum};
use bevy::prelude::*;
use bevy::tasks::{ComputeTaskPool, TaskPoolBuilder};
use bevy_accel::prelude::*;

mod common;
mod culling_scene;
use accel_testkit::Rng;
use common::headless_app;
use culling_scene::{Drawable, ViewIndex, drawable_class, frustum, visible_sets};

/// A box wobbling round `home` every frame; a leaper is across the world in frames 2 and 3.
#[derive(Component)]
struct Wobble {
    home: Vec3,
    phase: f32,
    leaps: bool,
}

/// Where the movers are.
#[derive(Clone, Copy, PartialEq)]
enum Layout {
    /// At random.
    Scattered,
    /// On a square grid in spawn order, row by row: the busy movers' runs are narrow.
    Rows,
}

#[derive(Resource, Default)]
struct Frame(f32);

fn wobble(mut frame: ResMut<Frame>, mut boxes: Query<(&Wobble, &mut Transform)>) {
    frame.0 += 1.0;
    for (w, mut t) in &mut boxes {
        let a = frame.0 * 0.3 + w.phase;
        // Out of its run's bounds, which grow round it, and back for good: the run is left
        // loose until the sweep of the runs' bounds comes round to it.
        let away = w.leaps && (2.0..=3.0).contains(&frame.0);
        t.translation = if away {
            Vec3::new(-w.home.x, 60.0, -w.home.z)
        } else {
            w.home + Vec3::new(a.sin(), 0.0, a.cos()) * 2.0
        };
    }
}

fn app(ours: bool) -> App {
    let mut app = headless_app();
    if ours {
        app.insert_resource(AccelSettings {
            busy_movers: BusyMoverSettings {
                mode: BusyMovers::On,
                ..default()
            },
            step_aside_below: 0,
            step_aside_when_slower: false,
            skip_unread_mover_upkeep: false,
            ..default()
        })
        .add_plugins(AccelCullingPlugin);
    }
    app.init_resource::<Frame>().add_systems(Update, wobble);
    app.finish();
    app
}

fn populate(app: &mut App, layout: Layout) -> Vec<Entity> {
    let mut rng = Rng::from_state(5);
    let class = drawable_class();
    let world = app.world_mut();
    let hidden = world.spawn((Transform::default(), Visibility::Hidden)).id();
    let entities = (0..24_000)
        .map(|i| {
            let home = match layout {
                Layout::Scattered => rng.vec3(-300.0, 300.0),
                Layout::Rows => Vec3::new(
                    (i % 160) as f32 * 4.0 - 320.0,
                    0.0,
                    (i / 160) as f32 * 4.0 - 300.0,
                ),
            };
            let half = Vec3::splat(rng.range(0.2, 2.0));
            let mut e = world.spawn((
                Transform::from_translation(home),
                Visibility::Inherited,
                class.clone(),
                Drawable,
                Aabb::from_min_max(-half, half),
            ));
            match i % 10 {
                0 => {
                    e.insert(AccelStatic);
                }
                1 => {
                    e.insert(ChildOf(hidden));
                }
                _ => {
                    e.insert(Wobble {
                        home,
                        phase: rng.range(0.0, 6.0),
                        leaps: layout == Layout::Rows && i % 50 == 7,
                    });
                }
            }
            e.id()
        })
        .collect();
    // A narrow view (the tree path) and one that sees most of the world (the flat pass);
    // over the rows, both look down on them.
    let (narrow, wide) = match layout {
        Layout::Scattered => (
            frustum(Vec3::new(0.0, 0.0, 320.0), Vec3::ZERO, 0.3),
            frustum(Vec3::new(0.0, 0.0, 600.0), Vec3::ZERO, 1.6),
        ),
        Layout::Rows => (
            frustum(Vec3::new(40.0, 400.0, 1.0), Vec3::new(40.0, 0.0, 0.0), 0.3),
            frustum(Vec3::new(0.0, 500.0, 1.0), Vec3::ZERO, 1.6),
        ),
    };
    world.spawn((Camera::default(), ViewIndex(0), narrow));
    world.spawn((Camera::default(), ViewIndex(1), wide));
    entities
}

/// Culls `layout` in both apps over `frames` frames, checking every frame's visible sets,
/// and returns the accel app.
fn check(layout: Layout, frames: usize) -> App {
    // Made before the apps, which then keep it (Bevy makes its pools once per process).
    let pool = ComputeTaskPool::get_or_init(|| TaskPoolBuilder::new().num_threads(4).build());
    assert_eq!(pool.thread_num(), 4);
    let (mut bevy_app, mut accel_app) = (app(false), app(true));
    let a = populate(&mut bevy_app, layout);
    let b = populate(&mut accel_app, layout);
    let mut most_busy = 0;
    let mut flat_views = 0;
    let mut decided_in_parts = 0;
    let mut kept_tree_walks = 0;
    for frame in 0..frames {
        bevy_app.update();
        accel_app.update();
        let (want, got) = (
            visible_sets(&mut bevy_app, &a).0,
            visible_sets(&mut accel_app, &b).0,
        );
        assert!(
            want[0].len() > 100 && want[1].len() > 10_000,
            "{}, {}",
            want[0].len(),
            want[1].len()
        );
        assert_eq!(want, got, "frame {frame}");
        most_busy = most_busy.max(accel_app.world().resource::<AccelStats>().busy_movers);
        let culling = accel_app.world().resource::<CullingStats>();
        flat_views += culling.flat_views;
        decided_in_parts += culling.views_decided_in_parts;
        kept_tree_walks += culling.kept_tree_walks;
    }
    assert!(most_busy > 16_384, "{most_busy} busy movers at most");
    assert!(flat_views > 0, "the wide view never took the flat pass");
    assert!(
        decided_in_parts > 0,
        "the narrow view's finds were never decided in parts"
    );
    // The cameras hold still while only busy movers move, in most frames: the narrow view
    // keeps its finds in the trees and tests the busy movers again.
    assert!(
        kept_tree_walks > 0,
        "the narrow view never kept its trees' finds"
    );
    accel_app
}

#[test]
fn busy_movers_culled_on_four_threads_equal_bevys() {
    let _ = check(Layout::Scattered, 8);
}

/// Movers in rows give the busy movers' list narrow runs, which the narrow view skips whole.
/// A leaper in nearly every run leaves it for two frames (the runs go stale, then are
/// recomputed round the leaper) and comes back: by the end the sweep has made them narrow
/// again.
#[test]
fn busy_movers_in_narrow_runs_that_leap_culled_as_bevy_culls_them() {
    let mut app = check(Layout::Rows, 24);
    let world = app.world_mut();
    let narrow = world
        .query::<(&ViewIndex, &Frustum)>()
        .iter(world)
        .find(|(i, _)| i.0 == 0)
        .map(|(_, f)| spatial_accel::Frustum::from_planes(f.half_spaces.map(|h| h.normal_d())))
        .unwrap();
    let busy = world.resource::<AccelTrees>().query().busy_movers();
    let skipped = busy
        .chunks()
        .filter(|c| {
            c.bounds
                .is_some_and(|b| narrow.classify_aabb(b) == spatial_accel::Containment::Outside)
        })
        .count();
    assert!(
        skipped * 2 > busy.chunk_count(),
        "the narrow view skips {skipped} of {} runs",
        busy.chunk_count()
    );
}
