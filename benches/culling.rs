//! Frustum culling: Bevy's `check_visibility_cpu_culling` against `AccelCullingPlugin`, side by
//! side in one run, at 100k and 1M entities with 5%, 50% and 100% of them in view, with the
//! camera still (the culling may keep its last walk of the trees) and moving. Each figure
//! is the time of the culling system alone (timestamps taken just before and after it, on the
//! single-threaded executor; Bevy's system still spreads its loop over the compute pool).
//!
//! `cargo bench --bench culling -- --warm-up-time 1 --measurement-time 3`

use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::{VisibilityClass, VisibilitySystems, check_visibility_cpu_culling};
use bevy::ecs::schedule::SingleThreadedExecutor;
use bevy::math::primitives::ViewFrustum;
use bevy::prelude::*;
use bevy_accel::AccelCullingPlugin;
use bevy_accel::culling::CullingStats;
use bevy_accel::prelude::*;
#[path = "../tests/common/mod.rs"]
mod common;
use common::{grid_point, headless_app};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::any::TypeId;
use std::time::{Duration, Instant};

#[derive(Component, Default)]
struct Drawable;

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

/// Entities on a cube grid of side `side * 4` units.
fn app(n: usize, ours: bool) -> App {
    let mut app = headless_app();
    app.init_resource::<CullTimer>();
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
    world.spawn_batch((0..n).map(move |i| {
        (
            Transform::from_translation(grid_point(i, side)),
            Visibility::Visible,
            class.clone(),
            Drawable,
            Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
            AccelStatic,
        )
    }));
    let extent = side as f32 * 4.0;
    world.spawn((
        Camera::default(),
        Transform::default(),
        frustum_for(1.0, extent),
    ));
    app.update();
    app.update();
    app
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

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("culling");
    g.sample_size(10);
    for n in [100_000usize, 1_000_000] {
        let mut bevy_app = app(n, false);
        let mut accel_app = app(n, true);
        for fraction in [0.05f32, 0.5, 1.0] {
            set_fraction(&mut bevy_app, fraction, n);
            set_fraction(&mut accel_app, fraction, n);
            bevy_app.update();
            // Twice: a view's first frame at a new fraction still follows the path its last
            // fraction chose.
            accel_app.update();
            accel_app.update();
            let stats = accel_app.world().resource::<CullingStats>();
            let visible = stats.visible;
            println!(
                "n = {n}, fraction {fraction}: {visible} visible ({:.1}%); {} accepted on a \
                 tree's word, {} given Bevy's frustum test; flat pass: {} (on the trees: {})",
                100.0 * visible as f64 / n as f64,
                stats.accepted_by_subtree,
                stats.tested,
                stats.flat_views > 0,
                stats.flat_views_on_trees > 0
            );
            let label = format!("{n}/{}pct", (fraction * 100.0) as u32);
            g.bench_function(BenchmarkId::new("bevy", &label), |b| {
                b.iter_custom(|iters| {
                    (0..iters)
                        .map(|_| {
                            bevy_app.update();
                            bevy_app.world().resource::<CullTimer>().last
                        })
                        .sum()
                })
            });
            g.bench_function(BenchmarkId::new("accel", &label), |b| {
                b.iter_custom(|iters| {
                    (0..iters)
                        .map(|_| {
                            accel_app.update();
                            accel_app.world().resource::<CullingStats>().time
                        })
                        .sum()
                })
            });
            let reused = accel_app.world().resource::<CullingStats>().reused_walks > 0;
            println!("{label}, still camera: the last frame reused its walk: {reused}");
            // The camera moves by a hair every frame: the same entities in view, but each
            // frame's frustum differs, so nothing about the last frame's walk can be kept.
            // (Inwards: the view's edge lies on a column of boxes' faces, and an outward nudge
            // would make that whole column cross the plane.)
            let mut frame = 0u32;
            g.bench_function(BenchmarkId::new("accel, moving camera", &label), |b| {
                b.iter_custom(|iters| {
                    (0..iters)
                        .map(|_| {
                            frame += 1;
                            let nudge = 1.0 - 1e-4 * (frame % 2) as f32;
                            set_fraction(&mut accel_app, fraction * nudge, n);
                            accel_app.update();
                            accel_app.world().resource::<CullingStats>().time
                        })
                        .sum()
                })
            });
            set_fraction(&mut accel_app, fraction, n);
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
