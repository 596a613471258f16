//! The picking benches' world: entities of about 1k-triangle meshes and rays aimed through
//! them, shared by `picking` (criterion, one contender after another) and `picking_ratio`
//! (`AccelRayCast` and `MeshRayCast` interleaved).

use accel_testkit::Rng;
use bevy::prelude::*;
use bevy_accel::picking::{AccelPickingSettings, SlotMeshTable, SlotMeshTableMode};
use bevy_accel::prelude::*;

#[path = "../../tests/common/mod.rs"]
mod common;
use common::headless_app;

/// A world of `n` meshes (a 1,024-triangle sphere and a 1,024-triangle torus), at the density
/// of 1 entity per 64 cubic units, and rays aimed through it. `is_static` marks every entity
/// [`AccelStatic`] (scenery: the flat static tree) instead of leaving it dynamic (the dynamic
/// tree, as for entities that may move). `snapshot` lets the plugin build a wide ray snapshot
/// of the dynamic tree once the world has stood still
/// ([`BvhIndexSettings::ray_snapshot_after_stable_frames`]); without it rays walk the binary
/// dynamic tree, as they do in a moving world that casts fewer rays than it moves entities
/// ([`BvhIndexSettings::ray_snapshot_rays_per_mover`]). `table` says whether ray casts find
/// candidates' meshes through the [`SlotMeshTable`] or the ECS.
pub fn world(
    n: usize,
    is_static: bool,
    snapshot: bool,
    table: SlotMeshTableMode,
) -> (App, Vec<Ray3d>) {
    let mut app = headless_app();
    app.add_plugins(AccelPickingPlugin);
    // The copy is made in the frame at every size the bench runs, so that the bench can print
    // its cost (by default, above 5,000 dynamic entities it is made on another thread).
    app.insert_resource(AccelSettings {
        bvh: BvhIndexSettings {
            ray_snapshot_after_stable_frames: snapshot.then_some(30),
            ray_snapshot_in_frame_max_entities: usize::MAX,
            ..default()
        },
        ..default()
    });
    // The bench casts its rays outside frames, where the table's default policy, which
    // watches rays per frame, would never switch it on: the mode is set outright.
    app.insert_resource(AccelPickingSettings {
        slot_mesh_table: table,
        ..default()
    });
    app.finish();
    let meshes = {
        let mut assets = app.world_mut().resource_mut::<Assets<Mesh>>();
        [
            assets.add(Sphere::new(1.0).mesh().uv(32, 17)),
            assets.add(
                Torus::new(0.5, 1.0)
                    .mesh()
                    .minor_resolution(16)
                    .major_resolution(32),
            ),
        ]
    };
    let half = (n as f32 * 64.0).cbrt() / 2.0;
    let mut rng = Rng::new(7);
    let batch: Vec<_> = (0..n)
        .map(|i| {
            let t = Transform::from_translation(rng.vec3(-half, half))
                .with_rotation(Quat::from_rotation_y(rng.f32() * 6.0))
                .with_scale(Vec3::new(1.0 + rng.f32(), 1.0 + rng.f32(), 1.0 + rng.f32()));
            (t, Mesh3d(meshes[i % 2].clone()))
        })
        .collect();
    if is_static {
        app.world_mut()
            .spawn_batch(batch.into_iter().map(|(t, m)| (t, m, AccelStatic)));
    } else {
        app.world_mut().spawn_batch(batch);
    }
    app.update();
    app.update();
    // Steady state: the dynamic tree's first rebuild (started in the background once the
    // spawns are in) is installed before anything is timed.
    for _ in 0..500 {
        let dynamic = app
            .world()
            .resource::<AccelTrees>()
            .dynamic_bvh()
            .expect("the BVH is the default index");
        if dynamic.is_empty() || (dynamic.rebuild_count() > 0 && !dynamic.rebuild_in_flight()) {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
        update_reporting_snapshot(&mut app);
    }
    // Still frames, after which the plugin copies the dynamic tree for rays (when allowed).
    for _ in 0..32 {
        update_reporting_snapshot(&mut app);
    }
    let rays = (0..1024)
        .map(|_| {
            let origin = rng.vec3(-half * 1.2, half * 1.2);
            let target = rng.vec3(-half * 0.5, half * 0.5);
            Ray3d::new(origin, Dir3::new(target - origin).unwrap_or(Dir3::X))
        })
        .collect();
    assert_eq!(
        app.world().resource::<SlotMeshTable>().is_active(),
        table == SlotMeshTableMode::Always
    );
    (app, rays)
}

/// Runs a frame, and prints what the ray snapshot of the dynamic tree cost if the frame took
/// one.
fn update_reporting_snapshot(app: &mut App) {
    let held = |app: &App| {
        app.world()
            .resource::<AccelTrees>()
            .query()
            .has_dynamic_ray_snapshot()
    };
    let before = held(app);
    app.update();
    if !before && held(app) {
        let world = app.world();
        println!(
            "{} dynamic entities: ray snapshot taken in {:?}",
            world.resource::<AccelTrees>().query().dynamic_len(),
            world.resource::<AccelStats>().maintain_time
        );
    }
}
