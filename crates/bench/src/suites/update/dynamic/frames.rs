//! Busy frames of the dynamic BVH: each frame a tenth of the leaves, chosen at random, take a
//! random step of up to 1 unit per axis, then the tree is maintained. Ours with its default
//! `maintain` (refit, optimiser within its budget, rebuild when the quality estimate says so)
//! and with refits only; obvhs's `Bvh2` with `resize_node` per moved leaf. Each is timed per
//! frame and rated afterwards by its SAH cost over a fresh build's. Then the empty frame (a
//! `maintain` with nothing moved) and the 8-wide copy of the tree that rays walk
//! (`StaticDynamicPair`'s ray snapshot, in the caller's thread and in the background).

use super::{Row, Section, built_tree, fig, to_obvhs};
use crate::suites::common::peers::ObvhsBvh2;
use crate::suites::{incoherent_rays, point};
use crate::timing::median;
use accel_testkit::Rng;
use glam::Vec3A;
use obvhs::bvh2::Bvh2;
use obvhs::faststack::HeapStack;
use spatial_accel::bvh::stats::tree_stats;
use spatial_accel::dynamic::StaticDynamicPair;
use spatial_accel::query::BruteForceIndex;
use spatial_accel::{
    Aabb, BuildConfig, Bvh, DynamicBvh, DynamicBvhConfig, SpatialQuery, SplitStrategy,
};
use std::time::Instant;

/// The moves of one frame, `(leaf, step)`, the same for every method (one seed).
struct Walk {
    rng: Rng,
    moves: Vec<(usize, Vec3A)>,
}

impl Walk {
    fn new() -> Self {
        Self {
            rng: Rng::new(2),
            moves: Vec::new(),
        }
    }

    /// Draws the next frame's moves over `n` leaves (before the frame's clock starts).
    fn next(&mut self, n: usize) -> &[(usize, Vec3A)] {
        self.moves.clear();
        for _ in 0..n / 10 {
            self.moves
                .push((self.rng.below(n), self.rng.vec3a(-1.0, 1.0)));
        }
        &self.moves
    }
}

/// What a run of frames of our tree measured.
struct Frames {
    /// Mean ms per frame, moves and maintenance.
    mean_ms: f64,
    /// Medians, ms: the moves' `update`s, the `maintain`.
    update_ms: f64,
    maintain_ms: f64,
    /// The optimiser's ms per frame, mean and max.
    optimize_mean_ms: f64,
    optimize_max_ms: f64,
    /// Frames that rebuilt.
    rebuilds: usize,
    /// The tree and its boxes after the frames.
    tree: DynamicBvh,
    boxes: Vec<Aabb>,
}

/// `frame_count` frames of our tree under `config`.
fn ours(boxes: &[Aabb], frame_count: usize, config: DynamicBvhConfig) -> Frames {
    let (mut tree, handles) = built_tree(boxes);
    tree.set_config(config);
    let mut now = boxes.to_vec();
    let mut walk = Walk::new();
    let (mut updates, mut maintains) = (Vec::new(), Vec::new());
    let (mut opt_total, mut opt_max, mut rebuilds) = (0.0f64, 0.0f64, 0);
    for _ in 0..frame_count {
        let moves = walk.next(now.len());
        let start = Instant::now();
        for &(i, d) in moves {
            now[i] = Aabb::new(now[i].min + d, now[i].max + d);
            tree.update(handles[i], now[i]).expect("a live handle");
        }
        updates.push(start.elapsed().as_secs_f64() * 1e3);
        let start = Instant::now();
        let report = tree.maintain();
        maintains.push(start.elapsed().as_secs_f64() * 1e3);
        let opt = report.optimize.elapsed.as_secs_f64() * 1e3;
        opt_total += opt;
        opt_max = opt_max.max(opt);
        rebuilds += usize::from(report.rebuilt);
    }
    let frames = frame_count.max(1) as f64;
    let total: f64 = updates.iter().chain(&maintains).sum();
    Frames {
        mean_ms: total / frames,
        update_ms: median(updates),
        maintain_ms: median(maintains),
        optimize_mean_ms: opt_total / frames,
        optimize_max_ms: opt_max,
        rebuilds,
        tree,
        boxes: now,
    }
}

/// The same frames of obvhs's tree, `resize_node` per moved leaf: mean ms per frame, the tree
/// and its boxes after them.
fn obvhs_frames(boxes: &[Aabb], frame_count: usize) -> (f64, Bvh2, Vec<Aabb>) {
    let mut ob = Bvh2::default();
    let mut stack = HeapStack::new_with_capacity(1000);
    for (i, b) in boxes.iter().enumerate() {
        ob.insert_primitive(to_obvhs(b), i as u32, &mut stack);
    }
    let mut now = boxes.to_vec();
    let mut walk = Walk::new();
    let mut total = 0.0;
    for _ in 0..frame_count {
        let moves = walk.next(now.len());
        let start = Instant::now();
        for &(i, d) in moves {
            now[i] = Aabb::new(now[i].min + d, now[i].max + d);
            let node = ob.primitives_to_nodes[i] as usize;
            ob.resize_node(node, to_obvhs(&now[i]));
        }
        total += start.elapsed().as_secs_f64() * 1e3;
    }
    (total / frame_count.max(1) as f64, ob, now)
}

/// The SAH cost of a fresh binned build over `boxes`, one box a leaf: the yardstick both
/// trees' costs are divided by (our tree's own fresh-build estimate, over its fat boxes, is
/// reported beside it).
fn fresh_tight_cost(boxes: &[Aabb], tree: &DynamicBvh) -> f64 {
    let config = BuildConfig {
        max_leaf_size: 1,
        sah_termination: false,
        ..BuildConfig::default()
    };
    Bvh::build(boxes, &config)
        .stats(&tree.config().sah)
        .sah_cost as f64
}

/// Closest hits through `tree` against a scan of `boxes`: the messages of the rays whose hit
/// distance differs.
fn check_rays(tree: &DynamicBvh, boxes: &[Aabb]) -> (u64, Vec<String>) {
    let brute = BruteForceIndex::from_boxes(boxes);
    let rays = incoherent_rays(256, 200.0, 0xd7);
    let mut wrong = Vec::new();
    for (k, ray) in rays.iter().enumerate() {
        let ours = tree.cast_ray(ray, |i, r| r.intersect_aabb(&boxes[i as usize]));
        let truth = brute.cast_ray(ray, |i, r| r.intersect_aabb(&boxes[i as usize]));
        if ours.map(|h| h.t) != truth.map(|h| h.t) {
            wrong.push(format!(
                "dynamic BVH after the frames, ray {k}: hit {ours:?}, a scan finds {truth:?}"
            ));
        }
    }
    (rays.len() as u64, wrong)
}

/// Seconds of `maintain` with nothing moved, the median of many calls.
fn empty_maintain_ns(tree: &mut DynamicBvh) -> f64 {
    // The first calls after the frames may still refit or optimise.
    for _ in 0..4 {
        tree.maintain();
    }
    let times: Vec<f64> = (0..1000)
        .map(|_| {
            let start = Instant::now();
            std::hint::black_box(tree.maintain());
            start.elapsed().as_secs_f64() * 1e9
        })
        .collect();
    median(times)
}

/// The ray snapshot of a tree over `boxes`: in the caller's thread, then started there and
/// installed from a background thread; medians of `rounds`, ms.
fn snapshot(s: &mut Section, boxes: &[Aabb], rounds: usize) {
    let config = BuildConfig::with_split(SplitStrategy::PLOC_FASTEST);
    let (tree, _) = built_tree(boxes);
    let mut pair = StaticDynamicPair::new(Bvh::default(), tree);
    let mut inline = Vec::new();
    for _ in 0..rounds {
        // Marks the dynamic tree changed, so that a snapshot is due.
        pair.dynamic_mut();
        let start = Instant::now();
        let made = pair.snapshot_dynamic_for_rays(&config);
        inline.push(start.elapsed().as_secs_f64() * 1e3);
        if !made {
            s.check(
                "StaticDynamicPair",
                "ray snapshot",
                1,
                vec!["the snapshot of a changed dynamic tree was not made".into()],
            );
            return;
        }
    }
    let (mut starts, mut totals) = (Vec::new(), Vec::new());
    for _ in 0..rounds {
        pair.dynamic_mut();
        let start = Instant::now();
        let started = pair.start_dynamic_ray_snapshot(&config);
        starts.push(start.elapsed().as_secs_f64() * 1e3);
        while started && !pair.poll_dynamic_ray_snapshot() {
            std::thread::yield_now();
        }
        totals.push(start.elapsed().as_secs_f64() * 1e3);
    }
    s.row(Row::alone(
        "8-wide ray snapshot of the dynamic tree (PLOC)".into(),
        median(inline),
        "ms",
        None,
    ));
    s.row(Row::text(
        "the same on a background thread: caller's thread / until installed".into(),
        format!(
            "{} / {}",
            fig(median(starts), "ms"),
            fig(median(totals), "ms")
        ),
        String::new(),
        String::new(),
    ));
}

/// Runs this part: `frame_count` busy frames per method, `rounds` snapshot rounds.
pub fn run(s: &mut Section, boxes: &[Aabb], frame_count: usize, rounds: usize) {
    let n = boxes.len();
    let scene = format!("{n} boxes, 10% moving, {frame_count} frames");
    s.step("frames: default maintain");
    let base = DynamicBvhConfig::default();
    let mut f = ours(boxes, frame_count, base);
    let fresh_tight = fresh_tight_cost(&f.boxes, &f.tree);
    let fresh_fat = f.tree.measure_fresh_build_cost() as f64;
    let cost = f.tree.stats(&f.tree.config().sah).sah_cost as f64;
    s.step("frames: obvhs");
    let (ob_ms, ob, ob_boxes) = obvhs_frames(boxes, frame_count);
    let ob_stats = tree_stats(&ObvhsBvh2(&ob), &f.tree.config().sah);
    let ob_cost = ob_stats.sah_cost as f64 / fresh_tight_cost(&ob_boxes, &f.tree);
    // The obvhs view must hold every leaf once for its cost to mean anything.
    let view_wrong = (ob_stats.primitives != n).then(|| {
        format!(
            "the obvhs tree seen through our view holds {} primitives, not {n}",
            ob_stats.primitives
        )
    });
    s.check(
        "obvhs Bvh2 view",
        "leaves after the frames",
        1,
        view_wrong.into_iter().collect(),
    );
    s.row(Row::peer(
        format!("frame: 10% moved by a random step, then maintenance (mean of {frame_count})"),
        (
            f.mean_ms,
            ob_ms,
            "ms",
            "obvhs `resize_node` per moved leaf, no optimiser",
        ),
        None,
    ));
    s.row(Row::alone(
        "frame with nothing moved (`maintain()`)".into(),
        empty_maintain_ns(&mut f.tree),
        "ns",
        Some((1_000.0, "1 us")),
    ));
    let sah = cost / fresh_tight;
    s.row(Row::text(
        format!("SAH after {frame_count} frames of 10% moving, over a fresh build's (tight boxes / our fat boxes)"),
        format!("{sah:.3}x / {:.3}x", cost / fresh_fat),
        format!("obvhs `resize_node` {ob_cost:.3}x (tight)"),
        Row::target(cost / fresh_fat, Some((1.15, "1.15x (fat boxes)"))),
    ));
    s.row(Row::text(
        "optimiser per frame, mean / max".into(),
        format!(
            "{} / {}",
            fig(f.optimize_mean_ms, "ms"),
            fig(f.optimize_max_ms, "ms")
        ),
        String::new(),
        Row::target(f.optimize_max_ms, Some((1.0, "1 ms"))),
    ));
    s.notes.push(format!(
        "10% moved, per frame (medians of {frame_count}): update {:.3} ms, maintain {:.3} ms; \
         {} rebuilds; quality estimate {:?}",
        f.update_ms,
        f.maintain_ms,
        f.rebuilds,
        f.tree.quality()
    ));
    let (cases, wrong) = check_rays(&f.tree, &f.boxes);
    s.check(
        "DynamicBvh after the frames",
        "closest hit vs a scan",
        cases,
        wrong,
    );
    s.points.push(point(
        &scene,
        "DynamicBvh",
        "default maintain",
        ("ms per frame", f.mean_ms),
        ("SAH cost / fresh build", Some(sah)),
    ));
    s.points.push(point(
        &scene,
        "obvhs Bvh2",
        "resize_node",
        ("ms per frame", ob_ms),
        ("SAH cost / fresh build", Some(ob_cost)),
    ));
    s.step("frames: refits only");
    let refit_only = DynamicBvhConfig {
        rotations: false,
        optimize_max_reinsertions: 0,
        rebuild_threshold: f32::INFINITY,
        ..base
    };
    let r = ours(boxes, frame_count, refit_only);
    let r_sah =
        r.tree.stats(&r.tree.config().sah).sah_cost as f64 / fresh_tight_cost(&r.boxes, &r.tree);
    s.points.push(point(
        &scene,
        "DynamicBvh",
        "refits only",
        ("ms per frame", r.mean_ms),
        ("SAH cost / fresh build", Some(r_sah)),
    ));
    s.notes.push(format!(
        "refits only (no rotations, optimiser or rebuilds): {:.3} ms per frame, SAH {r_sah:.3}x \
         a fresh build's",
        r.mean_ms
    ));
    s.step("ray snapshot");
    snapshot(s, boxes, rounds);
}
