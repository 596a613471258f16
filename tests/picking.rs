//! `AccelRayCast` and `AccelPickingPlugin` against Bevy's own `MeshRayCast` and mesh picking
//! backend, on random scenes of mixed meshes, scales, rotations, hidden entities and render
//! layers.

use bevy::asset::RenderAssetUsages;
use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::RenderLayers;
use bevy::ecs::system::RunSystemOnce;
use bevy::math::bounding::{Aabb3d, BoundingSphere};
use bevy::math::primitives::ViewFrustum;
use bevy::mesh::PrimitiveTopology;
use bevy::picking::Pickable;
use bevy::picking::backend::ray::{RayId, RayMap};
use bevy::picking::backend::{HitData, PointerHits};
use bevy::picking::mesh_picking::MeshPickingSettings;
use bevy::picking::mesh_picking::ray_cast::{
    MeshRayCastSettings, RayCastVisibility, RayMeshHit, ray_aabb_intersection_3d,
};
use bevy::picking::pointer::PointerId;
use bevy::prelude::*;
use bevy_accel::picking::{
    AccelHitExtra, AccelMeshCache, AccelPickingSettings, SlotMeshTable, SlotMeshTableMode,
};
use bevy_accel::prelude::*;

mod common;
mod picking_scene;
use accel_testkit::Rng;
use common::app;
use picking_scene::*;

#[test]
fn ray_casts_equal_mesh_ray_cast_on_random_scenes() {
    for seed in [1, 2, 3, 4] {
        let mut app = app();
        if seed == 2 {
            // Seed 2's candidates find their meshes through the slot mesh table.
            app.insert_resource(AccelPickingSettings {
                slot_mesh_table: SlotMeshTableMode::Always,
                ..default()
            });
        }
        if seed == 3 {
            // Seed 3's copy is made on a background thread.
            app.insert_resource(AccelSettings {
                bvh: BvhIndexSettings {
                    ray_snapshot_in_frame_max_entities: 0,
                    ..default()
                },
                ..default()
            });
        }
        if seed == 4 {
            // Seed 4's entities are busy movers: their own space comes from their rows.
            app.insert_resource(AccelSettings {
                busy_movers: BusyMoverSettings {
                    mode: BusyMovers::On,
                    ..default()
                },
                ..default()
            });
        }
        let entities = populate(&mut app, 1000, seed);
        if seed == 4 {
            app.update();
            // Every second entity moves, so the rays meet busy movers and tree entries.
            for &e in entities.iter().step_by(2) {
                app.world_mut().get_mut::<Transform>(e).unwrap().translation +=
                    Vec3::new(0.5, -0.25, 0.125);
            }
            app.update();
            let busy = app.world().resource::<AccelTrees>().busy_len();
            assert!(busy >= 400, "{busy} busy movers");
        }
        let copied = |app: &App| {
            app.world()
                .resource::<AccelTrees>()
                .query()
                .has_dynamic_ray_snapshot()
        };
        if (2..=3).contains(&seed) {
            // Seeds 2 and 3's rays walk the dynamic tree's wide copy, which the plugin makes
            // once the world has been still long enough; seed 1's walk the binary tree.
            let wait = AccelSettings::default()
                .bvh
                .ray_snapshot_after_stable_frames;
            for _ in 0..wait.expect("on by default") {
                app.update();
            }
            for _ in 0..1000 {
                if copied(&app) {
                    break;
                }
                std::thread::sleep(std::time::Duration::from_millis(1));
                app.update();
            }
        }
        assert_eq!(copied(&app), (2..=3).contains(&seed));
        assert_eq!(
            app.world().resource::<SlotMeshTable>().is_active(),
            seed == 2
        );
        let tally = equivalence(&mut app, 10_000, seed * 77);
        println!("seed {seed}: {tally:?}");
        assert!(
            tally.hits * 4 > tally.rays,
            "too few hits ({}) for the test to mean anything",
            tally.hits
        );
        assert_eq!(
            tally.different, 0,
            "{} of {} rays differ (first: {:?})",
            tally.different, tally.rays, tally.first
        );
        // Grazing rays are edge cases of the two triangle tests; random rays almost never
        // graze an edge to 1e-4.
        assert!(
            tally.grazing * 1000 <= tally.rays,
            "{} grazing rays",
            tally.grazing
        );
        // Lazy building: only meshes some ray reached have a BVH, at most one per asset.
        assert!(app.world().resource::<AccelMeshCache>().len() <= TEST_MESHES);
    }
}

#[test]
fn ray_casts_equal_mesh_ray_cast_on_every_index() {
    // The default (automatic) choice stays on the BVH at this size; the others here.
    for index in IndexChoice::ALL {
        if index == IndexChoice::Automatic || index == IndexChoice::Bvh {
            continue;
        }
        let mut app = app();
        app.insert_resource(AccelSettings {
            index,
            busy_movers: BusyMoverSettings {
                mode: BusyMovers::Off,
                ..default()
            },
            ..default()
        });
        populate(&mut app, 1000, 5);
        app.update();
        assert_eq!(app.world().resource::<AccelStats>().index, index);
        let tally = equivalence(&mut app, 2_000, 55);
        assert!(tally.hits * 4 > tally.rays, "{index:?}: too few hits");
        assert_eq!(
            tally.different, 0,
            "{index:?}: {} of {} rays differ (first: {:?})",
            tally.different, tally.rays, tally.first
        );
    }
}

/// Runs one backend system on a ray map and returns the hits it wrote, by camera order.
fn backend_hits<M>(app: &mut App, system: impl IntoSystem<(), (), M>) -> Vec<PointerHits> {
    app.world_mut().run_system_once(system).unwrap();
    let mut hits: Vec<PointerHits> = app
        .world_mut()
        .resource_mut::<Messages<PointerHits>>()
        .drain()
        .collect();
    hits.sort_by(|a, b| a.order.total_cmp(&b.order));
    hits
}

#[test]
fn backend_writes_what_bevys_mesh_backend_writes() {
    let mut app = app();
    app.add_message::<PointerHits>()
        .init_resource::<RayMap>()
        .insert_resource(MeshPickingSettings {
            require_markers: false,
            ray_cast_visibility: RayCastVisibility::Visible,
        })
        .insert_resource(AccelPickingSettings {
            require_markers: false,
            ray_cast_visibility: RayCastVisibility::Visible,
            // Through the slot mesh table, as a scene casting many rays runs.
            slot_mesh_table: SlotMeshTableMode::Always,
            ..default()
        });
    let entities = populate(&mut app, 1000, 9);
    let mut rng = Rng::from_state(5);
    for (i, &e) in entities.iter().enumerate() {
        match i % 7 {
            0 => {
                app.world_mut().entity_mut(e).insert(Pickable {
                    should_block_lower: false,
                    is_hoverable: true,
                });
            }
            1 => {
                app.world_mut().entity_mut(e).insert(Pickable::IGNORE);
            }
            _ => {}
        }
    }
    let cameras = [
        app.world_mut()
            .spawn(Camera {
                order: 0,
                ..default()
            })
            .id(),
        app.world_mut()
            .spawn((
                Camera {
                    order: 3,
                    ..default()
                },
                RenderLayers::from_layers(&[0, 1]),
            ))
            .id(),
    ];
    let (mut rays, mut compared, mut grazing) = (0, 0, 0);
    for _ in 0..300 {
        let mut map = RayMap::default();
        for (k, &camera) in cameras.iter().enumerate() {
            map.map.insert(
                RayId::new(camera, PointerId::Touch(k as u64)),
                random_ray(&mut rng),
            );
        }
        rays += map.map.len();
        app.insert_resource(map);
        let ours = backend_hits(&mut app, bevy_accel::picking::update_hits);
        let theirs = backend_hits(&mut app, bevy::picking::mesh_picking::update_hits);
        let as_pairs = |h: &PointerHits| -> Vec<(Entity, RayMeshHit)> {
            h.picks
                .iter()
                .map(|(e, d): &(Entity, HitData)| {
                    let extra = d.extra_as::<AccelHitExtra>();
                    let hit = RayMeshHit {
                        point: d.position.unwrap(),
                        normal: d.normal.unwrap(),
                        barycentric_coords: extra.map_or(Vec3::ONE, |x| x.barycentric_coords),
                        distance: d.depth,
                        triangle: None,
                        uv: None,
                        triangle_index: extra.and_then(|x| x.triangle_index),
                    };
                    (*e, hit)
                })
                .collect()
        };
        let mismatch = ours.len() != theirs.len()
            || ours.iter().zip(&theirs).any(|(a, b)| {
                a.pointer != b.pointer
                    || a.order != b.order
                    || match compare(&as_pairs(a), &as_pairs(b)) {
                        Outcome::Equal => false,
                        Outcome::Grazing => {
                            grazing += 1;
                            false
                        }
                        Outcome::Different(_) => true,
                    }
            });
        assert!(
            !mismatch,
            "backends differ: {} vs {} pointer hits",
            ours.len(),
            theirs.len()
        );
        compared += theirs.len();
        assert!(
            ours.iter()
                .flat_map(|h| &h.picks)
                .all(|(_, d)| d.extra_as::<AccelHitExtra>().is_some())
        );
    }
    assert!(compared > rays / 4, "only {compared} of {rays} rays hit");
    assert!(grazing <= 2, "{grazing} grazing rays");
}

#[test]
fn bounds_casts_overlaps_batches_and_max_distance_agree_with_brute_force() {
    let mut app = app();
    populate(&mut app, 500, 3);
    app.world_mut()
        .run_system_once(
            |mut ours: AccelRayCast,
             mut spatial: AccelSpatialQuery,
             targets: Query<(Entity, &Aabb, &GlobalTransform)>,
             trees: Res<AccelTrees>| {
                let mut rng = Rng::from_state(11);
                let any = MeshRayCastSettings::default()
                    .with_visibility(RayCastVisibility::Any)
                    .never_early_exit();
                let mut total = 0;
                for _ in 0..500 {
                    let ray = random_ray(&mut rng);
                    // Bounds only: every entity's oriented box, as Bevy's box test sees it.
                    let got: Vec<(Entity, f32)> = ours
                        .cast_ray_bounds(ray, f32::INFINITY, &any)
                        .iter()
                        .map(|(e, h)| (*e, h.distance))
                        .collect();
                    let mut want: Vec<(Entity, f32)> = targets
                        .iter()
                        .filter_map(|(e, aabb, t)| {
                            let b = Aabb3d::new(aabb.center, aabb.half_extents);
                            ray_aabb_intersection_3d(ray, &b, &t.affine()).map(|d| (e, d))
                        })
                        .collect();
                    want.sort_by(|a, b| a.1.total_cmp(&b.1));
                    assert_eq!(got.len(), want.len());
                    for ((a, da), (b, db)) in got.iter().zip(&want) {
                        assert!(a == b || (da - db).abs() < 1e-4, "{a} {da} vs {b} {db}");
                        assert!((da - db).abs() <= 1e-4 * db.max(1.0));
                    }
                    total += got.len();

                    // A max distance cuts the full list.
                    let full: Vec<(Entity, f32)> = ours
                        .cast_ray(ray, &any)
                        .iter()
                        .map(|(e, h)| (*e, h.distance))
                        .collect();
                    let limit = rng.range(0.0, 120.0);
                    let within: Vec<(Entity, f32)> = ours
                        .cast_ray_within(ray, limit, &any)
                        .iter()
                        .map(|(e, h)| (*e, h.distance))
                        .collect();
                    let cut: Vec<_> = full.iter().copied().filter(|h| h.1 <= limit).collect();
                    assert_eq!(within, cut);
                }
                assert!(total > 100, "only {total} box hits");

                // A batch equals its rays cast one by one.
                let rays: Vec<Ray3d> = (0..50).map(|_| random_ray(&mut rng)).collect();
                let batch: Vec<(usize, Entity, f32)> = ours
                    .cast_rays(&rays, f32::INFINITY, &any)
                    .iter()
                    .map(|(i, e, h)| (*i, *e, h.distance))
                    .collect();
                let single: Vec<(usize, Entity, f32)> = rays
                    .iter()
                    .enumerate()
                    .flat_map(|(i, &r)| {
                        ours.cast_ray(r, &any)
                            .iter()
                            .map(|(e, h)| (i, *e, h.distance))
                            .collect::<Vec<_>>()
                    })
                    .collect();
                assert_eq!(batch, single);
                assert!(!batch.is_empty());

                // Overlaps equal a scan of every tracked entity's exact world box.
                let brute = |keep: &dyn Fn(&bevy_accel::spatial_accel::Aabb) -> bool| {
                    common::entities_whose_box(&trees, keep)
                };
                let mut nonempty = 0;
                for _ in 0..100 {
                    let p = rng.vec3(-50.0, 50.0);
                    let got = spatial.overlap_point(p).to_vec();
                    assert_eq!(got, brute(&|b| b.contains_point(p)));
                    let half = Vec3::splat(rng.range(0.0, 10.0));
                    let query = Aabb3d::new(p, half);
                    let q = bevy_accel::spatial_accel::Aabb::new(p - half, p + half);
                    let got = spatial.overlap_aabb(query).to_vec();
                    assert_eq!(got, brute(&|b| b.intersects_aabb(&q)));
                    nonempty += usize::from(!got.is_empty());
                    let r = rng.range(0.0, 10.0);
                    let got = spatial.overlap_sphere(BoundingSphere::new(p, r)).to_vec();
                    assert_eq!(got, brute(&|b| b.distance_squared_to_point(p) <= r * r));
                    let view = Mat4::look_at_rh(p, rng.vec3(-50.0, 50.0), Vec3::Y);
                    let proj = Mat4::perspective_rh(0.8, 1.5, 0.1, rng.range(5.0, 80.0));
                    let clip = proj * view;
                    let frustum = Frustum(ViewFrustum::from_clip_from_world(&clip));
                    let planes = frustum.half_spaces.map(|h| h.normal_d());
                    let f = bevy_accel::spatial_accel::Frustum::from_planes(planes);
                    let got = spatial.overlap_frustum(&frustum).to_vec();
                    assert_eq!(got, brute(&|b| f.intersects_aabb(b)));
                }
                assert!(nonempty > 10);
            },
        )
        .unwrap();
}

#[test]
fn edited_meshes_are_rebuilt_and_unreadable_ones_hit_their_bounds() {
    let mut app = app();
    let (cube, lines) = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        let cube = meshes.add(Cuboid::from_length(2.0));
        let mut lines = Mesh::new(PrimitiveTopology::LineList, RenderAssetUsages::default());
        lines.insert_attribute(
            Mesh::ATTRIBUTE_POSITION,
            vec![[-1.0f32, -1.0, -1.0], [1.0, 1.0, 1.0]],
        );
        (cube, meshes.add(lines))
    };
    let a = app.world_mut().spawn(Mesh3d(cube.clone())).id();
    let b = app
        .world_mut()
        .spawn((Mesh3d(lines), Transform::from_xyz(10.0, 0.0, 0.0)))
        .id();
    app.update();
    app.update();
    let cast = |app: &mut App, x: f32| {
        app.world_mut()
            .run_system_once(move |mut rc: AccelRayCast| {
                let ray = Ray3d::new(Vec3::new(x, 0.2, 5.0), Dir3::NEG_Z);
                let settings =
                    MeshRayCastSettings::default().with_visibility(RayCastVisibility::Any);
                rc.cast_ray(ray, &settings)
                    .iter()
                    .map(|(e, h)| (*e, h.distance, h.triangle_index, h.normal))
                    .collect::<Vec<_>>()
            })
            .unwrap()
    };
    let hits = cast(&mut app, 0.0);
    assert_eq!(hits.len(), 1);
    assert_eq!((hits[0].0, hits[0].1), (a, 4.0));
    assert!(hits[0].2.is_some());
    assert!(app.world().resource::<AccelMeshCache>().contains(cube.id()));

    // Shrink the cube in place: the cached BVH must go, and the next ray sees the new faces.
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .insert(cube.id(), Mesh::from(Cuboid::from_length(1.0)))
        .unwrap();
    app.update();
    assert!(!app.world().resource::<AccelMeshCache>().contains(cube.id()));
    let hits = cast(&mut app, 0.0);
    assert_eq!((hits[0].0, hits[0].1), (a, 4.5));

    // A line list has no triangles: it is hit on its box, facing the ray.
    let hits = cast(&mut app, 10.0);
    assert_eq!(hits.len(), 1);
    assert_eq!((hits[0].0, hits[0].2), (b, None));
    assert!((hits[0].1 - 4.0).abs() < 1e-4);
    assert_eq!(hits[0].3, Vec3::Z);
}
