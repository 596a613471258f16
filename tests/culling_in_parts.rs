//! `AccelCullingPlugin` against Bevy's own `check_visibility_cpu_culling` where a view
//! proves tens of thousands of entities inside at once: the decisions split across the
//! compute task pool (CI runs this file at several pool sizes) must give Bevy's visible set,
//! `ViewVisibility` and its change ticks.

use bevy::camera::primitives::Frustum;
use bevy::camera::visibility::RenderLayers;
use bevy::math::primitives::ViewFrustum;
use bevy::prelude::*;
use bevy_accel::culling::CullingStats;
use bevy_accel::prelude::*;

mod common;
mod culling_scene;
use culling_scene::*;

/// A view that proves tens of thousands of entities inside (enough to decide them in parts on
/// the compute task pool) still gives Bevy's visible set, `ViewVisibility` and its change
/// ticks, with hidden entities, other render layers and visibility toggles among the ones
/// inside, and with entities moving between Bevy's tables and despawned under a still camera
/// (the rows the culling remembers go stale).
#[test]
fn many_entities_inside_decided_in_parts_equal_bevys() {
    const SIDE: usize = 40;
    let grid = |app: &mut App| -> Vec<Entity> {
        let world = app.world_mut();
        let hidden_parent = world.spawn((Transform::default(), Visibility::Hidden)).id();
        spawn_grid(world, SIDE, 0.4, |i, e| match i % 13 {
            0 => {
                e.insert(ChildOf(hidden_parent));
            }
            1 => {
                e.insert(RenderLayers::layer(2));
            }
            2 => {
                e.insert(AccelStatic);
            }
            _ => {}
        })
    };
    let (mut bevy_app, mut accel_app) = (app(false), app(true));
    let a = grid(&mut bevy_app);
    let b = grid(&mut accel_app);
    // An orthographic view down -z over the whole grid in y and its first 15% in x: six
    // columns (9,600 of the 64,000 entities) proved inside, and a seventh crossing its edge.
    let extent = SIDE as f32 * 4.0;
    let eye = Vec3::new(0.0, 0.0, extent + 10.0);
    let view = Mat4::look_at_rh(eye, eye - Vec3::Z, Vec3::Y);
    let proj = Mat4::orthographic_rh(-2.0, extent * 0.15, -2.0, extent + 2.0, 0.1, extent * 3.0);
    let frustum = Frustum(ViewFrustum::from_clip_from_world(&(proj * view)));
    for app in [&mut bevy_app, &mut accel_app] {
        app.world_mut().spawn((
            Camera::default(),
            ViewIndex(0),
            frustum,
            Transform::from_translation(eye),
        ));
        app.init_resource::<ChangedVisibility>()
            .add_systems(Last, record_changed_visibility);
    }
    let mut in_parts = 0;
    let mut reused_walks = 0;
    for frame in 0..8 {
        for (app, entities) in [(&mut bevy_app, &a), (&mut accel_app, &b)] {
            for (i, &e) in entities.iter().enumerate() {
                let Ok(mut e) = app.world_mut().get_entity_mut(e) else {
                    continue;
                };
                if (i + frame) % 17 == 0 {
                    e.insert(if frame % 2 == 0 {
                        Visibility::Hidden
                    } else {
                        Visibility::Inherited
                    });
                }
                // Rows move without the trees changing: the walk is kept, its rows are not.
                if (i + frame) % 11 == 0 {
                    if frame % 2 == 0 {
                        e.insert(Moved);
                    } else {
                        e.remove::<Moved>();
                    }
                }
                if frame == 5 && i % 29 == 0 {
                    e.despawn();
                }
            }
            app.update();
        }
        let bevy_lists = assert_culled_alike((&mut bevy_app, &a), (&mut accel_app, &b), frame);
        assert!(
            bevy_lists[0].len() > 6_000,
            "{} visible",
            bevy_lists[0].len()
        );
        let stats = accel_app.world().resource::<CullingStats>();
        assert_eq!(
            stats.flat_views, 0,
            "frame {frame}: the view stays on the tree path"
        );
        in_parts += stats.views_decided_in_parts;
        reused_walks += stats.reused_walks;
    }
    assert!(in_parts >= 7, "decided in parts in {in_parts} of 8 frames");
    assert!(
        reused_walks >= 3,
        "the still camera kept its walk {reused_walks} times"
    );
}
