//! The random scenes of the selection oracles: entities with meshes (3D and 2D) or flat
//! boxes, each with a rule (hidden, not pickable, another layer), the headless app that
//! selects among them, random cameras and rectangles, and the brute force's verdict for one
//! entity.

use super::{Screen, box_corners, box_triangles};
use accel_testkit::Rng;
use bevy::camera::primitives::{Aabb, MeshAabb};
use bevy::camera::visibility::RenderLayers;
use bevy::camera::{RenderTargetInfo, Viewport};
use bevy::ecs::system::RunSystemOnce;
use bevy::math::{DAffine3, DVec3};
use bevy::mesh::{Indices, VertexAttributeValues};
use bevy::picking::Pickable;
use bevy::picking::mesh_picking::ray_cast::RayCastVisibility;
use bevy::prelude::*;
use bevy_accel::prelude::*;

/// The render target's size: every camera draws into part of it.
pub const TARGET: UVec2 = UVec2::new(1280, 720);

/// How an entity of the random scene may be selected.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Rule {
    Allowed,
    Hidden,
    NotPickable,
    OtherLayer,
}

pub struct SceneEntity {
    pub entity: Entity,
    pub rule: Rule,
    pub affine: DAffine3,
    /// Local bounds.
    pub center: DVec3,
    pub half: DVec3,
    /// Local triangles (the box's faces for an entity without a mesh).
    pub triangles: Vec<[DVec3; 3]>,
}

/// The meshes of the random scenes: closed, flat, long and thin.
pub fn scene_meshes() -> Vec<Mesh> {
    vec![
        Mesh::from(Cuboid::new(1.0, 2.0, 0.5)),
        Sphere::new(1.0).mesh().uv(16, 10),
        Mesh::from(Torus::new(0.5, 1.0)),
        Mesh::from(Plane3d::new(Vec3::Y, Vec2::splat(1.0))),
        // A beam along a diagonal: its box is mostly empty.
        Mesh::from(Cuboid::new(6.0, 0.1, 0.1))
            .rotated_by(Quat::from_rotation_arc(Vec3::X, Vec3::ONE.normalize())),
        Mesh::from(Cone::default()),
    ]
}

pub fn mesh_triangles(mesh: &Mesh) -> Vec<[DVec3; 3]> {
    let Some(VertexAttributeValues::Float32x3(p)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION) else {
        panic!("positions")
    };
    let indices: Vec<usize> = match mesh.indices() {
        Some(Indices::U32(i)) => i.iter().map(|&i| i as usize).collect(),
        Some(Indices::U16(i)) => i.iter().map(|&i| i as usize).collect(),
        None => (0..p.len()).collect(),
    };
    indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]].map(|i| Vec3::from(p[i]).as_dvec3()))
        .collect()
}

/// A random scene around the origin: meshes (3D and 2D), sprite-like entities with a flat
/// `Aabb` and no mesh, some hidden, not pickable or on another layer.
pub fn populate(app: &mut App, rng: &mut Rng, n: usize) -> Vec<SceneEntity> {
    let meshes = scene_meshes();
    let handles: Vec<Handle<Mesh>> = {
        let mut assets = app.world_mut().resource_mut::<Assets<Mesh>>();
        meshes.iter().map(|m| assets.add(m.clone())).collect()
    };
    let world = app.world_mut();
    let mut out = Vec::new();
    for _ in 0..n {
        let axis = rng.vec3(-1.0, 1.0).normalize_or(Vec3::Y);
        let transform = Transform::from_translation(rng.vec3(-20.0, 20.0))
            .with_rotation(Quat::from_axis_angle(axis, rng.range(0.0, 6.3)))
            .with_scale(Vec3::new(
                rng.range(0.3, 3.0),
                rng.range(0.3, 3.0),
                rng.range(0.3, 3.0),
            ));
        let kind = rng.below(meshes.len() + 2);
        let (aabb, triangles) = if kind < meshes.len() {
            let aabb = meshes[kind].compute_aabb().unwrap();
            (aabb, mesh_triangles(&meshes[kind]))
        } else {
            // A sprite: a flat rectangle, no mesh.
            let half = Vec3::new(rng.range(0.2, 2.0), rng.range(0.2, 2.0), 0.0);
            let aabb = Aabb::from_min_max(-half, half);
            let corners = box_corners(&DAffine3::IDENTITY, DVec3::ZERO, half.as_dvec3());
            (aabb, box_triangles(&corners))
        };
        let mut e = world.spawn((transform, aabb));
        if kind < meshes.len() {
            if rng.chance(0.2) {
                e.insert(Mesh2d(handles[kind].clone()));
            } else {
                e.insert(Mesh3d(handles[kind].clone()));
            }
        }
        let rule = match rng.below(10) {
            0 => Rule::Hidden,
            1 => Rule::NotPickable,
            2 => Rule::OtherLayer,
            _ => Rule::Allowed,
        };
        match rule {
            Rule::Hidden => {
                e.insert(Visibility::Hidden);
            }
            Rule::NotPickable => {
                e.insert(Pickable::IGNORE);
            }
            Rule::OtherLayer => {
                e.insert(RenderLayers::layer(1));
            }
            Rule::Allowed => {
                if rng.chance(0.3) {
                    e.insert(Pickable::default());
                }
                if rng.chance(0.2) {
                    e.insert(RenderLayers::from_layers(&[0, 2]));
                }
            }
        }
        let affine = transform.compute_affine();
        out.push(SceneEntity {
            entity: e.id(),
            rule,
            affine: DAffine3 {
                matrix3: affine.matrix3.as_dmat3(),
                translation: affine.translation.as_dvec3(),
            },
            center: Vec3::from(aabb.center).as_dvec3(),
            half: Vec3::from(aabb.half_extents).as_dvec3(),
            triangles,
        });
    }
    out
}

/// A headless app with the selection plugin, seeing entities by `InheritedVisibility` (no
/// renderer computes `ViewVisibility` here).
pub fn app() -> App {
    let mut app = crate::common::headless_app();
    app.add_plugins((AccelPickingPlugin, AccelSelectionPlugin))
        .insert_resource(AccelSelectionSettings {
            visibility: RayCastVisibility::Visible,
            ..default()
        });
    app.finish();
    app
}

/// A random camera looking at the scene: perspective or orthographic, in a random viewport
/// of the target (most off-centre), its matrices set by hand as Bevy's camera system would.
pub fn spawn_camera(app: &mut App, rng: &mut Rng, orthographic: bool) -> (Entity, Mat4) {
    let eye = Vec3::from(rng.unit_vector()) * rng.range(8.0, 60.0);
    let up = Vec3::from(rng.unit_vector());
    let target = rng.vec3(-5.0, 5.0);
    let transform = Transform::from_translation(eye).looking_at(target, up);
    let size = UVec2::new(
        rng.range(100.0, TARGET.x as f32) as u32,
        rng.range(100.0, TARGET.y as f32) as u32,
    );
    let position = UVec2::new(
        rng.below((TARGET.x - size.x) as usize + 1) as u32,
        rng.below((TARGET.y - size.y) as usize + 1) as u32,
    );
    let aspect = size.x as f32 / size.y as f32;
    let clip_from_view = if orthographic {
        let h = rng.range(5.0, 40.0);
        let near = if rng.bool() {
            0.0
        } else {
            -rng.range(1.0, 100.0)
        };
        Mat4::orthographic_rh(-h * aspect, h * aspect, -h, h, 1000.0, near)
    } else {
        Mat4::perspective_infinite_reverse_rh(rng.range(0.4, 2.0), aspect, rng.range(0.05, 2.0))
    };
    let mut camera = Camera {
        viewport: Some(Viewport {
            physical_position: position,
            physical_size: size,
            ..default()
        }),
        ..default()
    };
    camera.computed.clip_from_view = clip_from_view;
    camera.computed.target_info = Some(RenderTargetInfo {
        physical_size: TARGET,
        scale_factor: 1.0,
    });
    let layers = RenderLayers::from_layers(&[0, 2]);
    let entity = app
        .world_mut()
        .spawn((camera, GlobalTransform::from(transform), transform, layers))
        .id();
    (entity, clip_from_view * transform.to_matrix().inverse())
}

/// A random rectangle in the target's pixels relative to the viewport: ordinary, inverted,
/// degenerate (a line, a point), tiny, off the viewport, larger than the screen.
pub fn random_rect(rng: &mut Rng, viewport: Rect) -> (Vec2, Vec2) {
    let size = viewport.size();
    let point =
        |rng: &mut Rng| viewport.min + Vec2::new(rng.range(-0.2, 1.2), rng.range(-0.2, 1.2)) * size;
    let a = point(rng);
    let mut b = point(rng);
    match rng.below(10) {
        0 => b.x = a.x,
        1 => b.y = a.y,
        2 => b = a,
        3 => b = a + Vec2::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0)),
        4 => return (viewport.min - size, viewport.max + size),
        5 => {
            let x = viewport.max.x + rng.range(1.0, 100.0);
            return (Vec2::new(x, a.y), Vec2::new(x + 50.0, b.y));
        }
        _ => {}
    }
    (a, b)
}

/// The verdict of the brute force for one entity, or `None` where a rounding band around the
/// rectangle's edges or the near plane could decide it.
pub fn expected(entity: &SceneEntity, mode: SelectionMode, screens: &[Screen; 2]) -> Option<bool> {
    let verdict = |s: &Screen| {
        let corners = box_corners(&entity.affine, entity.center, entity.half);
        let (min, max) = corners
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), &c| {
                (a.min(c), b.max(c))
            });
        match mode {
            SelectionMode::Center => s.point((min + max) * 0.5),
            SelectionMode::Enclosed => {
                let world = box_corners(&DAffine3::IDENTITY, (min + max) * 0.5, (max - min) * 0.5);
                world.iter().all(|&c| s.point(c))
            }
            SelectionMode::Touching => entity
                .triangles
                .iter()
                .any(|t| s.triangle(t.map(|p| entity.affine.transform_point3(p)))),
        }
    };
    let (wide, narrow) = (verdict(&screens[0]), verdict(&screens[1]));
    (wide == narrow).then_some(wide)
}

/// The modes in the order the tests take them round by round.
pub const MODES: [SelectionMode; 3] = [
    SelectionMode::Center,
    SelectionMode::Enclosed,
    SelectionMode::Touching,
];

/// What `AccelSelection::in_rect` selects through `camera`, sorted by entity.
pub fn select_in_rect(
    app: &mut App,
    camera: Entity,
    (a, b): (Vec2, Vec2),
    mode: SelectionMode,
) -> Vec<Entity> {
    app.world_mut()
        .run_system_once(move |mut selection: AccelSelection| {
            selection
                .in_rect(camera, a, b, mode, SelectionOrder::ByEntity)
                .unwrap()
                .to_vec()
        })
        .unwrap()
}

/// The rectangle `a`-`b` of `camera` grown and shrunk by the rounding band (see
/// [`Screen`]), or `None` when it lies off the viewport.
pub fn rect_screens(
    camera: &Camera,
    clip_from_world: Mat4,
    (a, b): (Vec2, Vec2),
) -> Option<[Screen; 2]> {
    let ndc = |p: Vec2| camera.viewport_to_ndc(p).unwrap().as_dvec2();
    let m = clip_from_world.as_dmat4();
    Some([
        Screen::new(m, ndc(a), ndc(b), 1e-4)?,
        Screen::new(m, ndc(a), ndc(b), -1e-4)?,
    ])
}
