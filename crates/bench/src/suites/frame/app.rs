//! The frame suite's apps: the scenes (a field of wobbling boxes, a city), the cameras, the
//! pointer ray, and one app per contender built over the very same scene.

use accel_testkit::Rng;
use accel_testkit::bevy_apps::plain_bevy_app;
use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::VisibilityClass;
use bevy::math::primitives::ViewFrustum;
use bevy::picking::mesh_picking::ray_cast::MeshRayCastSettings;
use bevy::prelude::*;
use bevy_accel::AccelCullingPlugin;
use bevy_accel::prelude::*;
use std::any::TypeId;

/// The visibility class of the scene's boxes (Bevy culls per class).
#[derive(Component, Default)]
struct Drawable;

/// A box that wobbles around `home`.
#[derive(Component)]
struct Mover {
    home: Vec3,
    phase: f32,
}

/// A car of the city, driving from `start` along `velocity` (units a frame) and wrapping
/// round the city, whose side is `side`.
#[derive(Component)]
struct Car {
    start: Vec3,
    velocity: Vec3,
    side: f32,
}

/// Frames run so far: the motion follows it, so every app moves its boxes alike.
#[derive(Resource, Default)]
struct FrameCount(u32);

/// The pointer ray of the frame, from the camera along its view with a small wobble.
#[derive(Resource)]
struct PointerRay(Ray3d);

/// One app of a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Contender {
    /// Plain Bevy with no camera: what every other contender pays too.
    Floor,
    /// Plain Bevy with the camera, culled by Bevy's `check_visibility`.
    Bevy,
    /// A second plain Bevy app like [`Contender::Bevy`]: Bevy against itself, the noise of
    /// a ratio in this run.
    BevyAgain,
    /// `AccelPlugin` and `AccelCullingPlugin` alone, no pointer ray: culling is all the
    /// trees serve, so they step aside in a small world, or where Bevy's culling is timed
    /// cheaper (`AccelTrees::stepped_aside`).
    AccelNoPointer(IndexChoice),
    /// The plugins with the movers in this index.
    Accel(IndexChoice),
    /// The same with the busy movers' flat list off: every mover in the index.
    AccelBusyOff(IndexChoice),
    /// The same with Bevy's gizmos (`GizmoPlugin`) added, which the overlays draw with.
    AccelGizmos(IndexChoice),
    /// The same with Bevy's gizmos and `AccelOverlaysPlugin`, every overlay off.
    AccelOverlaysOff(IndexChoice),
    /// The plugins with bevy_egui's `EguiPlugin`, which the panel draws with.
    AccelEgui(IndexChoice),
    /// The same with `AccelPanelPlugin`, the panel closed.
    AccelPanelClosed(IndexChoice),
}

impl Contender {
    /// The name of its table column and plot method.
    pub fn label(self) -> String {
        match self {
            Self::Floor => "floor".into(),
            Self::Bevy => "bevy".into(),
            Self::BevyAgain => "bevy-again".into(),
            Self::AccelNoPointer(index) => format!("accel/{index:?}-no-pointer"),
            Self::Accel(index) => format!("accel/{index:?}"),
            Self::AccelBusyOff(index) => format!("accel/{index:?}-busy-off"),
            Self::AccelGizmos(index) => format!("accel/{index:?}+gizmos"),
            Self::AccelOverlaysOff(index) => format!("accel/{index:?}+gizmos+overlays-off"),
            Self::AccelEgui(index) => format!("accel/{index:?}+egui"),
            Self::AccelPanelClosed(index) => format!("accel/{index:?}+egui+panel-closed"),
        }
    }

    /// Whether the app has the plugins (and so their statistics).
    pub fn is_accel(self) -> bool {
        matches!(
            self,
            Self::Accel(_)
                | Self::AccelNoPointer(_)
                | Self::AccelBusyOff(_)
                | Self::AccelGizmos(_)
                | Self::AccelOverlaysOff(_)
                | Self::AccelEgui(_)
                | Self::AccelPanelClosed(_)
        )
    }
}

/// Where the camera looks from.
#[derive(Clone, Copy, Debug)]
pub enum CameraKind {
    /// Straight down from above the field's centre, about 2% of it in view.
    Strategy,
    /// From the middle of one edge across the field, about 40% of it in view.
    Ground,
}

/// What stands in a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// Unit boxes on a square field 4 units apart, none marked static, a share wobbling.
    Field,
    /// A city on the same square: half the entities buildings of mixed sizes marked
    /// `AccelStatic`, a quarter small parked props (not marked), a quarter cars driving in
    /// straight lines every frame, and four huge ground tiles (static).
    City,
}

/// One scene: the boxes, the share of them that moves, and the camera.
#[derive(Clone, Copy, Debug)]
pub struct Scene {
    /// What stands on the square.
    pub layout: Layout,
    /// Entities in the scene.
    pub entities: usize,
    /// Percent of them that move every frame (the city's cars: a quarter).
    pub moving_pct: u32,
    /// The camera.
    pub camera: CameraKind,
}

/// Side of the square field for `n` boxes 4 units apart.
fn field_side(n: usize) -> f32 {
    (n as f32).sqrt().ceil() * 4.0
}

/// The camera's transform and frustum. Strategy: high enough for about 2% of the field (a
/// 45-degree vertical view at 16:9 covers 1.22 h^2). Ground: 3 units up with a 45-degree
/// horizontal view, which covers about 41% of a square from the middle of its edge.
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

fn drive(frames: Res<FrameCount>, mut cars: Query<(&Car, &mut Transform)>) {
    let t = frames.0 as f32;
    for (car, mut transform) in &mut cars {
        let p = car.start + car.velocity * t;
        transform.translation = Vec3::new(p.x.rem_euclid(car.side), p.y, p.z.rem_euclid(car.side));
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

/// A hover test's cost: bounds only, as a game's pointer over boxes would use.
fn cast_pointer(mut ray_cast: AccelRayCast, pointer: Res<PointerRay>) {
    let hits = ray_cast.cast_ray_bounds(pointer.0, f32::INFINITY, &MeshRayCastSettings::default());
    std::hint::black_box(hits.len());
}

/// The plugin's settings in every accel app: the defaults, with the movers in `index` and
/// the busy movers' list in `busy` mode.
fn accel_settings(index: IndexChoice, busy: BusyMovers) -> AccelSettings {
    AccelSettings {
        index,
        // The automatic choice settles within the warm-up rather than after a second of
        // frames; its thresholds are the defaults.
        automatic: bevy_accel::AutomaticIndexSettings {
            hold_frames: 10,
            ..default()
        },
        busy_movers: BusyMoverSettings {
            mode: busy,
            ..default()
        },
        ..default()
    }
}

/// The app of `contender` over `scene`, finished and updated once (the boxes spawned and
/// propagated). Every app draws the same boxes from the same seed, so all of a scene's apps
/// hold the same world.
pub fn build_app(contender: Contender, scene: Scene) -> App {
    let n = scene.entities;
    let mut app = plain_bevy_app();
    app.init_resource::<FrameCount>()
        .add_systems(First, count_frame)
        .add_systems(Update, (wobble, drive));
    if let Contender::AccelGizmos(_) | Contender::AccelOverlaysOff(_) = contender {
        app.add_plugins(bevy::gizmos::GizmoPlugin);
    }
    if let Contender::AccelOverlaysOff(_) = contender {
        app.add_plugins(bevy_accel::overlays::AccelOverlaysPlugin);
    }
    if let Contender::AccelEgui(_) | Contender::AccelPanelClosed(_) = contender {
        // What `DefaultPlugins` would bring for bevy_egui: input and window messages (no
        // window is opened), shader and texture assets. No egui context: with no renderer
        // to take its textures, egui's output could not be consumed, so the egui pass has
        // nothing to run and what remains is each plugin's per-frame systems.
        app.insert_resource(bevy_accel::panel::bevy_egui::EguiGlobalSettings {
            auto_create_primary_context: false,
            ..default()
        })
        .init_asset::<bevy::shader::Shader>()
        .init_asset::<Image>()
        .add_plugins((
            bevy::input::InputPlugin,
            bevy::window::WindowPlugin {
                primary_window: None,
                exit_condition: bevy::window::ExitCondition::DontExit,
                ..default()
            },
            bevy_accel::panel::bevy_egui::EguiPlugin::default(),
        ));
    }
    if let Contender::AccelPanelClosed(_) = contender {
        app.insert_resource(bevy_accel::panel::AccelPanelSettings {
            open: false,
            ..default()
        })
        .add_plugins(bevy_accel::panel::AccelPanelPlugin);
    }
    if let Contender::AccelNoPointer(index) = contender {
        app.add_plugins((
            AccelPlugin {
                settings: accel_settings(index, BusyMovers::default()),
            },
            AccelCullingPlugin,
        ));
    }
    if let Contender::Accel(index)
    | Contender::AccelBusyOff(index)
    | Contender::AccelGizmos(index)
    | Contender::AccelOverlaysOff(index)
    | Contender::AccelEgui(index)
    | Contender::AccelPanelClosed(index) = contender
    {
        let busy = if matches!(contender, Contender::AccelBusyOff(_)) {
            BusyMovers::Off
        } else {
            BusyMovers::default()
        };
        app.add_plugins((
            AccelPlugin {
                settings: accel_settings(index, busy),
            },
            AccelCullingPlugin,
            AccelPickingPlugin,
        ))
        .insert_resource(PointerRay(Ray3d::new(Vec3::ZERO, Dir3::NEG_Y)))
        .add_systems(Update, (aim_pointer, cast_pointer).chain());
    }
    app.finish();
    let side = field_side(n);
    let mut class = VisibilityClass::default();
    class.push(TypeId::of::<Drawable>());
    match scene.layout {
        Layout::Field => spawn_field(app.world_mut(), &class, n, scene.moving_pct),
        Layout::City => spawn_city(app.world_mut(), &class, n, side),
    }
    let world = app.world_mut();
    if contender != Contender::Floor {
        let (transform, frustum) = camera(scene.camera, side);
        world.spawn((Camera::default(), transform, frustum));
    }
    app.update();
    app
}

/// What every box of a scene is drawn with.
fn drawable(class: &VisibilityClass, at: Transform, half: Vec3) -> impl Bundle {
    (
        at,
        Visibility::Visible,
        class.clone(),
        Drawable,
        Aabb::from_min_max(-half, half),
    )
}

/// The field: unit boxes on a square 4 units apart with a jitter, `moving_pct` percent of
/// them (spread over the whole field) wobbling.
fn spawn_field(world: &mut World, class: &VisibilityClass, n: usize, moving_pct: u32) {
    let per_row = (n as f32).sqrt().ceil() as usize;
    let movers = n * moving_pct as usize / 100;
    let mut rng = Rng::new(0xf4a3e);
    let boxes: Vec<(Vec3, f32)> = (0..n)
        .map(|i| {
            let home = Vec3::new(
                (i % per_row) as f32 * 4.0 + rng.range(-1.0, 1.0),
                rng.range(0.5, 1.5),
                (i / per_row) as f32 * 4.0 + rng.range(-1.0, 1.0),
            );
            (home, rng.range(0.0, std::f32::consts::TAU))
        })
        .collect();
    // Movers spread over the whole field: every `stride`-th box.
    let stride = n.checked_div(movers).unwrap_or(usize::MAX);
    let mut moved = 0;
    for (i, &(home, phase)) in boxes.iter().enumerate() {
        let bundle = drawable(class, Transform::from_translation(home), Vec3::splat(0.5));
        if moved < movers && i % stride == 0 {
            moved += 1;
            world.spawn((bundle, Mover { home, phase }));
        } else {
            world.spawn(bundle);
        }
    }
}

/// The city on a square of side `side`: four ground tiles, then half the rest buildings
/// (widths 2 to 24 units, heights 3 to 60, scattered, overlapping where they fall), a
/// quarter parked props (under a unit) and a quarter cars (2 by 4 units, driving at up to
/// half a unit a frame along x or z).
fn spawn_city(world: &mut World, class: &VisibilityClass, n: usize, side: f32) {
    let mut rng = Rng::new(0xc17e);
    let tiles = n.min(4);
    for i in 0..tiles {
        let centre = Vec3::new(
            (i % 2) as f32 * side / 2.0 + side / 4.0,
            -0.5,
            (i / 2) as f32 * side / 2.0 + side / 4.0,
        );
        let half = Vec3::new(side / 4.0, 0.5, side / 4.0);
        world.spawn((
            drawable(class, Transform::from_translation(centre), half),
            AccelStatic,
        ));
    }
    let rest = n - tiles;
    let buildings = rest / 2;
    let props = rest / 4;
    let cars = rest - buildings - props;
    for _ in 0..buildings {
        let half = Vec3::new(
            rng.log_range(1.0, 12.0),
            rng.log_range(1.5, 30.0),
            rng.log_range(1.0, 12.0),
        );
        let at = Vec3::new(rng.range(0.0, side), half.y, rng.range(0.0, side));
        world.spawn((
            drawable(class, Transform::from_translation(at), half),
            AccelStatic,
        ));
    }
    for _ in 0..props {
        let half = Vec3::splat(rng.range(0.15, 0.5));
        let at = Vec3::new(rng.range(0.0, side), half.y, rng.range(0.0, side));
        world.spawn(drawable(class, Transform::from_translation(at), half));
    }
    for _ in 0..cars {
        let start = Vec3::new(rng.range(0.0, side), 0.75, rng.range(0.0, side));
        let speed = rng.range(0.05, 0.5) * if rng.bool() { 1.0 } else { -1.0 };
        let along_x = rng.bool();
        let (velocity, half) = if along_x {
            (Vec3::X * speed, Vec3::new(2.0, 0.75, 1.0))
        } else {
            (Vec3::Z * speed, Vec3::new(1.0, 0.75, 2.0))
        };
        world.spawn((
            drawable(class, Transform::from_translation(start), half),
            Car {
                start,
                velocity,
                side,
            },
        ));
    }
}

/// Percent of the scene's boxes in view after the app's last frame, by their
/// `ViewVisibility` (which Bevy's culling and ours both write); `None` for the floor, which
/// has no camera.
pub fn visible_share(app: &mut App, contender: Contender, n: usize) -> Option<f64> {
    if contender == Contender::Floor {
        return None;
    }
    let world = app.world_mut();
    let mut q = world.query_filtered::<&ViewVisibility, With<Drawable>>();
    let visible = q.iter(world).filter(|v| v.get()).count();
    Some(100.0 * visible as f64 / n.max(1) as f64)
}
