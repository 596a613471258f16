//! The mesh tree's touching query against the test over every triangle, in the mesh's own
//! space under mirrored and non-uniformly scaled transforms; and those local verdicts
//! against the screen-space oracle on the triangles placed in the world.

use super::oracle::{Camera, Kind, Oracle, random_rect};
use accel_testkit::Rng;
use accel_testkit::shapes::{icosphere, triangle_soup, uv_sphere};
use glam::{DVec3, Mat4, Quat, Vec2, Vec3, Vec3A};
use spatial_accel::mesh::{MeshBvh, SpatialSplits};
use spatial_accel::{BuildConfig, Frustum};

/// A random placement: rotated, scaled by 0.2 to 5 on each axis, mirrored on any of them.
fn random_placement(rng: &mut Rng) -> Mat4 {
    let scale = Vec3::new(
        rng.signed_log(0.2, 5.0),
        rng.signed_log(0.2, 5.0),
        rng.signed_log(0.2, 5.0),
    );
    let rotation = Quat::from_axis_angle(Vec3::from(rng.unit_vector_f64()), rng.range(0.0, 6.3));
    Mat4::from_scale_rotation_translation(scale, rotation, Vec3::from(rng.vec3a(-100.0, 100.0)))
}

/// A rectangle: a random one, or one grazing a vertex of the mesh (a corner of the rectangle
/// at its projection, a zero-size rectangle there, or a zero-width one through it).
fn rect(rng: &mut Rng, camera: &Camera, vertex: Vec3) -> (Vec2, Vec2, bool) {
    let ndc = camera.clip_from_world.project_point3(vertex).truncate();
    match rng.below(4) {
        0 => (
            ndc,
            ndc + Vec2::new(rng.signed_log(1e-3, 1.0), rng.signed_log(1e-3, 1.0)),
            true,
        ),
        1 => (ndc, ndc, true),
        2 => (Vec2::new(ndc.x, -2.0), Vec2::new(ndc.x, 2.0), true),
        _ => {
            let (a, b) = random_rect(rng);
            (a, b, false)
        }
    }
}

#[derive(Default, Debug)]
struct Counts {
    queries: u64,
    some: u64,
    triangles: u64,
    touching: u64,
    /// Local verdicts differing from the world-space oracle within the band.
    band: u64,
}

#[test]
fn mesh_query_is_the_test_over_every_triangle() {
    let mut rng = Rng::new(21);
    let shapes = [
        ("soup", triangle_soup(&mut rng, 300)),
        ("uv sphere", uv_sphere(10, 16, 2.0)),
        ("icosphere", icosphere(2)),
    ];
    let mut counts = Counts::default();
    for (name, shape) in &shapes {
        let mut vertices = shape.positions();
        let indices = shape.flat_indices();
        let mut meshes = [
            ("pre-split", MeshBvh::new(&vertices, &indices).unwrap()),
            (
                "whole",
                MeshBvh::with_config(&vertices, &indices, &BuildConfig::default()).unwrap(),
            ),
            (
                "spatial",
                MeshBvh::with_spatial_splits(
                    &vertices,
                    &indices,
                    &BuildConfig::default(),
                    &SpatialSplits::default(),
                )
                .unwrap(),
            ),
            ("refit", MeshBvh::new(&vertices, &indices).unwrap()),
        ];
        for round in 0..3 {
            if round > 0 {
                // A new pose for the refit tree; in the last one a vertex is lost (NaN).
                for v in &mut vertices {
                    *v += Vec3::from(rng.vec3a(-0.3, 0.3));
                }
                if round == 2 {
                    vertices[7] = Vec3::NAN;
                }
                meshes[3].1.refit(&vertices).unwrap();
            }
            for _ in 0..60 {
                let kind = [Kind::Perspective, Kind::Orthographic][rng.below(2)];
                let world_from_local = random_placement(&mut rng);
                let target = world_from_local.transform_point3(Vec3::ZERO);
                let camera = Camera::random(&mut rng, kind, 200.0, Some(target));
                for _ in 0..6 {
                    let vertex = vertices[rng.below(vertices.len())];
                    let (a, b, grazing) =
                        rect(&mut rng, &camera, world_from_local.transform_point3(vertex));
                    let Some(world) = Frustum::from_clip_rect(&camera.clip_from_world, a, b) else {
                        continue;
                    };
                    let local = world.transformed(&world_from_local);
                    let triangles: Vec<[Vec3A; 3]> = indices
                        .chunks_exact(3)
                        .map(|t| [0, 1, 2].map(|k| Vec3A::from(vertices[t[k] as usize])))
                        .collect();
                    let brute: Vec<u32> = (0..triangles.len() as u32)
                        .filter(|&t| local.touches_triangle(&triangles[t as usize]))
                        .collect();
                    for (build, mesh) in &meshes {
                        if *build != "refit" && round > 0 {
                            continue;
                        }
                        let what = || format!("{name} {build} round {round} {kind:?} rect {a} {b}");
                        assert_eq!(
                            mesh.any_triangle_in_frustum(&local),
                            !brute.is_empty(),
                            "{}",
                            what()
                        );
                        let mut got = Vec::new();
                        mesh.for_each_triangle_in_frustum(&local, |t| got.push(t));
                        got.sort_unstable();
                        assert_eq!(got, brute, "{}", what());
                        counts.queries += 1;
                        counts.some += u64::from(!brute.is_empty());
                    }
                    if !grazing {
                        compare_with_world(
                            &mut counts,
                            &camera,
                            a,
                            b,
                            world_from_local,
                            &triangles,
                            &brute,
                        );
                    }
                }
            }
        }
    }
    println!("{counts:?}");
    assert!(
        counts.some * 10 > counts.queries && (counts.queries - counts.some) * 10 > counts.queries
    );
    assert!(counts.touching * 50 > counts.triangles, "{counts:?}");
    assert!(counts.band <= 8, "{counts:?}");
}

/// The local verdicts against the projecting oracle on the triangles placed in the world
/// (in `f64`): differences only within the band (a few bands: the move to local space
/// rounds once more), and counted.
fn compare_with_world(
    counts: &mut Counts,
    camera: &Camera,
    a: Vec2,
    b: Vec2,
    world_from_local: Mat4,
    triangles: &[[Vec3A; 3]],
    brute: &[u32],
) {
    let oracle = Oracle::new(&camera.clip_from_world, a, b);
    let m = world_from_local.as_dmat4();
    for (t, corners) in triangles.iter().enumerate() {
        if !corners.iter().all(|c| c.is_finite()) {
            continue;
        }
        let world: [DVec3; 3] = corners.map(|c| m.transform_point3(c.as_dvec3()));
        let got = brute.binary_search(&(t as u32)).is_ok();
        let want = oracle.triangle(world);
        counts.triangles += 1;
        counts.touching += u64::from(want);
        if got != want {
            let excused = if got {
                oracle.triangle_within_band(world, 8.0)
            } else {
                !oracle.triangle_within_band(world, -8.0)
            };
            assert!(
                excused,
                "triangle {t} {corners:?}: local {got}, oracle {want}, rect {a} {b}"
            );
            counts.band += 1;
        }
    }
}

/// A point is inside the frustum moved into local space as its image is inside the world
/// frustum, by the projecting oracle, up to the band.
#[test]
fn transformed_frustum_holds_the_points_whose_images_are_inside() {
    let mut rng = Rng::new(22);
    let (mut inside, mut total, mut band) = (0, 0, 0);
    for _ in 0..300 {
        let kind = [Kind::Perspective, Kind::Orthographic][rng.below(2)];
        let world_from_local = random_placement(&mut rng);
        let camera = Camera::random(
            &mut rng,
            kind,
            200.0,
            Some(world_from_local.transform_point3(Vec3::ZERO)),
        );
        let (a, b) = random_rect(&mut rng);
        let world = Frustum::from_clip_rect(&camera.clip_from_world, a, b).unwrap();
        let local = world.transformed(&world_from_local);
        let oracle = Oracle::new(&camera.clip_from_world, a, b);
        let m = world_from_local.as_dmat4();
        for _ in 0..300 {
            let p = rng.vec3a(-20.0, 20.0);
            let image = m.transform_point3(p.as_dvec3());
            let (got, want) = (local.contains_point(p), oracle.point(image));
            total += 1;
            inside += u32::from(want);
            if got != want {
                assert!(
                    oracle.point_in_band(image, 8.0),
                    "{p} -> {image}: {got} vs {want}"
                );
                band += 1;
            }
        }
    }
    println!("{inside} of {total} inside, {band} in the band");
    assert!(inside * 20 > total && (total - inside) * 20 > total);
    assert!(band <= 8);
}
