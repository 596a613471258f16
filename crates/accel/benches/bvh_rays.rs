//! Queries, single-threaded, side by side with the peers on the same inputs:
//!
//! - `rays_1m_tris`: incoherent closest-hit rays (random origins in the scene cube, random
//!   directions) on the ~1M-triangle bunny scene, reported as rays per second on one core.
//!   Ours: `Bvh` over the triangle boxes, `SpatialQuery::cast_ray` with the watertight test in
//!   the callback (one `WatertightRay` precomputed per ray). obvhs BVH2 and CWBVH: their
//!   `ray_traverse` with their Möller-Trumbore test and triangles reordered to leaf order (their
//!   recommended use). `bvh` 0.13: `nearest_traverse_iterator` (ordered by box entry, stopped
//!   once a box starts beyond the best hit) with our watertight test, as it has no two-sided
//!   test. Before timing, every contender's closest-hit distance is checked against ours on a
//!   sample of rays: no comparison against wrong answers.
//! - `frustum_1m_boxes`: a camera frustum over 1M entity boxes with ~5% not outside, the tree's
//!   `for_each_in_frustum` (exact box test on leaves that cross a plane) against a flat loop of
//!   `Frustum::intersects_aabb`; both must find the same boxes.
//!
//! New layouts are one more entry in `ray_contenders` / `frustum_contenders`.
//!
//! Run: `cargo bench -p accel --bench bvh_rays -- --warm-up-time 1 --measurement-time 3`

mod common;

use accel::{
    Aabb, Backfaces, BuildConfig, Bvh, Containment, Frustum, Ray, SpatialQuery, SplitStrategy,
    Triangle, WatertightRay,
};
use accel_testkit::{TRI_EXTENT, entity_boxes, triangle_scene};
use common::peers::{self, BvhShape};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3A;
use obvhs::BvhBuildParams;
use std::hint::black_box;
use std::time::Duration;

const RAYS_PER_ITER: usize = 20_000;
const CHECKED_RAYS: usize = 4_000;

/// A closest-hit tracer: ray index to (triangle id, t). Each contender keeps its own
/// precomputed rays, built outside the timed loop.
type Trace<'a> = Box<dyn Fn(usize) -> Option<(u32, f32)> + 'a>;

struct RayContender<'a> {
    name: String,
    bytes: usize,
    trace: Trace<'a>,
}

fn accel_contender<'a>(
    name: &str,
    split: SplitStrategy,
    tris: &'a [Triangle],
    boxes: &[Aabb],
    rays: &[(Vec3A, Vec3A)],
) -> RayContender<'a> {
    let bvh = Bvh::build(boxes, &BuildConfig::with_split(split));
    let prepared: Vec<(Ray, WatertightRay)> = rays
        .iter()
        .map(|&(o, d)| {
            let r = Ray::new(o, d);
            (r, WatertightRay::new(&r))
        })
        .collect();
    RayContender {
        name: name.to_string(),
        bytes: bvh.memory_bytes(),
        trace: Box::new(move |i| {
            let (ray, wt) = &prepared[i];
            bvh.cast_ray(ray, |p, _| {
                wt.intersect(&tris[p as usize], Backfaces::Include)
                    .map(|h| h.t)
            })
            .map(|h| (h.primitive, h.t))
        }),
    }
}

fn ray_contenders<'a>(
    tris: &'a [Triangle],
    boxes: &[Aabb],
    rays: &[(Vec3A, Vec3A)],
) -> Vec<RayContender<'a>> {
    // Sweep SAH is left out: its tree costs within 0.5% of binned 16's (see bvh_build) and its
    // build takes ~10 s here.
    let mut c = vec![
        accel_contender(
            "accel binned16",
            SplitStrategy::BinnedSah { bins: 16 },
            tris,
            boxes,
            rays,
        ),
        accel_contender("accel median", SplitStrategy::Median, tris, boxes, rays),
        accel_contender(
            "accel ploc fastest",
            SplitStrategy::PLOC_FASTEST,
            tris,
            boxes,
            rays,
        ),
        accel_contender("accel ploc", SplitStrategy::PLOC, tris, boxes, rays),
    ];

    // The wide layouts over the same binned-16 tree (2-, 4- and 8-wide side by side).
    let bvh = Bvh::build(boxes, &BuildConfig::default());
    let prepared: std::rc::Rc<Vec<(Ray, WatertightRay)>> = std::rc::Rc::new(
        rays.iter()
            .map(|&(o, d)| {
                let r = Ray::new(o, d);
                (r, WatertightRay::new(&r))
            })
            .collect(),
    );
    let bvh4 = accel::bvh::wide::Bvh4::from_bvh(&bvh);
    let p4 = prepared.clone();
    c.push(RayContender {
        name: "accel binned16 4-wide".into(),
        bytes: bvh4.memory_bytes(),
        trace: Box::new(move |i| {
            let (ray, wt) = &p4[i];
            bvh4.cast_ray(ray, |p, _| {
                wt.intersect(&tris[p as usize], Backfaces::Include)
                    .map(|h| h.t)
            })
            .map(|h| (h.primitive, h.t))
        }),
    });
    let bvh8 = accel::bvh::wide::Bvh8::from_bvh(&bvh);
    let p8 = prepared.clone();
    c.push(RayContender {
        name: "accel binned16 8-wide".into(),
        bytes: bvh8.memory_bytes(),
        trace: Box::new(move |i| {
            let (ray, wt) = &p8[i];
            bvh8.cast_ray(ray, |p, _| {
                wt.intersect(&tris[p as usize], Backfaces::Include)
                    .map(|h| h.t)
            })
            .map(|h| (h.primitive, h.t))
        }),
    });
    // The mesh BVH: 8-wide with triangles copied into leaf order (what picking and the
    // preview use).
    let vertices: Vec<glam::Vec3> = tris
        .iter()
        .flat_map(|t| t.vertices.map(glam::Vec3::from))
        .collect();
    let indices: Vec<u32> = (0..vertices.len() as u32).collect();
    let mesh = accel::mesh::MeshBvh::new(&vertices, &indices).expect("a triangle list");
    let pm = prepared.clone();
    c.push(RayContender {
        name: "accel MeshBvh (8-wide, leaf-ordered)".into(),
        bytes: mesh.memory_bytes(),
        trace: Box::new(move |i| {
            mesh.cast_ray(&pm[i].0, Backfaces::Include)
                .map(|h| (h.triangle, h.t))
        }),
    });

    // Ours with obvhs' triangle test, to separate the tree from the triangle test.
    let bvh = Bvh::build(boxes, &BuildConfig::default());
    let ot: Vec<obvhs::triangle::Triangle> = tris.iter().map(peers::to_obvhs_tri).collect();
    let prepared: Vec<(Ray, obvhs::ray::Ray)> = rays
        .iter()
        .map(|&(o, d)| (Ray::new(o, d), obvhs::ray::Ray::new_inf(o, d)))
        .collect();
    c.push(RayContender {
        name: "accel binned16 + obvhs tri test".into(),
        bytes: bvh.memory_bytes(),
        trace: Box::new(move |i| {
            let (ray, oray) = &prepared[i];
            bvh.cast_ray(ray, |p, _| {
                let t = ot[p as usize].intersect(oray);
                t.is_finite().then_some(t)
            })
            .map(|h| (h.primitive, h.t))
        }),
    });

    let ot: Vec<obvhs::triangle::Triangle> = tris.iter().map(peers::to_obvhs_tri).collect();
    let orays: Vec<obvhs::ray::Ray> = rays
        .iter()
        .map(|&(o, d)| obvhs::ray::Ray::new_inf(o, d))
        .collect();
    let orays = std::rc::Rc::new(orays);
    for (preset, params) in [
        ("fast", BvhBuildParams::fast_build()),
        ("medium", BvhBuildParams::medium_build()),
    ] {
        let b2 = obvhs::bvh2::builder::build_bvh2_from_tris(&ot, params, &mut Duration::default());
        let leaf_tris: Vec<_> = b2
            .primitive_indices
            .iter()
            .map(|&p| ot[p as usize])
            .collect();
        let r = orays.clone();
        c.push(RayContender {
            name: format!("obvhs bvh2 {preset}"),
            bytes: peers::obvhs_bvh2_bytes(&b2),
            trace: Box::new(move |i| {
                let mut hit = obvhs::ray::RayHit::none();
                b2.ray_traverse(r[i], &mut hit, |ray, id| leaf_tris[id].intersect(ray))
                    .then(|| (b2.primitive_indices[hit.primitive_id as usize], hit.t))
            }),
        });
        let cw =
            obvhs::cwbvh::builder::build_cwbvh_from_tris(&ot, params, &mut Duration::default());
        let leaf_tris: Vec<_> = cw
            .primitive_indices
            .iter()
            .map(|&p| ot[p as usize])
            .collect();
        let r = orays.clone();
        c.push(RayContender {
            name: format!("obvhs cwbvh {preset}"),
            bytes: peers::obvhs_cwbvh_bytes(&cw),
            trace: Box::new(move |i| {
                let mut hit = obvhs::ray::RayHit::none();
                cw.ray_traverse(r[i], &mut hit, |ray, id| leaf_tris[id].intersect(ray))
                    .then(|| (cw.primitive_indices[hit.primitive_id as usize], hit.t))
            }),
        });
    }

    let mut shapes: Vec<BvhShape> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| BvhShape::new(i, b))
        .collect();
    let tree = bvh::bvh::Bvh::build(&mut shapes);
    let prepared: Vec<(Ray, WatertightRay, bvh::ray::Ray<f32, 3>)> = rays
        .iter()
        .map(|&(o, d)| {
            let r = Ray::new(o, d);
            let b = bvh::ray::Ray::new(
                nalgebra::Point3::new(o.x, o.y, o.z),
                nalgebra::Vector3::new(d.x, d.y, d.z),
            );
            (r, WatertightRay::new(&r), b)
        })
        .collect();
    let boxes = boxes.to_vec();
    c.push(RayContender {
        name: "bvh 0.13 (+ watertight test)".into(),
        bytes: peers::bvh_crate_bytes(&tree),
        trace: Box::new(move |i| {
            let (ray, wt, bray) = &prepared[i];
            let mut best: Option<(u32, f32)> = None;
            for s in tree.nearest_traverse_iterator(bray, &shapes) {
                // Leaves come in order of box entry: none after this one can be closer.
                let t_best = best.map_or(f32::INFINITY, |b| b.1);
                match ray.intersect_aabb(&boxes[s.id as usize]) {
                    None => continue,
                    Some(entry) if entry > t_best => break,
                    Some(_) => {}
                }
                if let Some(h) = wt.intersect(&tris[s.id as usize], Backfaces::Include)
                    && h.t < t_best
                {
                    best = Some((s.id, h.t));
                }
            }
            best
        }),
    });
    c
}

/// Every contender must find the same closest distance as the first (ours) on a sample.
fn check_rays(contenders: &[RayContender<'_>], n: usize) {
    let reference = &contenders[0];
    let hits = (0..n).filter(|&i| (reference.trace)(i).is_some()).count();
    println!(
        "\nray check: {hits}/{n} rays hit ({:.1}%); checking every contender against `{}`",
        100.0 * hits as f64 / n as f64,
        reference.name
    );
    for c in &contenders[1..] {
        let bad: Vec<usize> = (0..n)
            .filter(|&i| match ((reference.trace)(i), (c.trace)(i)) {
                (None, None) => false,
                // Relative 1e-4, with distances under one unit (the scene is 200 across)
                // held to 1e-4 absolute: Möller-Trumbore loses relative precision as t -> 0.
                (Some((_, a)), Some((_, b))) => {
                    (a - b).abs() > 1e-4 * a.abs().max(b.abs()).max(1.0)
                }
                _ => true,
            })
            .collect();
        assert!(
            bad.is_empty(),
            "{} disagrees with {} on {} of {n} rays, e.g. ray {}: {:?} vs {:?}",
            c.name,
            reference.name,
            bad.len(),
            bad[0],
            (reference.trace)(bad[0]),
            (c.trace)(bad[0])
        );
    }
    println!("ray check passed: every contender finds the same closest t");
}

/// A frustum query: the ids of the boxes not outside.
type Cull<'a> = Box<dyn Fn(&Frustum) -> Vec<u32> + 'a>;

fn frustum_contenders(boxes: &[Aabb]) -> Vec<(String, Cull<'_>)> {
    let mut c: Vec<(String, Cull<'_>)> = vec![(
        "flat loop".into(),
        Box::new(move |f: &Frustum| {
            (0..boxes.len() as u32)
                .filter(|&i| f.intersects_aabb(&boxes[i as usize]))
                .collect()
        }),
    )];
    for (name, split) in [
        ("accel binned16", SplitStrategy::BinnedSah { bins: 16 }),
        ("accel median", SplitStrategy::Median),
    ] {
        let bvh = Bvh::build(boxes, &BuildConfig::with_split(split));
        c.push((
            name.into(),
            Box::new(move |f: &Frustum| {
                let mut out = Vec::new();
                bvh.for_each_in_frustum(f, |p, how| {
                    if how == Containment::Inside || f.intersects_aabb(&boxes[p as usize]) {
                        out.push(p);
                    }
                });
                out
            }),
        ));
    }
    c
}

fn queries(c: &mut Criterion) {
    let tris = triangle_scene(1_000_000, 2);
    let boxes: Vec<Aabb> = tris.iter().map(Triangle::aabb).collect();
    let rays = common::incoherent_rays(RAYS_PER_ITER, TRI_EXTENT, 3);
    let contenders = ray_contenders(&tris, &boxes, &rays);
    check_rays(&contenders, CHECKED_RAYS);
    println!("| contender | bytes/tri |\n|---|---:|");
    for con in &contenders {
        println!(
            "| {} | {:.1} |",
            con.name,
            con.bytes as f64 / tris.len() as f64
        );
    }
    let mut g = c.benchmark_group("rays_1m_tris");
    g.throughput(Throughput::Elements(RAYS_PER_ITER as u64));
    g.sample_size(10);
    for con in &contenders {
        g.bench_function(&con.name, |b| {
            b.iter(|| {
                (0..RAYS_PER_ITER)
                    .filter(|&i| (con.trace)(i).is_some())
                    .count()
            })
        });
    }
    g.finish();
    drop(contenders);

    let boxes = entity_boxes(1_000_000, 4);
    let (frustum, visible) = common::frustum_selecting(&boxes, 0.05);
    println!(
        "\nfrustum: {visible} of {} boxes not outside ({:.2}%)",
        boxes.len(),
        100.0 * visible as f64 / boxes.len() as f64
    );
    let culls = frustum_contenders(&boxes);
    let mut expected = (culls[0].1)(&frustum);
    expected.sort_unstable();
    for (name, cull) in &culls[1..] {
        let mut got = cull(&frustum);
        got.sort_unstable();
        assert_eq!(got, expected, "{name} disagrees with the flat loop");
    }
    let mut g = c.benchmark_group("frustum_1m_boxes");
    for (name, cull) in &culls {
        g.bench_function(name, |b| {
            b.iter(|| black_box(cull(black_box(&frustum))).len())
        });
    }
    g.finish();
}

criterion_group!(benches, queries);
criterion_main!(benches);
