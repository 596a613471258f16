//! `AccelCullingPlugin` against Bevy's own `check_visibility_cpu_culling`: the same random
//! scenes and camera paths run in two apps, one with each, and the visible sets must agree.

use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::{NoFrustumCulling, RenderLayers};
use bevy::prelude::*;
use bevy_accel::culling::CullingStats;
use bevy_accel::prelude::*;

mod common;
mod culling_scene;
use accel_testkit::Rng;
use culling_scene::*;

/// Builds the same scene in an app: entities of varied size, some hidden through a parent,
/// some on other render layers, some without frustum culling (with and without an `Aabb`),
/// some static.
fn populate(app: &mut App, seed: u64, marked: bool) -> Vec<Entity> {
    let mut rng = Rng::from_state(seed);
    let world = app.world_mut();
    let class = drawable_class();
    let hidden_parent = world.spawn((Transform::default(), Visibility::Hidden)).id();
    let moving_parent = world
        .spawn((Transform::from_xyz(5.0, 0.0, 0.0), Visibility::Visible))
        .id();
    let mut out = Vec::new();
    for i in 0..3000 {
        let t = Transform::from_translation(rng.vec3(-200.0, 200.0))
            .with_rotation(Quat::from_rotation_y(rng.range(0.0, 6.0)))
            .with_scale(Vec3::new(
                rng.range(0.1, 4.0),
                rng.range(0.1, 4.0),
                rng.range(0.1, 4.0),
            ));
        let half = Vec3::new(
            rng.range(0.1, 3.0),
            rng.range(0.1, 3.0),
            rng.range(0.1, 3.0),
        );
        let mut e = world.spawn((
            t,
            Visibility::Inherited,
            class.clone(),
            Drawable,
            Aabb::from_min_max(-half, half),
        ));
        match i % 11 {
            0 => {
                e.insert(ChildOf(hidden_parent));
            }
            1 => {
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
            // In the trees (it has an `Aabb`) but visible wherever it is: a walk alone
            // would miss it out of view.
            5 => {
                e.insert(NoFrustumCulling);
            }
            _ => {}
        }
        // With `require_marker`, the unmarked third stays out of the trees and must still be
        // culled (the Bevy app ignores the marker).
        if marked && i % 3 != 0 {
            e.insert(AccelTracked);
        }
        out.push(e.id());
    }
    out
}

#[test]
fn visible_sets_equal_bevys_over_camera_paths() {
    check_camera_paths(Variant::Default);
}

#[test]
fn visible_sets_equal_bevys_with_required_markers() {
    check_camera_paths(Variant::RequireMarker);
}

#[test]
fn visible_sets_equal_bevys_while_the_plugin_pauses() {
    check_camera_paths(Variant::Paused(9..13));
}

#[test]
fn visible_sets_equal_bevys_on_every_index() {
    // The default (automatic) choice stays on the BVH at this size; the others here.
    for index in IndexChoice::ALL {
        if index != IndexChoice::Automatic && index != IndexChoice::Bvh {
            check_camera_paths(Variant::Index(index));
        }
    }
}

#[test]
fn visible_sets_equal_bevys_with_busy_movers() {
    check_camera_paths(Variant::BusyMovers);
}

#[test]
fn visible_sets_equal_bevys_while_culling_leaves_the_trees() {
    check_camera_paths(Variant::BevyPass(6..15));
}

/// How the accel app's settings differ from the defaults.
#[derive(Clone, PartialEq)]
enum Variant {
    Default,
    /// `require_marker` on, two entities in three marked.
    RequireMarker,
    /// `AccelSettings::enabled` off over these frames: the trees go stale while entities move
    /// (9..13 holds frame 9, where the parent alone moves far).
    Paused(std::ops::Range<usize>),
    /// `AccelCullingSettings::use_trees` off over these frames: Bevy's per-entity pass decides
    /// while the trees keep following the entities.
    BevyPass(std::ops::Range<usize>),
    /// Every mover kept in the busy movers' flat list, quiet ones back in the index after
    /// two frames.
    BusyMovers,
    /// The movers in this index, the busy movers' list off.
    Index(IndexChoice),
}

fn check_camera_paths(variant: Variant) {
    let mut bevy_app = app(false);
    let mut accel_app = app(true);
    let marked = variant == Variant::RequireMarker;
    accel_app
        .world_mut()
        .resource_mut::<AccelSettings>()
        .require_marker = marked;
    if variant != Variant::BusyMovers {
        // The other variants test the index's own path: the list would take these movers.
        accel_app
            .world_mut()
            .resource_mut::<AccelSettings>()
            .busy_movers
            .mode = BusyMovers::Off;
    }
    if let Variant::Index(index) = variant {
        accel_app.world_mut().resource_mut::<AccelSettings>().index = index;
    }
    if variant == Variant::BusyMovers {
        accel_app
            .world_mut()
            .resource_mut::<AccelSettings>()
            .busy_movers = BusyMoverSettings {
            mode: BusyMovers::On,
            quiet_frames: 2,
            ..default()
        };
    }
    let a = populate(&mut bevy_app, 3, marked);
    let b = populate(&mut accel_app, 3, marked);
    assert_eq!(a.len(), b.len());
    let mut rng = Rng::from_state(11);
    let mut cams: Vec<(Vec3, Vec3, f32)> = (0..2)
        .map(|_| {
            (
                rng.vec3(-150.0, 150.0),
                rng.vec3(-50.0, 50.0),
                rng.range(0.4, 1.4),
            )
        })
        .collect();
    // A narrow view: few hits, so it stays on the tree path (the wide views soon see enough of
    // the world to take the flat pass).
    cams.push((rng.vec3(-150.0, 150.0), rng.vec3(-50.0, 50.0), 0.05));
    for app in [&mut bevy_app, &mut accel_app] {
        for (i, &(eye, target, fov)) in cams.iter().enumerate() {
            let mut e = app.world_mut().spawn((
                Camera::default(),
                ViewIndex(i),
                frustum(eye, target, fov),
                Transform::from_translation(eye),
            ));
            if i == 1 {
                e.insert(RenderLayers::from_layers(&[0, 1]));
            }
        }
    }
    let mut rng_path = Rng::from_state(5);
    let (mut flat_views, mut tree_views, mut accepted_whole, mut reused_walks) = (0, 0, 0, 0);
    let (mut flat_views_on_trees, mut kept_tree_walks) = (0, 0);
    let mut busy_seen = 0;
    let mut step: Vec<(Vec3, Vec3, f32)> = cams.clone();
    let paused = match &variant {
        Variant::Paused(frames) => frames.clone(),
        _ => 0..0,
    };
    let bevy_pass = match &variant {
        Variant::BevyPass(frames) => frames.clone(),
        _ => 0..0,
    };
    for frame in 0..25 {
        accel_app
            .world_mut()
            .resource_mut::<AccelSettings>()
            .enabled = !paused.contains(&frame);
        accel_app
            .world_mut()
            .resource_mut::<bevy_accel::AccelCullingSettings>()
            .use_trees = !bevy_pass.contains(&frame);
        // Move the cameras along a path and the moving parent; identical in both apps. Every
        // third frame nothing moves but some entities are hidden or shown: the culling may
        // reuse its last walk then, and must still see the visibility change.
        let still = frame % 3 == 2;
        // Every sixth frame only the parent moves: the trees change under a camera that
        // did not, so a walk kept from the frame before must not be used.
        let camera_moves = !still && frame % 6 != 3;
        if camera_moves {
            step = cams
                .iter()
                .map(|&(e, t, f)| {
                    (
                        e + rng_path.vec3(-40.0, 40.0),
                        t + rng_path.vec3(-20.0, 20.0),
                        f,
                    )
                })
                .collect();
        }
        let shift = if still {
            Vec3::ZERO
        } else if !camera_moves {
            // Far enough for the parent's children to leave or enter the views.
            rng_path.vec3(-150.0, 150.0)
        } else {
            rng_path.vec3(-3.0, 3.0)
        };
        for (app, entities) in [(&mut bevy_app, &a), (&mut accel_app, &b)] {
            if still {
                for (i, &e) in entities.iter().enumerate() {
                    if (i + frame) % 7 == 0 {
                        let hidden = (i + frame) % 2 == 0;
                        app.world_mut().entity_mut(e).insert(if hidden {
                            Visibility::Hidden
                        } else {
                            Visibility::Inherited
                        });
                    }
                }
            }
            let world = app.world_mut();
            let mut q = world.query::<(&ViewIndex, &mut Frustum)>();
            for (i, mut f) in q.iter_mut(world) {
                let (eye, target, fov) = step[i.0];
                *f = frustum(eye, target, fov);
            }
            let mut parents = world.query_filtered::<&mut Transform, (Without<Aabb>, Without<Camera>, Without<Drawable>)>();
            for mut t in parents.iter_mut(world) {
                if shift != Vec3::ZERO {
                    t.translation += shift;
                }
            }
            app.update();
        }
        let (bevy_lists, bevy_flags) = visible_sets(&mut bevy_app, &a);
        let (accel_lists, accel_flags) = visible_sets(&mut accel_app, &b);
        for (view, (want, got)) in bevy_lists.iter().zip(&accel_lists).enumerate() {
            let missing: Vec<_> = want.iter().filter(|i| !got.contains(i)).take(5).collect();
            let extra: Vec<_> = got.iter().filter(|i| !want.contains(i)).take(5).collect();
            assert!(
                missing.is_empty() && extra.is_empty(),
                "frame {frame} view {view}: {} vs {} visible; missing {missing:?}, extra {extra:?}",
                want.len(),
                got.len()
            );
        }
        let differing = bevy_flags
            .iter()
            .zip(&accel_flags)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            differing, 0,
            "frame {frame}: ViewVisibility differs for {differing} entities"
        );
        assert!(
            bevy_lists.iter().any(|l| !l.is_empty()),
            "the camera path must see something"
        );
        busy_seen = busy_seen.max(accel_app.world().resource::<AccelStats>().busy_movers);
        let stats = accel_app.world().resource::<CullingStats>();
        if bevy_pass.contains(&frame) {
            // Off the trees, every view takes Bevy's own pass without the trees' word.
            assert_eq!(
                (stats.flat_views, stats.flat_views_on_trees),
                (stats.views, 0)
            );
        }
        flat_views += stats.flat_views;
        flat_views_on_trees += stats.flat_views_on_trees;
        tree_views += stats.views - stats.flat_views;
        accepted_whole += stats.accepted_by_subtree;
        reused_walks += stats.reused_walks;
        kept_tree_walks += stats.kept_tree_walks;
    }
    assert_eq!(
        busy_seen > 0,
        variant == Variant::BusyMovers,
        "busy movers: {busy_seen}"
    );
    assert!(reused_walks > 0, "still frames must reuse the last walk");
    // Frames where only the parent's children move under still cameras: the busy movers among
    // them are tested again, the rest of the narrow view's walk is kept.
    if variant == Variant::BusyMovers {
        assert!(
            kept_tree_walks > 0,
            "busy movers alone moved: keep the trees' finds"
        );
    }
    // Both the tree traversal and the flat pass (views that saw most of the world) ran; the
    // narrow view keeps the tree path busy every frame.
    assert!(
        flat_views > 0 && tree_views >= 25 - paused.len() - bevy_pass.len(),
        "flat {flat_views}, tree {tree_views}"
    );
    // The flat views took the trees' word where they could (they were current).
    assert!(
        flat_views_on_trees > 0,
        "flat {flat_views}, on trees {flat_views_on_trees}"
    );
    let stats = accel_app.world().resource::<CullingStats>();
    assert!(stats.views == 3 && stats.visible > 0);
    assert!(
        accepted_whole > 0,
        "whole subtrees must be accepted without per-entity tests"
    );
}

/// CI runs these tests at several compute-pool sizes (`ACCEL_TEST_COMPUTE_THREADS`): the
/// pool the apps run on must be the one asked for, or those runs test nothing new.
#[test]
fn compute_pool_has_the_size_asked_for() {
    let _app = app(true);
    let threads = bevy::tasks::ComputeTaskPool::get().thread_num();
    match std::env::var(accel_testkit::bevy_apps::COMPUTE_THREADS_VAR) {
        Ok(asked) => assert_eq!(threads.to_string(), asked.trim()),
        Err(_) => assert!(threads >= 1),
    }
}
