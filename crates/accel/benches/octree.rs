//! The loose octree against the dynamic BVH on the dynamic workload at 100,000 boxes
//! (`common/dynamic_workload.rs`: centres uniform in [-200, 200]^3, half extents 0.1 to 1):
//!
//! - `frame_10pct_moved`: a frame in which a tenth of the boxes take a random step of up to
//!   one unit per axis (the same steps for every contender), then the per-frame upkeep. The
//!   dynamic BVH runs twice: with its configured `maintain` (refit, then its optimiser's
//!   budget) and with `DynamicIndex::maintain(Duration::ZERO)` (refit only).
//! - `frustum`: a camera frustum with about 5% of the boxes not outside; candidates that
//!   cross a plane get the exact box test.
//! - `box_query`: 1,000 query boxes of half size 5 at random places, exact box test.
//! - `rays`: 1,000 incoherent closest-hit rays, the slab test of each box in the callback.
//!
//! Before timing, every query's answer is checked to be the same on every contender, and the
//! octree's shape (octants, depth, memory, the moves that changed octant) is printed.
//!
//! Run: `cargo bench -p accel --bench octree -- --quick`

mod common;
#[path = "common/dynamic_workload.rs"]
mod dynamic_workload;
#[path = "common/index_contest.rs"]
mod index_contest;
use index_contest::{bench_dynamic_bvh_frames, box_hits, frames, frustum_ids, play, ray_hits};

use accel::octree::{LooseOctree, OctreeConfig, OctreeHandle};
use accel::{Aabb, Ray};
use accel_testkit::Rng;
use criterion::Criterion;
use glam::Vec3A;
use std::hint::black_box;

const N: usize = 100_000;

/// An octree over the workload's boxes, ids the indices.
fn octree(boxes: &[Aabb], looseness: f32) -> (LooseOctree, Vec<OctreeHandle>) {
    let mut tree =
        LooseOctree::with_config(OctreeConfig::default().with_looseness(looseness)).unwrap();
    let handles = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| tree.insert(i as u32, *b).unwrap())
        .collect();
    tree.maintain();
    (tree, handles)
}

fn frame_benches(c: &mut Criterion, boxes: &[Aabb]) {
    let frames = frames();
    let mut g = c.benchmark_group("octree_100k/frame_10pct_moved");
    for looseness in [2.0, 1.5] {
        let (mut tree, handles) = octree(boxes, looseness);
        let mut now = boxes.to_vec();
        let mut i = 0;
        g.bench_function(format!("loose_octree_k{looseness}"), |b| {
            b.iter(|| {
                play(&frames, i, &mut now, |j, bx| {
                    black_box(tree.update(handles[j], bx).unwrap());
                });
                i += 1;
                black_box(tree.maintain())
            })
        });
        tree.validate().unwrap();
    }
    bench_dynamic_bvh_frames(&mut g, boxes, &frames);
    g.finish();
}

fn query_benches(c: &mut Criterion, boxes: &[Aabb]) {
    let (frustum, visible) = common::frustum_selecting(boxes, 0.05);
    let mut rng = Rng::new(4);
    let queries: Vec<Aabb> = (0..1000)
        .map(|_| Aabb::from_center_half_extents(rng.vec3a(-200.0, 200.0), Vec3A::splat(5.0)))
        .collect();
    let rays: Vec<Ray> = common::incoherent_rays(1000, 200.0, 5)
        .into_iter()
        .map(|(o, d)| Ray::new(o, d))
        .collect();
    let (bvh, _) = dynamic_workload::built_tree(boxes);
    let octrees = [(2.0, octree(boxes, 2.0).0), (1.5, octree(boxes, 1.5).0)];
    let want = (
        frustum_ids(&bvh, boxes, &frustum),
        box_hits(&bvh, boxes, &queries),
        ray_hits(&bvh, boxes, &rays),
    );
    assert!(want.0.len() >= visible / 2, "the frustum sees the boxes");
    for (k, tree) in &octrees {
        assert_eq!(frustum_ids(tree, boxes, &frustum), want.0, "k={k}: frustum");
        assert_eq!(box_hits(tree, boxes, &queries), want.1, "k={k}: boxes");
        assert_eq!(ray_hits(tree, boxes, &rays), want.2, "k={k}: rays");
    }
    let mut g = c.benchmark_group("octree_100k/frustum");
    g.bench_function("dynamic_bvh", |b| {
        b.iter(|| black_box(frustum_ids(&bvh, boxes, &frustum)))
    });
    for (k, tree) in &octrees {
        g.bench_function(format!("loose_octree_k{k}"), |b| {
            b.iter(|| black_box(frustum_ids(tree, boxes, &frustum)))
        });
    }
    g.finish();
    let mut g = c.benchmark_group("octree_100k/box_query_1000");
    g.bench_function("dynamic_bvh", |b| {
        b.iter(|| black_box(box_hits(&bvh, boxes, &queries)))
    });
    for (k, tree) in &octrees {
        g.bench_function(format!("loose_octree_k{k}"), |b| {
            b.iter(|| black_box(box_hits(tree, boxes, &queries)))
        });
    }
    g.finish();
    let mut g = c.benchmark_group("octree_100k/rays_1000");
    g.bench_function("dynamic_bvh", |b| {
        b.iter(|| black_box(ray_hits(&bvh, boxes, &rays)))
    });
    for (k, tree) in &octrees {
        g.bench_function(format!("loose_octree_k{k}"), |b| {
            b.iter(|| black_box(ray_hits(tree, boxes, &rays)))
        });
    }
    g.finish();
}

/// Prints the octree's shape on the workload, to read the timings against: octants,
/// depth, memory, and how many of one frame's moves changed octant.
fn shape_report(boxes: &[Aabb]) {
    let frames = frames();
    for looseness in [2.0, 1.5] {
        let (mut tree, handles) = octree(boxes, looseness);
        let mut now = boxes.to_vec();
        let mut moved = 0;
        play(&frames, 0, &mut now, |j, bx| {
            moved += usize::from(tree.update(handles[j], bx).unwrap());
        });
        let refit = tree.maintain();
        println!(
            "loose octree k={looseness}: {} octants, depth {}, {:.1} MB; one frame moved {moved} \
             of {} entries to another octant and refit {refit} octants",
            tree.octant_count(),
            tree.depth(),
            tree.memory_bytes() as f64 / 1e6,
            frames[0].len(),
        );
    }
}

fn main() {
    let boxes = dynamic_workload::scene(N, 1);
    shape_report(&boxes);
    let mut c = Criterion::default().configure_from_args();
    frame_benches(&mut c, &boxes);
    query_benches(&mut c, &boxes);
    c.final_summary();
}
