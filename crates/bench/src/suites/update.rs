//! Upkeep time under a moving workload against the quality it loses: the dynamic BVH with
//! refits only, with rotations, with the optimiser's reinsertions, rebuilt every frame; the
//! loose octree and the uniform grid. Each frame a tenth of the entries take a step of up to
//! 1% of the world; after the frames, the structure's ray time (and for the dynamic BVH its
//! SAH cost) is set against a fresh build of the same kind over the same boxes.
//!
//! Two parts of their own follow: the dynamic BVH at full size against obvhs ([`dynamic`],
//! BENCHMARKS.md's "Dynamic BVH") and a two-level scene's instance updates against a new
//! scene each frame ([`instances`], the instance rows of "Mesh builds and instanced scenes").

mod dynamic;
mod instances;

use super::{incoherent_rays, point};
use crate::json::{Point, Report};
use crate::progress::Progress;
use crate::timing::per_item;
use accel_testkit::{Rng, random_box};
use spatial_accel::query::DynamicIndex;
use spatial_accel::{
    Aabb, DynamicBvh, DynamicBvhConfig, LooseOctree, Ray, SahCosts, SpatialQuery, UniformGrid,
};
use std::time::{Duration, Instant};

const EXTENT: f32 = 500.0;

/// One frame's moves: `(entry, new box)`.
fn frames(boxes: &[Aabb], frames: usize, seed: u64) -> Vec<Vec<(usize, Aabb)>> {
    let mut rng = Rng::new(seed);
    let mut now = boxes.to_vec();
    (0..frames)
        .map(|_| {
            (0..now.len() / 10)
                .map(|_| {
                    let i = rng.below(now.len());
                    let step = rng.vec3a(-1.0, 1.0) * (EXTENT * 0.02);
                    now[i] = Aabb::new(now[i].min + step, now[i].max + step);
                    (i, now[i])
                })
                .collect()
        })
        .collect()
}

/// Seconds per closest-hit ray.
fn ray_time<T: SpatialQuery>(t: &T, boxes: &[Aabb], rays: &[Ray]) -> f64 {
    per_item(3, rays.len(), |i| {
        t.cast_ray(&rays[i], |p, r| r.intersect_aabb(&boxes[p as usize]))
    })
}

/// Runs the workload on a fresh `make()`, with `after_frame` run after each frame's
/// `maintain`; returns seconds per frame, the final index, and the final boxes.
fn drive<I: DynamicIndex>(
    make: &dyn Fn() -> I,
    start: &[Aabb],
    moves: &[Vec<(usize, Aabb)>],
    budget: Duration,
    after_frame: &dyn Fn(&mut I),
) -> (f64, I, Vec<Aabb>) {
    let mut index = make();
    let handles: Vec<I::Handle> = start
        .iter()
        .enumerate()
        .map(|(i, &b)| index.insert(i as u32, b).expect("a valid box"))
        .collect();
    index.maintain(Duration::ZERO);
    let mut boxes = start.to_vec();
    let t = Instant::now();
    for frame in moves {
        for &(i, b) in frame {
            let _ = index.update(handles[i], b);
            boxes[i] = b;
        }
        index.maintain(budget);
        after_frame(&mut index);
    }
    (
        t.elapsed().as_secs_f64() / moves.len().max(1) as f64,
        index,
        boxes,
    )
}

/// The points of one method: time per frame against ray time relative to a fresh build.
#[expect(
    clippy::too_many_arguments,
    reason = "one call per method, all of it its setting"
)]
fn measure<I: DynamicIndex>(
    out: &mut Vec<Point>,
    scene: &str,
    (method, setting): (&str, &str),
    make: &dyn Fn() -> I,
    start: &[Aabb],
    moves: &[Vec<(usize, Aabb)>],
    budget: Duration,
    after_frame: &dyn Fn(&mut I),
    rays: &[Ray],
) -> (I, Vec<Aabb>) {
    let (per_frame, index, boxes) = drive(make, start, moves, budget, after_frame);
    let mut fresh = make();
    for (i, &b) in boxes.iter().enumerate() {
        fresh.insert(i as u32, b).expect("a valid box");
    }
    fresh.maintain(Duration::ZERO);
    let ratio = ray_time(&index, &boxes, rays) / ray_time(&fresh, &boxes, rays);
    out.push(point(
        scene,
        method,
        setting,
        ("ms per frame", per_frame * 1e3),
        ("ray time / fresh build", Some(ratio)),
    ));
    (index, boxes)
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let (n, frame_count) = if quick { (4_000, 20) } else { (50_000, 100) };
    let mut rng = Rng::new(0xd1);
    let start: Vec<Aabb> = (0..n)
        .map(|_| random_box(&mut rng, EXTENT, 0.5..3.0))
        .collect();
    let moves = frames(&start, frame_count, 0xd2);
    let rays = incoherent_rays(if quick { 1_000 } else { 10_000 }, EXTENT, 0xd3);
    let scene = format!("{n} boxes, 10% moving");
    let mut points = Vec::new();
    let mut progress = Progress::new("update", 8);
    let dynamic = |config: DynamicBvhConfig| move || DynamicBvh::with_config(config);
    let base = DynamicBvhConfig::default();
    let methods: [(&str, &str, DynamicBvhConfig, Duration, bool); 5] = [
        (
            "DynamicBvh",
            "refit only",
            DynamicBvhConfig {
                rotations: false,
                optimize_max_reinsertions: 0,
                rebuild_threshold: f32::INFINITY,
                ..base
            },
            Duration::ZERO,
            false,
        ),
        (
            "DynamicBvh",
            "rotations",
            DynamicBvhConfig {
                rebuild_threshold: f32::INFINITY,
                ..base
            },
            Duration::ZERO,
            false,
        ),
        (
            "DynamicBvh",
            "reinsertion 0.2 ms",
            DynamicBvhConfig {
                optimize_budget: Duration::from_micros(200),
                rebuild_threshold: f32::INFINITY,
                ..base
            },
            Duration::from_micros(200),
            false,
        ),
        (
            "DynamicBvh",
            "default (rebuilds)",
            base,
            Duration::from_micros(200),
            false,
        ),
        (
            "DynamicBvh",
            "rebuild every frame",
            base,
            Duration::ZERO,
            true,
        ),
    ];
    for (method, setting, config, budget, rebuild) in methods {
        progress.step(setting);
        let after: &dyn Fn(&mut DynamicBvh) = if rebuild { &|t| t.rebuild() } else { &|_| {} };
        let (tree, boxes) = measure(
            &mut points,
            &scene,
            (method, setting),
            &dynamic(config),
            &start,
            &moves,
            budget,
            after,
            &rays,
        );
        let mut fresh = DynamicBvh::with_config(config);
        for (i, &b) in boxes.iter().enumerate() {
            fresh.insert(i as u32, b).expect("a valid box");
        }
        fresh.rebuild();
        let sah =
            tree.stats(&SahCosts::default()).sah_cost / fresh.stats(&SahCosts::default()).sah_cost;
        let frame_ms = points.last().map_or(0.0, |p| p.time);
        points.push(point(
            &scene,
            method,
            setting,
            ("ms per frame", frame_ms),
            ("SAH cost / fresh build", Some(sah as f64)),
        ));
    }
    progress.step("octree");
    measure(
        &mut points,
        &scene,
        ("LooseOctree", "default"),
        &LooseOctree::new,
        &start,
        &moves,
        Duration::ZERO,
        &|_| {},
        &rays,
    );
    progress.step("grid");
    measure(
        &mut points,
        &scene,
        ("UniformGrid", "default"),
        &UniformGrid::new,
        &start,
        &moves,
        Duration::ZERO,
        &|_| {},
        &rays,
    );
    progress.step("done");
    progress.finish();
    let mut report = Report {
        suite: "update".into(),
        quick,
        points,
        ..Report::default()
    };
    dynamic::run(quick, &mut report);
    instances::run(quick, &mut report);
    report
}
