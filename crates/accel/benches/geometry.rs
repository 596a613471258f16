//! Cost of one geometric test, in nanoseconds: each iteration runs the test over a batch of
//! precomputed random inputs (so branch prediction sees a realistic mix and the optimiser cannot
//! hoist anything), and criterion's time per iteration is divided by the batch size through
//! `Throughput::Elements`.

use accel::{Aabb, Backfaces, Frustum, Ray, Sphere, Triangle, WatertightRay};
use accel_testkit::Rng;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::{Affine3A, Mat4, Quat, Vec3, Vec3A};
use std::hint::black_box;

const BATCH: usize = 1024;

/// A box within 10 of the origin, half extents 0.1 to 2.
fn random_box(rng: &mut Rng) -> Aabb {
    accel_testkit::random_box(rng, 10.0, 0.1..2.0)
}

/// Rays from a shell around the scene aimed at a point of each box (hit) or well beside it (miss).
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

fn bench_ray_aabb(c: &mut Criterion) {
    let mut rng = Rng::new(1);
    let mut g = c.benchmark_group("ray_aabb");
    for (name, hit) in [("hit", true), ("miss", false)] {
        let pairs = ray_box_pairs(&mut rng, hit);
        g.throughput(Throughput::Elements(pairs.len() as u64));
        g.bench_function(name, |b| {
            b.iter(|| {
                black_box(&pairs)
                    .iter()
                    .filter(|(r, bx)| r.intersect_aabb(bx).is_some())
                    .count()
            })
        });
    }
    g.finish();
}

fn bench_ray_sphere(c: &mut Criterion) {
    let mut rng = Rng::new(2);
    let pairs: Vec<(Ray, Sphere)> = (0..BATCH)
        .map(|_| {
            let s = Sphere::new(rng.vec3a(-10.0, 10.0), rng.range(0.1, 2.0));
            let o = rng.unit_vector_f64() * 50.0;
            let target = s.center + rng.unit_vector_f64() * s.radius * rng.range(0.0, 2.0);
            (Ray::new(o, target - o), s)
        })
        .collect();
    let mut g = c.benchmark_group("ray_sphere");
    g.throughput(Throughput::Elements(BATCH as u64));
    g.bench_function("mixed", |b| {
        b.iter(|| {
            black_box(&pairs)
                .iter()
                .filter_map(|(r, s)| r.intersect_sphere(s))
                .count()
        })
    });
    g.finish();
}

fn bench_ray_triangle(c: &mut Criterion) {
    let mut rng = Rng::new(3);
    let mut g = c.benchmark_group("ray_triangle_watertight");
    for (name, hit) in [("hit", true), ("miss", false)] {
        let cases: Vec<(WatertightRay, Triangle)> = (0..BATCH)
            .map(|_| {
                let p = rng.vec3a(-10.0, 10.0);
                let tri = Triangle::new(
                    p + rng.vec3a(-1.0, 1.0),
                    p + rng.vec3a(-1.0, 1.0),
                    p + rng.vec3a(-1.0, 1.0),
                );
                let (u, v) = (rng.range(0.1, 0.4), rng.range(0.1, 0.4));
                let [a, b, cc] = tri.vertices;
                let inside = a * (1.0 - u - v) + b * u + cc * v;
                let target = if hit {
                    inside
                } else {
                    inside + (inside - a) * 3.0
                };
                let o = rng.unit_vector_f64() * 50.0;
                (WatertightRay::new(&Ray::new(o, target - o)), tri)
            })
            .filter(|(r, t)| r.intersect(t, Backfaces::Include).is_some() == hit)
            .collect();
        g.throughput(Throughput::Elements(cases.len() as u64));
        g.bench_function(name, |b| {
            b.iter(|| {
                black_box(&cases)
                    .iter()
                    .filter_map(|(r, t)| r.intersect(t, Backfaces::Include))
                    .count()
            })
        });
    }
    g.finish();
}

fn bench_frustum(c: &mut Criterion) {
    let mut rng = Rng::new(4);
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
    let mut g = c.benchmark_group("frustum");
    g.throughput(Throughput::Elements(BATCH as u64));
    g.bench_function("aabb", |b| {
        b.iter(|| {
            black_box(&boxes)
                .iter()
                .map(|x| black_box(&f).classify_aabb(x) as u32)
                .sum::<u32>()
        })
    });
    g.bench_function("sphere", |b| {
        b.iter(|| {
            black_box(&spheres)
                .iter()
                .map(|x| black_box(&f).classify_sphere(x) as u32)
                .sum::<u32>()
        })
    });
    g.finish();
}

fn bench_transform(c: &mut Criterion) {
    let mut rng = Rng::new(5);
    let cases: Vec<(Aabb, Affine3A)> = (0..BATCH)
        .map(|_| {
            let q = Quat::from_axis_angle(rng.unit_vector_f64().into(), rng.range(0.0, 6.3));
            let m = Affine3A::from_scale_rotation_translation(
                Vec3::splat(rng.range(0.5, 2.0)),
                q,
                rng.vec3a(-1e3, 1e3).into(),
            );
            (random_box(&mut rng), m)
        })
        .collect();
    let mut g = c.benchmark_group("aabb_transformed");
    g.throughput(Throughput::Elements(BATCH as u64));
    g.bench_function("affine", |b| {
        b.iter(|| {
            black_box(&cases)
                .iter()
                .fold(Vec3A::ZERO, |acc, (bx, m)| acc + bx.transformed(m).max)
        })
    });
    g.finish();
}

criterion_group!(
    benches,
    bench_ray_aabb,
    bench_ray_sphere,
    bench_ray_triangle,
    bench_frustum,
    bench_transform
);
criterion_main!(benches);
