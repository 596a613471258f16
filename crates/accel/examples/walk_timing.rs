//! Prints what the shared walks cost on entity boxes: closest-hit rays, frustum, views, box
//! overlap and k nearest, through the static binary tree, the dynamic tree, the 8-wide tree
//! and the sphere tree. Every query but the wide tree's rays runs the code of
//! `accel::query::walks`; comparing builds before and after a change to it (alternated) is
//! what this is for. Median of 7 rounds, nanoseconds per query.
//! `cargo run --release -p accel --example walk_timing -- 100000`.

use accel::bvh::SphereBvh;
use accel::bvh::wide::Bvh8;
use accel::query::views::ViewClassification;
use accel::{
    Aabb, BuildConfig, Bvh, Containment, DynamicBvh, Frustum, Ray, SpatialQuery, SplitStrategy,
};
use core::ops::ControlFlow;
use glam::{Mat4, Vec3, Vec3A};
use std::hint::black_box;
use std::time::Instant;

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(100_000);
    // A fixed stream of floats in [0, 1) (a 64-bit LCG's high bits), so that the scene is the
    // same in every build compared.
    let mut state = 0x853c_49e6_748f_ea9bu64;
    let mut next = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let half = (n as f32 * 64.0).cbrt() / 2.0;
    let mut point = || (Vec3A::new(next(), next(), next()) * 2.0 - 1.0) * half;
    let boxes: Vec<Aabb> = (0..n)
        .map(|_| Aabb::from_center_half_extents(point(), Vec3A::splat(1.5)))
        .collect();
    let rays: Vec<Ray> = (0..4096)
        .map(|_| Ray::new(point(), (point() - point()).normalize_or(Vec3A::X)))
        .collect();
    let centers: Vec<Vec3A> = (0..1024).map(|_| point()).collect();
    let frusta: Vec<Frustum> = (0..64)
        .map(|i| {
            let eye = Vec3::from(centers[i]);
            let view = Mat4::look_at_rh(eye, Vec3::from(centers[i + 64]), Vec3::Y);
            let proj = Mat4::perspective_rh(0.6, 1.5, 0.1, half * 0.5);
            Frustum::from_clip_from_world(&(proj * view))
        })
        .collect();

    let config = BuildConfig {
        split: SplitStrategy::PLOC_FASTEST,
        max_leaf_size: 4,
        ..BuildConfig::default()
    };
    let bvh = Bvh::build(&boxes, &config);
    let wide = Bvh8::from_bvh(&bvh);
    let spheres = SphereBvh::from_bvh(&bvh, &boxes);
    let mut dynamic = DynamicBvh::new();
    for (i, b) in boxes.iter().enumerate() {
        dynamic.insert(i as u32, *b).unwrap();
    }
    dynamic.maintain();

    println!("{n} entity boxes; ns per query, median of 7 rounds");
    println!(
        "{:<10} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "tree", "rays", "frustum", "views", "boxes", "knn"
    );
    report("Bvh", &bvh, &boxes, &rays, &frusta, &centers);
    report("Dynamic", &dynamic, &boxes, &rays, &frusta, &centers);
    report("Bvh8", &wide, &boxes, &rays, &frusta, &centers);
    report("SphereBvh", &spheres, &boxes, &rays, &frusta, &centers);
}

fn report<T: SpatialQuery>(
    name: &str,
    tree: &T,
    boxes: &[Aabb],
    rays: &[Ray],
    frusta: &[Frustum],
    centers: &[Vec3A],
) {
    let rays_ns = median_ns(rays.len(), || {
        for ray in rays {
            black_box(tree.cast_ray(ray, |i, r| r.intersect_aabb(&boxes[i as usize])));
        }
    });
    let frustum_ns = median_ns(frusta.len(), || {
        for f in frusta {
            let mut seen = 0usize;
            tree.for_each_in_frustum(f, |i, c| {
                if c == Containment::Inside || f.intersects_aabb(&boxes[i as usize]) {
                    seen += 1;
                }
            });
            black_box(seen);
        }
    });
    // Six views at once, as a point light's cube faces are walked.
    let views_ns = median_ns(frusta.len() / 6, || {
        for six in frusta.chunks_exact(6) {
            let classify = |b: &Aabb, undecided: u32| {
                let mut c = ViewClassification::default();
                for (v, f) in six
                    .iter()
                    .enumerate()
                    .filter(|(v, _)| undecided & (1 << v) != 0)
                {
                    match f.classify_aabb(b) {
                        Containment::Inside => c.inside |= 1 << v,
                        Containment::Outside => c.outside |= 1 << v,
                        Containment::Intersecting => {}
                    }
                }
                c
            };
            let mut seen = 0usize;
            tree.for_each_in_views(0b11_1111, classify, |_, m| {
                seen += m.inside.count_ones() as usize
            });
            black_box(seen);
        }
    });
    let boxes_ns = median_ns(centers.len(), || {
        for c in centers {
            let q = Aabb::from_center_half_extents(*c, Vec3A::splat(8.0));
            let mut seen = 0usize;
            tree.for_each_overlapping_aabb(&q, |i| {
                seen += usize::from(boxes[i as usize].intersects_aabb(&q));
                ControlFlow::Continue(())
            });
            black_box(seen);
        }
    });
    let knn_ns = median_ns(centers.len(), || {
        for c in centers {
            black_box(tree.nearest_k(*c, 8, |i| boxes[i as usize].distance_squared_to_point(*c)));
        }
    });
    println!(
        "{name:<10} {rays_ns:>9.0} {frustum_ns:>9.0} {views_ns:>9.0} {boxes_ns:>9.0} {knn_ns:>9.0}"
    );
}

/// The median over 7 rounds of one round's time per query.
fn median_ns(queries: usize, mut round: impl FnMut()) -> f64 {
    round();
    let mut times: Vec<f64> = (0..7)
        .map(|_| {
            let start = Instant::now();
            round();
            start.elapsed().as_nanos() as f64 / queries as f64
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[3]
}
