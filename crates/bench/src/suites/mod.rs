//! The suites, one file (or folder) each, and what they share: the point constructor, the
//! scenes and peers' adapters of `common`, and the plugin tests' headless app (the test kit's
//! plain Bevy app with the plugin).
//!
//! `stress`, `build`, `update`, `rays`, `meshes`, `walks`, `preview`, `geometry`,
//! `structures` and `triangles` measure the core crate alone; `frame`, `culling`, `lights`,
//! `picking`, `skinned`, `selection`, `sync` and `scenery` run the plugin in headless Bevy
//! apps, against Bevy's own systems where Bevy has them.

pub mod build;
pub mod culling;
pub mod frame;
pub mod geometry;
#[cfg(feature = "light_culling")]
pub mod lights;
pub mod meshes;
pub mod picking;
pub mod preview;
pub mod rays;
pub mod rounds;
pub mod scenery;
pub mod selection;
pub mod skinned;
pub mod static_builds;
pub mod stress;
pub mod structures;
pub mod sync;
pub mod triangles;
pub mod update;
pub mod walks;

pub mod common;

use crate::Options;
use crate::json::{Point, Report};
use accel_testkit::Rng;
use accel_testkit::bevy_apps::plain_bevy_app;
use bevy::app::App;
use bevy_accel::{AccelPlugin, AccelSettings, AccelStats, AccelTrees};
use glam::Vec3A;
use spatial_accel::Ray;

/// Runs the suite named `name`.
pub fn run(name: &str, opts: &Options) -> Report {
    match name {
        "stress" => stress::run(opts.quick),
        "build" => build::run(opts.quick),
        "update" => update::run(opts.quick),
        "rays" => rays::run(opts.quick),
        "meshes" => meshes::run(opts.quick),
        "preview" => preview::run(opts.quick),
        "frame" => frame::run(opts),
        "culling" => culling::run(opts.quick),
        "picking" => picking::run(opts.quick),
        "skinned" => skinned::run(opts.quick),
        "sync" => sync::run(opts.quick),
        "scenery" => scenery::run(opts.quick),
        "selection" => selection::run(opts.quick),
        #[cfg(feature = "light_culling")]
        "lights" => lights::run(opts.quick),
        "walks" => walks::run(opts.quick),
        "geometry" => geometry::run(opts.quick),
        "structures" => structures::run(opts.quick),
        "triangles" => triangles::run(opts.quick),
        other => unreachable!("the argument parser lets only known suites through: {other}"),
    }
}

/// The test kit's plain headless Bevy app with the trees (`AccelPlugin`), as the plugin tests'
/// `headless_app`. Not finished: add the plugins under test, then call `App::finish`. The
/// trees are kept current at every size (`AccelSettings::step_aside_below` 0,
/// `step_aside_when_slower` and `skip_unread_mover_upkeep` off), so that the suites built on
/// it time the trees' passes, not Bevy's standing in for them.
pub fn headless_app() -> App {
    let mut app = plain_bevy_app();
    app.add_plugins(AccelPlugin {
        settings: AccelSettings {
            step_aside_below: 0,
            step_aside_when_slower: false,
            skip_unread_mover_upkeep: false,
            ..AccelSettings::default()
        },
    });
    app
}

/// Whether `app`'s trees are being built on a thread of their own: the dynamic tree's first
/// rebuild after the spawn (later ones are the steady state of a moving world), its ray
/// snapshot, or a static tree. On a machine of two cores such a one-off build takes one of
/// them from the frames it overlaps, so nothing is timed while it runs.
pub fn trees_building_off_frame(app: &App) -> bool {
    let trees = app.world().resource::<AccelTrees>();
    // Trees that stand aside build nothing until they wake (and a read would wake them).
    if trees.stepped_aside() {
        return false;
    }
    let first_rebuild = trees
        .dynamic_bvh()
        .is_some_and(|d| d.rebuild_count() == 0 && d.rebuild_in_flight());
    // A read of the index while the busy movers' boxes are left out of date would keep them
    // current from then on (`AccelTrees::busy_movers_current`); no ray reads them then.
    let snapshot = trees.busy_movers_current()
        && trees
            .query()
            .bvh_pair()
            .is_some_and(|pair| pair.dynamic_ray_snapshot_pending());
    first_rebuild || snapshot || app.world().resource::<AccelStats>().static_build_in_flight
}

/// Runs `app`'s frames through `update` until its trees stand as in a world that has held
/// still for a while: the dynamic tree's rebuild after the spawn installed, then still frames
/// past the point where the dynamic tree's ray snapshot is due, until no build of the trees
/// runs off the frame ([`trees_building_off_frame`]). Nothing is timed before: a tree of
/// insertions is not what a game queries a second after its spawn.
pub fn settle_still_trees(app: &mut App, mut update: impl FnMut(&mut App)) {
    let wait = |app: &mut App, update: &mut dyn FnMut(&mut App)| {
        for _ in 0..2_000 {
            if !trees_building_off_frame(app) {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
            update(app);
        }
    };
    wait(app, &mut update);
    let still_frames = app
        .world()
        .resource::<AccelSettings>()
        .bvh
        .ray_snapshot_after_stable_frames
        .unwrap_or(0);
    for _ in 0..still_frames + 2 {
        update(app);
    }
    wait(app, &mut update);
}

/// One point of a plot.
pub fn point(
    scene: &str,
    method: &str,
    setting: &str,
    time: (&str, f64),
    quality: (&str, Option<f64>),
) -> Point {
    Point {
        scene: scene.to_string(),
        method: method.to_string(),
        setting: setting.to_string(),
        time_name: time.0.to_string(),
        time: time.1,
        quality_name: quality.0.to_string(),
        quality: quality.1,
        pareto: false,
    }
}

/// Incoherent rays: origins uniform in the cube of half side `extent`, directions uniform on
/// the sphere.
pub fn incoherent_rays(n: usize, extent: f32, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| Ray::new(rng.vec3a(-extent, extent), rng.unit_vector()))
        .collect()
}

/// A pinhole camera's pixel grid in scanline order, from `eye` towards the origin: coherent
/// primary rays.
pub fn camera_rays(n: usize, eye: Vec3A) -> Vec<Ray> {
    let side = (n as f64).sqrt().ceil() as usize;
    let forward = (-eye).normalize();
    let right = forward.cross(Vec3A::Y).normalize();
    let up = right.cross(forward);
    let half = 30f32.to_radians().tan();
    (0..n)
        .map(|i| {
            let (x, y) = ((i % side) as f32, (i / side) as f32);
            let sx = (2.0 * (x + 0.5) / side as f32 - 1.0) * half;
            let sy = (1.0 - 2.0 * (y + 0.5) / side as f32) * half;
            Ray::new(eye, (forward + right * sx + up * sy).normalize())
        })
        .collect()
}
