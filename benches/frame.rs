//! The whole frame against plain Bevy, the headline figure: apps with the same scene, updated
//! in turn frame by frame, each `App::update` timed whole.
//!
//! - *floor*: plain Bevy with no camera, what both others pay (transform propagation, the
//!   schedules, the motion system);
//! - *bevy*: plain Bevy (no bevy_accel at all) with one camera, culled by Bevy's own
//!   `check_visibility`;
//! - *accel/<index>*: the same scene with `AccelPlugin`, `AccelCullingPlugin` and
//!   `AccelPickingPlugin`, casting one pointer ray per frame (`AccelRayCast::cast_ray_bounds`),
//!   the moving entities in the chosen index.
//!
//! Scenes: unit boxes on a square field, 4 units apart with a jitter, all of them dynamic (a
//! user who marks nothing `AccelStatic`); a share of them wobble every frame. Cameras: a
//! *strategy* camera looking down from above (about 2% of the field in view) and a *ground*
//! camera at the edge of the field looking across it (about 40%; Bevy does not cull by the
//! far plane).
//!
//! `cargo bench --workspace --profile dev --bench frame -- [--entities 100000,1000000]
//! [--moving 0,10,25] [--camera strategy,ground] [--index bvh,octree,grid,quadtree,brute,auto] [--frames 40]
//! [--overlays-off]`
//!
//! `--overlays-off` adds, for each index, the same app with Bevy's gizmos, and with Bevy's
//! gizmos and `AccelOverlaysPlugin` with every overlay off: the difference of those two is
//! what the overlays cost when they are not used.
//!
//! Prints one table row per scene: median frame times, the whole-frame speed-up (bevy /
//! accel) and the speed-up of what each pays over the floor (the culling, and for us the
//! trees' upkeep and the ray); and, on stderr, where our frame goes (the plugin's own
//! timings of its sync, maintenance and culling).

use accel_testkit::Rng;
use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::{VisibilityClass, VisibilityPlugin};
use bevy::math::primitives::ViewFrustum;
use bevy::picking::mesh_picking::ray_cast::MeshRayCastSettings;
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

/// A box that wobbles around `home`.
#[derive(Component)]
struct Mover {
    home: Vec3,
    phase: f32,
}

/// Frames run so far: the motion follows it, so every app moves its boxes alike.
#[derive(Resource, Default)]
struct FrameCount(u32);

/// The pointer ray of the frame, from the camera along its view with a small wobble.
#[derive(Resource)]
struct PointerRay(Ray3d);

#[derive(Clone, Copy, Debug, PartialEq)]
enum Contender {
    Floor,
    Bevy,
    Accel(IndexChoice),
    /// The same with Bevy's gizmos (`GizmoPlugin`) added, which the overlays draw with.
    AccelGizmos(IndexChoice),
    /// The same with Bevy's gizmos and `AccelOverlaysPlugin`, every overlay off.
    AccelOverlaysOff(IndexChoice),
}

impl Contender {
    fn label(self) -> String {
        match self {
            Self::Floor => "floor".into(),
            Self::Bevy => "bevy".into(),
            Self::Accel(index) => format!("accel/{index:?}"),
            Self::AccelGizmos(index) => format!("accel/{index:?}+gizmos"),
            Self::AccelOverlaysOff(index) => format!("accel/{index:?}+gizmos+overlays-off"),
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum CameraKind {
    Strategy,
    Ground,
}

/// Side of the square field for `n` boxes 4 units apart.
fn field_side(n: usize) -> f32 {
    (n as f32).sqrt().ceil() * 4.0
}

/// The camera's transform and frustum. Strategy: above the field's centre looking straight
/// down, high enough for about 2% of the field (a 45-degree vertical view at 16:9 covers
/// 1.22 h^2). Ground: at the middle of one edge, 3 units up, looking across with a 45-degree
/// horizontal view, which covers about 41% of a square from there.
fn camera(kind: CameraKind, side: f32) -> (Transform, Frustum) {
    let aspect = 16.0 / 9.0;
    let (transform, vertical_fov) = match kind {
        CameraKind::Strategy => {
            let height = (0.02f32 / 1.219).sqrt() * side;
            let eye = Vec3::new(side / 2.0, height, side / 2.0);
            (
                Transform::from_translation(eye).looking_at(eye - Vec3::Y, Vec3::NEG_Z),
                45f32.to_radians(),
            )
        }
        CameraKind::Ground => {
            let eye = Vec3::new(-2.0, 3.0, side / 2.0);
            let horizontal = 45f32.to_radians();
            (
                Transform::from_translation(eye).looking_at(eye + Vec3::X, Vec3::Y),
                2.0 * ((horizontal / 2.0).tan() / aspect).atan(),
            )
        }
    };
    let proj = Mat4::perspective_rh(vertical_fov, aspect, 0.1, side * 4.0);
    let view = transform.to_matrix().inverse();
    (
        transform,
        Frustum(ViewFrustum::from_clip_from_world(&(proj * view))),
    )
}

fn count_frame(mut frames: ResMut<FrameCount>) {
    frames.0 += 1;
}

fn wobble(frames: Res<FrameCount>, mut movers: Query<(&Mover, &mut Transform)>) {
    let t = frames.0 as f32 * 0.05;
    for (mover, mut transform) in &mut movers {
        let a = t + mover.phase;
        transform.translation = mover.home + Vec3::new(a.sin(), 0.0, a.cos()) * 1.5;
    }
}

fn aim_pointer(
    frames: Res<FrameCount>,
    camera: Query<&Transform, With<Camera>>,
    mut pointer: ResMut<PointerRay>,
) {
    let Ok(t) = camera.single() else {
        return;
    };
    let a = frames.0 as f32 * 0.1;
    let dir =
        t.forward().as_vec3() + (t.right().as_vec3() * a.sin() + t.up().as_vec3() * a.cos()) * 0.1;
    pointer.0 = Ray3d::new(t.translation, Dir3::new(dir).unwrap_or(Dir3::NEG_Y));
}

fn cast_pointer(mut ray_cast: AccelRayCast, pointer: Res<PointerRay>) {
    let hits = ray_cast.cast_ray_bounds(pointer.0, f32::INFINITY, &MeshRayCastSettings::default());
    std::hint::black_box(hits.len());
}

fn build_app(contender: Contender, n: usize, moving_pct: u32, kind: CameraKind) -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        AssetPlugin::default(),
        TransformPlugin,
        VisibilityPlugin,
    ))
    .init_asset::<Mesh>()
    .init_asset::<bevy::mesh::skinning::SkinnedMeshInverseBindposes>()
    .init_resource::<FrameCount>()
    .add_systems(First, count_frame)
    .add_systems(Update, wobble);
    if let Contender::AccelGizmos(_) | Contender::AccelOverlaysOff(_) = contender {
        app.add_plugins(bevy::gizmos::GizmoPlugin);
    }
    if let Contender::AccelOverlaysOff(_) = contender {
        app.add_plugins(bevy_accel::overlays::AccelOverlaysPlugin);
    }
    if let Contender::Accel(index)
    | Contender::AccelGizmos(index)
    | Contender::AccelOverlaysOff(index) = contender
    {
        app.add_plugins((
            AccelPlugin {
                settings: AccelSettings {
                    index,
                    // The choice settles within the warm-up instead of a second of frames.
                    automatic: bevy_accel::AutomaticIndexSettings {
                        hold_frames: 10,
                        ..default()
                    },
                    ..default()
                },
            },
            AccelCullingPlugin,
            AccelPickingPlugin,
        ))
        .insert_resource(PointerRay(Ray3d::new(Vec3::ZERO, Dir3::NEG_Y)))
        .add_systems(Update, (aim_pointer, cast_pointer).chain());
    }
    app.finish();
    let side = field_side(n);
    let per_row = (n as f32).sqrt().ceil() as usize;
    let movers = n * moving_pct as usize / 100;
    let mut class = VisibilityClass::default();
    class.push(TypeId::of::<Drawable>());
    let mut rng = Rng::new(0xf4a3e);
    let place = move |i: usize, rng: &mut Rng| {
        Vec3::new(
            (i % per_row) as f32 * 4.0 + rng.range(-1.0, 1.0),
            rng.range(0.5, 1.5),
            (i / per_row) as f32 * 4.0 + rng.range(-1.0, 1.0),
        )
    };
    let boxes: Vec<(Vec3, f32)> = (0..n)
        .map(|i| (place(i, &mut rng), rng.range(0.0, std::f32::consts::TAU)))
        .collect();
    let bundle = move |home: Vec3, class: &VisibilityClass| {
        (
            Transform::from_translation(home),
            Visibility::Visible,
            class.clone(),
            Drawable,
            Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
        )
    };
    let world = app.world_mut();
    // Movers spread over the whole field: every `stride`-th box.
    let stride = n.checked_div(movers).unwrap_or(usize::MAX);
    let mut moved = 0;
    for (i, &(home, phase)) in boxes.iter().enumerate() {
        if moved < movers && i % stride == 0 {
            moved += 1;
            world.spawn((bundle(home, &class), Mover { home, phase }));
        } else {
            world.spawn(bundle(home, &class));
        }
    }
    if contender != Contender::Floor {
        let (transform, frustum) = camera(kind, side);
        world.spawn((Camera::default(), transform, frustum));
    }
    app.update();
    app
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort_unstable();
    v[v.len() / 2]
}

fn visible_share(app: &mut App, contender: Contender, n: usize) -> f64 {
    let visible = match contender {
        Contender::Floor => return 0.0,
        Contender::Bevy => {
            let world = app.world_mut();
            let mut q = world.query::<&ViewVisibility>();
            q.iter(world).filter(|v| v.get()).count()
        }
        Contender::Accel(_) | Contender::AccelGizmos(_) | Contender::AccelOverlaysOff(_) => {
            app.world().resource::<CullingStats>().visible
        }
    };
    100.0 * visible as f64 / n as f64
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let sizes = list(&args, "--entities", &[100_000usize, 1_000_000]);
    let moving = list(&args, "--moving", &[0u32, 10, 25]);
    let frames = list(&args, "--frames", &[40usize])[0];
    let overlays_off = args.iter().any(|a| a == "--overlays-off");
    let cameras: Vec<CameraKind> = list(
        &args,
        "--camera",
        &["strategy".to_string(), "ground".into()],
    )
    .iter()
    .map(|c| match c.as_str() {
        "strategy" => CameraKind::Strategy,
        "ground" => CameraKind::Ground,
        other => panic!("unknown camera {other}"),
    })
    .collect();
    let indexes: Vec<IndexChoice> = list(
        &args,
        "--index",
        &["bvh".to_string(), "octree".into(), "grid".into()],
    )
    .iter()
    .map(|c| match c.as_str() {
        "bvh" => IndexChoice::Bvh,
        "octree" => IndexChoice::Octree,
        "quadtree" => IndexChoice::Quadtree,
        "grid" => IndexChoice::Grid,
        "brute" => IndexChoice::BruteForce,
        "auto" => IndexChoice::Automatic,
        other => panic!("unknown index {other}"),
    })
    .collect();
    println!(
        "| entities | moving | camera | visible (bevy / ours) | floor | bevy | index | accel | \
         whole frame bevy/accel | over the floor bevy/accel |"
    );
    println!("|---:|---:|---|---|---:|---:|---|---:|---:|---:|");
    for &n in &sizes {
        for &pct in &moving {
            for &kind in &cameras {
                let mut contenders = vec![Contender::Floor, Contender::Bevy];
                contenders.extend(indexes.iter().map(|&i| Contender::Accel(i)));
                if overlays_off {
                    for &i in &indexes {
                        contenders
                            .extend([Contender::AccelGizmos(i), Contender::AccelOverlaysOff(i)]);
                    }
                }
                let mut apps: Vec<App> = contenders
                    .iter()
                    .map(|&c| build_app(c, n, pct, kind))
                    .collect();
                // Warm-up: first rebuilds, the ray snapshot's wait, caches.
                for _ in 0..20 {
                    for app in &mut apps {
                        app.update();
                    }
                }
                // The automatic choice: until its structure is the one it recommends (a
                // switch filled off the frame lands some frames later).
                for app in &mut apps {
                    for _ in 0..400 {
                        let settled = app.world().get_resource::<AccelStats>().is_none_or(|s| {
                            s.automatic.is_none_or(|a| a.recommended == s.index)
                                && !app
                                    .world()
                                    .resource::<AccelTrees>()
                                    .index_switch_in_flight()
                        });
                        if settled {
                            break;
                        }
                        app.update();
                    }
                }
                let mut times = vec![Vec::with_capacity(frames); apps.len()];
                let mut parts = vec![[const { Vec::new() }; 3]; apps.len()];
                for _ in 0..frames {
                    for ((app, t), part) in apps.iter_mut().zip(&mut times).zip(&mut parts) {
                        let start = Instant::now();
                        app.update();
                        t.push(start.elapsed());
                        if let Some(stats) = app.world().get_resource::<AccelStats>() {
                            part[0].push(stats.sync_time);
                            part[1].push(stats.maintain_time);
                            part[2].push(app.world().resource::<CullingStats>().time);
                        }
                    }
                }
                let medians: Vec<Duration> = times.into_iter().map(median).collect();
                let ms = |d: Duration| d.as_secs_f64() * 1e3;
                for ((c, part), app) in contenders.iter().zip(parts).zip(&apps).skip(2) {
                    let [sync, maintain, culling] = part.map(median);
                    let index = app.world().resource::<AccelStats>().index;
                    eprintln!(
                        "{n} {pct}% {kind:?} {} (on {index:?}): sync {:.2} ms, maintain {:.2} ms, \
                         culling {:.2} ms (medians)",
                        c.label(),
                        ms(sync),
                        ms(maintain),
                        ms(culling)
                    );
                }
                let (floor, bevy) = (medians[0], medians[1]);
                let bevy_share = visible_share(&mut apps[1], Contender::Bevy, n);
                for (k, &c) in contenders.iter().enumerate().skip(2) {
                    let ours = medians[k];
                    let our_share = visible_share(&mut apps[k], c, n);
                    let over = |t: Duration| t.saturating_sub(floor).as_secs_f64().max(1e-6);
                    println!(
                        "| {n} | {pct}% | {kind:?} | {bevy_share:.1}% / {our_share:.1}% | \
                         {:.2} ms | {:.2} ms | {} | {:.2} ms | {:.2}x | {:.2}x |",
                        floor.as_secs_f64() * 1e3,
                        bevy.as_secs_f64() * 1e3,
                        c.label(),
                        ours.as_secs_f64() * 1e3,
                        bevy.as_secs_f64() / ours.as_secs_f64(),
                        over(bevy) / over(ours),
                    );
                }
            }
        }
    }
}
