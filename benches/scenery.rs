//! Scenery streaming: frames that spawn and despawn static entities in a large static
//! level, against plain Bevy doing the same, each `App::update` timed whole.
//!
//! - *bevy*: plain Bevy (no bevy_accel) with one camera, culled by Bevy's own pass;
//! - *accel*: `AccelPlugin` and `AccelCullingPlugin` with the default settings, every box
//!   `AccelStatic`: the static tree is rebuilt off the frame once the level is larger than
//!   `AccelSettings::static_rebuild_in_frame_up_to`;
//! - *accel/in-frame*: the same with every rebuild in the frame that changes the set (the
//!   behaviour before builds moved off the frame).
//!
//! Each frame, before the timed update, every app despawns `--stream` of its static boxes
//! and spawns as many new ones at random places (the same in every app). The table gives
//! each contender's median and worst frame, and the worst frame's excess over plain Bevy's
//! median: the stall a streaming frame adds.
//!
//! `cargo bench --workspace --profile dev --bench scenery -- [--entities 4096,100000,1000000]
//! [--stream 1,1000] [--frames 60] [--trace]`
//!
//! The loading frame (the first update, with every box new) is printed on stderr.
//! `--trace` prints every frame's times on stderr, with the frames that swapped a static tree
//! in marked, and the plugin's sync and culling times.

use accel_testkit::Rng;
use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::{VisibilityClass, VisibilityPlugin};
use bevy::math::primitives::ViewFrustum;
use bevy::prelude::*;
use bevy_accel::AccelCullingPlugin;
use bevy_accel::culling::CullingStats;
use bevy_accel::prelude::*;
use std::any::TypeId;
use std::time::{Duration, Instant};

#[path = "bench_args/mod.rs"]
mod bench_args;
use bench_args::list;

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
        let mut app = App::new();
        app.add_plugins((
            MinimalPlugins,
            AssetPlugin::default(),
            TransformPlugin,
            VisibilityPlugin,
        ))
        .init_asset::<Mesh>()
        .init_asset::<bevy::mesh::skinning::SkinnedMeshInverseBindposes>();
        let static_rebuild_in_frame_up_to = match contender {
            Contender::AccelInFrame => usize::MAX,
            _ => AccelSettings::default().static_rebuild_in_frame_up_to,
        };
        if contender != Contender::Bevy {
            app.add_plugins((
                AccelPlugin {
                    settings: AccelSettings {
                        static_rebuild_in_frame_up_to,
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
        if let Some(stats) = level.app.world().get_resource::<AccelStats>() {
            eprintln!(
                "loading frame: sync {:.1} ms, maintenance {:.1} ms",
                ms(stats.sync_time),
                ms(stats.maintain_time)
            );
        }
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
}

/// Above the field's centre looking straight down, about 2% of the field in view (as in the
/// frame bench's strategy camera).
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

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let sizes = list(&args, "--entities", &[4_096usize, 100_000, 1_000_000]);
    let streams = list(&args, "--stream", &[1usize, 1000]);
    let frames = list(&args, "--frames", &[60usize])[0];
    let trace = args.iter().any(|a| a == "--trace");
    println!(
        "| static entities | streamed per frame | contender | median frame | worst frame | \
         worst over bevy's median | static trees swapped in |"
    );
    println!("|---:|---:|---|---:|---:|---:|---:|");
    for &n in &sizes {
        for &k in &streams {
            let mut levels: Vec<Level> = Contender::ALL.iter().map(|&c| Level::new(c, n)).collect();
            for (level, c) in levels.iter().zip(Contender::ALL) {
                eprintln!("{n} {}: loading frame {:.1} ms", c.label(), ms(level.load));
            }
            let mut times = vec![Vec::with_capacity(frames); levels.len()];
            let mut swaps = vec![0usize; levels.len()];
            for frame in 0..frames {
                let mut line = format!("{n} {k} frame {frame}:");
                for ((level, t), swapped) in levels.iter_mut().zip(&mut times).zip(&mut swaps) {
                    let time = level.stream_frame(k);
                    t.push(time);
                    line += &format!(" {:.2}", ms(time));
                    if let Some(stats) = level.app.world().get_resource::<AccelStats>() {
                        *swapped += usize::from(stats.static_rebuilt);
                        let culling = level.app.world().resource::<CullingStats>().time;
                        line += &format!(
                            " (sync {:.2}, culling {:.2}{})",
                            ms(stats.sync_time),
                            ms(culling),
                            if stats.static_rebuilt { ", swap" } else { "" }
                        );
                    }
                }
                if trace {
                    eprintln!("{line}");
                }
            }
            let summary: Vec<(Duration, Duration)> = times
                .into_iter()
                .map(|mut t| {
                    t.sort_unstable();
                    (t[t.len() / 2], *t.last().unwrap())
                })
                .collect();
            let bevy_median = summary[0].0;
            for (k_contender, &c) in Contender::ALL.iter().enumerate() {
                let (median, worst) = summary[k_contender];
                let swapped = match c {
                    Contender::Bevy => "-".to_string(),
                    _ => swaps[k_contender].to_string(),
                };
                println!(
                    "| {n} | {k} | {} | {:.2} ms | {:.2} ms | {:.2} ms | {swapped} |",
                    c.label(),
                    ms(median),
                    ms(worst),
                    ms(worst.saturating_sub(bevy_median)),
                );
            }
        }
    }
}
