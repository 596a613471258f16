//! Regressions for the bugs the numerical-stability stress suite (`accel-bench stress`)
//! found, one test each.

use accel::mesh::{Instance, InstancedScene, MeshBvh};
use accel::query::{BruteForceMesh, TriangleQuery};
use accel::{Aabb, Backfaces, BuildConfig, Bvh, Containment, Frustum, Ray, SpatialQuery};
use glam::{Affine3A, Mat4, Vec3, Vec3A};
use std::sync::Arc;

/// Far from the origin, the centre/half-extent form of the frustum test rounded a node box
/// outside while a small box inside it passed, so trees culled entries that the exact test
/// (and the brute-force oracle) kept. The corner form is monotone under inclusion.
#[test]
fn frustum_culling_keeps_boxes_far_from_the_origin() {
    let far = Vec3A::new(1e7, -7e6, 3e6);
    let mut rng = accel_testkit::Rng::new(3);
    let boxes: Vec<Aabb> = (0..2000)
        .map(|_| {
            let c = far + rng.vec3a(-1e4, 1e4);
            Aabb::from_center_half_extents(c, rng.vec3a(0.0, 0.5))
        })
        .collect();
    let bvh = Bvh::build(&boxes, &BuildConfig::default());
    for _ in 0..40 {
        let eye = far + rng.vec3a(-2e4, 2e4);
        let view = Mat4::look_at_rh(eye.into(), far.into(), Vec3::Y);
        let proj = Mat4::perspective_rh(rng.range(0.3, 1.5), 1.5, 10.0, 4e4);
        let f = Frustum::from_clip_from_world(&(proj * view));
        let mut got = Vec::new();
        bvh.for_each_in_frustum(&f, |id, _| got.push(id));
        got.retain(|&id| f.intersects_aabb(&boxes[id as usize]));
        got.sort_unstable();
        let want: Vec<u32> = (0..boxes.len() as u32)
            .filter(|&i| f.intersects_aabb(&boxes[i as usize]))
            .collect();
        assert_eq!(got, want);
    }
    // Inclusion: a box inside another is never classified further out.
    let f = Frustum::from_clip_from_world(&Mat4::perspective_rh(1.0, 1.0, 0.1, 100.0));
    let outer = Aabb::new(Vec3A::new(-1.0, -1.0, -50.0), Vec3A::new(1.0, 1.0, -40.0));
    let inner = Aabb::new(Vec3A::new(-0.5, -0.5, -45.0), Vec3A::new(0.5, 0.5, -44.0));
    assert_eq!(f.classify_aabb(&outer), Containment::Inside);
    assert_eq!(f.classify_aabb(&inner), Containment::Inside);
}

/// `nearest_k` with `k = usize::MAX` ("all of them") overflowed `k + 1` (a panic with
/// overflow checks on, a capacity error without).
#[test]
fn nearest_k_takes_any_k() {
    let boxes: Vec<Aabb> = (0..10)
        .map(|i| Aabb::from_point(Vec3A::splat(i as f32)))
        .collect();
    let bvh = Bvh::build(&boxes, &BuildConfig::default());
    let all = bvh.nearest_k(Vec3A::ZERO, usize::MAX, |i| {
        boxes[i as usize].distance_squared_to_point(Vec3A::ZERO)
    });
    assert_eq!(all.len(), 10);
    let mut grid = accel::UniformGrid::new();
    for (i, b) in boxes.iter().enumerate() {
        accel::query::DynamicIndex::insert(&mut grid, i as u32, *b).unwrap();
    }
    let all = grid.nearest_k(Vec3A::ZERO, usize::MAX, |i| {
        boxes[i as usize].distance_squared_to_point(Vec3A::ZERO)
    });
    assert_eq!(all.len(), 10);
}

/// The mesh oracle hit rays written field by field with an infinite direction, which every
/// tree turns away (`Ray::is_traceable`): oracle and trees disagreed.
#[test]
fn the_mesh_oracle_turns_untraceable_rays_away() {
    let vertices = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let oracle = BruteForceMesh::new(&vertices, &[0, 1, 2]).unwrap();
    let d = Vec3A::new(0.0, 0.0, f32::NEG_INFINITY);
    let ray = Ray {
        origin: Vec3A::new(0.0, 0.0, 1.0),
        direction: d,
        inv_direction: d.recip(),
        t_min: 0.0,
        t_max: f32::INFINITY,
    };
    let mut all = Vec::new();
    oracle.cast_ray_all(&ray, Backfaces::Include, &mut all);
    assert!(oracle.cast_ray(&ray, Backfaces::Include).is_none());
    assert!(!oracle.cast_ray_any(&ray, Backfaces::Include) && all.is_empty());
}

/// An instance whose finite transform overflows its world box could never be reached through
/// the top level; it is now rejected and reported.
#[test]
fn an_instance_whose_box_overflows_is_rejected() {
    let vertices = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let mesh = Arc::new(MeshBvh::new(&vertices, &[0, 1, 2]).unwrap());
    let huge = Affine3A::from_scale(Vec3::splat(f32::MAX));
    let scene = InstancedScene::new(vec![
        Instance {
            mesh: mesh.clone(),
            world_from_local: huge,
        },
        Instance {
            mesh,
            world_from_local: Affine3A::IDENTITY,
        },
    ]);
    assert_eq!(scene.rejected_instances(), &[0]);
    let hit = scene.cast_ray(
        &Ray::new(Vec3A::new(0.0, 0.0, 5.0), Vec3A::NEG_Z),
        Backfaces::Include,
    );
    assert_eq!(hit.map(|h| h.instance), Some(1));
}
