//! A 2D scene on the quadtree: twenty thousand sprites drifting over a field much larger than
//! the view, and a ring of `Mesh2d` discs. The movers live in a loose quadtree
//! (`IndexChoice::Quadtree`); the camera culls on the trees; sprites are picked through the
//! trees by `AccelSpritePickingPlugin` and the discs by `AccelPickingPlugin`. The sprite or
//! disc under the pointer is lit and a click selects it.
//!
//! Keys: `1` the quadtree's nodes, `3` every entity's box (green seen, red culled), `I` the
//! next index choice, `F1` the panel; the mouse wheel zooms (more of the field in view means
//! more sprites drawn).
//!
//! `ACCEL_SCREENSHOT=out.png cargo run --example 2d` clicks a known sprite (a synthetic press
//! and release at its screen position), saves a frame and exits, failing unless that sprite
//! was selected and some sprites were culled.

use bevy::camera::visibility::VisibleEntities;
use bevy::diagnostic::FrameTimeDiagnosticsPlugin;
use bevy::input::mouse::MouseWheel;
use bevy::picking::pointer::{PointerId, PointerInput};
use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy_accel::prelude::*;

mod support;
use support::screenshot;

const SPRITES: usize = 20_000;
/// Half the side of the square field the sprites drift over.
const FIELD: f32 = 4_000.0;

#[derive(Component)]
struct Drift {
    velocity: Vec2,
    color: Color,
}

/// The sprite or disc under the pointer and the one last clicked.
#[derive(Resource, Default, PartialEq, Clone, Copy)]
struct Highlight {
    hovered: Option<Entity>,
    selected: Option<Entity>,
}

/// In screenshot mode, the still sprite the synthetic click aims at.
#[derive(Resource)]
struct Target(Entity, Vec3);

fn main() -> AppExit {
    App::new()
        .add_plugins((
            DefaultPlugins,
            FrameTimeDiagnosticsPlugin::default(),
            AccelPlugins
                .build()
                .set(AccelPlugin {
                    settings: AccelSettings {
                        index: IndexChoice::Quadtree,
                        ..default()
                    },
                })
                .disable::<AccelPreviewPlugin>(),
        ))
        // Bevy's own sprite backend comes with its `sprite_picking` feature and cannot be
        // removed; with markers required and none given it reports nothing, and the trees'
        // backend answers alone.
        .insert_resource(bevy::sprite::SpritePickingSettings {
            require_markers: true,
            ..default()
        })
        .init_resource::<Highlight>()
        .add_systems(Startup, setup)
        .add_systems(
            Update,
            (
                drift,
                keys_and_zoom,
                (track_hover, paint).chain(),
                synthetic_click,
                screenshot_and_exit,
            ),
        )
        .add_observer(select_on_click)
        .run()
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<ColorMaterial>>,
) {
    commands.spawn(Camera2d);
    // A seeded stream: the same field every run, so screenshots compare.
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    for i in 0..SPRITES {
        let position = Vec2::new(next() * 2.0 - 1.0, next() * 2.0 - 1.0) * FIELD;
        let color = Color::hsl(next() * 360.0, 0.6, 0.45);
        let size = Vec2::new(8.0 + next() * 24.0, 8.0 + next() * 24.0);
        let angle = next() * core::f32::consts::TAU;
        commands.spawn((
            Sprite::from_color(color, size),
            // Sprite backends pick only sprites marked `Pickable`, as Bevy's does.
            Pickable::default(),
            Transform::from_translation(position.extend(i as f32 * 1e-4)),
            Drift {
                velocity: Vec2::from_angle(angle) * (10.0 + next() * 40.0),
                color,
            },
        ));
    }
    // The target: a still sprite near the centre, drawn above the drifting ones.
    let target_at = Vec3::new(120.0, -80.0, 10.0);
    let color = Color::srgb(0.2, 0.5, 0.9);
    let target = commands
        .spawn((
            Sprite::from_color(color, Vec2::splat(40.0)),
            Pickable::default(),
            Transform::from_translation(target_at),
            Drift {
                velocity: Vec2::ZERO,
                color,
            },
            AccelStatic,
        ))
        .id();
    commands.insert_resource(Target(target, target_at));
    let disc = meshes.add(Circle::new(18.0));
    for k in 0..24 {
        let at = Vec2::from_angle(k as f32 / 24.0 * core::f32::consts::TAU) * 260.0;
        let color = Color::srgb(0.9, 0.9, 0.3);
        commands.spawn((
            Mesh2d(disc.clone()),
            MeshMaterial2d(materials.add(color)),
            Transform::from_translation(at.extend(5.0)),
            Drift {
                velocity: Vec2::ZERO,
                color,
            },
            AccelStatic,
        ));
    }
}

fn drift(time: Res<Time>, mut q: Query<(&Drift, &mut Transform)>) {
    // Screenshot mode steps by a fixed time, so that runs compare.
    let dt = if screenshot::screenshot_mode() {
        1.0 / 30.0
    } else {
        time.delta_secs()
    };
    for (d, mut tf) in &mut q {
        if d.velocity == Vec2::ZERO {
            continue;
        }
        let mut p = tf.translation.truncate() + d.velocity * dt;
        // Wrap around the field's edges.
        p = (p + FIELD).rem_euclid(Vec2::splat(2.0 * FIELD)) - FIELD;
        tf.translation = p.extend(tf.translation.z);
    }
}

fn keys_and_zoom(
    keys: Res<ButtonInput<KeyCode>>,
    mut wheel: MessageReader<MouseWheel>,
    mut overlays: ResMut<AccelOverlaySettings>,
    mut settings: ResMut<AccelSettings>,
    mut projection: Single<&mut Projection, With<Camera2d>>,
) {
    if keys.just_pressed(KeyCode::Digit1) {
        overlays.dynamic_nodes = !overlays.dynamic_nodes;
    }
    if keys.just_pressed(KeyCode::Digit3) {
        overlays.entity_bounds = !overlays.entity_bounds;
    }
    if keys.just_pressed(KeyCode::KeyI) {
        settings.index = settings.index.next();
        info!("movers now in {:?}", settings.index);
    }
    let scroll: f32 = wheel.read().map(|w| w.y).sum();
    if scroll != 0.0
        && let Projection::Orthographic(ortho) = &mut **projection
    {
        ortho.scale = (ortho.scale * (1.0 - 0.1 * scroll)).clamp(0.2, 12.0);
    }
}

/// The topmost sprite or disc among the mouse's hover hits.
fn track_hover(
    hovers: Res<bevy::picking::hover::HoverMap>,
    movers: Query<(), With<Drift>>,
    mut highlight: ResMut<Highlight>,
) {
    let hovered = hovers.get(&PointerId::Mouse).and_then(|hits| {
        hits.iter()
            .filter(|(e, _)| movers.contains(**e))
            .min_by(|a, b| a.1.depth.total_cmp(&b.1.depth))
            .map(|(e, _)| *e)
    });
    if highlight.hovered != hovered {
        highlight.hovered = hovered;
    }
}

fn select_on_click(
    click: On<Pointer<Click>>,
    movers: Query<(), With<Drift>>,
    mut highlight: ResMut<Highlight>,
) {
    if movers.contains(click.entity) {
        info!("selected {}", click.entity);
        highlight.selected = Some(click.entity);
    }
}

/// Selected white, hovered pale; the others keep their colour.
fn paint(
    highlight: Res<Highlight>,
    mut painted: Local<Highlight>,
    mut sprites: Query<(&Drift, &mut Sprite)>,
    discs: Query<(&Drift, &MeshMaterial2d<ColorMaterial>)>,
    mut materials: ResMut<Assets<ColorMaterial>>,
) {
    if *highlight == *painted {
        return;
    }
    let look = |e: Entity, base: Color| {
        if highlight.selected == Some(e) {
            Color::WHITE
        } else if highlight.hovered == Some(e) {
            base.lighter(0.25)
        } else {
            base
        }
    };
    for e in [
        painted.hovered,
        painted.selected,
        highlight.hovered,
        highlight.selected,
    ]
    .into_iter()
    .flatten()
    {
        if let Ok((d, mut sprite)) = sprites.get_mut(e) {
            sprite.color = look(e, d.color);
        } else if let Ok((d, handle)) = discs.get(e)
            && let Some(mut m) = materials.get_mut(&handle.0)
        {
            m.color = look(e, d.color);
        }
    }
    *painted = *highlight;
}

/// Screenshot mode: moves the mouse pointer over the target, then clicks it.
fn synthetic_click(
    mut frame: Local<u32>,
    window: Single<Entity, With<PrimaryWindow>>,
    camera: Single<(&Camera, &GlobalTransform)>,
    target: Res<Target>,
    mut input: MessageWriter<PointerInput>,
) {
    if !screenshot::screenshot_mode() {
        return;
    }
    *frame += 1;
    screenshot::synthetic_click(*frame, *window, *camera, target.1, &mut input);
}

/// Screenshot mode: saves frame 30, and at frame 40 exits, failing unless the target was
/// selected and the camera saw some sprites but not all.
fn screenshot_and_exit(
    mut commands: Commands,
    mut frame: Local<u32>,
    highlight: Res<Highlight>,
    target: Res<Target>,
    view: Single<&VisibleEntities, With<Camera2d>>,
    sprites: Query<(), With<Sprite>>,
    mut exit: MessageWriter<AppExit>,
) {
    if !screenshot::check_due(&mut commands, &mut frame) {
        return;
    }
    let seen = view
        .get(core::any::TypeId::of::<Sprite>())
        .iter()
        .filter(|e| sprites.contains(**e))
        .count();
    let total = sprites.iter().count();
    screenshot::exit_with(
        &mut exit,
        highlight.selected == Some(target.0) && seen > 0 && seen < total,
        format!(
            "selected {:?}, expected {}; {seen} of {total} sprites seen",
            highlight.selected, target.0
        ),
    );
}
