//! Scenery streaming: frames that despawn and spawn static (`AccelStatic`) boxes in a large
//! static level, against plain Bevy doing the same, each `App::update` timed whole. Absorbs
//! the former `benches/scenery.rs`.
//!
//! - *bevy*: plain Bevy (no bevy_accel) with one camera, culled by Bevy's own pass;
//! - *accel*: `AccelPlugin` and `AccelCullingPlugin` with the default settings: the static
//!   tree is rebuilt off the frame once the level is larger than
//!   `AccelSettings::static_rebuild_in_frame_up_to`;
//! - *accel/in-frame*: the same with every rebuild in the frame that changes the set (the
//!   behaviour before builds moved off the frame).
//!
//! Each frame, before the timed update, every app despawns `k` of its boxes and spawns as
//! many at random places (the same in every app). The apps are updated in turn, so the
//! machine's slow phases fall on all of them. "Worst over bevy" is a contender's worst frame
//! less plain Bevy's median: the stall a streaming frame adds (its target: BENCHMARKS.md,
//! Static scenery streaming). The loading frame, every box new, is a note.
//!
//! Points: the median frame against that stall. Checks: after the frames, each accel app
//! tracks exactly the live boxes (an entity lost or kept after despawn is a leak in the
//! failure rows).

use super::point;
use crate::json::{Point, Report, StressRow};
use crate::progress::Progress;
use crate::timing::median;
use accel_testkit::Rng;
use accel_testkit::bevy_apps::plain_bevy_app;
use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::VisibilityClass;
use bevy::math::primitives::ViewFrustum;
use bevy::prelude::*;
use bevy_accel::AccelCullingPlugin;
use bevy_accel::prelude::*;
use std::any::TypeId;
use std::time::{Duration, Instant};

/// The visibility class of the scene's boxes (Bevy culls per class).
#[derive(Component, Default)]
struct Drawable;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Contender {
    Bevy,
    Accel,
    AccelInFrame,
}

impl Contender {
    const ALL: [Self; 3] = [Self::Bevy, Self::Accel, Self::AccelInFrame];

    fn label(self) -> &'static str {
        match self {
            Self::Bevy => "bevy",
            Self::Accel => "accel",
            Self::AccelInFrame => "accel/in-frame",
        }
    }
}

/// The sizes of one run.
struct Sizes {
    entities: &'static [usize],
    streams: &'static [usize],
    frames: usize,
}

const FULL: Sizes = Sizes {
    entities: &[4_096, 100_000, 1_000_000],
    streams: &[1, 1_000],
    frames: 40,
};

const QUICK: Sizes = Sizes {
    entities: &[4_096],
    streams: &[1, 100],
    frames: 6,
};

/// One app with its level: the live static boxes, and the generator that places newcomers
/// and picks leavers (seeded alike in every app, so all stream the same scenery).
struct Level {
    app: App,
    live: Vec<Entity>,
    rng: Rng,
    side: f32,
    class: VisibilityClass,
    /// The first update, which takes the whole level in: a loading frame.
    load: Duration,
}

impl Level {
    fn new(contender: Contender, n: usize) -> Self {
        let mut app = plain_bevy_app();
        let static_rebuild_in_frame_up_to = match contender {
            Contender::AccelInFrame => usize::MAX,
            _ => AccelSettings::default().static_rebuild_in_frame_up_to,
        };
        if contender != Contender::Bevy {
            app.add_plugins((
                AccelPlugin {
                    settings: AccelSettings {
                        static_rebuild_in_frame_up_to,
                        // The trees' streaming is what is timed, at 4,096 entities too.
                        step_aside_below: 0,
                        step_aside_when_slower: false,
                        skip_unread_mover_upkeep: false,
                        ..default()
                    },
                },
                AccelCullingPlugin,
            ));
        }
        app.finish();
        let mut class = VisibilityClass::default();
        class.push(TypeId::of::<Drawable>());
        let side = (n as f32).sqrt().ceil() * 4.0;
        let mut level = Self {
            app,
            live: Vec::with_capacity(n),
            rng: Rng::new(0x5ce7e),
            side,
            class,
            load: Duration::ZERO,
        };
        for _ in 0..n {
            level.spawn_one();
        }
        let (transform, frustum) = strategy_camera(side);
        level
            .app
            .world_mut()
            .spawn((Camera::default(), transform, frustum));
        let start = Instant::now();
        level.app.update();
        level.load = start.elapsed();
        level
    }

    fn spawn_one(&mut self) {
        let at = Vec3::new(
            self.rng.range(0.0, self.side),
            self.rng.range(0.5, 1.5),
            self.rng.range(0.0, self.side),
        );
        let e = self.app.world_mut().spawn((
            Transform::from_translation(at),
            Visibility::Visible,
            self.class.clone(),
            Drawable,
            Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
            AccelStatic,
        ));
        self.live.push(e.id());
    }

    /// Streams `k` boxes out and `k` in, then times one update.
    fn stream_frame(&mut self, k: usize) -> Duration {
        for _ in 0..k {
            let i = self.rng.next_u32() as usize % self.live.len();
            let e = self.live.swap_remove(i);
            self.app.world_mut().despawn(e);
        }
        for _ in 0..k {
            self.spawn_one();
        }
        let start = Instant::now();
        self.app.update();
        start.elapsed()
    }

    /// Live boxes the trees do not hold, plus entities the trees hold that are not live.
    fn tracking_errors(&self) -> u64 {
        let Some(trees) = self.app.world().get_resource::<AccelTrees>() else {
            return 0;
        };
        let missing = self.live.iter().filter(|&&e| !trees.contains(e)).count();
        let extra = trees.len().saturating_sub(self.live.len() - missing);
        (missing + extra) as u64
    }
}

/// Above the field's centre looking straight down, about 2% of the field in view (as in the
/// frame suite's strategy camera).
fn strategy_camera(side: f32) -> (Transform, Frustum) {
    let aspect = 16.0 / 9.0;
    let height = (0.02f32 / 1.219).sqrt() * side;
    let eye = Vec3::new(side / 2.0, height, side / 2.0);
    let transform = Transform::from_translation(eye).looking_at(eye - Vec3::Y, Vec3::NEG_Z);
    let proj = Mat4::perspective_rh(45f32.to_radians(), aspect, 0.1, side * 4.0);
    let view = transform.to_matrix().inverse();
    (
        transform,
        Frustum(ViewFrustum::from_clip_from_world(&(proj * view))),
    )
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let sizes = if quick { QUICK } else { FULL };
    let mut progress = Progress::new("scenery", sizes.entities.len() * sizes.streams.len() + 1);
    let mut points: Vec<Point> = Vec::new();
    let mut notes = Vec::new();
    let mut stress = Vec::new();
    let mut markdown = vec![
        "| static entities | streamed per frame | bevy median | accel median | in-frame median \
         | accel worst over bevy | in-frame worst over bevy | static trees swapped in |"
            .to_string(),
        "|---:|---:|---:|---:|---:|---:|---:|---:|".to_string(),
    ];
    for &n in sizes.entities {
        for &k in sizes.streams {
            progress.step(&format!("{n} static, {k} streamed per frame"));
            let mut levels: Vec<Level> = Contender::ALL.iter().map(|&c| Level::new(c, n)).collect();
            notes.push(format!(
                "{n} static: loading frame {}",
                levels
                    .iter()
                    .zip(Contender::ALL)
                    .map(|(l, c)| format!("{} {:.1} ms", c.label(), ms(l.load)))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
            let mut times = vec![Vec::with_capacity(sizes.frames); levels.len()];
            let mut swaps = [0usize; 3];
            for _ in 0..sizes.frames {
                for ((level, t), swapped) in levels.iter_mut().zip(&mut times).zip(&mut swaps) {
                    t.push(ms(level.stream_frame(k)));
                    if let Some(stats) = level.app.world().get_resource::<AccelStats>() {
                        *swapped += usize::from(stats.static_rebuilt);
                    }
                }
            }
            let summary: Vec<(f64, f64)> = times
                .into_iter()
                .map(|t| {
                    let worst = t.iter().copied().fold(0.0, f64::max);
                    (median(t), worst)
                })
                .collect();
            let bevy_median = summary[0].0;
            let over = |c: usize| (summary[c].1 - bevy_median).max(0.0);
            markdown.push(format!(
                "| {n} | {k} | {:.2} ms | {:.2} ms | {:.2} ms | {:.2} ms | {:.2} ms | {} |",
                summary[0].0,
                summary[1].0,
                summary[2].0,
                over(1),
                over(2),
                swaps[1]
            ));
            let scene = format!("{n} static, {k} streamed per frame");
            for (c, contender) in Contender::ALL.iter().enumerate() {
                points.push(point(
                    &scene,
                    contender.label(),
                    "",
                    ("median ms per frame", summary[c].0),
                    ("worst frame over bevy's median, ms", Some(over(c))),
                ));
            }
            for (level, contender) in levels.iter().zip(Contender::ALL).skip(1) {
                stress.push(StressRow {
                    structure: format!("plugin, {}", contender.label()),
                    query: format!("tracking while streaming ({n} static, {k} a frame)"),
                    cases: (sizes.frames * k * 2) as u64,
                    leaks: level.tracking_errors(),
                    ..StressRow::default()
                });
            }
        }
    }
    progress.step("done");
    progress.finish();
    Report {
        suite: "scenery".into(),
        quick,
        points,
        markdown,
        notes,
        stress,
        ..Report::default()
    }
}
