//! Cost of one geometric test, in nanoseconds: ray against box (hits and misses apart), ray
//! against sphere, the watertight ray/triangle test (hits and misses apart), the frustum's
//! box and sphere classifications, and `Aabb::transformed`. Each pass runs a test over a
//! batch of 1,024 precomputed random inputs, so that branch prediction sees a realistic mix
//! and nothing can be hoisted out of the loop; a test's time is the best pass divided by the
//! batch. There is no peer: these are what the trees' walks are built from.
//!
//! Quality, per test: for the ray tests, the mean relative error of the hit distance against
//! the same test done in f64 (the slab test widens its interval on purpose, so its entry
//! distance is a little short); for the frustum, the share of the volumes a test keeps (not
//! outside), where a sphere bounding a box keeps more than the box does.

use super::point;
use crate::json::{Point, Report};
use crate::timing::best_of;
use accel_testkit::Rng;
use glam::{Affine3A, Mat4, Quat, Vec3, Vec3A};
use spatial_accel::{Aabb, Backfaces, Containment, Frustum, Ray, Sphere, Triangle, WatertightRay};
use std::hint::black_box;

/// Inputs per batch.
const BATCH: usize = 1024;

/// The scene name of every point.
const SCENE: &str = "batches of 1024 random inputs";

/// A box within 10 of the origin, half extents 0.1 to 2.
fn random_box(rng: &mut Rng) -> Aabb {
    accel_testkit::random_box(rng, 10.0, 0.1..2.0)
}

/// Rays from a shell around the scene aimed at a point of each box (hit) or well beside it
/// (miss), kept only where the test agrees, so that each batch is all hits or all misses.
fn ray_box_pairs(rng: &mut Rng, hit: bool) -> Vec<(Ray, Aabb)> {
    (0..BATCH)
        .map(|_| {
            let b = random_box(rng);
            let o = rng.unit_vector_f64() * 50.0;
            let target = if hit {
                b.center() + b.half_extents() * rng.vec3a(-0.9, 0.9)
            } else {
                b.center() + rng.unit_vector_f64() * 20.0
            };
            (Ray::new(o, target - o), b)
        })
        .filter(|(r, b)| r.hits_aabb(b) == hit)
        .collect()
}

/// Rays aimed at points up to twice a sphere's radius from its centre: hits and misses mixed.
fn ray_sphere_pairs(rng: &mut Rng) -> Vec<(Ray, Sphere)> {
    (0..BATCH)
        .map(|_| {
            let s = Sphere::new(rng.vec3a(-10.0, 10.0), rng.range(0.1, 2.0));
            let o = rng.unit_vector_f64() * 50.0;
            let target = s.center + rng.unit_vector_f64() * s.radius * rng.range(0.0, 2.0);
            (Ray::new(o, target - o), s)
        })
        .collect()
}

/// Random triangles and rays aimed inside them (hit) or past an edge (miss), kept only where
/// the test agrees.
fn ray_triangle_pairs(rng: &mut Rng, hit: bool) -> Vec<(Ray, Triangle)> {
    (0..BATCH)
        .map(|_| {
            let p = rng.vec3a(-10.0, 10.0);
            let tri = Triangle::new(
                p + rng.vec3a(-1.0, 1.0),
                p + rng.vec3a(-1.0, 1.0),
                p + rng.vec3a(-1.0, 1.0),
            );
            let (u, v) = (rng.range(0.1, 0.4), rng.range(0.1, 0.4));
            let [a, b, c] = tri.vertices;
            let inside = a * (1.0 - u - v) + b * u + c * v;
            let target = if hit {
                inside
            } else {
                inside + (inside - a) * 3.0
            };
            let o = rng.unit_vector_f64() * 50.0;
            (Ray::new(o, target - o), tri)
        })
        .filter(|(r, t)| t.intersect(r, Backfaces::Include).is_some() == hit)
        .collect()
}

/// The entry distance of the exact slab test in f64 (the ray starts outside every box here).
fn slab_f64(r: &Ray, b: &Aabb) -> Option<f64> {
    let (o, d) = (r.origin.as_dvec3(), r.direction.as_dvec3());
    let (t0, t1) = ((b.min.as_dvec3() - o) / d, (b.max.as_dvec3() - o) / d);
    let (near, far) = (t0.min(t1).max_element(), t0.max(t1).min_element());
    (near <= far && far >= 0.0).then_some(near.max(0.0))
}

/// The nearer root of the ray/sphere quadratic in f64, where it is ahead of the origin.
fn sphere_f64(r: &Ray, s: &Sphere) -> Option<f64> {
    let (o, d) = (r.origin.as_dvec3(), r.direction.as_dvec3());
    let f = o - s.center.as_dvec3();
    let (a, b, c) = (
        d.length_squared(),
        f.dot(d),
        f.length_squared() - f64::from(s.radius).powi(2),
    );
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let (t0, t1) = ((-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a);
    if t1 < 0.0 { None } else { Some(t0.max(0.0)) }
}

/// Möller and Trumbore's test in f64: the reference distance of a triangle hit.
fn triangle_f64(r: &Ray, t: &Triangle) -> Option<f64> {
    let [a, b, c] = t.vertices.map(|v| v.as_dvec3());
    let (o, d) = (r.origin.as_dvec3(), r.direction.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= 0.0).then_some(t)
}

/// The mean relative error of `ours` against `reference` over the cases both hit; 0 when
/// none does.
fn mean_relative_error<C>(
    cases: &[C],
    ours: impl Fn(&C) -> Option<f32>,
    reference: impl Fn(&C) -> Option<f64>,
) -> f64 {
    let errors: Vec<f64> = cases
        .iter()
        .filter_map(|c| Some((f64::from(ours(c)?), reference(c)?)))
        .map(|(t, want)| (t - want).abs() / want.abs().max(f64::MIN_POSITIVE))
        .collect();
    errors.iter().sum::<f64>() / errors.len().max(1) as f64
}

/// Nanoseconds per test: the best of `runs` passes, each `reps` times over the batch.
fn ns_per_test<C, R>(cases: &[C], runs: usize, reps: usize, pass: impl Fn(&[C]) -> R) -> f64 {
    let (t, _) = best_of(runs, || {
        for _ in 0..reps {
            black_box(pass(black_box(cases)));
        }
    });
    t * 1e9 / (reps * cases.len().max(1)) as f64
}

/// One test's row: its name, nanoseconds, and its quality figure.
struct Row {
    name: &'static str,
    ns: f64,
    quality: (&'static str, Option<f64>),
}

/// The ray tests against their f64 references.
fn ray_rows(rng: &mut Rng, runs: usize, reps: usize) -> Vec<Row> {
    const ERROR: &str = "mean relative error of t vs f64";
    let mut rows = Vec::new();
    for (name, hit) in [("ray / aabb, hit", true), ("ray / aabb, miss", false)] {
        let pairs = ray_box_pairs(rng, hit);
        let ns = ns_per_test(&pairs, runs, reps, |ps| {
            ps.iter()
                .filter(|(r, b)| r.intersect_aabb(b).is_some())
                .count()
        });
        let err = mean_relative_error(
            &pairs,
            |(r, b)| r.intersect_aabb(b),
            |(r, b)| slab_f64(r, b),
        );
        rows.push(Row {
            name,
            ns,
            quality: (ERROR, hit.then_some(err)),
        });
    }
    let pairs = ray_sphere_pairs(rng);
    let ns = ns_per_test(&pairs, runs, reps, |ps| {
        ps.iter().filter_map(|(r, s)| r.intersect_sphere(s)).count()
    });
    let err = mean_relative_error(
        &pairs,
        |(r, s)| r.intersect_sphere(s),
        |(r, s)| sphere_f64(r, s),
    );
    rows.push(Row {
        name: "ray / sphere (hit and miss mix)",
        ns,
        quality: (ERROR, Some(err)),
    });
    for (name, hit) in [
        ("watertight ray / triangle, hit", true),
        ("watertight ray / triangle, miss", false),
    ] {
        let pairs = ray_triangle_pairs(rng, hit);
        let cases: Vec<(WatertightRay, Triangle)> = pairs
            .iter()
            .map(|(r, t)| (WatertightRay::new(r), *t))
            .collect();
        let ns = ns_per_test(&cases, runs, reps, |cs| {
            cs.iter()
                .filter_map(|(r, t)| r.intersect(t, Backfaces::Include))
                .count()
        });
        let err = mean_relative_error(
            &pairs,
            |(r, t)| t.intersect(r, Backfaces::Include).map(|h| h.t),
            |(r, t)| triangle_f64(r, t),
        );
        rows.push(Row {
            name,
            ns,
            quality: (ERROR, hit.then_some(err)),
        });
    }
    rows
}

/// The frustum's two classifications and the box transform.
fn volume_rows(rng: &mut Rng, runs: usize, reps: usize) -> Vec<Row> {
    const KEPT: &str = "share of volumes kept";
    let view = Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
    let f = Frustum::from_clip_from_world(
        &(Mat4::perspective_infinite_reverse_rh(1.0, 1.5, 0.1) * view),
    );
    // Volumes around the camera: a mix of outside, crossing and inside.
    let boxes: Vec<Aabb> = (0..BATCH)
        .map(|_| {
            Aabb::from_center_half_extents(
                rng.vec3a(-50.0, 50.0),
                Vec3A::splat(rng.range(0.5, 5.0)),
            )
        })
        .collect();
    let spheres: Vec<Sphere> = boxes.iter().map(Sphere::from_aabb).collect();
    let kept = |c: &[Containment]| {
        c.iter().filter(|&&c| c != Containment::Outside).count() as f64 / c.len() as f64
    };
    let by_box: Vec<Containment> = boxes.iter().map(|b| f.classify_aabb(b)).collect();
    let by_sphere: Vec<Containment> = spheres.iter().map(|s| f.classify_sphere(s)).collect();
    let aabb_ns = ns_per_test(&boxes, runs, reps, |bs| {
        bs.iter()
            .map(|x| black_box(&f).classify_aabb(x) as u32)
            .sum::<u32>()
    });
    let sphere_ns = ns_per_test(&spheres, runs, reps, |ss| {
        ss.iter()
            .map(|x| black_box(&f).classify_sphere(x) as u32)
            .sum::<u32>()
    });
    let transforms: Vec<(Aabb, Affine3A)> = (0..BATCH)
        .map(|_| {
            let q = Quat::from_axis_angle(rng.unit_vector_f64().into(), rng.range(0.0, 6.3));
            let m = Affine3A::from_scale_rotation_translation(
                Vec3::splat(rng.range(0.5, 2.0)),
                q,
                rng.vec3a(-1e3, 1e3).into(),
            );
            (random_box(rng), m)
        })
        .collect();
    let transform_ns = ns_per_test(&transforms, runs, reps, |cs| {
        cs.iter()
            .fold(Vec3A::ZERO, |acc, (bx, m)| acc + bx.transformed(m).max)
    });
    vec![
        Row {
            name: "frustum / aabb",
            ns: aabb_ns,
            quality: (KEPT, Some(kept(&by_box))),
        },
        Row {
            name: "frustum / sphere",
            ns: sphere_ns,
            quality: (KEPT, Some(kept(&by_sphere))),
        },
        Row {
            name: "`Aabb::transformed`",
            ns: transform_ns,
            quality: (KEPT, None),
        },
    ]
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let (runs, reps) = if quick { (3, 20) } else { (7, 400) };
    let mut rng = Rng::new(1);
    let mut rows = ray_rows(&mut rng, runs, reps);
    rows.extend(volume_rows(&mut rng, runs, reps));
    let mut markdown = vec!["| test | ns per test |".to_string(), "|---|---:|".into()];
    let mut points: Vec<Point> = Vec::new();
    for row in &rows {
        markdown.push(format!("| {} | {:.1} |", row.name, row.ns));
        points.push(point(
            SCENE,
            row.name,
            "batch of 1024",
            ("ns per test", row.ns),
            row.quality,
        ));
    }
    let ns = |name: &str| rows.iter().find(|r| r.name == name).map_or(0.0, |r| r.ns);
    let notes = vec![
        format!(
            "frustum: the sphere test takes {:.2}x the box test's time",
            ns("frustum / sphere") / ns("frustum / aabb")
        ),
        format!(
            "ray / aabb: a miss takes {:.2}x a hit's time",
            ns("ray / aabb, miss") / ns("ray / aabb, hit")
        ),
    ];
    Report {
        suite: "geometry".into(),
        quick,
        points,
        markdown,
        notes,
        ..Report::default()
    }
}
