//! What the octree and grid benches share: the moving frames they play on the dynamic
//! workload (a tenth of the boxes moved per frame by a random step of up to a unit per
//! axis), the dynamic BVH as the contender they are measured against, and the queries whose
//! answers they check against it.

use super::dynamic_workload;
use accel::query::DynamicIndex;
use accel::{Aabb, Containment, Frustum, Ray, SpatialQuery};
use accel_testkit::Rng;
use core::ops::ControlFlow;
use criterion::BenchmarkGroup;
use criterion::measurement::WallTime;
use glam::Vec3A;
use std::hint::black_box;
use std::time::Duration;

/// Distinct frames of moves; played forward, then backward with the steps negated, so the
/// boxes oscillate about where they started instead of drifting.
pub const FRAMES: usize = 8;

/// Boxes in the workload the frames move.
const N: usize = 100_000;

/// The moves of each frame: a tenth of the boxes, each with its step.
pub fn frames() -> Vec<Vec<(usize, Vec3A)>> {
    let mut rng = Rng::new(2);
    (0..FRAMES)
        .map(|_| {
            (0..N / 10)
                .map(|_| (rng.below(N), rng.vec3a(-1.0, 1.0)))
                .collect()
        })
        .collect()
}

/// Plays frame `i` of `frames` on `boxes`, calling `update` for each moved box.
pub fn play(
    frames: &[Vec<(usize, Vec3A)>],
    i: usize,
    boxes: &mut [Aabb],
    mut update: impl FnMut(usize, Aabb),
) {
    let sign = if (i / FRAMES).is_multiple_of(2) {
        1.0
    } else {
        -1.0
    };
    for &(b, step) in &frames[i % FRAMES] {
        let d = step * sign;
        boxes[b] = Aabb::new(boxes[b].min + d, boxes[b].max + d);
        update(b, boxes[b]);
    }
}

/// The dynamic BVH playing the frames: its configured `maintain` (refit, optimiser,
/// rebuilds) and its refit alone.
pub fn bench_dynamic_bvh_frames(
    g: &mut BenchmarkGroup<'_, WallTime>,
    boxes: &[Aabb],
    frames: &[Vec<(usize, Vec3A)>],
) {
    for refit_only in [false, true] {
        let (mut tree, handles) = dynamic_workload::built_tree(boxes);
        let mut now = boxes.to_vec();
        let mut i = 0;
        let name = if refit_only {
            "dynamic_bvh_refit_only"
        } else {
            "dynamic_bvh_maintain"
        };
        g.bench_function(name, |b| {
            b.iter(|| {
                play(frames, i, &mut now, |j, bx| {
                    black_box(tree.update(handles[j], bx).unwrap());
                });
                i += 1;
                if refit_only {
                    black_box(DynamicIndex::maintain(&mut tree, Duration::ZERO).refit_nodes)
                } else {
                    black_box(tree.maintain().refit_nodes)
                }
            })
        });
        if !refit_only {
            println!("dynamic_bvh: {} MiB", tree.memory_bytes() >> 20);
        }
    }
}

/// The ids a frustum query keeps after the exact test, sorted.
pub fn frustum_ids<S: SpatialQuery>(index: &S, boxes: &[Aabb], frustum: &Frustum) -> Vec<u32> {
    let mut ids = Vec::new();
    index.for_each_in_frustum(frustum, |id, c| {
        if c == Containment::Inside || frustum.intersects_aabb(&boxes[id as usize]) {
            ids.push(id);
        }
    });
    ids.sort_unstable();
    ids
}

/// How many boxes overlap each query box, summed.
pub fn box_hits<S: SpatialQuery>(index: &S, boxes: &[Aabb], queries: &[Aabb]) -> usize {
    let mut hits = 0;
    for q in queries {
        index.for_each_overlapping_aabb(q, |id| {
            hits += usize::from(boxes[id as usize].intersects_aabb(q));
            ControlFlow::Continue(())
        });
    }
    hits
}

/// The closest hit distance of each ray.
pub fn ray_hits<S: SpatialQuery>(index: &S, boxes: &[Aabb], rays: &[Ray]) -> Vec<Option<f32>> {
    rays.iter()
        .map(|r| {
            index
                .cast_ray(r, |id, r| r.intersect_aabb(&boxes[id as usize]))
                .map(|h| h.t)
        })
        .collect()
}
