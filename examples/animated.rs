//! Pick what is drawn: skinned characters (`assets/character.glb`, through Bevy's glTF
//! loader) walk in circles, played by Bevy's `AnimationPlayer`. Hovering a character lights
//! it, a click selects it: `AccelPickingPlugin` tests each skinned mesh at its posed
//! vertices (a swinging arm is hit where it is drawn, not where the bind pose left it),
//! through a triangle BVH per character refit only when a ray reaches it.
//!
//! `ACCEL_SCREENSHOT=out.png cargo run --example animated` holds the characters still in
//! mid-stride, clicks a swinging limb where Bevy's `MeshRayCast` (which tests the bind
//! pose) finds nothing of that character (a synthetic press and release at its screen
//! position), saves a frame and exits, failing unless that character was selected.

use bevy::mesh::skinning::SkinnedMesh;
use bevy::picking::mesh_picking::ray_cast::{MeshRayCast, MeshRayCastSettings, RayMeshHit};
use bevy::picking::pointer::PointerInput;
use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy::world_serialization::WorldInstanceReady;
use bevy_accel::prelude::*;

mod support;
use support::screenshot;

/// Characters on the circle.
const CHARACTERS: usize = 24;
/// The time of the walk cycle the screenshot mode holds (an arm swung well forward).
const HELD_AT: f32 = 0.25;

/// The walk, shared by every character.
#[derive(Resource)]
struct Walk {
    graph: Handle<AnimationGraph>,
    index: AnimationNodeIndex,
}

/// A character's root: its place on the circle and its phase in the walk.
#[derive(Component)]
struct Walker {
    angle: f32,
    phase: f32,
    /// The character's own material (its skinned mesh's, once the scene has spawned).
    material: Handle<StandardMaterial>,
}

/// Which character is hovered and which selected (their skinned mesh entities).
#[derive(Resource, Default)]
struct Picked {
    hovered: Option<Entity>,
    selected: Option<Entity>,
}

fn main() -> AppExit {
    App::new()
        .add_plugins(DefaultPlugins)
        .add_plugins(
            AccelPlugins
                .build()
                .disable::<AccelSpritePickingPlugin>()
                .disable::<AccelOverlaysPlugin>()
                .disable::<AccelPreviewPlugin>()
                .disable::<AccelPanelPlugin>(),
        )
        .init_resource::<Picked>()
        .add_systems(Startup, setup)
        .add_systems(
            Update,
            (walk_in_circles, colour_characters, check_in_screenshot_mode),
        )
        .add_observer(hover)
        .add_observer(unhover)
        .add_observer(select)
        .run()
}

fn setup(
    mut commands: Commands,
    assets: Res<AssetServer>,
    mut graphs: ResMut<Assets<AnimationGraph>>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let (graph, index) = AnimationGraph::from_clip(
        assets.load(GltfAssetLabel::Animation(0).from_asset("character.glb")),
    );
    commands.insert_resource(Walk {
        graph: graphs.add(graph),
        index,
    });
    let scene = assets.load(GltfAssetLabel::Scene(0).from_asset("character.glb"));
    for i in 0..CHARACTERS {
        let angle = i as f32 / CHARACTERS as f32 * std::f32::consts::TAU;
        let material = materials.add(Color::hsl(360.0 * i as f32 / CHARACTERS as f32, 0.45, 0.5));
        commands
            .spawn((
                WorldAssetRoot(scene.clone()),
                Transform::default(),
                Walker {
                    angle,
                    phase: (i as f32 * 0.37).fract(),
                    material,
                },
            ))
            .observe(start_walking);
    }
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(40.0, 40.0))),
        MeshMaterial3d(materials.add(Color::srgb(0.35, 0.42, 0.35))),
        // The ground is not what a click is for.
        Pickable::IGNORE,
    ));
    commands.spawn((
        DirectionalLight {
            shadow_maps_enabled: false,
            ..default()
        },
        Transform::from_xyz(4.0, 10.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(0.0, 5.5, 11.0).looking_at(Vec3::new(0.0, 0.8, 0.0), Vec3::Y),
    ));
}

/// Once a character's scene has spawned: its animation player plays the walk from the
/// character's phase (held in mid-stride in screenshot mode), and its mesh gets the
/// character's own material, so that it can be lit on its own.
fn start_walking(
    ready: On<WorldInstanceReady>,
    mut commands: Commands,
    walk: Res<Walk>,
    walkers: Query<&Walker>,
    children: Query<&Children>,
    mut players: Query<&mut AnimationPlayer>,
    skinned: Query<(), With<SkinnedMesh>>,
) {
    let Ok(walker) = walkers.get(ready.entity) else {
        return;
    };
    for child in children.iter_descendants(ready.entity) {
        if let Ok(mut player) = players.get_mut(child) {
            let held = screenshot::screenshot_mode();
            let phase = if held { HELD_AT } else { walker.phase };
            player.play(walk.index).repeat().seek_to(phase);
            if held {
                player.pause_all();
            }
            commands
                .entity(child)
                .insert(AnimationGraphHandle(walk.graph.clone()));
        }
        if skinned.contains(child) {
            commands
                .entity(child)
                .insert(MeshMaterial3d(walker.material.clone()));
        }
    }
}

/// Moves each character along the circle, facing the way it walks (they stand still in
/// screenshot mode).
fn walk_in_circles(time: Res<Time>, mut walkers: Query<(&mut Transform, &Walker)>) {
    let still = screenshot::screenshot_mode();
    for (mut transform, walker) in &mut walkers {
        let angle = walker.angle
            + if still {
                0.0
            } else {
                0.12 * time.elapsed_secs()
            };
        let radius = 5.0;
        transform.translation = Vec3::new(radius * angle.cos(), 0.0, radius * angle.sin());
        // The character faces +z; walking counter-clockwise, its heading is the tangent.
        transform.rotation = Quat::from_rotation_y(-angle);
    }
}

fn hover(
    over: On<Pointer<Over>>,
    mut picked: ResMut<Picked>,
    skinned: Query<(), With<SkinnedMesh>>,
) {
    if skinned.contains(over.entity) {
        picked.hovered = Some(over.entity);
    }
}

fn unhover(out: On<Pointer<Out>>, mut picked: ResMut<Picked>) {
    if picked.hovered == Some(out.entity) {
        picked.hovered = None;
    }
}

fn select(
    click: On<Pointer<Click>>,
    mut picked: ResMut<Picked>,
    skinned: Query<(), With<SkinnedMesh>>,
) {
    if skinned.contains(click.entity) {
        info!("selected {} at {:?}", click.entity, click.hit.position);
        picked.selected = Some(click.entity);
    }
}

/// Tints each character: its own colour, lighter when hovered, orange when selected.
fn colour_characters(
    picked: Res<Picked>,
    characters: Query<(Entity, &MeshMaterial3d<StandardMaterial>), With<SkinnedMesh>>,
    walkers: Query<&Walker>,
    parents: Query<&ChildOf>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    if !picked.is_changed() {
        return;
    }
    for (entity, material) in &characters {
        let Some(walker) = parents
            .iter_ancestors(entity)
            .find_map(|a| walkers.get(a).ok())
        else {
            continue;
        };
        let i = walkers
            .iter()
            .position(|w| w.material == walker.material)
            .unwrap_or(0);
        let base = Color::hsl(360.0 * i as f32 / CHARACTERS as f32, 0.45, 0.5);
        let colour = if picked.selected == Some(entity) {
            Color::srgb(1.0, 0.55, 0.1)
        } else if picked.hovered == Some(entity) {
            base.lighter(0.25)
        } else {
            base
        };
        if let Some(mut m) = materials.get_mut(&material.0) {
            m.base_color = colour;
        }
    }
}

/// Screenshot mode: clicks a limb that the pose moved away from its bind pose (on the
/// nearest character that has one in view, held in mid-stride), saves a frame, and exits
/// with an error unless that character was selected.
// A system's parameters are its dependencies; bundling them would only hide them.
#[allow(clippy::too_many_arguments)]
fn check_in_screenshot_mode(
    mut commands: Commands,
    mut frame: Local<u32>,
    mut settled: Local<u32>,
    mut target: Local<Option<(Entity, Vec3)>>,
    window: Single<Entity, With<PrimaryWindow>>,
    camera: Single<(&Camera, &GlobalTransform)>,
    joints: Query<(&Name, &GlobalTransform, &ChildOf)>,
    skinned: Query<(Entity, &SkinnedMesh)>,
    picked: Res<Picked>,
    mut ours: AccelRayCast,
    mut bevy_ray_cast: MeshRayCast,
    mut input: MessageWriter<PointerInput>,
    mut exit: MessageWriter<AppExit>,
) {
    if !screenshot::screenshot_mode() {
        return;
    }
    let (camera, camera_tf) = *camera;
    // Wait for every character's scene and pose, then aim once.
    if target.is_none() {
        if skinned.iter().count() < CHARACTERS {
            return;
        }
        // A few frames for the players to pose the joints.
        *settled += 1;
        if *settled < 5 {
            return;
        }
        // Points along each character's limbs (a bone extended past its joint, where the
        // next segment of a swinging arm or leg lies), nearest characters first: the first
        // that our ray cast hits on its character while Bevy's bind-pose test does not is
        // clicked, so the check shows the posed mesh picked where only the pose put it.
        let eye = camera_tf.translation();
        let mut candidates: Vec<(Entity, Vec3)> = Vec::new();
        for (mesh, skin) in &skinned {
            for &joint in &skin.joints {
                let Ok((_, at, parent)) = joints.get(joint) else {
                    continue;
                };
                let Ok((_, parent_at, _)) = joints.get(parent.parent()) else {
                    continue;
                };
                let (a, b) = (parent_at.translation(), at.translation());
                candidates.push((mesh, b + (b - a) * 0.6));
            }
        }
        candidates.sort_by(|a, b| a.1.distance(eye).total_cmp(&b.1.distance(eye)));
        let settings = MeshRayCastSettings::default();
        let first = |hits: &[(Entity, RayMeshHit)]| hits.first().map(|(e, _)| *e);
        *target = candidates.iter().copied().find(|&(mesh, point)| {
            let Ok(dir) = Dir3::new(point - eye) else {
                return false;
            };
            let ray = Ray3d::new(eye, dir);
            first(ours.cast_ray(ray, &settings)) == Some(mesh)
                && first(bevy_ray_cast.cast_ray(ray, &settings)) != Some(mesh)
        });
        match *target {
            Some((mesh, _)) => {
                info!("aiming at a limb of {mesh} that Bevy's MeshRayCast (the bind pose) misses")
            }
            None => {
                error!("no limb drawn outside its bind pose in view");
                exit.write(AppExit::error());
            }
        }
        return;
    }
    let Some((mesh, point)) = *target else { return };
    if screenshot::check_due(&mut commands, &mut frame) {
        screenshot::exit_with(
            &mut exit,
            picked.selected == Some(mesh),
            format!("selected {:?}, expected {mesh}", picked.selected),
        );
        return;
    }
    screenshot::synthetic_click(*frame, *window, (camera, camera_tf), point, &mut input);
}
