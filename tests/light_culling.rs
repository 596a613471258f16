//! `AccelCullingPlugin`'s light views against bevy_light's own shadow-caster culling
//! (`check_point_light_mesh_visibility`, `check_dir_light_mesh_visibility`): the same scene,
//! lights and camera paths in two apps, one with each; every light view's caster lists and
//! every entity's `ViewVisibility` must agree.

use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::{
    CascadesVisibleEntities, CubemapVisibleEntities, NoAutoAabb, NoFrustumCulling, RenderLayers,
    VisibleMeshEntities,
};
use bevy::light::NotShadowCaster;
use bevy::math::primitives::ViewFrustum;
use bevy::prelude::*;
use bevy_accel::AccelCullingPlugin;
use bevy_accel::culling::CullingStats;
use bevy_accel::prelude::*;
use core::time::Duration;
use std::collections::HashMap;

mod common;
use accel_testkit::Rng;
use common::{add_lights, headless_app};

/// Which of the test's cameras or lights an entity is (entity ids differ between the apps).
#[derive(Component, Clone, Copy)]
struct Tag(usize);

/// Which caster an entity is, by spawn order.
#[derive(Component, Clone, Copy)]
struct Caster(usize);

fn app(ours: bool) -> App {
    let mut app = headless_app();
    add_lights(&mut app);
    if ours {
        // The diagnostics too: the tests check that the light views' time is published.
        app.add_plugins((AccelCullingPlugin, AccelDiagnosticsPlugin));
    }
    app.finish();
    app
}

/// Casters of varied size and kind; returns the moving parent.
fn populate(app: &mut App, seed: u64) -> Entity {
    let mut rng = Rng::from_state(seed);
    let world = app.world_mut();
    let hidden_parent = world.spawn((Transform::default(), Visibility::Hidden)).id();
    let moving_parent = world
        .spawn((Transform::from_xyz(5.0, 0.0, 0.0), Visibility::Visible))
        .id();
    for i in 0..3000 {
        let mut t = Transform::from_translation(rng.vec3(-120.0, 120.0))
            .with_rotation(Quat::from_rotation_y(rng.range(0.0, 6.0)))
            .with_scale(Vec3::new(
                rng.range(0.1, 4.0),
                rng.range(0.1, 4.0),
                rng.range(0.1, 4.0),
            ));
        let mut half = Vec3::new(
            rng.range(0.1, 3.0),
            rng.range(0.1, 3.0),
            rng.range(0.1, 3.0),
        );
        if i % 13 == 9 {
            // Long sticks: Bevy's light-sphere test keeps some whose every point is out of
            // the light's range, and the walks must find them too.
            half = Vec3::new(rng.range(10.0, 30.0), 0.2, 0.2);
        }
        if i % 13 == 12 {
            // High above the scene, between the sun and the cameras' cascades: shadow casters
            // there still cast into the cascades (about a hundred of them do here).
            t.translation.y += 400.0;
        }
        let mut e = world.spawn((
            t,
            Visibility::Inherited,
            Mesh3d::default(),
            NoAutoAabb,
            Aabb::from_min_max(-half, half),
            Caster(i),
        ));
        match i % 13 {
            0 => {
                e.insert(ChildOf(hidden_parent));
            }
            1 | 7 => {
                e.insert(ChildOf(moving_parent));
            }
            2 => {
                e.insert(RenderLayers::layer(1));
            }
            3 => {
                e.insert(AccelStatic);
            }
            4 => {
                e.remove::<Aabb>();
                e.insert(NoFrustumCulling);
            }
            5 => {
                e.insert(NoFrustumCulling);
            }
            6 => {
                e.insert(NotShadowCaster);
            }
            8 => {
                e.insert(AccelIgnore);
            }
            _ => {}
        }
    }
    moving_parent
}

/// Spawns the cameras and lights.
fn lights_and_cameras(app: &mut App) {
    let world = app.world_mut();
    for i in 0..2 {
        world.spawn((
            Camera::default(),
            Projection::Perspective(PerspectiveProjection {
                far: 150.0,
                ..default()
            }),
            Transform::from_xyz(60.0 * i as f32, 10.0, 80.0).looking_at(Vec3::ZERO, Vec3::Y),
            Tag(i),
        ));
    }
    let point = |range: f32| PointLight {
        shadow_maps_enabled: true,
        range,
        ..default()
    };
    world.spawn((point(40.0), Transform::from_xyz(10.0, 5.0, -20.0), Tag(10)));
    // Reaches the whole scene: its walk finds most casters, and the flat pass decides it.
    world.spawn((point(500.0), Transform::from_xyz(0.0, 30.0, 0.0), Tag(12)));
    // Reaches about half the scene: flat too, with the light's range crossing many casters,
    // whose range test the trees cannot settle.
    world.spawn((point(130.0), Transform::from_xyz(-10.0, 0.0, 5.0), Tag(13)));
    world.spawn((
        point(25.0),
        Transform::from_xyz(-50.0, 0.0, 30.0),
        RenderLayers::from_layers(&[0, 1]),
        Tag(11),
    ));
    world.spawn((
        SpotLight {
            shadow_maps_enabled: true,
            range: 90.0,
            outer_angle: 0.6,
            inner_angle: 0.3,
            ..default()
        },
        Transform::from_xyz(0.0, 60.0, 0.0).looking_at(Vec3::new(20.0, 0.0, 10.0), Vec3::X),
        Tag(20),
    ));
    world.spawn((
        DirectionalLight {
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(0.0, 50.0, 0.0).looking_at(Vec3::new(1.0, 0.0, 2.0), Vec3::Y),
        Tag(30),
    ));
}

/// Every light view's casters (as spawn indices) keyed by light tag, face or camera tag and
/// cascade; and every caster's `ViewVisibility`.
type Views = HashMap<(usize, usize, usize), Vec<usize>>;

fn light_views(app: &mut App) -> (Views, Vec<bool>) {
    let world = app.world_mut();
    let mut casters: Vec<(usize, bool)> = world
        .query::<(&Caster, &ViewVisibility)>()
        .iter(world)
        .map(|(c, v)| (c.0, v.get()))
        .collect();
    casters.sort_unstable_by_key(|c| c.0);
    let index: HashMap<Entity, usize> = world
        .query::<(Entity, &Caster)>()
        .iter(world)
        .map(|(e, c)| (e, c.0))
        .collect();
    let tags: HashMap<Entity, usize> = world
        .query::<(Entity, &Tag)>()
        .iter(world)
        .map(|(e, t)| (e, t.0))
        .collect();
    let list = |v: &VisibleMeshEntities| -> Vec<usize> {
        let mut l: Vec<usize> = v.entities.iter().map(|e| index[e]).collect();
        l.sort_unstable();
        l
    };
    let mut views = Views::new();
    for (tag, cube) in world.query::<(&Tag, &CubemapVisibleEntities)>().iter(world) {
        for (face, v) in cube.iter().enumerate() {
            views.insert((tag.0, face, 0), list(v));
        }
    }
    for (tag, spot) in world
        .query_filtered::<(&Tag, &VisibleMeshEntities), With<SpotLight>>()
        .iter(world)
    {
        views.insert((tag.0, 0, 0), list(spot));
    }
    for (tag, cascades) in world
        .query::<(&Tag, &CascadesVisibleEntities)>()
        .iter(world)
    {
        for (view, lists) in &cascades.entities {
            for (cascade, v) in lists.iter().enumerate() {
                views.insert((tag.0, tags[view], cascade), list(v));
            }
        }
    }
    (views, casters.into_iter().map(|c| c.1).collect())
}

#[test]
fn light_views_equal_bevys_over_moving_lights() {
    check_light_views(BusyMovers::Off, IndexChoice::Automatic);
}

#[test]
fn light_views_equal_bevys_with_busy_movers() {
    check_light_views(BusyMovers::On, IndexChoice::Automatic);
}

#[test]
fn light_views_equal_bevys_on_every_index() {
    // The default (automatic) choice stays on the BVH at this size; the others here.
    for index in IndexChoice::ALL {
        if index != IndexChoice::Automatic && index != IndexChoice::Bvh {
            check_light_views(BusyMovers::Off, index);
        }
    }
}

fn check_light_views(busy: BusyMovers, index: IndexChoice) {
    let mut bevy_app = app(false);
    let mut accel_app = app(true);
    {
        let mut settings = accel_app.world_mut().resource_mut::<AccelSettings>();
        settings.index = index;
        settings.busy_movers = BusyMoverSettings {
            mode: busy,
            quiet_frames: 2,
            ..default()
        };
    }
    let mut busy_seen = 0;
    let parents = [populate(&mut bevy_app, 9), populate(&mut accel_app, 9)];
    lights_and_cameras(&mut bevy_app);
    lights_and_cameras(&mut accel_app);
    let mut rng = Rng::from_state(21);
    let (mut seen, mut reused, mut flat, mut flat_on_trees) = (0, 0, 0, 0);
    for frame in 0..16 {
        // Frames 12 and 13: the plugin is switched off and its trees go stale; every light
        // view must then take the flat pass.
        accel_app
            .world_mut()
            .resource_mut::<AccelSettings>()
            .enabled = !(12..14).contains(&frame);
        let light_step = rng.vec3(-15.0, 15.0);
        let mut parent_step = rng.vec3(-20.0, 20.0);
        if frame == 12 {
            // A jump while the trees are stale: the parent's children leave and enter light
            // ranges, which walks of the stale trees would miss.
            parent_step = Vec3::new(70.0, 0.0, -40.0);
        }
        let turn = rng.range(-0.3, 0.3);
        for (app, parent) in [(&mut bevy_app, parents[0]), (&mut accel_app, parents[1])] {
            let world = app.world_mut();
            // Every fourth frame nothing moves; some casters are hidden or shown instead.
            if frame % 4 == 3 {
                let mut q = world.query::<(&Caster, &mut Visibility)>();
                for (c, mut v) in q.iter_mut(world) {
                    if (c.0 + frame) % 9 == 0 {
                        *v = if (c.0 + frame) % 2 == 0 {
                            Visibility::Hidden
                        } else {
                            Visibility::Inherited
                        };
                    }
                }
            } else {
                // Every fourth frame, one after the still one, only the parent moves: the
                // trees change under still lights, whose kept walks must then be dropped.
                if frame % 4 != 0 {
                    let mut q = world.query::<(&Tag, &mut Transform)>();
                    for (tag, mut t) in q.iter_mut(world) {
                        match tag.0 {
                            10..=13 | 20 => t.translation += light_step,
                            30 => t.rotate_y(turn),
                            _ => t.rotate_around(Vec3::ZERO, Quat::from_rotation_y(turn)),
                        }
                    }
                }
                world.get_mut::<Transform>(parent).unwrap().translation += parent_step;
            }
            app.update();
        }
        busy_seen = busy_seen.max(accel_app.world().resource::<AccelStats>().busy_movers);
        let stats = accel_app.world().resource::<CullingStats>();
        reused += stats.reused_light_walks;
        flat += stats.flat_light_views;
        flat_on_trees += stats.flat_light_views_on_trees;
        let (want, want_flags) = light_views(&mut bevy_app);
        let (got, got_flags) = light_views(&mut accel_app);
        let mut keys: Vec<_> = want.keys().copied().collect();
        keys.sort_unstable();
        assert_eq!(
            keys.len(),
            got.len(),
            "frame {frame}: light views differ in number"
        );
        for key in keys {
            let (w, g) = (&want[&key], &got[&key]);
            let missing: Vec<_> = w.iter().filter(|i| !g.contains(i)).take(5).collect();
            let extra: Vec<_> = g.iter().filter(|i| !w.contains(i)).take(5).collect();
            assert!(
                w == g,
                "frame {frame} view {key:?}: {} vs {} casters; missing {missing:?}, extra {extra:?}",
                w.len(),
                g.len()
            );
            seen += w.len();
        }
        let differing = want_flags
            .iter()
            .zip(&got_flags)
            .filter(|(a, b)| a != b)
            .count();
        let only_bevy = want_flags
            .iter()
            .zip(&got_flags)
            .filter(|(a, b)| **a && !**b)
            .count();
        assert_eq!(
            differing, 0,
            "frame {frame}: ViewVisibility differs for {differing} casters ({only_bevy} visible only in Bevy's app)"
        );
    }
    assert_eq!(
        busy_seen > 0,
        busy == BusyMovers::On,
        "busy movers: {busy_seen}"
    );
    assert!(seen > 0, "the lights must see casters");
    assert!(reused > 0, "still frames must keep the lights' walks");
    assert!(flat > 0, "the far-reaching lights must take the flat pass");
    // Every flat view but those of the two frames with stale trees takes the trees' word.
    assert!(
        flat_on_trees > 0 && flat_on_trees < flat,
        "flat light views on the trees: {flat_on_trees} of {flat}"
    );
    let store = accel_app
        .world()
        .resource::<bevy::diagnostic::DiagnosticsStore>();
    for path in [CullingStats::TIME, CullingStats::LIGHT_TIME] {
        let measured = store.get(&path).and_then(|d| d.measurement());
        assert!(measured.is_some(), "diagnostic {path} has no measurement");
    }
    let stats = accel_app.world().resource::<CullingStats>();
    assert!(
        stats.light_views >= 6 + 6 + 6 + 1 + 2,
        "light views culled on the trees: {}",
        stats.light_views
    );
    assert!(
        stats.light_candidates < 3000 * stats.light_views / 2,
        "the walks must narrow the candidates: {} over {} views",
        stats.light_candidates,
        stats.light_views
    );
}

/// Lights and casters moving for `frames` frames in Bevy's app and ours (set up by
/// `settings`), their light views compared every frame; the frames ours stood aside.
fn moving_lights_culled_alike(
    settings: impl FnOnce(&mut AccelSettings),
    frames: usize,
) -> (App, usize, usize) {
    moving_lights_seen_alike(settings, |_| {}, frames)
}

/// [`moving_lights_culled_alike`], with `setup` applied to both apps' worlds after the lights
/// and cameras are spawned.
fn moving_lights_seen_alike(
    settings: impl FnOnce(&mut AccelSettings),
    setup: impl Fn(&mut World),
    frames: usize,
) -> (App, usize, usize) {
    let mut bevy_app = app(false);
    let mut accel_app = app(true);
    settings(&mut accel_app.world_mut().resource_mut::<AccelSettings>());
    let parents = [populate(&mut bevy_app, 5), populate(&mut accel_app, 5)];
    lights_and_cameras(&mut bevy_app);
    lights_and_cameras(&mut accel_app);
    setup(bevy_app.world_mut());
    setup(accel_app.world_mut());
    let mut rng = Rng::from_state(77);
    let mut aside_frames = 0;
    let mut unwritten_frames = 0;
    for frame in 0..frames {
        let light_step = rng.vec3(-10.0, 10.0);
        let parent_step = rng.vec3(-20.0, 20.0);
        for (app, parent) in [(&mut bevy_app, parents[0]), (&mut accel_app, parents[1])] {
            let world = app.world_mut();
            let mut q = world.query::<(&Tag, &mut Transform)>();
            for (tag, mut t) in q.iter_mut(world) {
                if let 10..=13 | 20 = tag.0 {
                    t.translation += light_step;
                }
            }
            world.get_mut::<Transform>(parent).unwrap().translation += parent_step;
            app.update();
        }
        aside_frames += accel_app.world().resource::<AccelTrees>().stepped_aside() as usize;
        unwritten_frames += usize::from(
            accel_app
                .world()
                .resource::<AccelStats>()
                .busy_moves_skipped
                > 0,
        );
        assert!(
            light_views(&mut bevy_app) == light_views(&mut accel_app),
            "frame {frame}: light views or caster flags differ"
        );
    }
    (accel_app, aside_frames, unwritten_frames)
}

/// Below `AccelSettings::step_aside_below`, with culling the trees' only use, bevy_light's
/// own caster tests stand in for the trees' light views: the views stay Bevy's through the
/// step aside while lights and casters move.
#[test]
fn light_views_equal_bevys_while_the_trees_step_aside() {
    let (_, aside_frames, _) =
        moving_lights_culled_alike(|settings| settings.step_aside_below = 5_000, 50);
    assert!(aside_frames >= 15, "stood aside {aside_frames} frames");
}

/// With `AccelSettings::step_aside_when_slower`, probe frames run bevy_light's caster tests
/// and then the trees' (timing both), and the timing may step the trees aside: the light
/// views stay Bevy's in every such frame.
#[test]
fn light_views_equal_bevys_through_timed_probe_frames() {
    let (accel_app, ..) = moving_lights_culled_alike(
        |settings| {
            settings.step_aside_below = 0;
            settings.step_aside_when_slower = true;
        },
        150,
    );
    let probe = accel_app
        .world()
        .resource::<AccelTrees>()
        .last_step_aside_probe()
        .expect("probed");
    assert!(
        probe.bevy > Duration::ZERO && probe.trees > Duration::ZERO,
        "{probe:?}"
    );
}

/// With `AccelSettings::skip_unread_mover_upkeep` and a crowd in front of the cameras (so
/// that they take the flat pass, which reads no busy mover), the light views' walks and
/// verdicts still read the busy movers, so their moves are written every frame (but perhaps
/// the first, before any light view was culled), and the light views stay Bevy's.
#[test]
fn light_views_keep_the_busy_movers_written() {
    let crowd_in_view = |world: &mut World| {
        for i in 0..4_000 {
            let at = Vec3::new((i % 20) as f32, (i / 20 % 10) as f32, (i / 200) as f32) * 2.0
                - Vec3::new(20.0, 10.0, 20.0);
            world.spawn((
                Transform::from_translation(at),
                Visibility::Visible,
                Mesh3d::default(),
                NoAutoAabb,
                Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
                Caster(3_000 + i),
            ));
        }
        // The cameras' frusta as `Projection` would give them, wide enough for the crowd.
        let mut cameras = world.query_filtered::<(&Transform, &mut Frustum), With<Camera>>();
        for (transform, mut frustum) in cameras.iter_mut(world) {
            let clip_from_view = Mat4::perspective_infinite_reverse_rh(1.2, 1.0, 0.1);
            let view_from_world = transform.to_matrix().inverse();
            *frustum = Frustum(ViewFrustum::from_clip_from_world(
                &(clip_from_view * view_from_world),
            ));
        }
    };
    let (accel_app, _, unwritten_frames) = moving_lights_seen_alike(
        |settings| {
            settings.step_aside_below = 0;
            settings.step_aside_when_slower = false;
            settings.skip_unread_mover_upkeep = true;
        },
        crowd_in_view,
        60,
    );
    let culling = accel_app.world().resource::<CullingStats>();
    assert_eq!(
        culling.flat_views, culling.views,
        "the cameras see most of the scene: {culling:?}"
    );
    assert!(accel_app.world().resource::<AccelStats>().busy_movers > 0);
    assert!(
        unwritten_frames <= 1,
        "moves unwritten in {unwritten_frames} frames"
    );
}
