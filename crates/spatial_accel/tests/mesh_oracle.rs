//! Mesh BVHs and two-level scenes against brute force over every triangle of every instance.

use accel_testkit::shapes::{triangle_soup, uv_sphere};
use accel_testkit::{Mesh, Rng};
use glam::{Affine3A, Quat, Vec3, Vec3A};
use spatial_accel::mesh::{Instance, InstancedScene, MeshBvh, SceneUpdateError, SpatialSplits};
use spatial_accel::{Aabb, Backfaces, BuildConfig, Ray, SplitStrategy, WatertightRay};
use std::sync::Arc;

/// A mesh in the form the mesh trees take: `Vec3` positions, three indices per triangle.
struct TestMesh {
    vertices: Vec<Vec3>,
    indices: Vec<u32>,
}

impl From<Mesh> for TestMesh {
    fn from(m: Mesh) -> Self {
        Self {
            vertices: m.positions(),
            indices: m.flat_indices(),
        }
    }
}

/// A random triangle soup: small triangles scattered in a box, plus a few large ones.
fn soup(rng: &mut Rng, n: usize) -> TestMesh {
    triangle_soup(rng, n).into()
}

/// A UV sphere of radius 2 with shared vertices.
fn sphere(rings: u32, segments: u32) -> TestMesh {
    uv_sphere(rings, segments, 2.0).into()
}

fn brute_mesh(m: &TestMesh, ray: &Ray, backfaces: Backfaces) -> Vec<(f32, u32)> {
    let wt = WatertightRay::new(ray);
    let mut hits: Vec<(f32, u32)> = m
        .indices
        .chunks_exact(3)
        .enumerate()
        .filter_map(|(i, t)| {
            let [a, b, c] = [0, 1, 2].map(|k| Vec3A::from(m.vertices[t[k] as usize]));
            wt.intersect_vertices(a, b, c, backfaces)
                .map(|h| (h.t, i as u32))
        })
        .collect();
    hits.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    hits
}

fn random_ray(rng: &mut Rng, extent: f32) -> Ray {
    let o = rng.vec3a(-extent, extent);
    let target = rng.vec3a(-extent * 0.5, extent * 0.5);
    Ray::new(o, target - o)
}

/// Long slivers slanted across the mesh's box among small triangles: the triangles whose
/// boxes waste the most, the ones pre-splitting cuts.
fn slivers(rng: &mut Rng, n: usize) -> TestMesh {
    let mut mesh = soup(rng, n);
    for _ in 0..n / 20 {
        let (a, b) = (rng.vec3a(-6.0, 6.0), rng.vec3a(-6.0, 6.0));
        let c = a + rng.vec3a(-0.3, 0.3);
        let first = mesh.vertices.len() as u32;
        mesh.vertices.extend([Vec3::from(a), b.into(), c.into()]);
        mesh.indices.extend([first, first + 1, first + 2]);
    }
    mesh
}

/// How a mesh's box queries may answer: exactly the triangles whose boxes overlap the query
/// (a tree over whole triangles), or at least every triangle that touches it and only ones
/// whose boxes overlap (over pre-split triangles, whose pieces' boxes are what the tree holds).
#[derive(Clone, Copy, PartialEq)]
enum Overlap {
    Exact,
    Touching,
}

/// Every query of `bvh` against brute force over `mesh`'s triangles, on random rays and boxes.
fn check_mesh_queries(mesh: &TestMesh, bvh: &MeshBvh, rng: &mut Rng, overlap: Overlap, what: &str) {
    bvh.validate().unwrap();
    assert_eq!(bvh.triangle_count(), mesh.indices.len() / 3, "{what}");
    let mut all = Vec::new();
    for _ in 0..2000 {
        let ray = random_ray(rng, 8.0);
        for bf in [Backfaces::Include, Backfaces::Cull] {
            let want = brute_mesh(mesh, &ray, bf);
            let got = bvh.cast_ray(&ray, bf);
            assert_eq!(got.map(|h| h.t), want.first().map(|w| w.0), "{what}");
            if let Some(h) = got {
                // The reported triangle is one at that distance, with consistent data.
                assert!(want.iter().any(|w| w.0 == h.t && w.1 == h.triangle));
                let s: f32 = h.barycentrics.iter().sum();
                assert!((s - 1.0).abs() < 1e-5 && h.barycentrics.iter().all(|&b| b >= -1e-6));
                assert!((h.geometric_normal.length() - 1.0).abs() < 1e-4);
            }
            assert_eq!(bvh.cast_ray_any(&ray, bf), !want.is_empty(), "{what}");
            all.clear();
            bvh.cast_ray_all(&ray, bf, &mut all);
            let got_all: Vec<(f32, u32)> = all.iter().map(|h| (h.t, h.triangle)).collect();
            assert_eq!(got_all, want, "{what}");
        }
    }
    for _ in 0..200 {
        let c = rng.vec3a(-8.0, 8.0);
        let query = Aabb::new(c, c + rng.vec3a(0.0, 4.0));
        let mut got = Vec::new();
        bvh.for_each_triangle_overlapping(&query, |t| got.push(t));
        let visited = got.len();
        got.sort_unstable();
        got.dedup();
        assert_eq!(got.len(), visited, "{what}: a triangle visited twice");
        let corners = |t: u32| {
            [0, 1, 2].map(|k| Vec3A::from(mesh.vertices[mesh.indices[3 * t as usize + k] as usize]))
        };
        let boxes_overlapping: Vec<u32> = (0..mesh.indices.len() as u32 / 3)
            .filter(|&t| Aabb::from_points(corners(t)).intersects_aabb(&query))
            .collect();
        match overlap {
            Overlap::Exact => assert_eq!(got, boxes_overlapping, "{what}"),
            Overlap::Touching => {
                assert!(got.iter().all(|t| boxes_overlapping.contains(t)), "{what}");
                // Triangles with a corner, an edge's middle or the centroid in the box
                // certainly touch it.
                for t in (0..mesh.indices.len() as u32 / 3).filter(|&t| {
                    let [a, b, c] = corners(t);
                    [
                        a,
                        b,
                        c,
                        (a + b) * 0.5,
                        (b + c) * 0.5,
                        (c + a) * 0.5,
                        (a + b + c) / 3.0,
                    ]
                    .iter()
                    .any(|&p| query.contains_point(p))
                }) {
                    assert!(got.contains(&t), "{what}: triangle {t} touches the box");
                }
            }
        }
    }
}

#[test]
fn mesh_bvh_matches_brute_force() {
    let mut rng = Rng::new(31);
    let meshes = [soup(&mut rng, 2000), sphere(24, 32), soup(&mut rng, 3)];
    // Whole triangles, with the binned SAH that `MeshBvh::default_config` picks for meshes
    // this small and the PLOC it picks for large ones; `MeshBvh::new`'s pre-split build is
    // checked on the same meshes.
    for (mi, mesh) in meshes.iter().enumerate() {
        for (name, config) in [
            ("binned", BuildConfig::default()),
            ("PLOC", BuildConfig::with_split(SplitStrategy::PLOC)),
        ] {
            let bvh = MeshBvh::with_config(&mesh.vertices, &mesh.indices, &config).unwrap();
            check_mesh_queries(
                mesh,
                &bvh,
                &mut rng,
                Overlap::Exact,
                &format!("mesh {mi} {name}"),
            );
        }
        let bvh = MeshBvh::new(&mesh.vertices, &mesh.indices).unwrap();
        check_mesh_queries(
            mesh,
            &bvh,
            &mut rng,
            Overlap::Touching,
            &format!("mesh {mi} new"),
        );
    }
}

/// Pre-split builds answer as whole-triangle ones: each hit once, every triangle found,
/// before and after a refit moves the vertices (which bounds whole triangles again).
#[test]
fn presplit_meshes_match_brute_force() {
    let mut rng = Rng::new(77);
    let mut mesh = slivers(&mut rng, 1500);
    for (name, config, budget) in [
        ("binned 0.3", BuildConfig::default(), 0.3),
        ("binned 2.0", BuildConfig::default(), 2.0),
        (
            "PLOC 0.3",
            BuildConfig::with_split(SplitStrategy::PLOC),
            0.3,
        ),
        (
            "leaves of 1",
            BuildConfig {
                max_leaf_size: 1,
                ..BuildConfig::default()
            },
            0.5,
        ),
    ] {
        let mut bvh = MeshBvh::with_splits(&mesh.vertices, &mesh.indices, &config, budget).unwrap();
        // The slivers were cut, and pieces of one sliver sit in several leaves.
        assert!(bvh.leaf_triangle_count() > bvh.triangle_count(), "{name}");
        check_mesh_queries(&mesh, &bvh, &mut rng, Overlap::Touching, name);
        refit_and_check(&mut mesh, &mut bvh, &mut rng, name);
    }
}

/// Moves every vertex a little, refits, and checks the queries of a tree over pieces.
fn refit_and_check(mesh: &mut TestMesh, bvh: &mut MeshBvh, rng: &mut Rng, name: &str) {
    for v in &mut mesh.vertices {
        *v += rng.vec3(-0.2, 0.2);
    }
    bvh.refit(&mesh.vertices).unwrap();
    check_mesh_queries(mesh, bvh, rng, Overlap::Touching, &format!("{name}, refit"));
}

/// Many copies of one large slanted triangle over a few small ones: every spatial split
/// cuts all the copies alike, so it is the budget that stops the cutting.
fn stacked_copies(rng: &mut Rng) -> TestMesh {
    let mut mesh = soup(rng, 100);
    let base = mesh.vertices.len() as u32;
    mesh.vertices.extend([
        Vec3::new(-5.0, -5.0, -5.0),
        Vec3::new(5.0, 4.0, 5.0),
        Vec3::new(5.0, 5.0, 4.5),
    ]);
    for _ in 0..200 {
        mesh.indices.extend([base, base + 1, base + 2]);
    }
    mesh
}

/// Spatial-split builds answer as whole-triangle ones, on slivers, a soup and stacked copies
/// of one triangle, with spatial splits priced everywhere or as by default, before and after
/// a refit.
#[test]
fn spatial_split_meshes_match_brute_force() {
    let mut rng = Rng::new(91);
    let everywhere = SpatialSplits {
        reference_budget: 2.0,
        bins: 4,
        overlap_threshold: 0.0,
    };
    let leaves_of_1 = BuildConfig {
        max_leaf_size: 1,
        ..BuildConfig::default()
    };
    let meshes = [
        ("slivers", slivers(&mut rng, 1500)),
        ("soup", soup(&mut rng, 2000)),
        ("stacked copies", stacked_copies(&mut rng)),
    ];
    for (mesh_name, mut mesh) in meshes {
        for (name, config, splits) in [
            ("default", BuildConfig::default(), SpatialSplits::default()),
            ("everywhere", BuildConfig::default(), everywhere),
            ("leaves of 1", leaves_of_1, SpatialSplits::default()),
            (
                "no budget",
                BuildConfig::default(),
                SpatialSplits {
                    reference_budget: 0.0,
                    ..everywhere
                },
            ),
        ] {
            let name = format!("{mesh_name}, {name}");
            let mut bvh =
                MeshBvh::with_spatial_splits(&mesh.vertices, &mesh.indices, &config, &splits)
                    .unwrap();
            if splits.reference_budget == 0.0 {
                assert_eq!(bvh.leaf_triangle_count(), bvh.triangle_count(), "{name}");
            } else if mesh_name == "slivers" {
                assert!(bvh.leaf_triangle_count() > bvh.triangle_count(), "{name}");
            }
            check_mesh_queries(&mesh, &bvh, &mut rng, Overlap::Touching, &name);
            let original = mesh.vertices.clone();
            refit_and_check(&mut mesh, &mut bvh, &mut rng, &name);
            mesh.vertices = original;
        }
    }
}

#[test]
fn refit_follows_moved_vertices() {
    let mut rng = Rng::new(5);
    let mut mesh = sphere(16, 16);
    let mut bvh = MeshBvh::new(&mesh.vertices, &mesh.indices).unwrap();
    for frame in 0..5 {
        for v in &mut mesh.vertices {
            *v += rng.vec3(-0.3, 0.3);
        }
        bvh.refit(&mesh.vertices).unwrap();
        bvh.validate().unwrap();
        for _ in 0..500 {
            let ray = random_ray(&mut rng, 4.0);
            let want = brute_mesh(&mesh, &ray, Backfaces::Include);
            assert_eq!(
                bvh.cast_ray(&ray, Backfaces::Include).map(|h| h.t),
                want.first().map(|w| w.0),
                "frame {frame}"
            );
        }
    }
    assert!(bvh.refit(&mesh.vertices[1..]).is_err());
}

#[test]
fn bad_meshes_are_errors_not_panics() {
    let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
    assert!(MeshBvh::new(&v, &[0, 1]).is_err());
    assert!(MeshBvh::new(&v, &[0, 1, 3]).is_err());
    let nan = [Vec3::ZERO, Vec3::X, Vec3::NAN, Vec3::Z];
    let m = MeshBvh::new(&nan, &[0, 1, 2, 0, 1, 3]).unwrap();
    assert_eq!(m.triangle_count(), 1);
    let empty = MeshBvh::new(&v, &[]).unwrap();
    assert!(
        empty
            .cast_ray(&Ray::new(Vec3A::ZERO, Vec3A::X), Backfaces::Include)
            .is_none()
    );
}

fn random_transform(rng: &mut Rng) -> Affine3A {
    let axis = rng.unit_vector();
    let rot = Quat::from_axis_angle(axis.into(), rng.range(0.0, core::f32::consts::TAU));
    let mut scale = Vec3::new(
        rng.range(0.2, 3.0),
        rng.range(0.2, 3.0),
        rng.range(0.2, 3.0),
    );
    if rng.below(3) == 0 {
        scale.x = -scale.x; // mirrored instances
    }
    Affine3A::from_scale_rotation_translation(scale, rot, rng.vec3(-40.0, 40.0))
}

/// Where each instance of a scene is: its mesh (an index into the test's meshes) and its
/// world-from-local transform; `None` where the scene must reject the instance.
type Placements = Vec<Option<(usize, Affine3A)>>;

/// Closest, any and all hits of `scene` against brute force over every triangle of every
/// placed instance, on `rays` random rays; the rejected instances, and the top level against
/// its validator.
fn check_scene(
    scene: &InstancedScene,
    meshes: &[TestMesh],
    bvhs: &[Arc<MeshBvh>],
    placed: &Placements,
    rng: &mut Rng,
    rays: usize,
) {
    let rejected: Vec<u32> = (0..)
        .zip(placed)
        .filter_map(|(i, p)| p.is_none().then_some(i))
        .collect();
    assert_eq!(scene.rejected_instances(), rejected.as_slice());
    let boxes: Vec<Aabb> = placed
        .iter()
        .map(|p| p.map_or(Aabb::EMPTY, |(mi, m)| bvhs[mi].bounds().transformed(&m)))
        .collect();
    scene.top_level().validate(&boxes).unwrap();
    let inverses: Vec<Option<(usize, Affine3A)>> = placed
        .iter()
        .map(|p| p.map(|(mi, m)| (mi, m.inverse())))
        .collect();
    let mut all = Vec::new();
    for _ in 0..rays {
        let ray = random_ray(rng, 60.0);
        let mut want: Vec<(f32, u32, u32)> = Vec::new();
        for (i, p) in inverses.iter().enumerate() {
            let Some((mi, inv)) = p else { continue };
            let local = ray.transformed(inv);
            want.extend(
                brute_mesh(&meshes[*mi], &local, Backfaces::Include)
                    .into_iter()
                    .map(|(t, tri)| (t, i as u32, tri)),
            );
        }
        want.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let got = scene.cast_ray(&ray, Backfaces::Include);
        assert_eq!(got.map(|h| h.hit.t), want.first().map(|w| w.0));
        if let Some(h) = got {
            assert!(
                want.iter()
                    .any(|w| w.0 == h.hit.t && w.1 == h.instance && w.2 == h.hit.triangle)
            );
        }
        assert_eq!(
            scene.cast_ray_any(&ray, Backfaces::Include),
            !want.is_empty()
        );
        all.clear();
        scene.cast_ray_all(&ray, Backfaces::Include, &mut all);
        let got_all: Vec<(f32, u32, u32)> = all
            .iter()
            .map(|h| (h.hit.t, h.instance, h.hit.triangle))
            .collect();
        assert_eq!(got_all, want);
    }
}

/// A soup and a sphere, each as a mesh BVH.
fn two_meshes(rng: &mut Rng) -> ([TestMesh; 2], Vec<Arc<MeshBvh>>) {
    let meshes = [soup(rng, 300), sphere(12, 16)];
    let bvhs = meshes
        .iter()
        .map(|m| Arc::new(MeshBvh::new(&m.vertices, &m.indices).unwrap()))
        .collect();
    (meshes, bvhs)
}

/// A transform that no instance can be placed under.
fn singular_transform() -> Affine3A {
    Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0))
}

/// The counting walk (`cast_ray_counted`, for heat maps) finds the fast walk's closest hit,
/// on meshes and on a two-level scene with mirrored instances, and counts work that grows
/// with what the ray passes: at least one node and one triangle for a hit, both levels'
/// nodes in a scene, a leaf depth exactly when there is a hit.
#[test]
fn counted_walks_find_the_fast_walks_hits() {
    let mut rng = Rng::new(31);
    let (_, bvhs) = two_meshes(&mut rng);
    let instances: Vec<Instance> = (0..120)
        .map(|i| Instance {
            mesh: bvhs[i % 2].clone(),
            world_from_local: random_transform(&mut rng),
        })
        .collect();
    let scene = InstancedScene::new(instances);
    let (mut hits, mut deeper) = (0, 0);
    for _ in 0..3000 {
        let ray = random_ray(&mut rng, 60.0);
        for bf in [Backfaces::Include, Backfaces::Cull] {
            for mesh in &bvhs {
                let local = Ray::new(ray.origin / 10.0, ray.direction);
                let counted = mesh.cast_ray_counted(&local, bf);
                assert_eq!(counted.hit, mesh.cast_ray(&local, bf));
                assert_eq!(counted.leaf_depth.is_some(), counted.hit.is_some());
                if counted.hit.is_some() {
                    assert!(counted.cost.nodes >= 1 && counted.cost.triangles >= 1);
                }
            }
            let counted = scene.cast_ray_counted(&ray, bf);
            assert_eq!(counted.hit, scene.cast_ray(&ray, bf));
            assert_eq!(counted.leaf_depth.is_some(), counted.hit.is_some());
            if let Some(depth) = counted.leaf_depth {
                hits += 1;
                // A top-level node and a mesh node at least.
                assert!(depth >= 2 && counted.cost.nodes >= 2 && counted.cost.triangles >= 1);
                deeper += usize::from(depth > 2);
            }
        }
    }
    assert!(
        hits > 1000 && deeper > 0,
        "{hits} hits, {deeper} below depth 2"
    );
}

#[test]
fn two_level_scene_matches_brute_force() {
    let mut rng = Rng::new(8);
    let (meshes, bvhs) = two_meshes(&mut rng);
    let mut placed: Placements = (0..200)
        .map(|i| Some((i % 2, random_transform(&mut rng))))
        .collect();
    // A singular instance is rejected, not a panic.
    placed.push(None);
    let mut instances: Vec<Instance> = placed
        .iter()
        .flatten()
        .map(|&(mi, m)| Instance {
            mesh: bvhs[mi].clone(),
            world_from_local: m,
        })
        .collect();
    instances.push(Instance {
        mesh: bvhs[0].clone(),
        world_from_local: singular_transform(),
    });
    let scene = InstancedScene::new(instances);
    // One instance a leaf: the walk enters every instance of a leaf whose box it hits.
    for node in scene.top_level().nodes() {
        for slot in (0..node.child.len()).filter(|&s| node.is_used(s) && node.is_leaf(s)) {
            assert_eq!(
                node.count[slot], 1,
                "a top-level leaf holds several instances"
            );
        }
    }
    check_scene(&scene, &meshes, &bvhs, &placed, &mut rng, 1500);
}

/// Instances moved, swapped to the other mesh, made singular and placed again, round after
/// round: every answer stays brute force's, through refits and the rebuilds that changes of
/// membership make, and an update naming a missing instance changes nothing.
#[test]
fn two_level_scene_follows_updates() {
    let mut rng = Rng::new(21);
    let (meshes, bvhs) = two_meshes(&mut rng);
    let count = 150u32;
    let mut placed: Placements = (0..count as usize)
        .map(|i| Some((i % 2, random_transform(&mut rng))))
        .collect();
    let instance = |mi: usize, m: Affine3A| Instance {
        mesh: bvhs[mi].clone(),
        world_from_local: m,
    };
    let mut scene = InstancedScene::new(
        placed
            .iter()
            .flatten()
            .map(|&(mi, m)| instance(mi, m))
            .collect(),
    );
    for round in 0..12 {
        let mut updates = Vec::new();
        for _ in 0..=rng.below(30) {
            let i = rng.below(count as usize);
            let mi = rng.below(2);
            // Rounds 3, 7 and 11 also reject instances (and place rejected ones again);
            // the others only move them: small steps from where they are, or anywhere.
            let m = if round % 4 == 3 && rng.below(4) == 0 {
                singular_transform()
            } else if let (Some((_, at)), true) = (placed[i], rng.below(2) == 0) {
                Affine3A::from_translation(rng.vec3(-2.0, 2.0)) * at
            } else {
                random_transform(&mut rng)
            };
            placed[i] = (m != singular_transform()).then_some((mi, m));
            updates.push((i as u32, instance(mi, m)));
        }
        scene.update_instances(updates).unwrap();
        check_scene(&scene, &meshes, &bvhs, &placed, &mut rng, 150);
    }
    let before = scene.top_level().nodes().len();
    assert_eq!(
        scene.update_instances([
            (0, instance(0, Affine3A::IDENTITY)),
            (count, instance(0, Affine3A::IDENTITY))
        ]),
        Err(SceneUpdateError::NoSuchInstance {
            instance: count,
            instance_count: count as usize
        })
    );
    assert_eq!(scene.top_level().nodes().len(), before);
    check_scene(&scene, &meshes, &bvhs, &placed, &mut rng, 150);
    scene.rebuild_top_level();
    check_scene(&scene, &meshes, &bvhs, &placed, &mut rng, 150);
}

/// Every instance scattered anew in one update leaves refits far looser than a fresh build:
/// the scene rebuilds its top level (as fresh as `InstancedScene::new` makes it), unless told
/// never to.
#[test]
fn loose_top_levels_are_rebuilt() {
    let mut rng = Rng::new(34);
    let (_, bvhs) = two_meshes(&mut rng);
    let scattered = |rng: &mut Rng| -> Vec<Instance> {
        (0..400)
            .map(|i| Instance {
                mesh: bvhs[i % 2].clone(),
                world_from_local: random_transform(rng),
            })
            .collect()
    };
    let first = scattered(&mut rng);
    let second = scattered(&mut rng);
    let fresh = InstancedScene::new(second.clone())
        .top_level()
        .slot_area_cost();
    for threshold in [InstancedScene::DEFAULT_REBUILD_THRESHOLD, f32::INFINITY] {
        let mut scene = InstancedScene::new(first.clone());
        scene.set_rebuild_threshold(threshold);
        scene
            .update_instances((0..).zip(second.iter().cloned()))
            .unwrap();
        let cost = scene.top_level().slot_area_cost();
        if threshold.is_finite() {
            assert_eq!(cost, fresh, "not rebuilt");
        } else {
            assert!(cost > fresh * 1.5, "refit only: {cost} against {fresh}");
        }
    }
}
