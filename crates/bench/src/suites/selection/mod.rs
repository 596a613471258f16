//! Box selection: `AccelSelection` against the brute force a game would write with Bevy
//! alone (project every entity's world box through the camera and compare with the
//! rectangle), on a field of units seen from above at an angle.
//!
//! Units are small boxes (one shared cube mesh) on a square field; the rectangle is centred
//! and sized to hold about 1% or 10% of them. Each time is the median over the measured
//! queries. The brute force's centre and enclosed verdicts are compared with ours: a unit one
//! selects and the other does not is a failure, unless it lies within rounding of an edge.

mod drag;

use super::{headless_app, point, settle_still_trees};
use crate::json::{Point, Report, StressRow};
use crate::progress::Progress;
use crate::timing::median;
use bevy::camera::primitives::Aabb;
use bevy::camera::{RenderTargetInfo, Viewport};
use bevy::ecs::system::SystemId;
use bevy::picking::mesh_picking::ray_cast::RayCastVisibility;
use bevy::prelude::*;
use bevy_accel::prelude::*;
use std::time::{Duration, Instant};

/// The unit counts, the shares inside the rectangle, and the queries timed per row.
struct Sizes {
    units: &'static [usize],
    /// Unit counts run again with every unit moving every frame.
    moving_units: &'static [usize],
    shares: &'static [f32],
    queries: usize,
}

const FULL: Sizes = Sizes {
    units: &[10_000, 100_000, 1_000_000],
    moving_units: &[100_000],
    shares: &[0.01, 0.1],
    queries: 15,
};

const QUICK: Sizes = Sizes {
    units: &[2_000, 20_000],
    moving_units: &[],
    shares: &[0.1],
    queries: 3,
};

/// The field's half side for `n` units, 2 units apart.
fn half_side(n: usize) -> f32 {
    (n as f32).sqrt()
}

/// A unit's place on the field, which a moving unit circles.
#[derive(Component)]
struct Home(Vec3);

/// Every unit a step further round its small circle: each moves every frame, as units
/// walking about do.
fn circle_homes(mut frame: Local<u32>, mut units: Query<(&Home, &mut Transform)>) {
    *frame += 1;
    units.par_iter_mut().for_each(|(home, mut transform)| {
        let a = *frame as f32 * 0.1 + home.0.x * 0.37 + home.0.z * 0.61;
        transform.translation = home.0 + 0.3 * Vec3::new(a.cos(), 0.0, a.sin());
    });
}

/// The app: `n` units on the field and a camera above it that sees all of it; with
/// `moving`, every unit moving every frame.
fn scene(n: usize, moving: bool) -> (App, Entity, Mat4) {
    let mut app = headless_app();
    // The input plugin for the drags' mouse button (`drag`).
    app.add_plugins((
        AccelPickingPlugin,
        AccelSelectionPlugin,
        bevy::input::InputPlugin,
    ))
    // As the brute force: no renderer decides visibility here.
    .insert_resource(AccelSelectionSettings {
        visibility: RayCastVisibility::Any,
        ..default()
    });
    app.finish();
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(0.8, 0.8, 0.8));
    let aabb = Aabb::from_min_max(Vec3::splat(-0.4), Vec3::splat(0.4));
    let side = (n as f32).sqrt().ceil() as usize;
    let half = half_side(n);
    let units: Vec<_> = (0..n)
        .map(|i| {
            let (x, z) = (
                (i % side) as f32 * 2.0 - half,
                (i / side) as f32 * 2.0 - half,
            );
            let home = Vec3::new(x, 0.4, z);
            (
                Transform::from_translation(home),
                aabb,
                Mesh3d(cube.clone()),
                Home(home),
            )
        })
        .collect();
    app.world_mut().spawn_batch(units);
    if moving {
        app.add_systems(Update, circle_homes);
    }
    // From above and to the south, tilted: the field fills the view.
    let eye = Vec3::new(0.0, half * 2.2, half * 0.8);
    let transform = Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y);
    let size = UVec2::new(1280, 720);
    let clip_from_view =
        Mat4::perspective_infinite_reverse_rh(1.0, size.x as f32 / size.y as f32, 0.1);
    let mut camera = Camera {
        viewport: Some(Viewport {
            physical_size: size,
            ..default()
        }),
        ..default()
    };
    camera.computed.clip_from_view = clip_from_view;
    camera.computed.target_info = Some(RenderTargetInfo {
        physical_size: size,
        scale_factor: 1.0,
    });
    let camera = app
        .world_mut()
        .spawn((camera, transform, GlobalTransform::from(transform)))
        .id();
    // A few frames: the moving units are then kept as busy movers.
    for _ in 0..if moving { 6 } else { 2 } {
        app.update();
    }
    if !moving {
        settle_still_trees(&mut app, App::update);
    }
    (
        app,
        camera,
        clip_from_view * transform.to_matrix().inverse(),
    )
}

/// What one timed query gives back.
#[derive(Resource, Default)]
struct Outcome {
    time: Duration,
    selected: Vec<Entity>,
}

/// The rectangle (NDC corners) and mode of the next query.
#[derive(Resource, Clone, Copy)]
struct Ask {
    lo: Vec2,
    hi: Vec2,
    mode: SelectionMode,
    camera: Entity,
    clip_from_world: Mat4,
}

fn ours(ask: Res<Ask>, mut selection: AccelSelection, mut out: ResMut<Outcome>) {
    let start = Instant::now();
    let found = selection
        .in_ndc_rect(
            ask.camera,
            ask.lo,
            ask.hi,
            ask.mode,
            SelectionOrder::ByEntity,
        )
        .map(<[Entity]>::len)
        .unwrap_or(0);
    out.time = start.elapsed();
    out.selected = selection
        .in_ndc_rect(
            ask.camera,
            ask.lo,
            ask.hi,
            ask.mode,
            SelectionOrder::ByEntity,
        )
        .map(<[Entity]>::to_vec)
        .unwrap_or_default();
    debug_assert_eq!(found, out.selected.len());
}

/// The game's own loop: every unit's world box, projected corner by corner.
fn brute_force(
    ask: Res<Ask>,
    units: Query<(Entity, &GlobalTransform, &Aabb)>,
    mut out: ResMut<Outcome>,
) {
    let start = Instant::now();
    let m = ask.clip_from_world;
    let inside = |p: Vec3| {
        let c = m * p.extend(1.0);
        if !(c.w > 0.0 && c.z <= c.w) {
            return false;
        }
        let ndc = c.truncate().truncate() / c.w;
        ndc.cmpge(ask.lo).all() && ndc.cmple(ask.hi).all()
    };
    let mut selected = Vec::new();
    for (entity, transform, aabb) in &units {
        let affine = transform.affine();
        let center = affine.transform_point3a(aabb.center);
        let h = aabb.half_extents;
        let half = affine.matrix3.x_axis.abs() * h.x
            + affine.matrix3.y_axis.abs() * h.y
            + affine.matrix3.z_axis.abs() * h.z;
        let hit = match ask.mode {
            SelectionMode::Enclosed => (0..8).all(|i| {
                let s = Vec3A::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                );
                inside((center + half * s).into())
            }),
            _ => inside(center.into()),
        };
        if hit {
            selected.push(entity);
        }
    }
    out.time = start.elapsed();
    out.selected = selected;
}

/// Runs a registered query `times` times: the median time and the last selection.
fn time(app: &mut App, system: SystemId, ask: Ask, times: usize) -> (f64, Vec<Entity>) {
    app.world_mut().insert_resource(ask);
    let mut samples = Vec::with_capacity(times);
    for _ in 0..times {
        app.world_mut().run_system(system).expect("the query runs");
        samples.push(app.world().resource::<Outcome>().time.as_secs_f64());
    }
    let mut selected = std::mem::take(&mut app.world_mut().resource_mut::<Outcome>().selected);
    selected.sort_unstable();
    (median(samples), selected)
}

fn ms(seconds: f64) -> String {
    format!("{:.3} ms", seconds * 1e3)
}

fn count(n: usize) -> String {
    if n >= 1_000_000 {
        format!("{}M", n / 1_000_000)
    } else {
        format!("{}k", n / 1000)
    }
}

pub fn run(quick: bool) -> Report {
    let sizes = if quick { QUICK } else { FULL };
    let cases: Vec<(usize, bool)> = (sizes.units.iter().map(|&n| (n, false)))
        .chain(sizes.moving_units.iter().map(|&n| (n, true)))
        .collect();
    let mut progress = Progress::new("selection", cases.len() * (2 + sizes.shares.len()));
    let mut points: Vec<Point> = Vec::new();
    let mut markdown = vec![
        "| units | inside | mode | selected | brute force | accel | speed-up | accel per selected |"
            .to_string(),
        "|---:|---:|---|---:|---:|---:|---:|---:|".to_string(),
    ];
    let mut drag_rows = vec![
        String::new(),
        "Drags (the frame, `App::update` whole; in brackets over the idle frame):".to_string(),
        String::new(),
        "| units | inside | selected | idle frame | press or move (median) | release, empty selection | release, replacing |"
            .to_string(),
        "|---:|---:|---:|---:|---:|---:|---:|".to_string(),
    ];
    let mut differences = 0u64;
    let mut checked = 0u64;
    let mut samples = Vec::new();
    for &(n, moving) in &cases {
        let units = format!("{}{}", count(n), if moving { " moving" } else { "" });
        progress.step(&format!("{units} units: the scene"));
        let (mut app, camera, clip_from_world) = scene(n, moving);
        app.init_resource::<Outcome>();
        let ours_id = app.world_mut().register_system(ours);
        let brute_id = app.world_mut().register_system(brute_force);
        for &share in sizes.shares {
            progress.step(&format!("{n} units, {}%", share * 100.0));
            // The field fills most of the view: a centred square of this share of the screen
            // holds about as large a share of the units.
            let half = Vec2::splat(share.sqrt());
            for mode in [
                SelectionMode::Center,
                SelectionMode::Enclosed,
                SelectionMode::Touching,
            ] {
                let ask = Ask {
                    lo: -half,
                    hi: half,
                    mode,
                    camera,
                    clip_from_world,
                };
                let (accel, found) = time(&mut app, ours_id, ask, sizes.queries);
                let (brute, expected) = time(&mut app, brute_id, ask, sizes.queries);
                if mode != SelectionMode::Touching {
                    checked += expected.len() as u64;
                    let missing = expected.iter().filter(|e| found.binary_search(e).is_err());
                    let extra = found.iter().filter(|e| expected.binary_search(e).is_err());
                    let wrong = missing.count() + extra.count();
                    // Units exactly on an edge may go either way in f32: a few per million.
                    if wrong > n / 100_000 + 2 {
                        differences += wrong as u64;
                        samples.push(format!(
                            "{n} units, {share}, {mode:?}: {wrong} differ from the brute force"
                        ));
                    }
                }
                let scene = format!("{units} units, {}% inside", share * 100.0);
                let mode_name = format!("{mode:?}").to_lowercase();
                points.push(point(
                    &scene,
                    "brute force",
                    &mode_name,
                    ("ms", brute * 1e3),
                    ("selected", Some(expected.len() as f64)),
                ));
                points.push(point(
                    &scene,
                    "accel",
                    &mode_name,
                    ("ms", accel * 1e3),
                    ("selected", Some(found.len() as f64)),
                ));
                let per = if found.is_empty() {
                    "-".to_string()
                } else {
                    format!("{:.0} ns", accel * 1e9 / found.len() as f64)
                };
                let peer = if mode == SelectionMode::Touching {
                    "(centre's)".to_string()
                } else {
                    format!("{:.1}x", brute / accel)
                };
                markdown.push(format!(
                    "| {} | {}% | {} | {} | {} | {} | {} | {} |",
                    units,
                    share * 100.0,
                    mode_name,
                    found.len(),
                    ms(brute),
                    ms(accel),
                    peer,
                    per
                ));
            }
        }
        progress.step(&format!("{units} units: drags"));
        drag::run(app, &units, sizes.shares, &mut drag_rows, &mut points);
    }
    markdown.extend(drag_rows);
    Report {
        suite: "selection".into(),
        quick,
        points,
        markdown,
        notes: vec![format!(
            "{checked} brute-force verdicts checked (centre, enclosed), {differences} differences"
        )],
        stress: vec![StressRow {
            structure: "AccelSelection".into(),
            query: "box selection against the brute force".into(),
            cases: checked,
            misses: differences,
            ..StressRow::default()
        }],
        failure_samples: samples,
        ..Report::default()
    }
}
