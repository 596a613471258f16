//! The trees stepping aside in a small world that only culling uses
//! (`AccelSettings::step_aside_below`, `AccelTrees::stepped_aside`), or where Bevy's culling is
//! timed cheaper, and the busy movers' moves left unwritten while no view reads them
//! (`AccelSettings::skip_unread_mover_upkeep`): the culling stays Bevy's through the step
//! aside and back, the trees catch up with every spawn, move and despawn made while they
//! stood still, and a reader keeps them current.

use bevy::camera::primitives::Frustum;
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

/// Bevy's app and ours over the same grid, with a camera looking into it, and the same
/// churn applied to both each frame.
struct Twins {
    bevy: (App, Vec<Entity>, Vec<bool>),
    accel: (App, Vec<Entity>, Vec<bool>),
    rng: Rng,
}

impl Twins {
    /// Twins whose trees step aside by size alone.
    fn new(step_aside_below: usize, seed: u64) -> Self {
        Self::with(step_aside_below, false, seed)
    }

    fn with(step_aside_below: usize, step_aside_when_slower: bool, seed: u64) -> Self {
        Self::configured(seed, |settings| {
            settings.step_aside_below = step_aside_below;
            settings.step_aside_when_slower = step_aside_when_slower;
        })
    }

    /// Twins whose settings `configure` sets (from the tests' own: trees kept current).
    fn configured(seed: u64, configure: impl Fn(&mut AccelSettings)) -> Self {
        let make = |ours: bool| {
            let mut app = app(ours);
            app.init_resource::<ChangedVisibility>()
                .add_systems(Last, record_changed_visibility);
            if ours {
                configure(&mut app.world_mut().resource_mut::<AccelSettings>());
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
            let live = vec![true; entities.len()];
            (app, entities, live)
        };
        Self {
            bevy: make(false),
            accel: make(true),
            rng: Rng::from_state(seed),
        }
    }

    /// One frame of churn in both apps, checked culled alike; whether ours stood aside.
    fn churned_frame(&mut self, frame: usize) -> bool {
        let c = churn(&mut self.rng, &self.bevy.2);
        for (app, entities, live) in [&mut self.bevy, &mut self.accel] {
            apply(app, entities, live, &c);
            app.update();
        }
        self.checked(frame)
    }

    /// One frame in which every live entity moves a little, the same in both apps, checked
    /// culled alike; whether ours stood aside.
    fn swarming_frame(&mut self, frame: usize) -> bool {
        for (app, entities, live) in [&mut self.bevy, &mut self.accel] {
            let world = app.world_mut();
            for (i, (&e, &l)) in entities.iter().zip(live.iter()).enumerate() {
                if l {
                    let phase = (frame + i) as f32 * 0.37;
                    world.get_mut::<Transform>(e).unwrap().translation +=
                        Vec3::new(phase.sin(), phase.cos(), (phase * 0.5).sin()) * 0.2;
                }
            }
            app.update();
        }
        self.checked(frame)
    }

    /// Checks that both apps culled alike in `frame`; whether ours stood aside.
    fn checked(&mut self, frame: usize) -> bool {
        assert_culled_alike(
            (&mut self.bevy.0, &self.bevy.1),
            (&mut self.accel.0, &self.accel.1),
            frame,
        );
        self.stepped_aside()
    }

    /// Points both apps' camera at `frustum`.
    fn look(&mut self, frustum: Frustum) {
        for (app, ..) in [&mut self.bevy, &mut self.accel] {
            let world = app.world_mut();
            let mut cameras = world.query_filtered::<&mut Frustum, With<Camera>>();
            *cameras.single_mut(world).unwrap() = frustum;
        }
    }

    fn stats(&self) -> &AccelStats {
        self.accel.0.world().resource::<AccelStats>()
    }

    fn stepped_aside(&self) -> bool {
        self.accel
            .0
            .world()
            .resource::<AccelTrees>()
            .stepped_aside()
    }

    /// A reader appears (a system with `AccelSpatialQuery`): the trees wake in its first
    /// frame and hold the world as it is now.
    fn wake_for_a_reader(&mut self) {
        self.accel
            .0
            .world_mut()
            .run_system_once(|q: AccelSpatialQuery| q.trees().stepped_aside())
            .unwrap();
        self.accel.0.update();
        assert!(!self.stepped_aside());
        self.assert_trees_hold();
    }

    /// Our trees hold exactly the live entities, each with its current world box.
    fn assert_trees_hold(&mut self) {
        let (app, entities, live) = &mut self.accel;
        let trees = app.world().resource::<AccelTrees>();
        let expected = live.iter().filter(|&&l| l).count();
        assert_eq!(trees.len(), expected, "tracked count");
        for (&e, &l) in entities.iter().zip(live.iter()) {
            assert_eq!(trees.contains(e), l, "{e} held");
        }
        common::check_consistency(app);
    }
}

#[test]
fn a_small_world_steps_aside_culls_as_bevy_and_catches_up() {
    let mut twins = Twins::new(5_000, 0x57e9_a51d);
    let stepped_aside_frames = (0..SETTLE + 60)
        .filter(|&frame| twins.churned_frame(frame))
        .count();
    assert!(
        stepped_aside_frames >= 60,
        "stood aside {stepped_aside_frames} frames"
    );
    twins.wake_for_a_reader();
    for frame in 0..SETTLE + 10 {
        assert!(
            !twins.churned_frame(frame),
            "frame {frame}: aside with a reader"
        );
    }
    twins.assert_trees_hold();
}

#[test]
fn a_world_that_grows_past_the_threshold_wakes_the_trees() {
    let mut twins = Twins::new(600, 0x9a0_77e5);
    for _ in 0..SETTLE {
        twins.bevy.0.update();
        twins.accel.0.update();
    }
    assert!(twins.stepped_aside());
    // 512 entities and 3 a frame: past 600 within 30 frames.
    let mut woke_at = None;
    for frame in 0..40 {
        let aside = twins.churned_frame(frame);
        if !aside && woke_at.is_none() {
            woke_at = Some(frame);
        }
        assert!(
            woke_at.is_none() || !aside,
            "frame {frame}: stepped aside again above the threshold"
        );
    }
    assert!(woke_at.is_some(), "never woke");
    twins.assert_trees_hold();
}

#[test]
fn zero_keeps_the_trees_current() {
    let mut twins = Twins::new(0, 1);
    for frame in 0..SETTLE * 2 {
        assert!(!twins.churned_frame(frame));
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
    let Twins {
        accel: (mut accel, b, _),
        ..
    } = Twins::new(5_000, 2);
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

/// Measured, not by size: in a world whose every entity moves every frame, the trees' upkeep
/// costs several times Bevy's pass, so probe frames (both passes, timed) step the trees aside
/// and trials wake them now and then. The culling is Bevy's in every frame of it: the trees'
/// own, the probes' double passes, the aside frames and the trials' catch-ups; a reader then
/// wakes the trees holding the world as it is.
#[test]
fn timed_cheaper_bevy_passes_step_the_trees_aside_at_any_size() {
    let mut twins = Twins::with(0, true, 0x7140_a51d);
    // Movers kept in the BVH, every one reinserted or refit each frame: several times the
    // cost of Bevy's test of the same entities.
    twins
        .accel
        .0
        .world_mut()
        .resource_mut::<AccelSettings>()
        .busy_movers
        .mode = BusyMovers::Off;
    let verdicts: Vec<bool> = (0..600).map(|frame| twins.swarming_frame(frame)).collect();
    let probe = twins
        .accel
        .0
        .world()
        .resource::<AccelTrees>()
        .last_step_aside_probe()
        .expect("probed");
    assert!(probe.trees > probe.bevy, "{probe:?}");
    let first_aside = verdicts
        .iter()
        .position(|&aside| aside)
        .unwrap_or_else(|| panic!("never stepped aside; last probe {probe:?}"));
    let woken_after = verdicts[first_aside..]
        .iter()
        .filter(|&&aside| !aside)
        .count();
    assert!(woken_after > 0, "no trial woke the trees");
    twins.wake_for_a_reader();
    for frame in 0..SETTLE + 40 {
        assert!(!twins.swarming_frame(600 + frame), "aside with a reader");
    }
    twins.assert_trees_hold();
}

/// Measured, the other way: a world of still entities and a narrow view, where Bevy's pass
/// tests every entity and the trees only the few in view, is probed and never steps aside.
#[test]
fn timed_dearer_bevy_passes_keep_the_trees_awake() {
    let mut app = app(true);
    {
        let mut settings = app.world_mut().resource_mut::<AccelSettings>();
        settings.step_aside_below = 0;
        settings.step_aside_when_slower = true;
    }
    spawn_grid(app.world_mut(), 32, 0.4, |_, _| {});
    // A narrow view into one corner of the grid.
    app.world_mut().spawn((
        Camera::default(),
        Transform::default(),
        frustum(Vec3::splat(-20.0), Vec3::ZERO, 0.05),
    ));
    for frame in 0..300 {
        app.update();
        assert!(
            !app.world().resource::<AccelTrees>().stepped_aside(),
            "frame {frame}: stepped aside, last probe {:?}",
            app.world().resource::<AccelTrees>().last_step_aside_probe()
        );
    }
    let probe = app
        .world()
        .resource::<AccelTrees>()
        .last_step_aside_probe()
        .expect("probed");
    assert!(probe.bevy > probe.trees, "{probe:?}");
}

/// Under a camera that sees most of the world, every view takes the flat pass, which gives
/// the busy movers Bevy's own test: their moves are left unwritten, and the culling is Bevy's
/// all the same, through spawns and despawns. The camera turns to a narrow view: the trees
/// write every busy mover's box and walk again. Back to the wide view, and a reader appears:
/// it finds every entity where it is.
#[test]
fn busy_moves_no_view_reads_are_left_unwritten_and_caught_up() {
    let mut twins = Twins::configured(0x5c1b_b05e, |settings| {
        settings.step_aside_below = 0;
        settings.step_aside_when_slower = false;
        settings.skip_unread_mover_upkeep = true;
    });
    let wide = frustum(Vec3::new(-40.0, 40.0, -40.0), Vec3::splat(14.0), 1.4);
    let narrow = frustum(Vec3::splat(-20.0), Vec3::ZERO, 0.05);
    let mut frame = 0;
    let mut run = |twins: &mut Twins, frames: usize| {
        let mut skipped = 0;
        for _ in 0..frames {
            if frame % 5 == 4 {
                twins.churned_frame(frame);
            } else {
                twins.swarming_frame(frame);
            }
            assert!(!twins.stepped_aside(), "frame {frame}");
            skipped += usize::from(twins.stats().busy_moves_skipped > 0);
            frame += 1;
        }
        skipped
    };
    twins.look(wide);
    let skipped = run(&mut twins, 60);
    assert!(
        twins.stats().busy_movers > 100,
        "the movers are busy movers"
    );
    assert!(skipped > 40, "moves skipped in {skipped} of 60 frames");
    let trees = twins.accel.0.world().resource::<AccelTrees>();
    assert!(!trees.busy_movers_current());
    twins.look(narrow);
    run(&mut twins, 3);
    let skipped = run(&mut twins, 20);
    assert_eq!(skipped, 0, "a narrow view reads the busy movers");
    let culling = twins.accel.0.world().resource::<CullingStats>();
    assert_eq!(culling.flat_views, 0, "the narrow view walks the trees");
    twins.look(wide);
    let skipped = run(&mut twins, 30);
    assert!(skipped > 20, "moves skipped in {skipped} of 30 frames");
    twins.wake_for_a_reader();
    assert!(
        twins
            .accel
            .0
            .world()
            .resource::<AccelTrees>()
            .busy_movers_current()
    );
    for _ in 0..10 {
        twins.swarming_frame(frame);
        assert_eq!(
            twins.stats().busy_moves_skipped,
            0,
            "frame {frame}: a reader"
        );
        frame += 1;
    }
    twins.assert_trees_hold();
}
