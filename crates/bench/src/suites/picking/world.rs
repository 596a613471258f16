//! The picking suite's world: entities of about 1k-triangle meshes and rays aimed through
//! them, brought to a steady state (first rebuilds installed, the ray snapshot taken where
//! allowed) before anything is timed.

use crate::suites::{headless_app, settle_still_trees};
use accel_testkit::Rng;
use bevy::prelude::*;
use bevy_accel::picking::{AccelPickingSettings, SlotMeshTable, SlotMeshTableMode};
use bevy_accel::prelude::*;

/// How the world's entities are held.
#[derive(Clone, Copy, Debug)]
pub struct WorldKind {
    /// What the report calls it.
    pub name: &'static str,
    /// Every entity marked [`AccelStatic`] (scenery: the flat static tree) instead of left
    /// dynamic (the movers' index, as for entities that may move).
    pub is_static: bool,
    /// Whether the plugin may build a wide ray snapshot of the dynamic BVH once the world
    /// has stood still ([`BvhIndexSettings::ray_snapshot_after_stable_frames`]); without it
    /// rays walk the binary dynamic tree, as they do in a moving world that casts fewer rays
    /// than it moves entities.
    pub snapshot: bool,
    /// Whether ray casts find candidates' meshes through the [`SlotMeshTable`] or the ECS.
    pub table: SlotMeshTableMode,
    /// The movers' index.
    pub index: IndexChoice,
    /// Per mille of the entities that take a small step before every round (`None`: at
    /// rest); the snapshot, where allowed, is then refit along their paths.
    pub moving_per_mille: Option<usize>,
}

/// A world of `n` meshes (a 1,024-triangle sphere and a 1,024-triangle torus, with random
/// rotations about y and non-uniform scales), at the density of 1 entity per 64 cubic units,
/// and `rays` rays aimed through it; and the ray snapshot's cost where a frame took one.
pub fn world(n: usize, kind: WorldKind, rays: usize) -> (App, Vec<Ray3d>, Option<String>) {
    let mut app = headless_app();
    app.add_plugins(AccelPickingPlugin);
    // The copy is made in the frame at every size the suite runs, so that its cost can be
    // reported (by default, above 5,000 dynamic entities it is made on another thread).
    app.insert_resource(AccelSettings {
        index: kind.index,
        bvh: BvhIndexSettings {
            ray_snapshot_after_stable_frames: kind.snapshot.then_some(30),
            ray_snapshot_in_frame_max_entities: usize::MAX,
            // With motion the snapshot is kept whatever the ray count: the suite measures
            // what a ray costs through it (by default it is kept only while rays outnumber
            // the movers, which 1,024 rays against 1% of 100,000 movers would leave to
            // chance).
            ray_snapshot_rays_per_mover: if kind.moving_per_mille.is_some() {
                0.0
            } else {
                BvhIndexSettings::default().ray_snapshot_rays_per_mover
            },
            ..default()
        },
        ..default()
    });
    // The suite casts its rays outside frames, where the table's default policy, which
    // watches rays per frame, would never switch it on: the mode is set outright.
    app.insert_resource(AccelPickingSettings {
        slot_mesh_table: kind.table,
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
    if kind.is_static {
        app.world_mut()
            .spawn_batch(batch.into_iter().map(|(t, m)| (t, m, AccelStatic)));
    } else {
        app.world_mut().spawn_batch(batch);
    }
    app.update();
    app.update();
    let mut snapshot_note = None;
    // Steady state: the dynamic BVH's first rebuild (started in the background once the
    // spawns are in) installed, and the ray snapshot taken where allowed.
    settle_still_trees(&mut app, |app| {
        update_noting_snapshot(app, &mut snapshot_note)
    });
    let rays = (0..rays)
        .map(|_| {
            let origin = rng.vec3(-half * 1.2, half * 1.2);
            let target = rng.vec3(-half * 0.5, half * 0.5);
            Ray3d::new(origin, Dir3::new(target - origin).unwrap_or(Dir3::X))
        })
        .collect();
    assert_eq!(
        app.world().resource::<SlotMeshTable>().is_active(),
        kind.table == SlotMeshTableMode::Always,
        "the slot mesh table follows its mode"
    );
    (app, rays, snapshot_note)
}

/// Whether rays walk the snapshot of the dynamic tree now.
pub fn has_snapshot(app: &App) -> bool {
    app.world()
        .resource::<AccelTrees>()
        .query()
        .has_dynamic_ray_snapshot()
}

/// Runs a frame, and notes what the ray snapshot of the dynamic tree cost if the frame took
/// one.
fn update_noting_snapshot(app: &mut App, note: &mut Option<String>) {
    let before = has_snapshot(app);
    app.update();
    if !before && has_snapshot(app) {
        let world = app.world();
        *note = Some(format!(
            "{} dynamic entities: ray snapshot taken in {:.2} ms",
            world.resource::<AccelTrees>().query().dynamic_len(),
            world.resource::<AccelStats>().maintain_time.as_secs_f64() * 1e3
        ));
    }
}
