//! `AccelRayCast` and `AccelPickingPlugin` against Bevy's own `MeshRayCast` and mesh picking
//! backend, on random scenes of mixed meshes, scales, rotations, hidden entities and render
//! layers.

use bevy::asset::RenderAssetUsages;
use bevy::camera::primitives::{Aabb, Frustum};
use bevy::camera::visibility::RenderLayers;
use bevy::ecs::system::RunSystemOnce;
use bevy::math::bounding::{Aabb3d, BoundingSphere};
use bevy::math::primitives::ViewFrustum;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::picking::Pickable;
use bevy::picking::backend::ray::{RayId, RayMap};
use bevy::picking::backend::{HitData, PointerHits};
use bevy::picking::mesh_picking::MeshPickingSettings;
use bevy::picking::mesh_picking::ray_cast::{
    MeshRayCast, MeshRayCastSettings, RayCastBackfaces, RayCastVisibility, RayMeshHit,
    SimplifiedMesh, ray_aabb_intersection_3d,
};
use bevy::picking::pointer::PointerId;
use bevy::prelude::*;
use bevy_accel::picking::{AccelHitExtra, AccelMeshCache, AccelPickingSettings};
use bevy_accel::prelude::*;

mod common;
use common::{Rng, app};

/// Entities whose hits stop the ray in the mixed early-exit mode.
#[derive(Component)]
struct Blocker;

/// Mesh assets of every kind Bevy's ray cast reads: u32, u16 and no indices, with and without
/// normals and uvs, closed and open, flat.
fn test_meshes(meshes: &mut Assets<Mesh>) -> [Handle<Mesh>; TEST_MESHES] {
    let mut u16_sphere = Sphere::new(0.7).mesh().uv(16, 12);
    if let Some(Indices::U32(i)) = u16_sphere.indices() {
        let short = i.iter().map(|&i| i as u16).collect();
        u16_sphere.insert_indices(Indices::U16(short));
    }
    // Every seventh triangle names a vertex the mesh does not have: Bevy skips those
    // triangles and keeps the rest.
    let mut broken_sphere = Sphere::new(0.9).mesh().uv(24, 14);
    if let Some(Indices::U32(i)) = broken_sphere.indices_mut() {
        for triangle in i.chunks_exact_mut(3).step_by(7) {
            triangle[1] = u32::MAX;
        }
    }
    let mut bare_torus = Mesh::from(Torus::new(0.3, 0.8));
    bare_torus.remove_attribute(Mesh::ATTRIBUTE_NORMAL);
    bare_torus.remove_attribute(Mesh::ATTRIBUTE_UV_0);
    [
        Mesh::from(Cuboid::new(1.0, 2.0, 0.5)),
        Sphere::new(1.0).mesh().uv(32, 18),
        Sphere::new(0.8).mesh().ico(3).unwrap(),
        Mesh::from(Torus::new(0.5, 1.0)),
        Mesh::from(Cylinder::new(0.5, 2.0)),
        Mesh::from(Capsule3d::default()),
        Mesh::from(Cone::default()),
        Mesh::from(Plane3d::new(Vec3::Y, Vec2::splat(1.0))),
        u16_sphere,
        Mesh::from(Torus::new(0.3, 0.8)).with_duplicated_vertices(),
        bare_torus,
        broken_sphere,
    ]
    .map(|m| meshes.add(m))
}

/// How many assets [`test_meshes`] makes.
const TEST_MESHES: usize = 12;

/// A random scene of `n` mesh entities (some hidden, on other layers, double-sided, with a
/// simplified mesh, blocking) and a few mesh-less entities with bounds only.
fn populate(app: &mut App, n: usize, seed: u64) -> Vec<Entity> {
    let mut rng = Rng(seed);
    let handles = test_meshes(&mut app.world_mut().resource_mut::<Assets<Mesh>>());
    let world = app.world_mut();
    let mut out = Vec::new();
    for _ in 0..n {
        let axis = rng.vec3(1.0).normalize_or(Vec3::Y);
        let scale = Vec3::new(
            rng.range(0.3, 3.0),
            rng.range(0.3, 3.0),
            rng.range(0.3, 3.0),
        );
        let transform = Transform::from_translation(rng.vec3(50.0))
            .with_rotation(Quat::from_axis_angle(axis, rng.range(0.0, 6.3)))
            .with_scale(scale);
        let mesh = handles[rng.next() as usize % handles.len()].clone();
        let mut e = world.spawn((transform, Mesh3d(mesh)));
        if rng.chance(0.1) {
            e.insert(Visibility::Hidden);
        }
        if rng.chance(0.1) {
            e.insert(RenderLayers::layer(1));
        }
        if rng.chance(0.1) {
            e.insert(RayCastBackfaces);
        }
        if rng.chance(0.05) {
            // A smaller stand-in inside the same bounds (the cuboid fits every mesh's box
            // only partly, which Bevy handles by its box test: so must we).
            e.insert(SimplifiedMesh(handles[0].clone()));
        }
        if rng.chance(0.3) {
            e.insert(Blocker);
        }
        out.push(e.id());
    }
    for _ in 0..n / 20 {
        let t = Transform::from_translation(rng.vec3(50.0));
        world.spawn((t, Aabb::from_min_max(Vec3::splat(-1.0), Vec3::splat(1.0))));
    }
    app.update();
    app.update();
    out
}

fn random_ray(rng: &mut Rng) -> Ray3d {
    let origin = rng.vec3(70.0);
    let target = rng.vec3(45.0);
    Ray3d::new(origin, Dir3::new(target - origin).unwrap_or(Dir3::X))
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * b.abs().max(1e-2)
}

/// How one ray's results compare.
enum Outcome {
    Equal,
    /// Differ only where a hit lies within 1e-4 (barycentric) of a triangle edge, where
    /// Möller-Trumbore and the watertight test may decide differently.
    Grazing,
    Different(String),
}

fn near_edge(hit: &RayMeshHit) -> bool {
    hit.barycentric_coords.min_element() < 1e-4
}

fn compare(ours: &[(Entity, RayMeshHit)], theirs: &[(Entity, RayMeshHit)]) -> Outcome {
    let same_entities = ours.len() == theirs.len()
        && ours.iter().zip(theirs).all(|((a, ha), (b, hb))| {
            // Two hits at one distance may come in either order.
            a == b || close(ha.distance, hb.distance)
        });
    if same_entities {
        for ((e, a), (_, b)) in ours.iter().zip(theirs) {
            let scale = 1e-4 * (1.0 + b.point.length());
            if !close(a.distance, b.distance) || a.point.distance(b.point) > scale {
                if near_edge(a) || near_edge(b) {
                    return Outcome::Grazing;
                }
                return Outcome::Different(format!(
                    "{e}: distance {} vs {}, point {} vs {}",
                    a.distance, b.distance, a.point, b.point
                ));
            }
            if a.triangle_index == b.triangle_index
                && a.normal.distance(b.normal) > 1e-3 * (1.0 + b.normal.length())
            {
                return Outcome::Different(format!("{e}: normal {} vs {}", a.normal, b.normal));
            }
        }
        return Outcome::Equal;
    }
    // A hit one side has and the other lacks, on an edge: a grazing ray.
    let only = |x: &[(Entity, RayMeshHit)], y: &[(Entity, RayMeshHit)]| {
        x.iter()
            .filter(|(e, _)| !y.iter().any(|(f, _)| f == e))
            .map(|(_, h)| near_edge(h))
            .collect::<Vec<_>>()
    };
    let differing: Vec<bool> = only(ours, theirs)
        .into_iter()
        .chain(only(theirs, ours))
        .collect();
    if !differing.is_empty() && differing.iter().all(|&edge| edge) {
        return Outcome::Grazing;
    }
    let brief = |x: &[(Entity, RayMeshHit)]| {
        x.iter()
            .take(4)
            .map(|(e, h)| format!("{e}@{}", h.distance))
            .collect::<Vec<_>>()
            .join(", ")
    };
    Outcome::Different(format!(
        "{} hits [{}] vs {} hits [{}]",
        ours.len(),
        brief(ours),
        theirs.len(),
        brief(theirs)
    ))
}

#[derive(Default, Debug)]
struct Tally {
    rays: usize,
    hits: usize,
    grazing: usize,
    different: usize,
    first: Vec<String>,
}

/// Casts `rays` random rays with both ray casts under three settings and tallies the outcomes.
fn equivalence(app: &mut App, rays: usize, seed: u64) -> Tally {
    app.world_mut()
        .run_system_once(
            move |mut ours: AccelRayCast,
                  mut bevy: MeshRayCast,
                  layers: Query<&RenderLayers>,
                  blockers: Query<(), With<Blocker>>| {
                let mut rng = Rng(seed);
                let mut tally = Tally::default();
                let on_layer_0 = |e| {
                    layers
                        .get(e)
                        .map_or(true, |l| l.intersects(&RenderLayers::default()))
                };
                let blocks = |e| blockers.contains(e);
                for i in 0..rays {
                    let ray = random_ray(&mut rng);
                    let base = MeshRayCastSettings::default();
                    let settings = match i % 3 {
                        0 => base
                            .with_visibility(RayCastVisibility::Visible)
                            .with_filter(&on_layer_0),
                        1 => base
                            .with_visibility(RayCastVisibility::Any)
                            .never_early_exit(),
                        _ => base
                            .with_visibility(RayCastVisibility::Visible)
                            .with_early_exit_test(&blocks),
                    };
                    let a = ours.cast_ray(ray, &settings).to_vec();
                    let b = bevy.cast_ray(ray, &settings);
                    tally.rays += 1;
                    tally.hits += b.len();
                    match compare(&a, b) {
                        Outcome::Equal => {}
                        Outcome::Grazing => tally.grazing += 1,
                        Outcome::Different(why) => {
                            tally.different += 1;
                            if tally.first.len() < 5 {
                                tally.first.push(format!("ray {i} {ray:?}: {why}"));
                            }
                        }
                    }
                }
                tally
            },
        )
        .unwrap()
}

#[test]
fn ray_casts_equal_mesh_ray_cast_on_random_scenes() {
    for seed in [1, 2, 3] {
        let mut app = app();
        if seed == 3 {
            // Seed 3's copy is made on a background thread.
            app.insert_resource(AccelSettings {
                ray_snapshot_in_frame_max_entities: 0,
                ..default()
            });
        }
        populate(&mut app, 1000, seed);
        let copied = |app: &App| {
            app.world()
                .resource::<AccelTrees>()
                .query()
                .has_dynamic_ray_snapshot()
        };
        if seed >= 2 {
            // Seeds 2 and 3's rays walk the dynamic tree's wide copy, which the plugin makes
            // once the world has been still long enough; seed 1's walk the binary tree.
            let wait = AccelSettings::default().ray_snapshot_after_stable_frames;
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
        assert_eq!(copied(&app), seed >= 2);
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
        });
    let entities = populate(&mut app, 1000, 9);
    let mut rng = Rng(5);
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
             targets: Query<(Entity, &Aabb, &GlobalTransform)>,
             trees: Res<AccelTrees>| {
                let mut rng = Rng(11);
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
                let brute = |keep: &dyn Fn(&bevy_accel::accel::Aabb) -> bool| {
                    let mut v: Vec<Entity> = trees
                        .iter()
                        .filter(|&(_, slot)| keep(&trees.world_bounds(slot)))
                        .map(|(e, _)| e)
                        .collect();
                    v.sort_unstable();
                    v
                };
                let mut nonempty = 0;
                for _ in 0..100 {
                    let p = rng.vec3(50.0);
                    let got = ours.overlap_point(p).to_vec();
                    assert_eq!(got, brute(&|b| b.contains_point(p)));
                    let half = Vec3::splat(rng.range(0.0, 10.0));
                    let query = Aabb3d::new(p, half);
                    let q = bevy_accel::accel::Aabb::new(p - half, p + half);
                    let got = ours.overlap_aabb(query).to_vec();
                    assert_eq!(got, brute(&|b| b.intersects_aabb(&q)));
                    nonempty += usize::from(!got.is_empty());
                    let r = rng.range(0.0, 10.0);
                    let got = ours.overlap_sphere(BoundingSphere::new(p, r)).to_vec();
                    assert_eq!(got, brute(&|b| b.distance_squared_to_point(p) <= r * r));
                    let view = Mat4::look_at_rh(p, rng.vec3(50.0), Vec3::Y);
                    let proj = Mat4::perspective_rh(0.8, 1.5, 0.1, rng.range(5.0, 80.0));
                    let clip = proj * view;
                    let frustum = Frustum(ViewFrustum::from_clip_from_world(&clip));
                    let planes = frustum.half_spaces.map(|h| h.normal_d());
                    let f = bevy_accel::accel::Frustum::from_planes(planes);
                    let got = ours.overlap_frustum(&frustum).to_vec();
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
