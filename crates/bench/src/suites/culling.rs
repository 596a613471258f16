//! Frustum culling: Bevy's `check_visibility_cpu_culling` against `AccelCullingPlugin`, two
//! apps over the same static grid of entities with the same view, updated in turn. Absorbs
//! the former `benches/culling.rs`.
//!
//! Views show 5%, 50% and 100% of the grid (an orthographic view down -z over a slab of it),
//! with the camera still (our culling may keep its last walk of the trees) and moving (the
//! frustum nudged inwards by 1e-4 every other frame, so no walk can be kept). Each time is the
//! culling system alone, the median over the measured frames: Bevy's from timestamps taken
//! just before and after its system (on the single-threaded executor; the system still
//! spreads its loop over the compute pool), ours from `CullingStats::time`.
//!
//! Every measured frame, each entity's `ViewVisibility` is compared between the apps: an
//! entity we show and Bevy does not is a false positive (the error of the points, as a share
//! of the entities: drawn for nothing); one Bevy shows and we do not is a false negative, a
//! wrong picture, counted as a miss in the report's failure rows, so that the tool exits
//! non-zero.

use super::headless_app;
use super::point;
use crate::json::{Point, Report, StressRow};
use crate::progress::Progress;
use crate::timing::median;
use accel_testkit::bevy_apps::grid_point;
use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::{VisibilityClass, VisibilitySystems, check_visibility_cpu_culling};
use bevy::ecs::schedule::SingleThreadedExecutor;
use bevy::math::primitives::ViewFrustum;
use bevy::prelude::*;
use bevy_accel::AccelCullingPlugin;
use bevy_accel::culling::CullingStats;
use bevy_accel::prelude::*;
use std::any::TypeId;
use std::time::{Duration, Instant};

/// At most this many false negatives are described in the report.
const SAMPLES: usize = 10;

/// The visibility class of the grid's boxes (Bevy culls per class).
#[derive(Component, Default)]
struct Drawable;

/// The time of Bevy's culling system in the last frame.
#[derive(Resource, Default)]
struct CullTimer {
    start: Option<Instant>,
    last: Duration,
}

fn start_timer(mut t: ResMut<CullTimer>) {
    t.start = Some(Instant::now());
}

fn stop_timer(mut t: ResMut<CullTimer>) {
    if let Some(s) = t.start.take() {
        t.last = s.elapsed();
    }
}

/// One contender: the app and its entities in spawn order (entity ids may differ between
/// the apps, since plugins spawn observers).
struct Contender {
    app: App,
    entities: Vec<Entity>,
}

/// `n` static entities on a cube grid 4 units apart, culled by Bevy (`ours` false, its
/// system timed) or by `AccelCullingPlugin`.
fn contender(n: usize, ours: bool) -> Contender {
    let mut app = headless_app();
    app.init_resource::<CullTimer>();
    // One thread for the schedule, so that the timer systems run right before and after
    // Bevy's, not while it runs.
    app.edit_schedule(PostUpdate, |s| {
        s.set_executor(SingleThreadedExecutor::new());
    });
    if ours {
        app.add_plugins(AccelCullingPlugin);
    } else {
        app.add_systems(
            PostUpdate,
            (
                start_timer.before(check_visibility_cpu_culling),
                stop_timer.after(check_visibility_cpu_culling),
            )
                .in_set(VisibilitySystems::CheckVisibility),
        );
    }
    app.finish();
    let side = (n as f32).cbrt().ceil() as usize;
    let mut class = VisibilityClass::default();
    class.push(TypeId::of::<Drawable>());
    let world = app.world_mut();
    let entities = world
        .spawn_batch((0..n).map(move |i| {
            (
                Transform::from_translation(grid_point(i, side)),
                Visibility::Visible,
                class.clone(),
                Drawable,
                Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
                AccelStatic,
            )
        }))
        .collect();
    world.spawn((
        Camera::default(),
        Transform::default(),
        frustum_for(1.0, side as f32 * 4.0),
    ));
    app.update();
    app.update();
    Contender { app, entities }
}

/// An orthographic view down -z over the whole grid in y and the first `fraction` of it in x.
fn frustum_for(fraction: f32, extent: f32) -> Frustum {
    let eye = Vec3::new(0.0, 0.0, extent + 10.0);
    let view = Mat4::look_at_rh(eye, eye - Vec3::Z, Vec3::Y);
    let x_max = -2.0 + (extent + 2.0) * fraction;
    let proj = Mat4::orthographic_rh(-2.0, x_max, -2.0, extent + 2.0, 0.1, extent * 3.0);
    Frustum(ViewFrustum::from_clip_from_world(&(proj * view)))
}

fn set_fraction(app: &mut App, fraction: f32, n: usize) {
    let extent = (n as f32).cbrt().ceil() * 4.0;
    let world = app.world_mut();
    let mut q = world.query_filtered::<&mut Frustum, With<Camera>>();
    for mut f in q.iter_mut(world) {
        *f = frustum_for(fraction, extent);
    }
}

fn visible_flags(c: &Contender) -> Vec<bool> {
    let world = c.app.world();
    c.entities
        .iter()
        .map(|&e| world.get::<ViewVisibility>(e).is_some_and(|v| v.get()))
        .collect()
}

/// What the measured frames of one view gave.
#[derive(Default)]
struct Measured {
    bevy_ms: Vec<f64>,
    accel_ms: Vec<f64>,
    false_positives: u64,
    false_negatives: u64,
    /// Spawn indices of the first false negatives.
    missed: Vec<usize>,
}

/// Runs `frames` frames of both apps at `fraction` (nudged every other frame when
/// `moving`), after `warm_up` frames at the same view, and compares their verdicts.
fn measure(
    bevy: &mut Contender,
    accel: &mut Contender,
    (n, fraction, moving): (usize, f32, bool),
    (warm_up, frames): (usize, usize),
) -> Measured {
    let mut out = Measured::default();
    for frame in 0..warm_up + frames {
        // Inwards: the view's edge lies on a column of boxes' faces, and an outward nudge
        // would make that whole column cross the plane.
        let nudge = if moving {
            1.0 - 1e-4 * (frame % 2) as f32
        } else {
            1.0
        };
        for c in [&mut *bevy, &mut *accel] {
            set_fraction(&mut c.app, fraction * nudge, n);
            c.app.update();
        }
        if frame < warm_up {
            continue;
        }
        let bevy_time = bevy.app.world().resource::<CullTimer>().last;
        let accel_time = accel.app.world().resource::<CullingStats>().time;
        out.bevy_ms.push(bevy_time.as_secs_f64() * 1e3);
        out.accel_ms.push(accel_time.as_secs_f64() * 1e3);
        let (theirs, ours) = (visible_flags(bevy), visible_flags(accel));
        for (i, (&b, &a)) in theirs.iter().zip(&ours).enumerate() {
            out.false_positives += u64::from(a && !b);
            if b && !a {
                out.false_negatives += 1;
                if out.missed.len() < SAMPLES {
                    out.missed.push(i);
                }
            }
        }
    }
    out
}

/// The sizes of one run.
struct Sizes {
    entities: &'static [usize],
    fractions: &'static [f32],
    warm_up: usize,
    frames: usize,
}

const FULL: Sizes = Sizes {
    entities: &[100_000, 1_000_000],
    fractions: &[0.05, 0.5, 1.0],
    // A view's first frame at a new fraction still follows the path its last fraction chose.
    warm_up: 3,
    frames: 15,
};

const QUICK: Sizes = Sizes {
    entities: &[10_000],
    fractions: &[0.05, 1.0],
    warm_up: 2,
    frames: 5,
};

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let sizes = if quick { QUICK } else { FULL };
    let mut progress = Progress::new(
        "culling",
        sizes.entities.len() * (1 + sizes.fractions.len() * 2) + 1,
    );
    let mut points: Vec<Point> = Vec::new();
    let mut notes = Vec::new();
    let mut stress = Vec::new();
    let mut samples = Vec::new();
    for &n in sizes.entities {
        progress.step(&format!("{n} entities: the apps"));
        let mut bevy = contender(n, false);
        let mut accel = contender(n, true);
        let side = (n as f32).cbrt().ceil() as usize;
        for &fraction in sizes.fractions {
            let scene = format!("{n} entities, {:.0}% in view", fraction * 100.0);
            for moving in [false, true] {
                let camera = if moving {
                    "moving camera"
                } else {
                    "still camera"
                };
                progress.step(&format!("{scene}, {camera}"));
                let m = measure(
                    &mut bevy,
                    &mut accel,
                    (n, fraction, moving),
                    (sizes.warm_up, sizes.frames),
                );
                let cases = (n * sizes.frames) as u64;
                let (bevy_ms, accel_ms) = (median(m.bevy_ms), median(m.accel_ms));
                points.push(point(
                    &scene,
                    "bevy check_visibility",
                    camera,
                    ("ms culling", bevy_ms),
                    ("false positives, % of entities", Some(0.0)),
                ));
                points.push(point(
                    &scene,
                    "AccelCullingPlugin",
                    camera,
                    ("ms culling", accel_ms),
                    (
                        "false positives, % of entities",
                        Some(100.0 * m.false_positives as f64 / cases.max(1) as f64),
                    ),
                ));
                let stats = accel.app.world().resource::<CullingStats>();
                notes.push(format!(
                    "{scene}, {camera}: bevy/accel {:.2}x; {} visible ({:.1}%), {} accepted on \
                     a tree's word, {} given Bevy's frustum test; flat pass: {} (on the \
                     trees: {}); the last frame reused its walk: {}",
                    bevy_ms / accel_ms.max(1e-6),
                    stats.visible,
                    100.0 * stats.visible as f64 / n as f64,
                    stats.accepted_by_subtree,
                    stats.tested,
                    stats.flat_views > 0,
                    stats.flat_views_on_trees > 0,
                    stats.reused_walks > 0,
                ));
                for &i in m.missed.iter().take(SAMPLES.saturating_sub(samples.len())) {
                    samples.push(format!(
                        "{scene}, {camera}: entity {i} at {} visible to Bevy, culled by us",
                        grid_point(i, side)
                    ));
                }
                stress.push(StressRow {
                    structure: "AccelCullingPlugin".into(),
                    query: format!("{scene}, {camera}: Bevy's visible set"),
                    cases,
                    misses: m.false_negatives,
                    ..StressRow::default()
                });
            }
        }
    }
    progress.step("done");
    progress.finish();
    Report {
        suite: "culling".into(),
        quick,
        points,
        notes,
        stress,
        failure_samples: samples,
        ..Report::default()
    }
}
