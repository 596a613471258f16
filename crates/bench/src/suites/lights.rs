//! Shadow-caster culling for light views: bevy_light's `check_point_light_mesh_visibility` and
//! `check_dir_light_mesh_visibility` against `AccelCullingPlugin`'s light views, side by side
//! in one run, on a grid of static casters (unit boxes 4 units apart). Absorbs the former
//! `benches/light_culling.rs`.
//!
//! Scenarios: eight shadow-mapped point lights, each reaching about 0.5% of the casters (six
//! cube faces each); one directional light with Bevy's default four cascades over a camera at
//! a corner of the grid; the eight point lights reaching the whole grid (*far*: every light
//! view takes the flat pass, the check that it is never slower than Bevy's own loop). Ours
//! also runs with the lights moving by a hair each frame, so that no light view can keep its
//! last walk.
//!
//! Bevy's figure is the time of its two systems run alone in a schedule of their own after
//! each frame (taken out of the frame itself; they spread their loops over the compute pool);
//! ours is what our systems report in `CullingStats::light_time`. Each figure is the median
//! over the measured frames.
//!
//! Check: after the still frames and after the moving ones (both apps' lights move alike),
//! every light view's list of casters (cube face, cascade) equals Bevy's; a caster Bevy lists and we do not is a miss in the failure rows (a missing
//! shadow), one we list and Bevy does not is counted in the notes (work for nothing). Points:
//! time against the share of listed casters Bevy does not list.

use super::headless_app;
use super::point;
use crate::json::{Point, Report, StressRow};
use crate::progress::Progress;
use crate::timing::median;
use accel_testkit::bevy_apps::{add_lights, grid_point};
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::{
    CascadesVisibleEntities, CubemapVisibleEntities, NoAutoAabb, VisibleMeshEntities,
};
use bevy::ecs::schedule::{ScheduleCleanupPolicy, ScheduleLabel};
use bevy::light::{check_dir_light_mesh_visibility, check_point_light_mesh_visibility};
use bevy::prelude::*;
use bevy_accel::AccelCullingPlugin;
use bevy_accel::culling::CullingStats;
use bevy_accel::prelude::*;
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// Bevy's two light-culling systems, alone.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
struct BevyLightCulling;

/// Which lights cast shadows in a scenario.
#[derive(Clone, Copy, Debug)]
enum Scenario {
    PointLights,
    Directional,
    FarPointLights,
}

impl Scenario {
    /// `FarPointLights` last: it widens the lights for good.
    const ALL: [Self; 3] = [Self::PointLights, Self::Directional, Self::FarPointLights];

    fn label(self) -> &'static str {
        match self {
            Self::PointLights => "8 point lights",
            Self::Directional => "directional",
            Self::FarPointLights => "far point lights (flat)",
        }
    }
}

/// The sizes of one run.
struct Sizes {
    casters: &'static [usize],
    frames: usize,
}

const FULL: Sizes = Sizes {
    casters: &[100_000, 1_000_000],
    frames: 12,
};

const QUICK: Sizes = Sizes {
    casters: &[8_000],
    frames: 3,
};

/// One app and its casters and lights in spawn order (entity ids differ between the apps:
/// plugins spawn observers).
struct LightApp {
    app: App,
    casters: HashMap<Entity, u32>,
    lights: Vec<Entity>,
}

fn light_app(n: usize, ours: bool) -> LightApp {
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
        let removed = [
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
        ];
        for r in removed {
            assert_eq!(r.ok(), Some(1), "bevy_light's system is in PostUpdate");
        }
    }
    let side = (n as f32).cbrt().ceil() as usize;
    let extent = side as f32 * 4.0;
    let world = app.world_mut();
    let casters = world
        .spawn_batch((0..n).map(move |i| {
            (
                Transform::from_translation(grid_point(i, side)),
                Visibility::Visible,
                Mesh3d::default(),
                NoAutoAabb,
                Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
                AccelStatic,
            )
        }))
        .zip(0u32..)
        .collect();
    // A sphere holding 0.5% of the grid's volume.
    let range = (0.005 * extent.powi(3) * 3.0 / (4.0 * std::f32::consts::PI)).cbrt();
    let mut lights: Vec<Entity> = (0..8)
        .map(|k| {
            let t = (k as f32 + 0.5) / 8.0;
            world
                .spawn((
                    PointLight {
                        shadow_maps_enabled: true,
                        range,
                        ..default()
                    },
                    Transform::from_translation(Vec3::new(t, 1.0 - t, 0.5) * extent),
                ))
                .id()
        })
        .collect();
    lights.push(
        world
            .spawn((
                DirectionalLight {
                    shadow_maps_enabled: true,
                    ..default()
                },
                Transform::from_xyz(0.0, 1.0, 0.0).looking_at(Vec3::new(0.3, 0.0, 0.2), Vec3::Y),
            ))
            .id(),
    );
    // A camera at a corner of the grid looking into it, as a player in a large level.
    world.spawn((
        Camera::default(),
        Projection::Perspective(PerspectiveProjection {
            far: extent,
            ..default()
        }),
        Transform::from_xyz(0.0, 0.5 * extent, 0.0).looking_at(Vec3::splat(0.5 * extent), Vec3::Y),
    ));
    for _ in 0..2 {
        settle(&mut app, ours);
    }
    LightApp {
        app,
        casters,
        lights,
    }
}

/// One frame, and for Bevy's app its light systems after it: so that the lists Bevy keeps
/// from frame to frame (those of lights whose shadows are off stay as they were) have the
/// same history in both apps.
fn settle(app: &mut App, ours: bool) {
    if ours {
        app.update();
    } else {
        bevy_time(app);
    }
}

fn set_scenario(app: &mut App, scenario: Scenario, ours: bool) {
    let world = app.world_mut();
    let points = !matches!(scenario, Scenario::Directional);
    let far = matches!(scenario, Scenario::FarPointLights);
    for mut light in world.query::<&mut PointLight>().iter_mut(world) {
        light.shadow_maps_enabled = points;
        if far {
            light.range = 1e6;
        }
    }
    for mut light in world.query::<&mut DirectionalLight>().iter_mut(world) {
        light.shadow_maps_enabled = !points;
    }
    settle(app, ours);
    settle(app, ours);
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

/// One frame of Bevy's app, then its two light systems alone, timed.
fn bevy_time(app: &mut App) -> Duration {
    app.update();
    let start = Instant::now();
    app.world_mut().run_schedule(BevyLightCulling);
    start.elapsed()
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Every light view's casters as sorted spawn indices, keyed by light (spawn order), cube
/// face or cascade.
fn light_lists(l: &mut LightApp) -> HashMap<(usize, usize), Vec<u32>> {
    let list = |v: &VisibleMeshEntities| -> Vec<u32> {
        let mut out: Vec<u32> = v
            .entities
            .iter()
            .filter_map(|e| l.casters.get(e).copied())
            .collect();
        out.sort_unstable();
        out
    };
    let mut views = HashMap::new();
    let world = l.app.world_mut();
    for (k, &light) in l.lights.iter().enumerate() {
        if let Some(cube) = world.get::<CubemapVisibleEntities>(light) {
            for (face, v) in cube.iter().enumerate() {
                views.insert((k, face), list(v));
            }
        }
        if let Some(cascades) = world.get::<CascadesVisibleEntities>(light) {
            for lists in cascades.entities.values() {
                for (cascade, v) in lists.iter().enumerate() {
                    views.insert((k, cascade), list(v));
                }
            }
        }
    }
    views
}

/// Casters Bevy lists that we do not, and those we list that Bevy does not, and Bevy's total.
fn compare(bevy: &mut LightApp, ours: &mut LightApp) -> (u64, u64, u64) {
    let (theirs, mine) = (light_lists(bevy), light_lists(ours));
    let (mut missing, mut extra, mut total) = (0u64, 0u64, 0u64);
    for (key, list) in &theirs {
        let empty = Vec::new();
        let other = mine.get(key).unwrap_or(&empty);
        total += list.len() as u64;
        missing += list
            .iter()
            .filter(|c| other.binary_search(c).is_err())
            .count() as u64;
        extra += other
            .iter()
            .filter(|c| list.binary_search(c).is_err())
            .count() as u64;
    }
    (missing, extra, total)
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let sizes = if quick { QUICK } else { FULL };
    let mut progress = Progress::new("lights", sizes.casters.len() * 3 + 1);
    let mut points: Vec<Point> = Vec::new();
    let mut notes = Vec::new();
    let mut stress = Vec::new();
    let mut markdown = vec![
        "| scene | bevy_light | accel, still lights | accel, moving lights | speed-up, still / \
         moving |"
            .to_string(),
        "|---|---:|---:|---:|---:|".to_string(),
    ];
    for &n in sizes.casters {
        let mut bevy = light_app(n, false);
        let mut ours = light_app(n, true);
        for scenario in Scenario::ALL {
            let scene = format!("{n} casters, {}", scenario.label());
            progress.step(&scene);
            set_scenario(&mut bevy.app, scenario, false);
            set_scenario(&mut ours.app, scenario, true);
            let (mut bevy_ms, mut still_ms, mut moving_ms) = (Vec::new(), Vec::new(), Vec::new());
            for _ in 0..sizes.frames {
                bevy_ms.push(ms(bevy_time(&mut bevy.app)));
                ours.app.update();
                still_ms.push(ms(ours.app.world().resource::<CullingStats>().light_time));
            }
            let (missing, extra, total) = compare(&mut bevy, &mut ours);
            let stats = ours.app.world().resource::<CullingStats>();
            notes.push(format!(
                "{scene}: {} light views ({} by the flat pass), {} kept their walk with the \
                 lights still; {total} casters listed by Bevy, {missing} of them missing from \
                 ours, {extra} listed by us only",
                stats.light_views, stats.flat_light_views, stats.reused_light_walks
            ));
            // Both apps' lights move alike, so that every later list compares like with
            // like (Bevy's light frusta keep state of their own); Bevy's time with moving
            // lights is its still time, as it keeps nothing from frame to frame.
            for frame in 0..sizes.frames as u32 {
                nudge_lights(&mut bevy.app, frame);
                bevy_time(&mut bevy.app);
                nudge_lights(&mut ours.app, frame);
                ours.app.update();
                moving_ms.push(ms(ours.app.world().resource::<CullingStats>().light_time));
            }
            let (missing_moving, _, total_moving) = compare(&mut bevy, &mut ours);
            let (missing, total) = (missing + missing_moving, total + total_moving);
            let (b, s, m) = (median(bevy_ms), median(still_ms), median(moving_ms));
            markdown.push(format!(
                "| {n}, {} | {b:.2} ms | {s:.2} ms | {m:.2} ms | {:.1}x / {:.1}x |",
                scenario.label(),
                b / s.max(1e-6),
                b / m.max(1e-6)
            ));
            let extra_share = Some(extra as f64 / total.max(1) as f64);
            for (method, t, err) in [
                ("bevy_light", b, Some(0.0)),
                ("accel, still lights", s, extra_share),
                ("accel, moving lights", m, None),
            ] {
                points.push(point(
                    &scene,
                    method,
                    "",
                    ("ms per frame", t),
                    ("casters listed for nothing, share", err),
                ));
            }
            stress.push(StressRow {
                structure: "plugin, light views".into(),
                query: format!("casters listed against bevy_light ({scene})"),
                cases: total,
                misses: missing,
                ..StressRow::default()
            });
        }
    }
    progress.step("done");
    progress.finish();
    Report {
        suite: "lights".into(),
        quick,
        points,
        markdown,
        notes,
        stress,
        ..Report::default()
    }
}
