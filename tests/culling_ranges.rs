//! `AccelCullingPlugin` against Bevy's own `check_visibility_cpu_culling` with Bevy's
//! visibility ranges and the ways out of CPU culling (`NoCpuCulling`, `NoFrustumCulling`).

use bevy::camera::primitives::Frustum;
use bevy::camera::visibility::NoFrustumCulling;
use bevy::prelude::*;
use bevy_accel::culling::CullingStats;
use bevy_accel::prelude::*;

mod common;
mod culling_scene;
use accel_testkit::Rng;
use common::headless_app;
use culling_scene::*;

/// Bevy's visibility ranges (HLOD bands measured from each camera), entities and a camera that
/// opt out of CPU culling, and entities without frustum culling, under moving cameras: the
/// same visible sets, `ViewVisibility` and changes as Bevy's own culling.
#[test]
fn visible_sets_equal_bevys_with_ranges_and_opt_outs() {
    use bevy::camera::visibility::{NoCpuCulling, VisibilityRange, VisibilityRangePlugin};
    const SIDE: usize = 16;
    let grid = |app: &mut App| -> Vec<Entity> {
        spawn_grid(app.world_mut(), SIDE, 0.6, |i, e| {
            if i % 5 == 0 {
                e.insert(VisibilityRange {
                    start_margin: 20.0..26.0,
                    end_margin: 45.0..52.0,
                    use_aabb: i % 10 == 0,
                });
            }
            if i % 11 == 0 {
                e.insert(NoCpuCulling);
            }
            if i % 13 == 0 {
                e.insert(NoFrustumCulling);
            }
            if i % 7 == 0 {
                e.insert(AccelStatic);
            }
        })
    };
    let ranged_app = |ours: bool| {
        let mut app = headless_app();
        app.add_plugins(VisibilityRangePlugin);
        if ours {
            app.add_plugins(AccelCullingPlugin);
        }
        app.finish();
        app
    };
    let (mut bevy_app, mut accel_app) = (ranged_app(false), ranged_app(true));
    let a = grid(&mut bevy_app);
    let b = grid(&mut accel_app);
    let centre = Vec3::splat(SIDE as f32 * 2.0);
    for app in [&mut bevy_app, &mut accel_app] {
        app.init_resource::<ChangedVisibility>()
            .add_systems(Last, record_changed_visibility);
        for i in 0..3 {
            let mut e = app.world_mut().spawn((
                Camera::default(),
                ViewIndex(i),
                frustum(Vec3::ZERO, Vec3::Z, 1.0),
                Transform::default(),
            ));
            if i == 2 {
                e.insert(NoCpuCulling);
            }
        }
    }
    let mut rng = Rng::from_state(17);
    let (mut tree_views, mut in_range_changes) = (0, 0);
    for frame in 0..12 {
        // Eyes inside and around the grid, so that range bands cut through what is in view.
        let cams: Vec<(Vec3, Vec3, f32)> = (0..3)
            .map(|_| {
                let eye = centre + rng.vec3(-40.0, 40.0);
                (eye, centre + rng.vec3(-10.0, 10.0), rng.range(0.3, 1.2))
            })
            .collect();
        for (app, entities) in [(&mut bevy_app, &a), (&mut accel_app, &b)] {
            let world = app.world_mut();
            let mut q = world.query::<(&ViewIndex, &mut Frustum, &mut Transform)>();
            for (i, mut f, mut t) in q.iter_mut(world) {
                let (eye, target, fov) = cams[i.0];
                *f = frustum(eye, target, fov);
                t.translation = eye;
            }
            for (i, &e) in entities.iter().enumerate() {
                if (i + frame) % 9 == 0 {
                    app.world_mut().entity_mut(e).insert(if frame % 2 == 0 {
                        Visibility::Hidden
                    } else {
                        Visibility::Inherited
                    });
                }
            }
            app.update();
        }
        let bevy_lists = assert_culled_alike((&mut bevy_app, &a), (&mut accel_app, &b), frame);
        // Some ranged entities are in view and some are not, this frame or overall.
        let ranged_seen = bevy_lists[0].iter().filter(|&&i| i % 5 == 0).count();
        in_range_changes += usize::from(ranged_seen > 0 && ranged_seen < bevy_lists[0].len());
        let stats = accel_app.world().resource::<CullingStats>();
        tree_views += stats.views - stats.flat_views;
    }
    assert!(tree_views > 0, "some views took the tree path");
    assert!(in_range_changes > 0, "range bands cut through the views");
}
