//! Every [`TriangleQuery`] against [`BruteForceMesh`] on the same triangles.

use crate::scenes::rays;
use accel_testkit::Rng;
use glam::Vec3;
use spatial_accel::mesh::MeshHit;
use spatial_accel::query::{BruteForceMesh, TriangleQuery};
use spatial_accel::{Aabb, Backfaces, Ray, Triangle};

/// Compares closest, any and all hits (both backface modes) and box overlap of `mesh` with
/// brute force over `vertices` / `indices`.
pub fn check_triangles<M: TriangleQuery>(
    name: &str,
    mesh: &M,
    vertices: &[Vec3],
    indices: &[u32],
    seed: u64,
) {
    let oracle = BruteForceMesh::new(vertices, indices).expect("a valid mesh");
    assert_eq!(
        mesh.triangle_count(),
        oracle.triangle_count(),
        "{name}: triangle count"
    );
    assert!(
        mesh.bounds().contains_aabb(&oracle.bounds()),
        "{name}: bounds {:?} do not hold the triangles' {:?}",
        mesh.bounds(),
        oracle.bounds()
    );
    let triangle = |i: u32| {
        let c = |k: usize| vertices[indices[3 * i as usize + k] as usize];
        Triangle::new(c(0), c(1), c(2))
    };
    let extent = oracle.bounds().extent().max_element().max(1.0);
    let center = oracle.bounds().center();
    let mut rng = Rng::new(seed);
    for ray in rays(200, seed, extent) {
        let ray = Ray::with_range(ray.origin + center, ray.direction, 0.0, f32::INFINITY);
        for backfaces in [Backfaces::Include, Backfaces::Cull] {
            let want = oracle.cast_ray(&ray, backfaces);
            let got = mesh.cast_ray(&ray, backfaces);
            assert_eq!(
                got.map(|h| h.t),
                want.map(|h| h.t),
                "{name}: closest hit of {ray:?}"
            );
            if let Some(got) = got {
                // Two triangles may meet the ray at one distance (a shared edge): either may
                // be reported, with its own record.
                let own = triangle(got.triangle).intersect(&ray, backfaces);
                assert_eq!(
                    own.map(|h| h.t),
                    Some(got.t),
                    "{name}: hit record of {ray:?}"
                );
            }
            assert_eq!(
                mesh.cast_ray_any(&ray, backfaces),
                want.is_some(),
                "{name}: any hit of {ray:?}"
            );
            let (mut want_all, mut got_all): (Vec<MeshHit>, Vec<MeshHit>) = (vec![], vec![]);
            oracle.cast_ray_all(&ray, backfaces, &mut want_all);
            mesh.cast_ray_all(&ray, backfaces, &mut got_all);
            let key = |h: &MeshHit| (h.t.to_bits(), h.triangle, h.front_face);
            assert_eq!(
                got_all.iter().map(key).collect::<Vec<_>>(),
                want_all.iter().map(key).collect::<Vec<_>>(),
                "{name}: all hits of {ray:?}"
            );
        }
    }
    for _ in 0..100 {
        let q = Aabb::from_center_half_extents(
            center + rng.vec3a(-extent, extent) * 0.5,
            rng.vec3a(0.0, extent * 0.2),
        );
        let mut got = Vec::new();
        mesh.for_each_triangle_overlapping(&q, |t| got.push(t));
        got.sort_unstable();
        assert!(
            got.windows(2).all(|w| w[0] < w[1]),
            "{name}: a triangle reported twice"
        );
        let mut boxes_overlap = Vec::new();
        oracle.for_each_triangle_overlapping(&q, |t| boxes_overlap.push(t));
        // Only triangles whose box overlaps; every triangle with a corner in the box.
        assert!(
            got.iter().all(|t| boxes_overlap.binary_search(t).is_ok()),
            "{name}: reported a triangle whose box misses {q:?}"
        );
        for &t in &boxes_overlap {
            if triangle(t).vertices.iter().any(|&v| q.contains_point(v)) {
                assert!(
                    got.binary_search(&t).is_ok(),
                    "{name}: missed triangle {t} in {q:?}"
                );
            }
        }
    }
}
