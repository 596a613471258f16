//! Intersecting transparent surfaces in the exact order of a BSP tree (`spatial_accel::bsp`), beside
//! Bevy's own order. Bevy sorts transparent meshes by their centres, which no order of whole
//! meshes can get right when they cross each other: on the right, three crossing quads and
//! three cyclically overlapping sticks are each a mesh of their own, sorted by Bevy. On the
//! left the same triangles are one mesh, cut by a polygon-aligned BSP tree where they cross,
//! and its index buffer is rewritten back to front from the camera whenever the camera
//! moves: every piece is blended over everything behind it.
//!
//! The two halves of the window show the two copies from the same relative viewpoint.
//! Keys: arrows orbit both cameras.
//!
//! `ACCEL_SCREENSHOT=out.png cargo run --example transparency` saves a frame and exits,
//! failing unless the BSP order was rewritten after the camera moved; `.ci/real-window`
//! checks that the two halves differ.

use bevy::asset::RenderAssetUsages;
use bevy::camera::Viewport;
use bevy::camera::visibility::RenderLayers;
use bevy::math::Vec3A;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::window::PrimaryWindow;
use bevy_accel::prelude::*;
use spatial_accel::bsp::BspTree;

mod support;
use support::screenshot;

/// How far apart the two copies stand (each is seen by its own camera on its own layer).
const APART: f32 = 100.0;

/// The BSP copy: its tree and the pieces' first vertex index in the mesh.
#[derive(Component)]
struct BspOrdered {
    tree: BspTree,
    /// The eye (in the mesh's space) the index buffer was last ordered for.
    ordered_for: Option<Vec3>,
    /// Times the order was rewritten.
    rewrites: u32,
}

#[derive(Component)]
struct Orbit {
    yaw: f32,
    pitch: f32,
    /// The copy this camera looks at.
    centre: Vec3,
}

/// The scene's triangles, each with its colour: three quads crossing at the origin, and
/// three sticks each lying over the next (no order of whole sticks is right).
fn triangles() -> Vec<([Vec3; 3], Color)> {
    let mut out = Vec::new();
    let mut quad = |corners: [Vec3; 4], colour: Color| {
        out.push(([corners[0], corners[1], corners[2]], colour));
        out.push(([corners[0], corners[2], corners[3]], colour));
    };
    let s = 2.0;
    quad(
        [
            Vec3::new(-s, -s, 0.0),
            Vec3::new(s, -s, 0.0),
            Vec3::new(s, s, 0.0),
            Vec3::new(-s, s, 0.0),
        ],
        Color::srgba(0.95, 0.2, 0.2, 0.55),
    );
    quad(
        [
            Vec3::new(0.0, -s, -s),
            Vec3::new(0.0, -s, s),
            Vec3::new(0.0, s, s),
            Vec3::new(0.0, s, -s),
        ],
        Color::srgba(0.2, 0.9, 0.3, 0.55),
    );
    quad(
        [
            Vec3::new(-s, 0.3, -s),
            Vec3::new(-s, 0.3, s),
            Vec3::new(s, -0.3, s),
            Vec3::new(s, -0.3, -s),
        ],
        Color::srgba(0.25, 0.4, 0.95, 0.55),
    );
    // The sticks, each tilted so that it passes over the next one's end and under the
    // previous one's: a cycle.
    let colours = [
        Color::srgba(1.0, 0.85, 0.2, 0.6),
        Color::srgba(0.9, 0.3, 0.9, 0.6),
        Color::srgba(0.2, 0.9, 0.9, 0.6),
    ];
    for (k, colour) in colours.into_iter().enumerate() {
        let angle = k as f32 * core::f32::consts::TAU / 3.0;
        let along = Vec3::new(angle.cos(), 0.0, angle.sin());
        let across = Vec3::new(-along.z, 0.0, along.x) * 0.35;
        let centre = Vec3::new(0.0, -3.2, 0.0) + along.cross(Vec3::Y) * 0.6;
        let (a, b) = (centre - along * 2.2, centre + along * 2.2);
        let lift = Vec3::Y * 0.25;
        quad(
            [
                a - across - lift,
                b - across + lift,
                b + across + lift,
                a + across - lift,
            ],
            colour,
        );
    }
    out
}

/// A mesh of separate triangles (three vertices each), with colours.
fn mesh_of(tris: &[([Vec3; 3], Color)]) -> Mesh {
    let positions: Vec<[f32; 3]> = tris
        .iter()
        .flat_map(|(t, _)| t.map(|v| v.to_array()))
        .collect();
    let colours: Vec<[f32; 4]> = tris
        .iter()
        .flat_map(|(_, c)| [c.to_linear().to_f32_array(); 3])
        .collect();
    let normals: Vec<[f32; 3]> = tris
        .iter()
        .flat_map(|(t, _)| {
            let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
            [n.to_array(); 3]
        })
        .collect();
    Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
    .with_inserted_attribute(Mesh::ATTRIBUTE_NORMAL, normals)
    .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, colours)
    .with_inserted_indices(Indices::U32((0..tris.len() as u32 * 3).collect()))
}

fn main() -> AppExit {
    App::new()
        .add_plugins(DefaultPlugins)
        .insert_resource(ClearColor(Color::srgb(0.08, 0.08, 0.1)))
        .add_systems(Startup, setup)
        .add_systems(
            Update,
            (orbit, split_viewports, order_bsp_mesh, screenshot_and_exit).chain(),
        )
        .run()
}

fn setup(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    let tris = triangles();
    let material = materials.add(StandardMaterial {
        base_color: Color::WHITE,
        alpha_mode: AlphaMode::Blend,
        unlit: true,
        double_sided: true,
        cull_mode: None,
        ..default()
    });
    // Left: one mesh of the BSP's pieces, each with its source triangle's colour.
    let vertices: Vec<Vec3> = tris.iter().flat_map(|(t, _)| *t).collect();
    let indices: Vec<u32> = (0..vertices.len() as u32).collect();
    let tree = BspTree::new(&vertices, &indices).expect("a valid mesh");
    let pieces: Vec<([Vec3; 3], Color)> = tree
        .pieces()
        .iter()
        .map(|p| (p.vertices.map(Vec3::from), tris[p.source as usize].1))
        .collect();
    info!(
        "{} triangles cut into {} pieces by the BSP",
        tris.len(),
        pieces.len()
    );
    commands.spawn((
        Mesh3d(meshes.add(mesh_of(&pieces))),
        MeshMaterial3d(material.clone()),
        Transform::default(),
        RenderLayers::layer(1),
        BspOrdered {
            tree,
            ordered_for: None,
            rewrites: 0,
        },
    ));
    // Right: each quad and stick a mesh of its own, which Bevy sorts by centre.
    for pair in tris.chunks(2) {
        let centre = pair.iter().flat_map(|(t, _)| *t).sum::<Vec3>() / 6.0;
        let local: Vec<([Vec3; 3], Color)> = pair
            .iter()
            .map(|(t, c)| (t.map(|v| v - centre), *c))
            .collect();
        commands.spawn((
            Mesh3d(meshes.add(mesh_of(&local))),
            MeshMaterial3d(material.clone()),
            Transform::from_translation(centre + Vec3::X * APART),
            RenderLayers::layer(2),
        ));
    }
    for (order, centre, layer) in [(0, Vec3::ZERO, 1), (1, Vec3::X * APART, 2)] {
        commands.spawn((
            Camera3d::default(),
            Camera { order, ..default() },
            Transform::default(),
            RenderLayers::layer(layer),
            Orbit {
                yaw: 0.6,
                pitch: 0.35,
                centre,
            },
        ));
    }
}

fn orbit(
    keys: Res<ButtonInput<KeyCode>>,
    time: Res<Time>,
    mut frame: Local<u32>,
    mut cameras: Query<(&mut Orbit, &mut Transform)>,
) {
    *frame += 1;
    let step = if screenshot::screenshot_mode() {
        // A fixed nudge at frame 10: the order must follow it.
        if *frame == 10 { 0.4 } else { 0.0 }
    } else {
        time.delta_secs()
    };
    for (mut orbit, mut tf) in &mut cameras {
        if keys.pressed(KeyCode::ArrowLeft) {
            orbit.yaw -= step;
        }
        if keys.pressed(KeyCode::ArrowRight) || screenshot::screenshot_mode() {
            orbit.yaw += step;
        }
        if keys.pressed(KeyCode::ArrowUp) {
            orbit.pitch = (orbit.pitch + step).min(1.4);
        }
        if keys.pressed(KeyCode::ArrowDown) {
            orbit.pitch = (orbit.pitch - step).max(-1.4);
        }
        let offset = Quat::from_euler(EulerRot::YXZ, orbit.yaw, -orbit.pitch, 0.0) * Vec3::Z;
        let wanted = Transform::from_translation(orbit.centre + offset * 9.0)
            .looking_at(orbit.centre - Vec3::Y * 0.6, Vec3::Y);
        if *tf != wanted {
            *tf = wanted;
        }
    }
}

/// Each camera gets one half of the window.
fn split_viewports(
    window: Single<&Window, With<PrimaryWindow>>,
    mut cameras: Query<(&mut Camera, &Orbit)>,
) {
    let size = window.physical_size();
    let half = UVec2::new(size.x / 2, size.y).max(UVec2::ONE);
    for (mut camera, orbit) in &mut cameras {
        let left = orbit.centre == Vec3::ZERO;
        let position = UVec2::new(if left { 0 } else { size.x / 2 }, 0);
        if camera
            .viewport
            .as_ref()
            .is_none_or(|v| v.physical_position != position || v.physical_size != half)
        {
            camera.viewport = Some(Viewport {
                physical_position: position,
                physical_size: half,
                ..default()
            });
        }
    }
}

/// Rewrites the BSP mesh's index buffer back to front whenever its camera moved.
fn order_bsp_mesh(
    cameras: Query<(&GlobalTransform, &Orbit)>,
    mut bsp: Single<(&Mesh3d, &GlobalTransform, &mut BspOrdered)>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut order: Local<Vec<u32>>,
) {
    let (mesh, mesh_tf, state) = &mut *bsp;
    let Some((eye, _)) = cameras.iter().find(|(_, o)| o.centre == Vec3::ZERO) else {
        return;
    };
    let eye = mesh_tf
        .affine()
        .inverse()
        .transform_point3(eye.translation());
    if state.ordered_for == Some(eye) {
        return;
    }
    order.clear();
    state.tree.back_to_front(Vec3A::from(eye), &mut order);
    if let Some(mut mesh) = meshes.get_mut(&mesh.0) {
        let indices: Vec<u32> = order
            .iter()
            .flat_map(|&p| [3 * p, 3 * p + 1, 3 * p + 2])
            .collect();
        mesh.insert_indices(Indices::U32(indices));
    }
    state.ordered_for = Some(eye);
    state.rewrites += 1;
}

/// Screenshot mode: saves frame 30 and exits at frame 40, failing unless the order was
/// rewritten for the moved camera (once at the start, once after the nudge).
fn screenshot_and_exit(
    mut commands: Commands,
    mut frame: Local<u32>,
    bsp: Single<&BspOrdered>,
    mut exit: MessageWriter<AppExit>,
) {
    if !screenshot::check_due(&mut commands, &mut frame) {
        return;
    }
    screenshot::exit_with(
        &mut exit,
        bsp.rewrites >= 2,
        format!("the BSP order was written {} times", bsp.rewrites),
    );
}
