//! `AccelSelection` against the brute force a game would write with Bevy alone (project every
//! triangle or every box corner), on random scenes, cameras (perspective and orthographic,
//! off-centre viewports) and rectangles (degenerate, inverted, off the screen, larger than
//! it); and the rules (hidden, non-pickable, other render layers) and the mouse.

use accel_testkit::Rng;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::RenderLayers;
use bevy::ecs::system::RunSystemOnce;
use bevy::math::DVec3;
use bevy::math::bounding::BoundingSphere;
use bevy::picking::Pickable;
use bevy::picking::mesh_picking::ray_cast::RayCastVisibility;
use bevy::prelude::*;
use bevy_accel::prelude::*;

mod common;
mod selection_oracle;
use selection_oracle::box_corners;
use selection_oracle::scene::{
    MODES, Rule, SceneEntity, app, expected, populate, random_rect, rect_screens, select_in_rect,
    spawn_camera,
};

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
            let rect = random_rect(&mut rng, viewport);
            let (a, b) = rect;
            let mode = MODES[round % 3];
            let found = select_in_rect(&mut app, camera, rect, mode);
            let Some(screens) = rect_screens(&cam, clip_from_world, rect) else {
                assert!(
                    found.is_empty(),
                    "a rectangle off the viewport selected {found:?}"
                );
                continue;
            };
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
