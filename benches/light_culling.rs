//! Shadow-caster culling for light views: bevy_light's `check_point_light_mesh_visibility` and
//! `check_dir_light_mesh_visibility` against `AccelCullingPlugin`'s light views, side by side
//! in one run, at 100k and 1M casters on a grid:
//! - eight shadow-mapped point lights, each reaching about 0.5% of the casters (six cube
//!   faces each);
//! - one directional light with Bevy's default four cascades over one camera;
//! - the eight point lights reaching the whole grid (every light view takes the flat pass).
//!
//! Ours also runs with the lights moving by a hair each frame, so that no light view can keep
//! its last walk.
//!
//! Bevy's figure is the time of its two systems run alone in a schedule of their own after
//! each frame, once a frame (they are taken out of the frame itself; they spread their loops
//! over the compute pool); ours is the time our two systems report in
//! `CullingStats::light_time` (one thread, or the compute pool on the flat pass).
//!
//! `cargo bench --profile dev --bench light_culling -- --warm-up-time 1 --measurement-time 3`

use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::NoAutoAabb;
use bevy::ecs::schedule::{ScheduleCleanupPolicy, ScheduleLabel};
use bevy::light::{check_dir_light_mesh_visibility, check_point_light_mesh_visibility};
use bevy::prelude::*;
use bevy_accel::AccelCullingPlugin;
use bevy_accel::culling::CullingStats;
use bevy_accel::prelude::*;
#[path = "../tests/common/mod.rs"]
mod common;
use common::{add_lights, grid_point, headless_app};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use std::time::{Duration, Instant};

/// Bevy's two light-culling systems, alone.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
struct BevyLightCulling;

/// Which lights cast shadows in a scenario.
#[derive(Clone, Copy, Debug)]
enum Scenario {
    PointLights,
    Directional,
    /// The eight point lights, each reaching the whole grid: every light view takes the flat
    /// pass (the check that it is never slower than Bevy's own loop).
    FarPointLights,
}

fn app(n: usize, ours: bool) -> App {
    let mut app = headless_app();
    add_lights(&mut app);
    if ours {
        app.add_plugins(AccelCullingPlugin);
    } else {
        app.add_systems(
            BevyLightCulling,
            (
                check_dir_light_mesh_visibility,
                check_point_light_mesh_visibility,
            ),
        );
    }
    app.finish();
    if !ours {
        // Bevy's systems run once a frame, in their own schedule after it (timed there), not
        // also inside the frame: a second run right after the first would find every row
        // already in cache.
        for system in [
            app.remove_systems_in_set(
                PostUpdate,
                check_dir_light_mesh_visibility,
                ScheduleCleanupPolicy::RemoveSystemsOnly,
            ),
            app.remove_systems_in_set(
                PostUpdate,
                check_point_light_mesh_visibility,
                ScheduleCleanupPolicy::RemoveSystemsOnly,
            ),
        ] {
            assert_eq!(system.ok(), Some(1), "bevy_light's system is in PostUpdate");
        }
    }
    let side = (n as f32).cbrt().ceil() as usize;
    let extent = side as f32 * 4.0;
    let world = app.world_mut();
    world.spawn_batch((0..n).map(move |i| {
        (
            Transform::from_translation(grid_point(i, side)),
            Visibility::Visible,
            Mesh3d::default(),
            NoAutoAabb,
            Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
            AccelStatic,
        )
    }));
    // A sphere holding 0.5% of the grid's volume.
    let range = (0.005 * extent.powi(3) * 3.0 / (4.0 * std::f32::consts::PI)).cbrt();
    for k in 0..8 {
        let t = (k as f32 + 0.5) / 8.0;
        world.spawn((
            PointLight {
                shadow_maps_enabled: true,
                range,
                ..default()
            },
            Transform::from_translation(Vec3::new(t, 1.0 - t, 0.5) * extent),
        ));
    }
    world.spawn((
        DirectionalLight {
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(0.0, 1.0, 0.0).looking_at(Vec3::new(0.3, 0.0, 0.2), Vec3::Y),
    ));
    // A camera at a corner of the grid looking into it, as a player in a large level.
    world.spawn((
        Camera::default(),
        Projection::Perspective(PerspectiveProjection {
            far: extent,
            ..default()
        }),
        Transform::from_xyz(0.0, 0.5 * extent, 0.0).looking_at(Vec3::splat(0.5 * extent), Vec3::Y),
    ));
    app.update();
    app.update();
    app
}

fn set_scenario(app: &mut App, scenario: Scenario) {
    let world = app.world_mut();
    let points = !matches!(scenario, Scenario::Directional);
    let far = matches!(scenario, Scenario::FarPointLights);
    for mut light in world.query::<&mut PointLight>().iter_mut(world) {
        light.shadow_maps_enabled = points;
        if far {
            // For good: this scenario runs last.
            light.range = 1e6;
        }
    }
    for mut light in world.query::<&mut DirectionalLight>().iter_mut(world) {
        light.shadow_maps_enabled = !points;
    }
    app.update();
    app.update();
}

/// Moves every light by a hair, back and forth.
fn nudge_lights(app: &mut App, frame: u32) {
    let step = if frame.is_multiple_of(2) { 1e-3 } else { -1e-3 };
    let world = app.world_mut();
    let mut lights =
        world.query_filtered::<&mut Transform, Or<(With<PointLight>, With<DirectionalLight>)>>();
    for mut t in lights.iter_mut(world) {
        t.translation.x += step;
        t.rotate_y(step);
    }
}

fn bevy_time(app: &mut App) -> Duration {
    app.update();
    let start = Instant::now();
    app.world_mut().run_schedule(BevyLightCulling);
    start.elapsed()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("light_culling");
    g.sample_size(10);
    for n in [100_000usize, 1_000_000] {
        let mut bevy_app = app(n, false);
        let mut accel_app = app(n, true);
        // `FarPointLights` last: it widens the lights for good.
        for scenario in [
            Scenario::PointLights,
            Scenario::Directional,
            Scenario::FarPointLights,
        ] {
            set_scenario(&mut bevy_app, scenario);
            set_scenario(&mut accel_app, scenario);
            let stats = accel_app.world().resource::<CullingStats>();
            println!(
                "n = {n}, {scenario:?}: {} light views ({} by the flat pass), {} candidates \
                 decided on the tree path ({:.2}% of casters per view)",
                stats.light_views,
                stats.flat_light_views,
                stats.light_candidates,
                100.0 * stats.light_candidates as f64 / (n * stats.light_views.max(1)) as f64
            );
            let label = format!("{n}/{scenario:?}");
            g.bench_function(BenchmarkId::new("bevy", &label), |b| {
                b.iter_custom(|iters| (0..iters).map(|_| bevy_time(&mut bevy_app)).sum())
            });
            g.bench_function(BenchmarkId::new("accel", &label), |b| {
                b.iter_custom(|iters| {
                    (0..iters)
                        .map(|_| {
                            accel_app.update();
                            accel_app.world().resource::<CullingStats>().light_time
                        })
                        .sum()
                })
            });
            let reused = accel_app
                .world()
                .resource::<CullingStats>()
                .reused_light_walks;
            println!("{label}, still lights: {reused} light views kept their walk");
            // The lights move by a hair every frame: nothing about the last frame's walks
            // can be kept.
            let mut frame = 0u32;
            g.bench_function(BenchmarkId::new("accel, moving lights", &label), |b| {
                b.iter_custom(|iters| {
                    (0..iters)
                        .map(|_| {
                            frame += 1;
                            nudge_lights(&mut accel_app, frame);
                            accel_app.update();
                            accel_app.world().resource::<CullingStats>().light_time
                        })
                        .sum()
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
