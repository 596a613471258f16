//! The kd-tree: its three builds give the same tree, the validator holds on every input, and
//! adversarial meshes (coplanar, degenerate, duplicated, grid-aligned, far from the origin,
//! NaN corners) and rays (axis-parallel with either zero, NaN, infinite) answer as brute
//! force does.

#[path = "scenes/mod.rs"]
mod scenes;
#[path = "conformance/triangles.rs"]
mod triangles;

use accel_testkit::{Mesh, Rng, shapes};
use glam::{Vec3, Vec3A};
use spatial_accel::kdtree::{KdBuild, KdTree, KdTreeConfig};
use spatial_accel::mesh::MeshHit;
use spatial_accel::query::{BruteForceMesh, TriangleQuery};
use spatial_accel::{Backfaces, Ray};
use triangles::check_triangles;

/// A mesh as the trees take it.
type TestMesh = (Vec<Vec3>, Vec<u32>);

fn from_mesh(m: Mesh) -> TestMesh {
    (m.positions(), m.flat_indices())
}

/// Unshared triangles from corner triples.
fn soup_of(corners: impl IntoIterator<Item = [Vec3; 3]>) -> TestMesh {
    let vertices: Vec<Vec3> = corners.into_iter().flatten().collect();
    let indices = (0..vertices.len() as u32).collect();
    (vertices, indices)
}

fn build(m: &TestMesh, config: &KdTreeConfig) -> KdTree {
    KdTree::with_config(&m.0, &m.1, config).expect("a valid mesh")
}

/// The first `n` triangles of the bunny: big enough to split many times, small enough for
/// the O(N^2) build.
fn bunny_part(n: usize) -> TestMesh {
    let mut m = accel_testkit::bunny();
    m.indices.truncate(n);
    from_mesh(m)
}

/// Asserts that the trees are the same: nodes (splits), leaves and statistics.
fn assert_same_tree(name: &str, a: &KdTree, b: &KdTree) {
    assert_eq!(a.nodes(), b.nodes(), "{name}: nodes differ");
    assert_eq!(
        a.leaf_references(),
        b.leaf_references(),
        "{name}: leaves differ"
    );
    assert_eq!(a.stats(), b.stats(), "{name}: statistics differ");
}

/// Builds with every algorithm (the O(N^2) one only when `naive`), checks they agree and
/// validate, and returns the event-sweep tree.
fn every_build(name: &str, m: &TestMesh, config: KdTreeConfig, naive: bool) -> KdTree {
    let with = |build| build_checked(m, &KdTreeConfig { build, ..config });
    let sweep = with(KdBuild::EventSweep);
    assert_same_tree(
        &format!("{name}, sort each level"),
        &sweep,
        &with(KdBuild::SortEachLevel),
    );
    if naive {
        assert_same_tree(&format!("{name}, naive"), &sweep, &with(KdBuild::Naive));
    }
    sweep
}

fn build_checked(m: &TestMesh, config: &KdTreeConfig) -> KdTree {
    let tree = build(m, config);
    tree.validate(&m.0, &m.1).expect("a valid tree");
    let s = tree.stats();
    assert!(s.depth <= config.depth_limit(m.1.len() / 3));
    assert_eq!(s.nodes, 2 * s.leaves - 1);
    tree
}

/// The configurations the builds are compared under: the paper's, one that splits much
/// further (cheap traversal, strong empty bonus), and a shallow one.
fn configs() -> [KdTreeConfig; 3] {
    [
        KdTreeConfig::default(),
        KdTreeConfig {
            traversal_cost: 1.0,
            intersection_cost: 80.0,
            empty_bonus: 0.5,
            ..KdTreeConfig::default()
        },
        KdTreeConfig {
            max_depth: Some(4),
            ..KdTreeConfig::default()
        },
    ]
}

#[test]
fn three_builds_give_the_same_tree_on_small_meshes() {
    let mut rng = Rng::new(5);
    let meshes = [
        ("cube", from_mesh(shapes::cube())),
        ("icosphere", from_mesh(shapes::icosphere(2))),
        ("uv sphere", from_mesh(shapes::uv_sphere(8, 12, 2.0))),
        ("soup", from_mesh(shapes::triangle_soup(&mut rng, 300))),
        ("bunny part", bunny_part(700)),
    ];
    for (name, m) in &meshes {
        for (c, config) in configs().into_iter().enumerate() {
            let tree = every_build(&format!("{name}, config {c}"), m, config, true);
            if c == 0 {
                assert!(tree.stats().leaves > 1, "{name}: never split");
            }
        }
    }
}

#[test]
fn the_fast_builds_give_the_same_tree_on_large_meshes() {
    let bunny = from_mesh(accel_testkit::bunny());
    let scene = soup_of(
        accel_testkit::triangle_scene(20_000, 7)
            .iter()
            .map(|t| t.vertices.map(Vec3::from)),
    );
    for (name, m) in [("bunny", &bunny), ("bunny scene", &scene)] {
        for (c, config) in configs().into_iter().enumerate() {
            let tree = every_build(&format!("{name}, config {c}"), m, config, false);
            let s = tree.stats();
            assert!(s.references >= m.1.len() / 3);
            // No explosion of empty leaves: cutting off empty space ends where a triangle's
            // box begins, so there are fewer of them than of references.
            assert!(s.empty_leaves < s.references, "{name}, config {c}: {s:?}");
        }
    }
}

/// Checks every query against brute force, with every build agreeing on the tree first.
fn check_adversarial(name: &str, m: &TestMesh, seed: u64) -> KdTree {
    let naive = m.1.len() / 3 <= 1_000;
    let tree = every_build(name, m, KdTreeConfig::default(), naive);
    check_triangles(name, &tree, &m.0, &m.1, seed);
    tree
}

#[test]
fn coplanar_triangles() {
    let mut rng = Rng::new(8);
    // In an axis-aligned plane (the tree is flat on that axis), and in a slanted one.
    let flat: Vec<[Vec3; 3]> = (0..500)
        .map(|_| {
            let c = rng.vec3(-10.0, 10.0);
            [0, 1, 2].map(|_| {
                let p = c + rng.vec3(-1.5, 1.5);
                Vec3::new(p.x, p.y, 2.0)
            })
        })
        .collect();
    check_adversarial("coplanar, axis-aligned", &soup_of(flat.clone()), 1);
    let slanted = flat
        .iter()
        .map(|t| t.map(|p| Vec3::new(p.x, p.y, 0.3 * p.x - 0.7 * p.y)));
    check_adversarial("coplanar, slanted", &soup_of(slanted), 2);
}

#[test]
fn degenerate_triangles() {
    let mut rng = Rng::new(9);
    let mut tris = Vec::new();
    for k in 0..300 {
        let a = rng.vec3(-5.0, 5.0);
        let b = rng.vec3(-5.0, 5.0);
        tris.push(match k % 4 {
            // A point, a segment, a sliver, and an ordinary one among them.
            0 => [a; 3],
            1 => [a, b, a.lerp(b, 0.25)],
            2 => [a, b, b + Vec3::splat(1e-6)],
            _ => [a, b, rng.vec3(-5.0, 5.0)],
        });
    }
    check_adversarial("degenerate", &soup_of(tris), 3);
    // Only points and segments: nothing to hit, nothing to panic over.
    let lines: Vec<[Vec3; 3]> = (0..100)
        .map(|k| {
            let a = Vec3::new(k as f32, 0.0, 0.0);
            [a, a + Vec3::X, a + Vec3::X * 0.5]
        })
        .collect();
    check_adversarial("collinear", &soup_of(lines), 4);
}

#[test]
fn duplicated_triangles() {
    let one = [
        Vec3::ZERO,
        Vec3::new(3.0, 0.0, 1.0),
        Vec3::new(0.0, 2.0, -1.0),
    ];
    let mut tris = vec![one; 200];
    let mut rng = Rng::new(10);
    tris.extend((0..200).map(|_| {
        let c = rng.vec3(-4.0, 4.0);
        [c, c + rng.vec3(-1.0, 1.0), c + rng.vec3(-1.0, 1.0)]
    }));
    let m = soup_of(tris);
    let tree = check_adversarial("duplicated", &m, 5);
    // Every copy is hit, each once.
    let ray = Ray::new(Vec3A::new(0.5, 0.5, 10.0), Vec3A::NEG_Z);
    let mut hits = Vec::new();
    tree.cast_ray_all(&ray, Backfaces::Include, &mut hits);
    assert!(hits.iter().filter(|h| h.triangle < 200).count() == 200);
}

/// Unit squares (two triangles each) on the faces of an `n`^3 lattice of cubes: every edge
/// on a plane the tree may split at.
fn lattice(n: i32) -> TestMesh {
    let mut tris = Vec::new();
    for i in 0..n {
        for j in 0..n {
            for k in 0..=n {
                for axis in 0..3 {
                    let p = |a: i32, b: i32| {
                        let mut v = [0.0f32; 3];
                        v[axis] = k as f32;
                        v[(axis + 1) % 3] = (i + a) as f32;
                        v[(axis + 2) % 3] = (j + b) as f32;
                        Vec3::from_array(v)
                    };
                    tris.push([p(0, 0), p(1, 0), p(1, 1)]);
                    tris.push([p(0, 0), p(1, 1), p(0, 1)]);
                }
            }
        }
    }
    soup_of(tris)
}

/// Closest and all hits of `tree` against brute force on `rays`.
fn assert_rays_match(name: &str, tree: &KdTree, m: &TestMesh, rays: &[Ray]) {
    let oracle = BruteForceMesh::new(&m.0, &m.1).unwrap();
    for ray in rays {
        for backfaces in [Backfaces::Include, Backfaces::Cull] {
            assert_eq!(
                tree.cast_ray(ray, backfaces)
                    .map(|h| (h.t.to_bits(), h.triangle)),
                oracle
                    .cast_ray(ray, backfaces)
                    .map(|h| (h.t.to_bits(), h.triangle)),
                "{name}: closest hit of {ray:?}"
            );
            assert_eq!(
                tree.cast_ray_any(ray, backfaces),
                oracle.cast_ray_any(ray, backfaces),
                "{name}: any hit of {ray:?}"
            );
            let (mut got, mut want): (Vec<MeshHit>, Vec<MeshHit>) = (vec![], vec![]);
            tree.cast_ray_all(ray, backfaces, &mut got);
            oracle.cast_ray_all(ray, backfaces, &mut want);
            let key = |h: &MeshHit| (h.t.to_bits(), h.triangle, h.front_face);
            assert_eq!(
                got.iter().map(key).collect::<Vec<_>>(),
                want.iter().map(key).collect::<Vec<_>>(),
                "{name}: all hits of {ray:?}"
            );
        }
    }
}

#[test]
fn axis_aligned_grid_and_axis_parallel_rays() {
    let m = lattice(4);
    let tree = check_adversarial("lattice", &m, 6);
    assert!(tree.stats().leaves > 1);
    // Rays along the lattice's lines and planes (origins on split planes, directions with
    // +0 and -0 components), and through its cells' centres.
    let mut rays = Vec::new();
    for a in [-1.0f32, 0.0, 0.5, 1.0, 2.0, 3.5, 4.0, 5.0] {
        for b in [0.0f32, 1.0, 2.5, 4.0] {
            for axis in 0..3 {
                for sign in [1.0f32, -1.0] {
                    for zero in [0.0f32, -0.0] {
                        let mut o = [a, b, 0.0];
                        o.rotate_right(axis);
                        let mut origin = Vec3A::from_array(o);
                        let mut d = [zero; 3];
                        d[(axis + 2) % 3] = sign;
                        origin[(axis + 2) % 3] = if sign > 0.0 { -1.0 } else { 5.0 };
                        rays.push(Ray::new(origin, Vec3A::from_array(d)));
                        // From inside, starting on a plane.
                        origin[(axis + 2) % 3] = 2.0;
                        rays.push(Ray::new(origin, Vec3A::from_array(d)));
                    }
                }
            }
        }
    }
    assert_rays_match("lattice, axis-parallel", &tree, &m, &rays);
}

#[test]
fn huge_coordinates() {
    let mut rng = Rng::new(11);
    let offset = Vec3::new(1e7, -1e7, 3e7);
    let tris = (0..800).map(|k| {
        let size = if k % 20 == 0 { 5_000.0 } else { 200.0 };
        let c = offset + rng.vec3(-2e4, 2e4);
        [0, 1, 2].map(|_| c + rng.vec3(-size, size))
    });
    check_adversarial("far from the origin", &soup_of(tris), 7);
    // Coordinates near f32's limit build and answer without overflow trouble.
    let big = [
        Vec3::splat(-1e37),
        Vec3::new(1e37, -1e37, 0.0),
        Vec3::new(0.0, 1e37, 1e37),
    ];
    let m = soup_of([big, big.map(|v| v * 0.5)]);
    let tree = check_adversarial("near f32::MAX", &m, 8);
    let rays = [
        Ray::new(Vec3A::new(0.0, 0.0, -1e38), Vec3A::Z),
        Ray::new(Vec3A::new(1e36, -1e36, 0.0), Vec3A::NEG_ONE),
        Ray::new(Vec3A::ZERO, Vec3A::new(0.3, -0.2, 1.0)),
    ];
    assert_rays_match("near f32::MAX", &tree, &m, &rays);
}

#[test]
fn nan_vertices_are_left_out() {
    let mut rng = Rng::new(12);
    let mut tris: Vec<[Vec3; 3]> = (0..400)
        .map(|_| {
            let c = rng.vec3(-5.0, 5.0);
            [c, c + rng.vec3(-1.0, 1.0), c + rng.vec3(-1.0, 1.0)]
        })
        .collect();
    for (k, t) in tris.iter_mut().enumerate().step_by(7) {
        t[k % 3] = match k % 3 {
            0 => Vec3::NAN,
            1 => Vec3::new(0.0, f32::INFINITY, 0.0),
            _ => Vec3::new(f32::NAN, 1.0, 1.0),
        };
    }
    let m = soup_of(tris);
    let tree = check_adversarial("NaN corners", &m, 9);
    assert_eq!(tree.triangle_count(), 400);
    assert!(tree.leaf_references().iter().all(|&t| t % 7 != 0));
    assert!(tree.bounds().is_finite());
    // Only non-finite triangles: an empty tree.
    let m = soup_of([[Vec3::NAN; 3], [Vec3::INFINITY, Vec3::ZERO, Vec3::ONE]]);
    let tree = check_adversarial("all NaN", &m, 10);
    assert_eq!(tree.stats().references, 0);
    let empty = check_adversarial("no triangles", &(vec![], vec![]), 11);
    assert!(
        empty
            .cast_ray(&Ray::new(Vec3A::ZERO, Vec3A::X), Backfaces::Include)
            .is_none()
    );
}

#[test]
fn non_finite_rays_miss_without_panic() {
    let m = from_mesh(accel_testkit::bunny());
    let tree = build(&m, &KdTreeConfig::default());
    let c = tree.bounds().center();
    let specials = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0, 1.0];
    let mut rays = Vec::new();
    for &x in &specials {
        for &y in &specials {
            rays.push(Ray::new(c + Vec3A::new(x, y, 0.0), Vec3A::Z));
            rays.push(Ray::new(c, Vec3A::new(x, y, 1.0)));
            rays.push(Ray::with_range(c, Vec3A::Y, x, y));
            // Fields set directly, past the constructor's checks.
            let mut raw = Ray::new(c, Vec3A::X);
            raw.origin.y = x;
            raw.inv_direction.z = y;
            raw.t_max = x;
            rays.push(raw);
        }
    }
    for ray in &rays {
        let hit = tree.cast_ray(ray, Backfaces::Include);
        if !ray.origin.is_finite() || !ray.direction.is_finite() || ray.is_degenerate() {
            assert!(hit.is_none(), "{ray:?} hit {hit:?}");
            assert!(!tree.cast_ray_any(ray, Backfaces::Include));
        }
        let mut all = Vec::new();
        tree.cast_ray_all(ray, Backfaces::Cull, &mut all);
    }
    // A NaN box overlaps nothing.
    let mut n = 0;
    tree.for_each_triangle_overlapping(&spatial_accel::Aabb::new(Vec3A::NAN, Vec3A::ONE), |_| {
        n += 1
    });
    assert_eq!(n, 0);
}

#[test]
fn splits_cut_triangles_and_stay_within_the_depth_limit() {
    // A few large triangles across many small ones: splits must cross the large ones, and
    // their references in each leaf come from clipping.
    let mut rng = Rng::new(13);
    let mut tris: Vec<[Vec3; 3]> = (0..2_000)
        .map(|_| {
            let c = rng.vec3(-50.0, 50.0);
            [c, c + rng.vec3(-0.5, 0.5), c + rng.vec3(-0.5, 0.5)]
        })
        .collect();
    tris.extend((0..10).map(|_| {
        [
            rng.vec3(-60.0, 60.0),
            rng.vec3(-60.0, 60.0),
            rng.vec3(-60.0, 60.0),
        ]
    }));
    let m = soup_of(tris);
    let tree = check_adversarial("large among small", &m, 14);
    let s = tree.stats();
    assert!(s.straddled > 0 && s.references > 2_010, "{s:?}");
    assert_eq!(
        s.references,
        2_010 + s.straddled - s.clipped_away,
        "each straddling triangle adds a reference per side it reaches"
    );
    // A depth limit of zero is a single leaf, still answering correctly.
    let leaf = build(
        &m,
        &KdTreeConfig {
            max_depth: Some(0),
            ..KdTreeConfig::default()
        },
    );
    assert_eq!(leaf.stats().nodes, 1);
    check_triangles("one leaf", &leaf, &m.0, &m.1, 15);
}
