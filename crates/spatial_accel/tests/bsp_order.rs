//! The BSP tree's painter's orders against a depth buffer, from many eye points, on scenes no
//! depth sort can order; and what its cuts must keep (area, planes, shared points).

#[path = "support/raster.rs"]
mod raster;

use accel_testkit::{Mesh, Rng};
use glam::{Vec3, Vec3A};
use raster::{Camera, Comparison, compare};
use spatial_accel::bsp::{BspConfig, BspPlane, BspTree};
use spatial_accel::{Aabb, Triangle};

/// A scene: its name, vertices and flat indices.
struct Scene {
    name: &'static str,
    vertices: Vec<Vec3>,
    indices: Vec<u32>,
}

impl Scene {
    fn unshared(name: &'static str, triangles: &[[Vec3; 3]]) -> Self {
        Self {
            name,
            vertices: triangles.iter().flatten().copied().collect(),
            indices: (0..3 * triangles.len() as u32).collect(),
        }
    }

    fn from_mesh(name: &'static str, mesh: &Mesh) -> Self {
        Self {
            name,
            vertices: mesh.positions(),
            indices: mesh.flat_indices(),
        }
    }

    fn tree(&self) -> BspTree {
        BspTree::new(&self.vertices, &self.indices).expect("a valid mesh")
    }

    fn source(&self, i: usize) -> [Vec3A; 3] {
        [0, 1, 2].map(|k| self.vertices[self.indices[3 * i + k] as usize].into())
    }

    fn bounds(&self) -> Aabb {
        Aabb::from_points(self.vertices.iter().copied())
    }
}

/// The two triangles of the quad `a b c d` (counter-clockwise).
fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3) -> [[Vec3; 3]; 2] {
    [[a, b, c], [a, c, d]]
}

/// Two quads through each other: z = 0 and the tilted x = 0.3 z, crossing along a line.
fn crossing_quads() -> Scene {
    let mut t = quad(
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    )
    .to_vec();
    t.extend(quad(
        Vec3::new(-0.3, -0.8, -1.0),
        Vec3::new(-0.3, 0.8, -1.0),
        Vec3::new(0.3, 0.8, 1.0),
        Vec3::new(0.3, -0.8, 1.0),
    ));
    Scene::unshared("crossing quads", &t)
}

/// The classic three sticks, each a long thin triangle: each lies over the next where they
/// cross and under the one before, so whichever is drawn last hides a stick it should be
/// under, and no order of the whole triangles paints them right.
fn cyclic_sticks() -> Scene {
    let corner = |k: usize| {
        let a = (90.0f32 + 120.0 * k as f32).to_radians();
        Vec3::new(a.cos(), a.sin(), 0.0)
    };
    let (extend, half_width, slope) = (0.8, 0.45, 0.25);
    let mut t = Vec::new();
    for k in 0..3 {
        let (from, to) = (corner(k), corner((k + 1) % 3));
        let dir = (to - from).normalize();
        let side = Vec3::new(-dir.y, dir.x, 0.0) * half_width;
        let half = (to - from).length() / 2.0 + extend;
        let mid = (from + to) / 2.0;
        // Height rises along the stick: its head lies over the next stick's tail.
        let at = |s: f32| mid + dir * s + Vec3::Z * (slope * s);
        t.push([at(-half) - side, at(half), at(-half) + side]);
    }
    Scene::unshared("cyclic sticks", &t)
}

/// Large random triangles crossing each other everywhere in a cube of side 4.
fn dense_soup(seed: u64, n: usize) -> Scene {
    let mut rng = Rng::new(seed);
    let t: Vec<[Vec3; 3]> = (0..n)
        .map(|_| {
            let c = rng.vec3(-2.0, 2.0);
            [0; 3].map(|_| c + rng.vec3(-1.5, 1.5))
        })
        .collect();
    Scene::unshared("dense soup", &t)
}

fn scenes() -> Vec<Scene> {
    let mut rng = Rng::new(3);
    vec![
        crossing_quads(),
        cyclic_sticks(),
        dense_soup(1, 40),
        dense_soup(2, 120),
        Scene::from_mesh(
            "small soup",
            &accel_testkit::shapes::triangle_soup(&mut rng, 300),
        ),
        Scene::from_mesh("bunny", &accel_testkit::bunny().normalized(2.0)),
    ]
}

/// `n` cameras looking at the scene from random points around it, and (for `inside`) from
/// within its box too, each towards a point near its centre.
fn cameras(scene: &Scene, n: usize, inside: bool, seed: u64) -> Vec<Camera> {
    let bounds = scene.bounds();
    let (center, radius) = (bounds.center(), bounds.extent().length() / 2.0);
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|i| {
            let reach = if inside && i % 2 == 1 {
                rng.range(0.1, 1.0)
            } else {
                rng.range(1.2, 3.0)
            };
            let eye = center + rng.unit_vector() * radius * reach;
            let target = center + rng.vec3a(-0.2, 0.2) * radius;
            Camera::look_at(eye, target, 1e-3 * f64::from(radius), resolution(scene))
        })
        .collect()
}

/// Every piece of the tree with its source index, as the raster takes them.
fn pieces_of(tree: &BspTree) -> Vec<([Vec3A; 3], u32)> {
    tree.pieces()
        .iter()
        .map(|p| (p.vertices, p.source))
        .collect()
}

/// The views of a scene: fewer for the bunny, at a higher resolution, so that its small
/// triangles have pixels away from their edges.
fn view_count(scene: &Scene) -> usize {
    if scene.indices.len() > 3000 { 8 } else { 24 }
}

/// Pixels a side of the scene's images (see [`view_count`]).
fn resolution(scene: &Scene) -> usize {
    if scene.indices.len() > 3000 { 512 } else { 128 }
}

#[test]
fn painting_back_to_front_matches_the_depth_buffer() {
    for (s, scene) in scenes().iter().enumerate() {
        let tree = scene.tree();
        tree.validate().unwrap();
        let pieces = pieces_of(&tree);
        let mut total = Comparison::default();
        let inside = scene.name != "bunny";
        for (v, camera) in cameras(scene, view_count(scene), inside, 100 + s as u64)
            .iter()
            .enumerate()
        {
            let mut order = Vec::new();
            tree.back_to_front(camera.eye.as_vec3a(), &mut order);
            let c = compare(camera, &pieces, &order);
            assert_eq!(
                c.wrong, 0,
                "{}: view {v} from {}: {c:?}",
                scene.name, camera.eye
            );
            total.compared += c.compared;
            total.overlapped += c.overlapped;
        }
        println!("{}: {total:?}", scene.name);
        // The comparison saw real overlap, not empty screens.
        assert!(total.overlapped > 1000, "{}: only {total:?}", scene.name);
    }
}

#[test]
fn wrong_orders_are_caught_and_no_depth_sort_orders_the_sticks() {
    for scene in [crossing_quads(), cyclic_sticks(), dense_soup(1, 40)] {
        let tree = scene.tree();
        let pieces = pieces_of(&tree);
        // Painting nearest first must show wrong pixels: the comparison can fail.
        let wrong: usize = cameras(&scene, 24, false, 7)
            .iter()
            .map(|camera| {
                let mut order = Vec::new();
                tree.front_to_back(camera.eye.as_vec3a(), &mut order);
                compare(camera, &pieces, &order).wrong
            })
            .sum();
        assert!(
            wrong > 100,
            "{}: front to back painted only {wrong} wrong pixels",
            scene.name
        );
    }
    // Looking down on the sticks, every order of the three whole triangles paints some
    // pixel wrong: they overlap in a cycle. The tree, cutting them, paints them right.
    let sticks = cyclic_sticks();
    let sources: Vec<([Vec3A; 3], u32)> = (0..3).map(|i| (sticks.source(i), i as u32)).collect();
    let camera = Camera::look_at(Vec3A::new(0.05, 0.1, 5.0), Vec3A::ZERO, 1e-3, 128);
    for order in [
        [0, 1, 2],
        [0, 2, 1],
        [1, 0, 2],
        [1, 2, 0],
        [2, 0, 1],
        [2, 1, 0],
    ] {
        let c = compare(&camera, &sources, &order);
        assert!(c.wrong > 10, "{order:?} painted the sticks right: {c:?}");
    }
    let tree = sticks.tree();
    assert!(tree.stats().splits > 0);
    let mut order = Vec::new();
    tree.back_to_front(camera.eye.as_vec3a(), &mut order);
    let c = compare(&camera, &pieces_of(&tree), &order);
    assert!(c.wrong == 0 && c.compared > 1000, "{c:?}");
}

#[test]
fn front_to_back_is_back_to_front_reversed_and_lists_every_piece_once() {
    for scene in scenes() {
        let tree = scene.tree();
        let mut rng = Rng::new(5);
        let bounds = scene.bounds();
        for _ in 0..20 {
            let eye = bounds.center() + rng.vec3a(-1.0, 1.0) * bounds.extent();
            let (mut back, mut front) = (Vec::new(), Vec::new());
            tree.back_to_front(eye, &mut back);
            tree.front_to_back(eye, &mut front);
            back.reverse();
            assert_eq!(front, back, "{}", scene.name);
            back.sort_unstable();
            assert!(
                back.iter().copied().eq(0..tree.pieces().len() as u32),
                "{}: not every piece once",
                scene.name
            );
        }
        // A NaN eye gets some order of every piece, without a panic.
        let mut order = Vec::new();
        tree.back_to_front(Vec3A::NAN, &mut order);
        assert_eq!(order.len(), tree.pieces().len());
    }
}

#[test]
fn pieces_keep_their_source_area_and_plane() {
    for scene in scenes() {
        let tree = scene.tree();
        tree.validate().unwrap();
        let stats = tree.stats();
        let mut area = vec![0.0f64; scene.indices.len() / 3];
        for p in tree.pieces() {
            area[p.source as usize] += p.area();
            let source = scene.source(p.source as usize);
            let plane = BspPlane::from_triangle(&source).unwrap();
            for v in p.vertices {
                let d = plane.signed_distance(v).abs();
                assert!(
                    d <= tree.tolerance(),
                    "{}: piece {v} {d} off its source",
                    scene.name
                );
            }
            // Same winding as the source: the normals agree.
            let n = Triangle::new(p.vertices[0], p.vertices[1], p.vertices[2]).normal();
            assert!(
                n.as_dvec3().dot(plane.normal) >= 0.0,
                "{}: flipped piece",
                scene.name
            );
        }
        for (i, &a) in area.iter().enumerate() {
            let want = Triangle::new(scene.source(i)[0], scene.source(i)[1], scene.source(i)[2]);
            let want = want.normal().as_dvec3().length() / 2.0;
            assert!(
                (a - want).abs() <= 1e-5 * want + 1e-12,
                "{}: source {i} area {want}, pieces {a}",
                scene.name
            );
        }
        assert_eq!(stats.sources, scene.indices.len() / 3, "{}", scene.name);
        assert_eq!(stats.depth_limited, 0, "{}", scene.name);
        println!(
            "{}: {} sources, {} splits, {} pieces ({:.2} per source, at most {}), {} nodes, depth {}",
            scene.name,
            stats.sources,
            stats.splits,
            stats.pieces,
            stats.pieces_per_source(),
            stats.max_pieces_per_source,
            stats.nodes,
            stats.depth
        );
    }
}

/// A bumpy height field (no two triangles coplanar) cut by tall walls: two neighbours cut
/// at their shared edge must get the same cut point there, to the bit. A corner one has on
/// the edge that lies within rounding of a corner the other has there, but is not equal to
/// it, would open a crack or a T-junction gap between them.
#[test]
fn neighbours_share_the_cut_points_of_their_edge() {
    let mut rng = Rng::new(21);
    let mut shared_points = 0;
    for _ in 0..4 {
        let n = 16;
        let mut mesh = Mesh::default();
        for y in 0..=n {
            for x in 0..=n {
                let h = rng.range(-0.05, 0.05);
                mesh.vertices
                    .push(Vec3A::new(x as f32 / n as f32, y as f32 / n as f32, h));
            }
        }
        let at = |x: u32, y: u32| y * (n + 1) + x;
        for y in 0..n {
            for x in 0..n {
                mesh.indices
                    .push([at(x, y), at(x + 1, y), at(x + 1, y + 1)]);
                mesh.indices
                    .push([at(x, y), at(x + 1, y + 1), at(x, y + 1)]);
            }
        }
        let field = mesh.indices.len();
        let mut scene = Scene::from_mesh("height field", &mesh);
        for _ in 0..3 {
            // A vertical wall through the field at a random angle.
            let c = rng.vec3(0.3, 0.7) * Vec3::new(1.0, 1.0, 0.0);
            let a = rng.range(0.0, std::f32::consts::PI);
            let d = Vec3::new(a.cos(), a.sin(), 0.0) * 3.0;
            scene
                .vertices
                .extend([c - d - Vec3::Z, c + d - Vec3::Z, c + Vec3::Z]);
            let base = scene.vertices.len() as u32 - 3;
            scene.indices.extend([base, base + 1, base + 2]);
        }
        let tree = scene.tree();
        tree.validate().unwrap();
        let mut corners = vec![Vec::new(); field];
        for p in tree.pieces().iter().filter(|p| (p.source as usize) < field) {
            corners[p.source as usize].extend(p.vertices);
        }
        // Each interior edge of the field and the two triangles on it.
        let mut edges = std::collections::HashMap::new();
        for (t, tri) in mesh.indices.iter().enumerate() {
            for k in 0..3 {
                let (u, v) = (tri[k], tri[(k + 1) % 3]);
                edges
                    .entry((u.min(v), u.max(v)))
                    .or_insert_with(Vec::new)
                    .push(t);
            }
        }
        for (&(u, v), tris) in &edges {
            let [t1, t2] = tris[..] else { continue };
            let (a, b) = (mesh.vertices[u as usize], mesh.vertices[v as usize]);
            let on_edge = |p: &&Vec3A| {
                let t = ((**p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
                **p != a && **p != b && (a + (b - a) * t).distance(**p) < 1e-6
            };
            for p in corners[t1].iter().filter(on_edge) {
                for q in corners[t2].iter().filter(on_edge) {
                    if p.distance(*q) < 1e-5 {
                        assert_eq!(
                            p.to_array().map(f32::to_bits),
                            q.to_array().map(f32::to_bits)
                        );
                        shared_points += 1;
                    }
                }
            }
        }
    }
    assert!(shared_points > 50, "only {shared_points} cut points shared");
}

#[test]
fn nearly_coplanar_degenerate_and_non_finite_input() {
    // Fifty triangles within rounding of one plane: they share a node, nothing recurses.
    let mut rng = Rng::new(9);
    let mut t: Vec<[Vec3; 3]> = (0..50)
        .map(|_| {
            [0; 3].map(|_| {
                rng.vec3(-1.0, 1.0) * Vec3::new(1.0, 1.0, 0.0) + Vec3::Z * rng.range(-1e-7, 1e-7)
            })
        })
        .collect();
    // Degenerate: a point, a line, and a sliver thinner than the tolerance.
    t.push([Vec3::ONE; 3]);
    t.push([Vec3::ZERO, Vec3::X, Vec3::X * 2.0]);
    t.push([Vec3::ZERO, Vec3::X, Vec3::new(0.5, 1e-9, 1e-9)]);
    t.push([Vec3::ZERO, Vec3::NAN, Vec3::X]);
    t.push([Vec3::ZERO, Vec3::Y, Vec3::splat(f32::INFINITY)]);
    let scene = Scene::unshared("nearly coplanar", &t);
    let tree = scene.tree();
    tree.validate().unwrap();
    let stats = tree.stats();
    assert_eq!(
        (stats.degenerate, stats.non_finite, stats.sources),
        (3, 2, 50)
    );
    assert_eq!(tree.degenerate_triangles(), &[50, 51, 52]);
    assert_eq!(
        (stats.splits, stats.nodes, stats.depth),
        (0, 1, 1),
        "{stats:?}"
    );

    // Planes just beyond the tolerance apart: a stack of parallel triangles ends as a tree
    // of them, one plane each, however thin the gaps.
    let gap = (tree.tolerance() * 4.0) as f32;
    let stack: Vec<[Vec3; 3]> = (0..200)
        .map(|i| [Vec3::ZERO, Vec3::X, Vec3::Y].map(|v| v + Vec3::Z * (gap * i as f32)))
        .collect();
    let stack = Scene::unshared("stack", &stack);
    let tree = stack.tree();
    tree.validate().unwrap();
    assert_eq!(tree.stats().splits, 0);
    assert!(
        tree.stats().nodes == 200 && tree.stats().depth < 40,
        "{:?}",
        tree.stats()
    );

    // A depth limit of 3 stops the build and counts what it left unordered.
    let soup = dense_soup(4, 60);
    let config = BspConfig {
        max_depth: 3,
        ..BspConfig::default()
    };
    let tree = BspTree::with_config(&soup.vertices, &soup.indices, &config).unwrap();
    tree.validate().unwrap();
    assert!(
        tree.stats().depth <= 3 && tree.stats().depth_limited > 0,
        "{:?}",
        tree.stats()
    );
    let mut order = Vec::new();
    tree.back_to_front(Vec3A::ZERO, &mut order);
    assert_eq!(order.len(), tree.pieces().len());
}
