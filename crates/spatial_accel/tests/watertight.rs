//! Watertightness of the ray/triangle test on closed meshes, near and far from the origin, and
//! the orientation, parameter and barycentrics it reports.
//!
//! The bar is Embree's leak test with the tolerance taken away: a ray leaving a point strictly
//! inside a closed mesh must hit at least one triangle, including rays aimed exactly at shared
//! vertices and edges, where a non-watertight test lets rays slip between the two sides.

mod support;

use accel_testkit::shapes::{cube, icosphere};
use accel_testkit::{Mesh, Rng, bunny};
use glam::{DVec3, Vec3A};
use spatial_accel::{Backfaces, Ray, Triangle, WatertightRay, intersect_triangle_f64};
use support::d;

/// Far offsets along a direction with no zero component, so every coordinate is rounded.
const OFFSETS: [f32; 3] = [0.0, 1e3, 1e5];

fn offset_vector(o: f32) -> Vec3A {
    Vec3A::new(o, -0.61 * o, 0.37 * o)
}

/// Brute force any-hit with both sides counting.
fn hits_mesh(ray: &Ray, mesh: &Mesh) -> bool {
    let wr = WatertightRay::new(ray);
    let v = &mesh.vertices;
    mesh.indices.iter().any(|&[a, b, c]| {
        wr.intersect_vertices(
            v[a as usize],
            v[b as usize],
            v[c as usize],
            Backfaces::Include,
        )
        .is_some()
    })
}

/// Points strictly inside, certified in f64 on the f32 mesh itself: winding number about 1 and
/// a clearance from the surface, so the hit parameter cannot round to the wrong side of 0.
fn inside_points(mesh: &Mesh, count: usize, rng: &mut Rng) -> Vec<Vec3A> {
    let (lo, hi) = mesh
        .vertices
        .iter()
        .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    let clearance = 1e-3 * f64::from((hi - lo).max_element());
    let mut points = Vec::with_capacity(count);
    let mut tries = 0;
    while points.len() < count {
        tries += 1;
        assert!(tries < 100 * count, "could not find points inside the mesh");
        let t = Vec3A::new(rng.f32(), rng.f32(), rng.f32());
        let p = lo + (hi - lo) * t;
        let w = mesh.winding_number(d(p));
        if (w - 1.0).abs() < 1e-3 && mesh.distance_to_surface(d(p)) > clearance {
            points.push(p);
        }
    }
    points
}

/// Random directions, with some axis-parallel ones carrying signed zeros.
fn direction(rng: &mut Rng) -> Vec3A {
    if rng.below(8) == 0 {
        let z = |rng: &mut Rng| if rng.bool() { 0.0 } else { -0.0 };
        let mut v = Vec3A::new(z(rng), z(rng), z(rng));
        v[rng.below(3)] = if rng.bool() { 1.0 } else { -1.0 };
        v
    } else {
        rng.unit_vector_f64()
    }
}

struct Tally {
    rays: u64,
    missed: u64,
    examples: Vec<String>,
}

impl Tally {
    fn check(&mut self, mesh: &Mesh, origin: Vec3A, dir: Vec3A, what: &str) {
        self.rays += 1;
        if !hits_mesh(&Ray::new(origin, dir), mesh) {
            self.missed += 1;
            if self.examples.len() < 10 {
                self.examples
                    .push(format!("{what}: origin {origin:?} direction {dir:?}"));
            }
        }
    }
}

/// Runs random, vertex-aimed and edge-midpoint-aimed rays from inside points of `base` scaled to
/// `size`, at every offset; returns the number of rays traced.
fn leak_test(
    name: &str,
    base: &Mesh,
    size: f64,
    origins: usize,
    random_per_origin: usize,
    aimed_per_origin: usize,
    seed: u64,
) -> u64 {
    base.check_closed()
        .unwrap_or_else(|e| panic!("{name} is not closed: {e}"));
    let mut total = 0;
    for (k, &o) in OFFSETS.iter().enumerate() {
        let mesh = base.normalized(size).translated(offset_vector(o));
        let mut rng = Rng::new(seed + k as u64);
        let points = inside_points(&mesh, origins, &mut rng);
        let edges = mesh.edges();
        let mut tally = Tally {
            rays: 0,
            missed: 0,
            examples: Vec::new(),
        };
        for &p in &points {
            for _ in 0..random_per_origin {
                tally.check(&mesh, p, direction(&mut rng), "random");
            }
            for _ in 0..aimed_per_origin {
                // Direction = target - origin in f32: exactly what a caller aiming at it computes.
                let v = mesh.vertices[rng.below(mesh.vertices.len())];
                tally.check(&mesh, p, v - p, "vertex");
                let [a, b] = edges[rng.below(edges.len())];
                let mid = (mesh.vertices[a as usize] + mesh.vertices[b as usize]) * 0.5;
                tally.check(&mesh, p, mid - p, "edge midpoint");
            }
        }
        assert!(
            tally.missed == 0,
            "{name} at offset {o}: rays from inside missed the closed mesh ({} of {}), e.g.\n{}",
            tally.missed,
            tally.rays,
            tally.examples.join("\n")
        );
        total += tally.rays;
    }
    println!("{name}: {total} rays, 0 misses");
    total
}

#[test]
fn cube_is_watertight() {
    let rays = leak_test("cube", &cube(), 40.0, 500, 200, 100, 1);
    assert!(rays >= 600_000);
}

/// From the centre of the cube the 26 directions of {-1, 0, 1}^3 (with both zeros) run exactly
/// through its corners, edge midpoints and face centres: the worst case for shared edges.
#[test]
fn cube_center_through_corners_and_edges() {
    for &o in &OFFSETS {
        let mesh = cube().normalized(40.0).translated(offset_vector(o));
        let center = mesh.vertices.iter().fold(Vec3A::ZERO, |s, &v| s + v) / 8.0;
        let comps = [-1.0, -0.0, 0.0, 1.0f32];
        let mut rays = 0;
        for &x in &comps {
            for &y in &comps {
                for &z in &comps {
                    let dir = Vec3A::new(x, y, z);
                    if dir == Vec3A::ZERO {
                        continue;
                    }
                    rays += 1;
                    assert!(
                        hits_mesh(&Ray::new(center, dir), &mesh),
                        "offset {o}: ray from the centre along {dir:?} missed"
                    );
                }
            }
        }
        assert_eq!(rays, 4 * 4 * 4 - 8);
    }
}

#[test]
fn icosphere_is_watertight() {
    let rays = leak_test("icosphere(3)", &icosphere(3), 60.0, 500, 120, 40, 2);
    assert!(rays >= 300_000);
}

#[test]
fn bunny_is_watertight() {
    let rays = leak_test("bunny", &bunny(), 50.0, 100, 300, 100, 3);
    assert!(rays >= 150_000);
}

/// The test meshes must be outward-oriented for `front_face` checks built on them to mean
/// anything; the winding number at an inside point says so.
#[test]
fn test_meshes_are_closed_and_outward() {
    for (name, mesh, inside) in [
        ("cube", cube(), DVec3::ZERO),
        ("icosphere", icosphere(3), DVec3::ZERO),
    ] {
        mesh.check_closed()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let w = mesh.winding_number(inside);
        assert!(
            (w - 1.0).abs() < 1e-9,
            "{name}: winding number {w} at an inside point"
        );
        assert!(mesh.winding_number(DVec3::splat(5.0)).abs() < 1e-9);
    }
    assert_eq!(icosphere(3).indices.len(), 1280);
    let bunny = bunny();
    bunny.check_closed().unwrap();
    assert!(bunny.indices.len() > 1000);
}

/// A random well-shaped triangle with a point `P` inside it, both away from the edges.
fn random_triangle(rng: &mut Rng) -> ([Vec3A; 3], DVec3) {
    loop {
        let scale = rng.log_range(0.5, 1e3);
        let c = rng.vec3a(-1e3, 1e3);
        let tri = [0, 1, 2].map(|_| c + rng.vec3a(-scale, scale));
        let [a, b, e] = tri.map(d);
        let n = (b - a).cross(e - a);
        let longest = (b - a).length().max((e - b).length()).max((a - e).length());
        if n.length() > 0.1 * longest * longest {
            let (u, v) = (rng.range_f64(0.05, 0.9), rng.range_f64(0.05, 0.9));
            if u + v < 0.95 {
                return (tri, a * (1.0 - u - v) + b * u + e * v);
            }
        }
    }
}

/// Front means counter-clockwise as seen from the ray origin, i.e. the geometric normal
/// `(b - a) x (c - a)` points back at the origin; `Cull` keeps exactly those hits.
#[test]
fn front_face_and_culling() {
    let mut rng = Rng::new(10);
    let (mut front_seen, mut back_seen) = (0, 0);
    for i in 0..200_000 {
        let (tri, p) = random_triangle(&mut rng);
        let n = d(Triangle::new(tri[0], tri[1], tri[2]).normal()).normalize();
        // Mostly along the normal, with a sideways component so all six dominant axes occur.
        let side = if i % 2 == 0 { 1.0 } else { -1.0 };
        let away = (n * side + d(rng.unit_vector_f64()) * 0.5).normalize();
        let dist = f64::from(rng.log_range(1e-1, 1e3));
        let origin = (p + away * dist).as_vec3a();
        let dir = (p - d(origin)).as_vec3a();
        let ray = Ray::new(origin, dir);
        let t = Triangle::new(tri[0], tri[1], tri[2]);
        let hit = t
            .intersect(&ray, Backfaces::Include)
            .unwrap_or_else(|| panic!("ray at an interior point missed: {tri:?} {ray:?}"));
        let expect_front = d(ray.direction).dot(n) < 0.0;
        assert_eq!(hit.front_face, expect_front, "{tri:?} {ray:?}");
        assert_eq!(
            t.intersect(&ray, Backfaces::Cull).is_some(),
            expect_front,
            "{tri:?} {ray:?}"
        );
        if expect_front {
            front_seen += 1
        } else {
            back_seen += 1
        }
    }
    assert!(front_seen > 50_000 && back_seen > 50_000);
}

/// The worked example the doc comment promises: looking down -z at a counter-clockwise triangle.
#[test]
fn front_face_worked_example() {
    let tri = Triangle::new(
        Vec3A::new(-1.0, -1.0, 0.0),
        Vec3A::new(1.0, -1.0, 0.0),
        Vec3A::new(0.0, 1.0, 0.0),
    );
    assert!(tri.normal().z > 0.0);
    let from_front = Ray::new(Vec3A::new(0.0, 0.0, 5.0), Vec3A::NEG_Z);
    let from_back = Ray::new(Vec3A::new(0.0, 0.0, -5.0), Vec3A::Z);
    let hit = tri
        .intersect(&from_front, Backfaces::Cull)
        .expect("front face culled");
    assert!(hit.front_face);
    assert_eq!(hit.t, 5.0);
    assert!(tri.intersect(&from_back, Backfaces::Cull).is_none());
    assert!(
        !tri.intersect(&from_back, Backfaces::Include)
            .unwrap()
            .front_face
    );
}

/// `t` and the barycentrics agree with the f64 reference. Errors are measured against the
/// conditioning of each case: `t` in units of the largest corner distance from the origin (the
/// magnitude the f32 arithmetic works at), barycentrics scaled by the triangle's area as seen
/// along the ray over that distance squared (small projected areas amplify edge-function
/// rounding).
#[test]
fn t_and_barycentrics_match_f64() {
    let mut rng = Rng::new(11);
    let (mut worst_t, mut worst_uv) = (0.0f64, 0.0f64);
    for _ in 0..200_000 {
        let (tri, p) = random_triangle(&mut rng);
        let n = d(Triangle::new(tri[0], tri[1], tri[2]).normal());
        let away = (n.normalize() * if rng.bool() { 1.0 } else { -1.0 }
            + d(rng.unit_vector_f64()) * 0.7)
            .normalize();
        let origin = (p + away * f64::from(rng.log_range(1e-1, 1e3))).as_vec3a();
        let dir = (p - d(origin)).as_vec3a();
        let ray = Ray::new(origin, dir);
        let hit = Triangle::new(tri[0], tri[1], tri[2])
            .intersect(&ray, Backfaces::Include)
            .expect("interior hit missed");
        let (t, u, v) =
            intersect_triangle_f64(d(origin), d(dir), tri.map(d)).expect("f64 reference missed");
        let reach = tri
            .iter()
            .map(|&v| (d(v) - d(origin)).length())
            .fold(0.0, f64::max);
        let dir_len = d(dir).length();
        worst_t = worst_t.max((f64::from(hit.t) - t).abs() * dir_len / reach);
        let projected = n.dot(d(dir)).abs() / dir_len;
        let uv_err = (f64::from(hit.u) - u)
            .abs()
            .max((f64::from(hit.v) - v).abs());
        worst_uv = worst_uv.max(uv_err * projected / (reach * reach));
    }
    println!("worst scaled t error {worst_t:e}, worst scaled barycentric error {worst_uv:e}");
    assert!(
        worst_t < 1e-6,
        "t off by {worst_t:e} of the corner distance"
    );
    assert!(worst_uv < 1e-6, "barycentrics off by {worst_uv:e} (scaled)");
}
