//! Regressions for the bugs the numerical-stability stress suite (`accel-bench stress`)
//! found, one test each.

use core::ops::ControlFlow;
use glam::{Affine3A, Mat4, Vec3, Vec3A};
use spatial_accel::bvh::SphereBvh;
use spatial_accel::mesh::{Instance, InstancedScene, MeshBvh};
use spatial_accel::query::{BruteForceMesh, DynamicIndex, TriangleQuery};
use spatial_accel::{Aabb, Backfaces, BuildConfig, Bvh, Containment, DynamicBvh, Frustum, Ray};
use spatial_accel::{SpatialQuery, Sphere, UniformGrid, WatertightRay};
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
    let mut grid = spatial_accel::UniformGrid::new();
    for (i, b) in boxes.iter().enumerate() {
        spatial_accel::query::DynamicIndex::insert(&mut grid, i as u32, *b).unwrap();
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

/// A box with an infinite bound gave its sphere the NaN centre `(-inf + inf) / 2`, which
/// made every ancestor sphere invalid: the sphere tree lost all its finite boxes.
#[test]
fn sphere_tree_keeps_finite_boxes_beside_an_infinite_one() {
    let mut boxes: Vec<Aabb> = (0..40)
        .map(|i| Aabb::from_center_half_extents(Vec3A::new(i as f32 * 3.0, 0.0, 0.0), Vec3A::ONE))
        .collect();
    boxes.push(Aabb::new(
        Vec3A::new(f32::NEG_INFINITY, 0.0, 0.0),
        Vec3A::new(f32::INFINITY, 1.0, 1.0),
    ));
    boxes.push(Aabb::new(Vec3A::splat(-f32::MAX), Vec3A::splat(f32::MAX)));
    let tree = SphereBvh::from_bvh(&Bvh::build(&boxes, &BuildConfig::default()), &boxes);
    assert!(tree.spheres().iter().all(Sphere::is_valid));
    let ray = Ray::new(Vec3A::new(30.0, 0.0, -10.0), Vec3A::Z);
    let hit = tree.cast_ray(&ray, |i, r| {
        (i < 40)
            .then(|| r.intersect_aabb(&boxes[i as usize]))
            .flatten()
    });
    assert_eq!(hit.map(|h| h.primitive), Some(10));
    let mut found = Vec::new();
    tree.for_each_containing_point(Vec3A::new(60.5, 0.5, 0.5), |i| {
        found.push(i);
        ControlFlow::Continue(())
    });
    assert!(found.contains(&20));
}

/// The sphere rule: a non-finite centre makes a sphere invalid, and an invalid sphere holds
/// nothing, in `Sphere`'s own tests as in every structure. A huge finite sphere is tested
/// without overflow, and only boxes that meet its own box pass (the grid visits those cells):
/// `Sphere::is_valid` accepted infinite centres, its test said yes, the grid said no.
#[test]
fn spheres_follow_one_rule_for_non_finite_and_huge_values() {
    let b = Aabb::new(Vec3A::new(0.0, 0.0, -60.0), Vec3A::new(1.0, 1.0, -50.0));
    let inf_centre = Sphere::new(Vec3A::new(0.0, f32::INFINITY, 0.0), 1e30);
    assert!(!inf_centre.is_valid() && !inf_centre.intersects_aabb(&b));
    assert!(!inf_centre.contains_point(Vec3A::ZERO));
    let everything = Sphere::new(Vec3A::ZERO, f32::INFINITY);
    assert!(everything.is_valid() && everything.intersects_aabb(&b));
    // Centre at z = 3e38, radius 3e38: it reaches down to z = 0, not to -50 (the distance
    // `3e38 + 50` rounds to `3e38`).
    let huge = Sphere::new(Vec3A::new(0.0, 0.0, 3.0e38), 3.0e38);
    assert!(!huge.intersects_aabb(&b));
    assert!(huge.intersects_aabb(&Aabb::from_point(Vec3A::new(0.0, 0.0, 1.0))));
    // Radius 1e30 squared overflows; a point 1.5e30 away along a diagonal is outside.
    let big = Sphere::new(Vec3A::ZERO, 1e30);
    assert!(!big.contains_point(Vec3A::splat(0.9e30)));
    assert!(big.contains_point(Vec3A::splat(0.5e30)));
    let mut grid = UniformGrid::new();
    grid.insert(0, b).unwrap();
    grid.insert(1, Aabb::from_point(Vec3A::new(0.0, 0.0, 1.0)))
        .unwrap();
    for s in [inf_centre, everything, huge, big] {
        let mut got = Vec::new();
        grid.for_each_overlapping_sphere(&s, |id| {
            got.push(id);
            ControlFlow::Continue(())
        });
        got.sort_unstable();
        let boxes = [b, Aabb::from_point(Vec3A::new(0.0, 0.0, 1.0))];
        let want: Vec<u32> = (0..2)
            .filter(|&i| s.intersects_aabb(&boxes[i as usize]))
            .collect();
        assert_eq!(got, want, "{s:?}");
    }
    // Rays meet spheres too large for the f32 quadratic, and an infinite one from the start.
    let ray = Ray::new(Vec3A::new(0.0, 0.0, -10.0), Vec3A::Z);
    assert_eq!(ray.intersect_sphere(&everything), Some(0.0));
    let far = Sphere::new(Vec3A::new(0.0, 0.0, 2e30), 1e30);
    let t = ray.intersect_sphere(&far).unwrap();
    assert!((t - 1e30).abs() <= 1e24, "{t}");
}

/// Area sums in f32 areas: a finite box with extents past 1.8e19 has an infinite f32 area,
/// and when it left the tree the kept sum became `inf - inf = NaN` (`AreaSums` from
/// `validate`). Its removal now also recounts the sums, which it left as rounding errors.
#[test]
fn dynamic_area_sums_survive_huge_boxes() {
    let mut tree = DynamicBvh::new();
    let mut handles = Vec::new();
    for i in 0..50 {
        let c = Vec3A::new(i as f32, 0.0, 0.0);
        handles.push(
            tree.insert(i, Aabb::from_center_half_extents(c, Vec3A::ONE))
                .unwrap(),
        );
    }
    let huge = tree
        .insert(99, Aabb::new(Vec3A::splat(-1e30), Vec3A::splat(1e30)))
        .unwrap();
    tree.maintain();
    tree.validate().unwrap();
    tree.remove(huge).unwrap();
    tree.update(handles[3], Aabb::new(Vec3A::splat(-1e25), Vec3A::ZERO))
        .unwrap();
    tree.maintain();
    tree.validate().unwrap();
    tree.update(handles[3], Aabb::from_point(Vec3A::ONE))
        .unwrap();
    tree.maintain();
    tree.validate().unwrap();
    assert!(tree.quality().sah_cost.is_finite());
}

/// A triangle with a non-finite corner at the build is in no leaf; a refit that made it
/// finite left it unreachable (rays the oracle sent through it missed). Such a refit now
/// builds again. A refit that makes a whole packet non-finite leaves it in its leaf with an
/// empty box, which `validate` called an unknown primitive.
#[test]
fn mesh_refit_brings_back_triangles_left_out_at_the_build() {
    let sphere = accel_testkit::shapes::icosphere(2).normalized(100.0);
    let indices = sphere.flat_indices();
    let clean = sphere.positions();
    let mut broken = clean.clone();
    for v in broken.iter_mut().step_by(7) {
        *v = Vec3::NAN;
    }
    let mut mesh = MeshBvh::new(&broken, &indices).unwrap();
    mesh.validate().unwrap();
    mesh.refit(&clean).unwrap();
    mesh.validate().unwrap();
    let oracle = BruteForceMesh::new(&clean, &indices).unwrap();
    let mut rng = accel_testkit::Rng::new(11);
    for _ in 0..500 {
        let ray = Ray::new(rng.vec3a(-150.0, 150.0), rng.unit_vector());
        let got = mesh.cast_ray(&ray, Backfaces::Include).map(|h| h.t);
        assert_eq!(got, oracle.cast_ray(&ray, Backfaces::Include).map(|h| h.t));
    }
    // Every vertex non-finite: every packet's box is empty, and the tree still validates.
    mesh.refit(&vec![Vec3::INFINITY; clean.len()]).unwrap();
    mesh.validate().unwrap();
    assert!(
        mesh.cast_ray(&Ray::new(Vec3A::ZERO, Vec3A::X), Backfaces::Include)
            .is_none()
    );
}

/// Arvo's centre/half-extent form rounded the low corner of a box from -100 to 1e30 up to
/// 0 (`c - h` at 5e29): an instance of such a mesh had a world box without its ordinary
/// triangles, and the top level never offered rays to them.
#[test]
fn transformed_boxes_keep_small_corners_beside_huge_ones() {
    let b = Aabb::new(Vec3A::new(-100.0, -1.0, -1.0), Vec3A::new(1e30, 1.0, 1.0));
    let w = b.transformed(&Affine3A::from_translation(Vec3::new(5.0, 0.0, 0.0)));
    assert_eq!(w.min, Vec3A::new(-95.0, -1.0, -1.0));
    let vertices = [
        Vec3::new(-50.0, -1.0, 0.0),
        Vec3::new(-40.0, -1.0, 0.0),
        Vec3::new(-45.0, 1.0, 0.0),
        Vec3::new(1e30, 0.0, 5.0),
        Vec3::new(1e30, 1.0, 5.0),
        Vec3::new(1e30, 0.0, 6.0),
    ];
    let mesh = Arc::new(MeshBvh::new(&vertices, &[0, 1, 2, 3, 4, 5]).unwrap());
    let scene = InstancedScene::new(vec![Instance {
        mesh,
        world_from_local: Affine3A::from_translation(Vec3::new(5.0, 0.0, 0.0)),
    }]);
    let ray = Ray::new(Vec3A::new(-40.0, -0.5, 5.0), Vec3A::NEG_Z);
    assert_eq!(
        scene.cast_ray(&ray, Backfaces::Include).map(|h| h.hit.t),
        Some(5.0)
    );
}

/// Hits the ray/triangle test's rounding invents: at `t = inf` (a subnormal direction),
/// which no box test reaches, and outside the triangle's own box (corners near the float
/// range's ends). The oracle reported them, the trees did not; neither counts them now.
#[test]
fn triangle_hits_at_infinity_or_outside_the_box_are_misses() {
    let tri = [
        Vec3A::new(-1.0, -1.0, 5.0),
        Vec3A::new(1.0, -1.0, 5.0),
        Vec3A::new(0.0, 1.0, 5.0),
    ];
    let ray = Ray::new(Vec3A::ZERO, Vec3A::new(0.0, 0.0, 1e-40));
    let wt = WatertightRay::new(&ray);
    assert!(
        wt.intersect_vertices(tri[0], tri[1], tri[2], Backfaces::Include)
            .is_none()
    );
    let vertices = tri.map(Vec3::from);
    let oracle = BruteForceMesh::new(&vertices, &[0, 1, 2]).unwrap();
    assert!(oracle.cast_ray(&ray, Backfaces::Include).is_none());
    // The case the stress suite found: the watertight test says the origin lies on a
    // triangle of subnormal height whose box it is outside of.
    let ray = Ray::new(
        Vec3A::new(21.87587, -1e-40, -26.416695),
        Vec3A::new(-1e30, -2.6856995, 96.02321),
    );
    let tri = [
        Vec3::new(42.53254, 0.0, -26.286554),
        Vec3::new(-12.093842, 1e-40, -28.782532),
        Vec3::new(48.09692, 0.0, -13.663326),
    ];
    let oracle = BruteForceMesh::new(&tri, &[0, 1, 2]).unwrap();
    let mesh = MeshBvh::new(&tri, &[0, 1, 2]).unwrap();
    assert!(!ray.hits_aabb(&Aabb::from_points(tri)));
    assert!(oracle.cast_ray(&ray, Backfaces::Include).is_none());
    assert!(mesh.cast_ray(&ray, Backfaces::Include).is_none());
}

/// A direction component past 2^126 has a subnormal reciprocal, less precise than the slab
/// test's widening allows: an instance's world box was missed by a ray that hit its mesh in
/// local space. Such rays are not traceable.
#[test]
fn rays_with_directions_past_the_limit_are_not_traceable() {
    let ray = Ray::new(Vec3A::ZERO, Vec3A::new(1.0, f32::MAX, 0.0));
    assert!(ray.is_degenerate() && !ray.is_traceable());
    let d = Vec3A::new(0.0, f32::MAX, 0.0);
    let field_by_field = Ray {
        origin: Vec3A::ZERO,
        direction: d,
        inv_direction: d.recip(),
        t_min: 0.0,
        t_max: f32::INFINITY,
    };
    assert!(!field_by_field.is_traceable());
    assert!(Ray::new(Vec3A::ZERO, Vec3A::splat(Ray::MAX_DIRECTION)).is_traceable());
}

/// An instance placed at `z = -f32::MAX` under a general matrix: `Aabb::transformed` rounded
/// its world box to nearest, a ray from `-f32::MAX` met the triangle an ulp outside that box,
/// and the two-level scene missed what the instance's own mesh hit. World boxes are grown by
/// a few ulps of their magnitude now.
#[test]
fn instance_boxes_far_from_the_origin_hold_their_triangles() {
    let sphere = accel_testkit::shapes::icosphere(2).normalized(100.0);
    let mesh = Arc::new(MeshBvh::new(&sphere.positions(), &sphere.flat_indices()).unwrap());
    let m = Affine3A::from_cols(
        Vec3A::new(112.02707, -72.094284, -9.178436),
        Vec3A::new(-37.17543, 66.15706, 31.463516),
        Vec3A::new(-36.03311, 91.18683, 29.286179),
        Vec3A::new(75.31378, -65.03221, -3.4028235e38),
    );
    let ray = Ray::with_range(
        Vec3A::new(-99.569466, -1e30, -3.4028235e38),
        Vec3A::new(57.204514, -117.33119, 64.42317),
        -52.612366,
        f32::INFINITY,
    );
    let scene = InstancedScene::new(vec![Instance {
        mesh: mesh.clone(),
        world_from_local: m,
    }]);
    let own = if scene.rejected_instances().is_empty() {
        mesh.cast_ray(&ray.transformed(&m.inverse()), Backfaces::Include)
    } else {
        None
    };
    let got = scene.cast_ray(&ray, Backfaces::Include);
    assert_eq!(got.map(|h| h.hit.t), own.map(|h| h.t));
}
