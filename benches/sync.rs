//! The plugin's per-frame cost through a real `App::update`: 100k entities with 10% moving,
//! and 100k static entities with nothing moving. The figure is the time the plugin's own
//! systems report (`AccelStats::sync_time + maintain_time`), so transform propagation and
//! the scheduler are not counted.
//!
//! `cargo bench --bench sync -- --warm-up-time 1 --measurement-time 3`

use bevy::camera::primitives::Aabb;
use bevy::prelude::*;
use bevy_accel::prelude::*;
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Duration;

const N: usize = 100_000;

fn app_with(n: usize, is_static: bool) -> (App, Vec<Entity>) {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin::default()));
    let side = (n as f32).cbrt().ceil() as usize;
    let entities = (0..n)
        .map(|i| {
            let p = Vec3::new(
                (i % side) as f32,
                (i / side % side) as f32,
                (i / side / side) as f32,
            ) * 3.0;
            let mut e = app.world_mut().spawn((
                Transform::from_translation(p),
                Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
            ));
            if is_static {
                e.insert(AccelStatic);
            }
            e.id()
        })
        .collect();
    app.update();
    app.update();
    (app, entities)
}

/// Moves a different 10% each frame, each a little (a typical game step).
fn move_tenth(app: &mut App, entities: &[Entity], frame: u64) {
    for (k, &e) in entities
        .iter()
        .enumerate()
        .skip((frame % 10) as usize)
        .step_by(10)
    {
        let mut t = app.world_mut().get_mut::<Transform>(e).unwrap();
        t.translation.y += if (frame + k as u64).is_multiple_of(2) {
            0.3
        } else {
            -0.3
        };
    }
}

fn plugin_time(app: &App) -> Duration {
    let s = app.world().resource::<AccelStats>();
    s.sync_time + s.maintain_time
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("plugin_frame");
    g.sample_size(20);
    let (mut app, entities) = app_with(N, false);
    let mut frame = 0u64;
    // One frame's split between applying updates and maintaining the tree, for the record.
    for (k, &e) in entities.iter().enumerate().step_by(10) {
        app.world_mut()
            .get_mut::<Transform>(e)
            .unwrap()
            .translation
            .y += if k % 20 == 0 { 0.3 } else { -0.3 };
    }
    app.update();
    let s = app.world().resource::<AccelStats>();
    println!(
        "10% moving: sync {:?} ({} updated), maintain {:?}",
        s.sync_time, s.updated, s.maintain_time
    );
    g.bench_function("100k_dynamic_10pct_moving", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                frame += 1;
                move_tenth(&mut app, &entities, frame);
                app.update();
                total += plugin_time(&app);
            }
            total
        })
    });
    // The steady state's split, for the record: the first frame above moved every entity out
    // of its fat box, later frames let motion prediction keep some inside. The optimiser's
    // share of the maintenance is its per-frame budget (`AccelSettings`), not refit work.
    let (mut sync, mut maintain, mut optimize, mut updated) =
        (Duration::ZERO, Duration::ZERO, Duration::ZERO, 0);
    const SPLIT_FRAMES: u32 = 100;
    for _ in 0..SPLIT_FRAMES {
        frame += 1;
        move_tenth(&mut app, &entities, frame);
        app.update();
        let s = app.world().resource::<AccelStats>();
        sync += s.sync_time;
        maintain += s.maintain_time;
        optimize += s
            .bvh
            .and_then(|b| b.last_maintain)
            .map_or(Duration::ZERO, |m| m.optimize.elapsed);
        updated += s.updated;
    }
    println!(
        "steady state, mean of {SPLIT_FRAMES} frames: sync {:?} ({} tree updates), maintain {:?} \
         (of which the optimiser {:?})",
        sync / SPLIT_FRAMES,
        updated / SPLIT_FRAMES as usize,
        maintain / SPLIT_FRAMES,
        optimize / SPLIT_FRAMES,
    );
    let dynamic = app
        .world()
        .resource::<AccelTrees>()
        .dynamic_bvh()
        .expect("the BVH is the default index");
    println!(
        "after the moving frames: {} rebuilds installed, quality {:?}",
        dynamic.rebuild_count(),
        dynamic.quality()
    );
    let (mut app, _) = app_with(N, true);
    g.bench_function("100k_static_idle", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                app.update();
                total += plugin_time(&app);
            }
            total
        })
    });
    let (mut app, _) = app_with(N, false);
    g.bench_function("100k_dynamic_idle", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                app.update();
                total += plugin_time(&app);
            }
            total
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
