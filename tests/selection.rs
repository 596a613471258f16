//! `AccelSelection` against the brute force a game would write with Bevy alone (project every
//! triangle or every box corner), on random scenes, cameras (perspective and orthographic,
//! off-centre viewports) and rectangles (degenerate, inverted, off the screen, larger than
//! it); and the rules (hidden, non-pickable, other render layers) and the mouse.

use accel_testkit::Rng;
use bevy::camera::primitives::{Aabb, MeshAabb};
use bevy::camera::visibility::RenderLayers;
use bevy::camera::{RenderTargetInfo, Viewport};
use bevy::ecs::system::RunSystemOnce;
use bevy::math::bounding::BoundingSphere;
use bevy::math::{DAffine3, DVec3};
use bevy::mesh::{Indices, VertexAttributeValues};
use bevy::picking::Pickable;
use bevy::picking::mesh_picking::ray_cast::RayCastVisibility;
use bevy::prelude::*;
use bevy_accel::prelude::*;

mod common;
mod selection_oracle;
use selection_oracle::{Screen, box_corners, box_triangles};

/// The render target's size: every camera draws into part of it.
const TARGET: UVec2 = UVec2::new(1280, 720);

/// How an entity of the random scene may be selected.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Rule {
    Allowed,
    Hidden,
    NotPickable,
    OtherLayer,
}

struct SceneEntity {
    entity: Entity,
    rule: Rule,
    affine: DAffine3,
    /// Local bounds.
    center: DVec3,
    half: DVec3,
    /// Local triangles (the box's faces for an entity without a mesh).
    triangles: Vec<[DVec3; 3]>,
}

/// The meshes of the random scenes: closed, flat, long and thin.
fn scene_meshes() -> Vec<Mesh> {
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

fn mesh_triangles(mesh: &Mesh) -> Vec<[DVec3; 3]> {
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
fn populate(app: &mut App, rng: &mut Rng, n: usize) -> Vec<SceneEntity> {
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
fn app() -> App {
    let mut app = common::headless_app();
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
fn spawn_camera(app: &mut App, rng: &mut Rng, orthographic: bool) -> (Entity, Mat4) {
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
fn random_rect(rng: &mut Rng, viewport: Rect) -> (Vec2, Vec2) {
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
fn expected(entity: &SceneEntity, mode: SelectionMode, screens: &[Screen; 2]) -> Option<bool> {
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

#[test]
fn every_mode_equals_the_projection_brute_force() {
    let (mut compared, mut banded, mut selected) = (0usize, 0usize, 0usize);
    for seed in 0..24u64 {
        let mut rng = Rng::from_state(seed + 1000);
        let mut app = app();
        let scene = populate(&mut app, &mut rng, 120);
        let (camera, clip_from_world) = spawn_camera(&mut app, &mut rng, seed % 2 == 1);
        app.update();
        app.update();
        let cam = app.world().get::<Camera>(camera).unwrap().clone();
        let viewport = cam.logical_viewport_rect().unwrap();
        for round in 0..16 {
            let (a, b) = random_rect(&mut rng, viewport);
            let mode = [
                SelectionMode::Center,
                SelectionMode::Enclosed,
                SelectionMode::Touching,
            ][round % 3];
            let found: Vec<Entity> = app
                .world_mut()
                .run_system_once(move |mut selection: AccelSelection| {
                    selection
                        .in_rect(camera, a, b, mode, SelectionOrder::ByEntity)
                        .unwrap()
                        .to_vec()
                })
                .unwrap();
            let ndc = |p: Vec2| cam.viewport_to_ndc(p).unwrap().as_dvec2();
            let m = clip_from_world.as_dmat4();
            let screens = [
                Screen::new(m, ndc(a), ndc(b), 1e-4),
                Screen::new(m, ndc(a), ndc(b), -1e-4),
            ];
            let [Some(wide), Some(narrow)] = screens else {
                assert!(
                    found.is_empty(),
                    "a rectangle off the viewport selected {found:?}"
                );
                continue;
            };
            let screens = [wide, narrow];
            for e in &scene {
                let got = found.binary_search(&e.entity).is_ok();
                if e.rule != Rule::Allowed {
                    assert!(
                        !got,
                        "seed {seed}: {:?} entity {} selected",
                        e.rule, e.entity
                    );
                    continue;
                }
                match expected(e, mode, &screens) {
                    Some(want) => {
                        compared += 1;
                        selected += usize::from(want);
                        assert_eq!(
                            got, want,
                            "seed {seed} round {round} {mode:?}: {} (rect {a} {b})",
                            e.entity
                        );
                    }
                    None => banded += 1,
                }
            }
        }
    }
    // The comparison must have weight: many verdicts, both ways, few left to rounding.
    assert!(compared > 20_000, "{compared} compared");
    assert!(
        selected > compared / 20,
        "{selected} of {compared} selected"
    );
    assert!(
        banded * 100 < compared,
        "{banded} in the rounding band of {compared}"
    );
}

#[test]
fn sphere_and_frustum_selections_equal_the_world_boxes() {
    let mut rng = Rng::from_state(7);
    let mut app = app();
    let scene = populate(&mut app, &mut rng, 300);
    app.update();
    app.update();
    let allowed: Vec<&SceneEntity> = scene
        .iter()
        .filter(|e| e.rule == Rule::Allowed || e.rule == Rule::OtherLayer)
        .collect();
    let world_box = |e: &SceneEntity| {
        let c = box_corners(&e.affine, e.center, e.half);
        c.iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), &p| {
                (a.min(p), b.max(p))
            })
    };
    for round in 0..60 {
        let center = rng.vec3(-20.0, 20.0);
        let radius = rng.range(0.5, 15.0);
        let mode = [
            SelectionMode::Center,
            SelectionMode::Enclosed,
            SelectionMode::Touching,
        ][round % 3];
        let found: Vec<Entity> = app
            .world_mut()
            .run_system_once(move |mut selection: AccelSelection| {
                selection
                    .in_sphere(
                        BoundingSphere::new(center, radius),
                        mode,
                        SelectionOrder::ByDistance,
                    )
                    .to_vec()
            })
            .unwrap();
        let c = center.as_dvec3();
        let r2 = f64::from(radius).powi(2);
        let mut want: Vec<(f64, Entity)> = Vec::new();
        let mut banded = Vec::new();
        for e in &allowed {
            let (min, max) = world_box(e);
            let d2 = match mode {
                SelectionMode::Center => ((min + max) * 0.5).distance_squared(c),
                SelectionMode::Enclosed => (min - c).abs().max((max - c).abs()).length_squared(),
                SelectionMode::Touching => c.clamp(min, max).distance_squared(c),
            };
            if (d2 - r2).abs() < 1e-3 * r2.max(1.0) {
                banded.push(e.entity);
            } else if d2 < r2 {
                want.push((c.clamp(min, max).distance_squared(c), e.entity));
            }
        }
        want.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let found: Vec<Entity> = found.into_iter().filter(|e| !banded.contains(e)).collect();
        let want: Vec<Entity> = want.into_iter().map(|(_, e)| e).collect();
        // Equal distances (entities containing the centre) may come in either order.
        let mut sorted_found = found.clone();
        sorted_found.sort();
        let mut sorted_want = want.clone();
        sorted_want.sort();
        assert_eq!(sorted_found, sorted_want, "round {round} {mode:?}");
        assert_eq!(found.len(), want.len());
    }
}

#[test]
fn the_rules_keep_hidden_unpickable_and_other_layer_entities_out() {
    let mut rng = Rng::from_state(3);
    let mut app = app();
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::default());
    let aabb = Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5));
    let spawn = |app: &mut App, x: f32, extra: &dyn Fn(&mut EntityWorldMut)| {
        let mut e =
            app.world_mut()
                .spawn((Transform::from_xyz(x, 0.0, 0.0), aabb, Mesh3d(cube.clone())));
        extra(&mut e);
        e.id()
    };
    let plain = spawn(&mut app, 0.0, &|_| {});
    let hidden = spawn(&mut app, 1.0, &|e| {
        e.insert(Visibility::Hidden);
    });
    let ignored = spawn(&mut app, 2.0, &|e| {
        e.insert(Pickable::IGNORE);
    });
    let layered = spawn(&mut app, -1.0, &|e| {
        e.insert(RenderLayers::layer(5));
    });
    let marked = spawn(&mut app, -2.0, &|e| {
        e.insert(Pickable::default());
    });
    let (camera, _) = spawn_camera(&mut app, &mut rng, false);
    app.world_mut()
        .entity_mut(camera)
        .insert(Transform::from_xyz(0.0, 0.0, 20.0))
        .insert(GlobalTransform::from_xyz(0.0, 0.0, 20.0));
    app.update();
    app.update();
    let select = |app: &mut App, mode| {
        app.world_mut()
            .run_system_once(move |mut selection: AccelSelection| {
                selection
                    .in_ndc_rect(
                        camera,
                        Vec2::NEG_ONE,
                        Vec2::ONE,
                        mode,
                        SelectionOrder::ByEntity,
                    )
                    .unwrap()
                    .to_vec()
            })
            .unwrap()
    };
    for mode in [
        SelectionMode::Center,
        SelectionMode::Enclosed,
        SelectionMode::Touching,
    ] {
        let mut want = [plain, marked];
        want.sort();
        assert_eq!(select(&mut app, mode), want, "{mode:?}");
    }
    app.world_mut()
        .resource_mut::<AccelSelectionSettings>()
        .require_pickable = true;
    assert_eq!(select(&mut app, SelectionMode::Center), [marked]);
    // Off the camera's viewport, nothing; a camera that is not one, an error.
    let off = app
        .world_mut()
        .run_system_once(move |mut selection: AccelSelection| {
            let off = selection
                .in_ndc_rect(
                    camera,
                    Vec2::new(1.5, -1.0),
                    Vec2::new(3.0, 1.0),
                    SelectionMode::Touching,
                    SelectionOrder::ByEntity,
                )
                .unwrap()
                .len();
            let error = selection
                .in_ndc_rect(
                    plain,
                    Vec2::NEG_ONE,
                    Vec2::ONE,
                    SelectionMode::Center,
                    SelectionOrder::ByEntity,
                )
                .unwrap_err();
            (off, error)
        })
        .unwrap();
    assert_eq!(off, (0, SelectionError::NotACamera(plain)));
    // Without the visibility rule, the hidden entity is selected; the others' own rules
    // still hold (some entity has a `Pickable`, some a `RenderLayers`: each is read).
    app.world_mut().insert_resource(AccelSelectionSettings {
        visibility: RayCastVisibility::Any,
        ..default()
    });
    let mut want = [plain, hidden, marked];
    want.sort();
    assert_eq!(select(&mut app, SelectionMode::Center), want);
    // No `Pickable` and no `RenderLayers` left anywhere: every entity passes unread.
    for entity in [ignored, marked, layered] {
        app.world_mut()
            .entity_mut(entity)
            .remove::<(Pickable, RenderLayers)>();
    }
    app.world_mut().entity_mut(camera).remove::<RenderLayers>();
    let mut all = [plain, hidden, ignored, layered, marked];
    all.sort();
    assert_eq!(select(&mut app, SelectionMode::Center), all);
    // A camera that does not see layer 0 then selects nothing.
    app.world_mut()
        .entity_mut(camera)
        .insert(RenderLayers::layer(3));
    assert!(select(&mut app, SelectionMode::Center).is_empty());
}
