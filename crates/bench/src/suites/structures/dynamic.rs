//! The loose octree (looseness 2 and 1.5) and the uniform grid (automatic cell size, and a
//! fixed cell of 4, four times the largest box's half extent) against the dynamic BVH on the
//! dynamic workload (`accel_testkit::dynamic_workload`: 100,000 boxes, centres uniform in
//! [-200, 200]^3, half extents 0.1 to 1; 10,000 at `--quick`):
//!
//! - a frame: a tenth of the boxes take a random step of up to a unit per axis (the same
//!   steps for every contender; eight frames played forward, then backward with the steps
//!   negated, so nothing drifts), then the per-frame upkeep. The dynamic BVH runs twice: its
//!   configured `maintain` (refit, optimiser, rebuilds) and its refit alone;
//! - a camera frustum with about 5% of the boxes not outside, the exact box test on the
//!   candidates that cross a plane;
//! - 1,000 query boxes of half size 5 at random places, the exact box test;
//! - 1,000 incoherent closest-hit rays, the slab test of each box in the callback.
//!
//! The queries run on fresh structures, every answer checked equal to the BVH's; after the
//! frames, each structure's rays are checked again against a fresh BVH over the moved boxes,
//! and timed against a fresh build of the same kind (the plots' quality: what the upkeep
//! left of the fresh structure's speed).

use super::{check_row, secs};
use crate::json::Report;
use crate::progress::Progress;
use crate::suites::common::frustum_selecting;
use crate::suites::{incoherent_rays, point};
use crate::timing::best_of;
use accel_testkit::Rng;
use accel_testkit::dynamic_workload::{built_tree, scene};
use core::ops::ControlFlow;
use glam::Vec3A;
use spatial_accel::grid::{GridConfig, UniformGrid};
use spatial_accel::octree::{LooseOctree, OctreeConfig};
use spatial_accel::query::DynamicIndex;
use spatial_accel::{Aabb, Containment, DynamicBvh, Frustum, Ray, SpatialQuery};
use std::hint::black_box;
use std::time::Duration;

/// Progress steps this part takes: one per contender.
pub const STEPS: usize = 6;

/// Distinct frames of moves.
const FRAMES: usize = 8;

/// The fixed cell side of the second grid, in world units.
const SMALL_CELL: f32 = 4.0;

/// The moves of one frame: a box and its step.
type Frame = Vec<(usize, Vec3A)>;

/// `FRAMES` frames, each moving a tenth of `n` boxes.
fn frames(n: usize) -> Vec<Frame> {
    let mut rng = Rng::new(2);
    (0..FRAMES)
        .map(|_| {
            (0..n / 10)
                .map(|_| (rng.below(n), rng.vec3a(-1.0, 1.0)))
                .collect()
        })
        .collect()
}

/// Plays frame `i` of the cycle (forward, then backward) on `boxes`, calling `update` for
/// each moved box.
fn play(frames: &[Frame], i: usize, boxes: &mut [Aabb], mut update: impl FnMut(usize, Aabb)) {
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

/// The ids a frustum query keeps after the exact test, sorted.
fn frustum_ids<S: SpatialQuery>(index: &S, boxes: &[Aabb], frustum: &Frustum) -> Vec<u32> {
    let mut ids = Vec::new();
    index.for_each_in_frustum(frustum, |id, c| {
        if c == Containment::Inside || frustum.intersects_aabb(&boxes[id as usize]) {
            ids.push(id);
        }
    });
    ids.sort_unstable();
    ids
}

/// How many boxes overlap each query box.
fn box_hits<S: SpatialQuery>(index: &S, boxes: &[Aabb], queries: &[Aabb]) -> Vec<usize> {
    queries
        .iter()
        .map(|q| {
            let mut hits = 0;
            index.for_each_overlapping_aabb(q, |id| {
                hits += usize::from(boxes[id as usize].intersects_aabb(q));
                ControlFlow::Continue(())
            });
            hits
        })
        .collect()
}

/// The closest hit distance of each ray.
fn ray_hits<S: SpatialQuery>(index: &S, boxes: &[Aabb], rays: &[Ray]) -> Vec<Option<f32>> {
    rays.iter()
        .map(|r| {
            index
                .cast_ray(r, |id, r| r.intersect_aabb(&boxes[id as usize]))
                .map(|h| h.t)
        })
        .collect()
}

/// Answers that differ between `a` and `b`, position by position.
fn differ<T: PartialEq>(a: &[T], b: &[T]) -> usize {
    a.iter().zip(b).filter(|(x, y)| x != y).count() + a.len().abs_diff(b.len())
}

/// Ids in one sorted list and not in the other.
fn id_difference(a: &[u32], b: &[u32]) -> usize {
    let (mut i, mut j, mut out) = (0, 0, 0);
    while i < a.len() && j < b.len() {
        match a[i].cmp(&b[j]) {
            core::cmp::Ordering::Less => (out, i) = (out + 1, i + 1),
            core::cmp::Ordering::Greater => (out, j) = (out + 1, j + 1),
            core::cmp::Ordering::Equal => (i, j) = (i + 1, j + 1),
        }
    }
    out + (a.len() - i) + (b.len() - j)
}

/// What every contender runs on, with the BVH's answers to check against.
struct Workload {
    boxes: Vec<Aabb>,
    frames: Vec<Frame>,
    frustum: Frustum,
    queries: Vec<Aabb>,
    rays: Vec<Ray>,
    runs: usize,
    want: (Vec<u32>, Vec<usize>, Vec<Option<f32>>),
}

/// One contender: how it is made, loaded and kept up each frame.
struct Contender<I> {
    name: &'static str,
    make: fn() -> I,
    /// After the inserts, as a game's index looks after loading.
    load: fn(&mut I),
    /// The per-frame upkeep.
    upkeep: fn(&mut I),
    /// Whether its queries are timed (the BVH's two upkeeps share one fresh tree).
    queries: bool,
}

/// One contender's figures, in milliseconds (`None`: not timed).
struct Figures {
    name: &'static str,
    frame: f64,
    frustum: Option<f64>,
    boxes: Option<f64>,
    rays: Option<f64>,
    memory_mb: f64,
}

fn loaded<I: DynamicIndex>(c: &Contender<I>, boxes: &[Aabb]) -> (I, Vec<I::Handle>) {
    let mut index = (c.make)();
    let handles = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| index.insert(i as u32, *b).expect("a finite box"))
        .collect();
    (c.load)(&mut index);
    (index, handles)
}

/// Times `c` on the workload, checks its answers and adds its stress rows and points.
fn measure<I: DynamicIndex + SpatialQuery>(
    c: &Contender<I>,
    w: &Workload,
    report: &mut Report,
) -> Figures {
    let (mut index, handles) = loaded(c, &w.boxes);
    let ms = |s: f64| s * 1e3;
    let (mut frustum, mut boxes, mut rays) = (None, None, None);
    if c.queries {
        let (t, ids) = best_of(w.runs, || frustum_ids(&index, &w.boxes, &w.frustum));
        report.stress.push(check_row(
            c.name,
            "frustum ids = DynamicBvh's",
            w.want.0.len(),
            id_difference(&ids, &w.want.0),
        ));
        frustum = Some(ms(t));
        let (t, hits) = best_of(w.runs, || box_hits(&index, &w.boxes, &w.queries));
        report.stress.push(check_row(
            c.name,
            "box query hit counts = DynamicBvh's",
            hits.len(),
            differ(&hits, &w.want.1),
        ));
        boxes = Some(ms(t));
        let (t, hits) = best_of(w.runs, || ray_hits(&index, &w.boxes, &w.rays));
        report.stress.push(check_row(
            c.name,
            "ray distances = DynamicBvh's",
            hits.len(),
            differ(&hits, &w.want.2),
        ));
        rays = Some(ms(t));
    }
    // One untimed cycle first: the first moves out of where loading put the boxes.
    let cycle = 2 * FRAMES;
    let mut now = w.boxes.clone();
    let mut frame = f64::INFINITY;
    for run in 0..=w.runs {
        let s = secs(|| {
            for i in run * cycle..(run + 1) * cycle {
                play(&w.frames, i, &mut now, |j, b| {
                    black_box(index.update(handles[j], b).expect("a finite box"));
                });
                (c.upkeep)(&mut index);
            }
        });
        if run > 0 {
            frame = frame.min(ms(s) / cycle as f64);
        }
    }
    let memory_mb = index.index_stats().memory_bytes as f64 / 1e6;
    let after = ray_hits(&index, &now, &w.rays);
    report.stress.push(check_row(
        c.name,
        "ray distances after the frames = fresh DynamicBvh's",
        after.len(),
        differ(&after, &ray_hits(&built_tree(&now).0, &now, &w.rays)),
    ));
    let (fresh, _) = loaded(c, &now);
    let (moved_t, _) = best_of(w.runs, || ray_hits(&index, &now, &w.rays));
    let (fresh_t, _) = best_of(w.runs, || ray_hits(&fresh, &now, &w.rays));
    let scene = format!("{} boxes, 10% moving", w.boxes.len());
    let time = ("ms per frame", frame);
    report.points.push(point(
        &scene,
        c.name,
        "",
        time,
        (
            "ray time after the frames / fresh build",
            Some(moved_t / fresh_t),
        ),
    ));
    report.points.push(point(
        &scene,
        c.name,
        "",
        time,
        ("memory MB", Some(memory_mb)),
    ));
    Figures {
        name: c.name,
        frame,
        frustum,
        boxes,
        rays,
        memory_mb,
    }
}

/// Shape notes: the octrees' octants and how many of one frame's moves changed octant, the
/// grids' cells.
fn shape_notes(w: &Workload, report: &mut Report) {
    for k in [2.0, 1.5] {
        let mut tree = LooseOctree::with_config(OctreeConfig::default().with_looseness(k))
            .expect("a valid looseness");
        let handles: Vec<_> = (w.boxes.iter().enumerate())
            .map(|(i, b)| tree.insert(i as u32, *b).expect("a finite box"))
            .collect();
        tree.maintain();
        let mut now = w.boxes.clone();
        let mut moved = 0;
        play(&w.frames, 0, &mut now, |j, b| {
            moved += usize::from(tree.update(handles[j], b).expect("a finite box"));
        });
        let refit = tree.maintain();
        report.notes.push(format!(
            "loose octree k = {k}: {} octants, depth {}, {:.1} MB; one frame moved {moved} of \
             {} entries to another octant and refit {refit} octants",
            tree.octant_count(),
            tree.depth(),
            tree.memory_bytes() as f64 / 1e6,
            w.frames[0].len(),
        ));
    }
    for (name, config) in [
        ("auto", GridConfig::default()),
        ("cell 4", GridConfig::fixed(SMALL_CELL)),
    ] {
        let mut grid = UniformGrid::with_config(config);
        for (i, b) in w.boxes.iter().enumerate() {
            grid.insert(i as u32, *b).expect("a finite box");
        }
        grid.maintain(Duration::ZERO);
        let stats = grid.index_stats();
        report.notes.push(format!(
            "uniform grid {name}: cell size {:.2}, {} cells, {} oversize, {:.1} MB",
            grid.cell_size(),
            stats.nodes,
            grid.oversize_count(),
            stats.memory_bytes as f64 / 1e6
        ));
    }
}

/// Reads one measurement of a contender's figures.
type Pick = fn(&Figures) -> Option<f64>;

/// A Markdown table of `cols` against the BVH (`bvh`), one row per measurement, the ratios
/// `contender / BVH` last (below 1 the contender is faster).
fn table(title: &str, bvh: &Figures, cols: [&Figures; 2]) -> Vec<String> {
    let cell = |x: Option<f64>| x.map_or("-".into(), |x| format!("{x:.3} ms"));
    let ratio = |x: Option<f64>, y: Option<f64>| match (x, y) {
        (Some(x), Some(y)) => format!("{:.2}x", x / y),
        _ => "-".into(),
    };
    let rows: [(&str, Pick); 4] = [
        ("update + upkeep per frame", |f| Some(f.frame)),
        ("frustum, 5% of boxes", |f| f.frustum),
        ("1,000 box queries", |f| f.boxes),
        ("1,000 incoherent rays", |f| f.rays),
    ];
    let mut out = vec![
        format!("{title}:"),
        String::new(),
        format!(
            "| measurement | DynamicBvh | {} | {} | {} / BVH | {} / BVH |",
            cols[0].name, cols[1].name, cols[0].name, cols[1].name
        ),
        "|---|---:|---:|---:|---:|---:|".into(),
    ];
    for (label, get) in rows {
        out.push(format!(
            "| {label} | {} | {} | {} | {} | {} |",
            cell(get(bvh)),
            cell(get(cols[0])),
            cell(get(cols[1])),
            ratio(get(cols[0]), get(bvh)),
            ratio(get(cols[1]), get(bvh)),
        ));
    }
    out.push(format!(
        "| memory | {:.1} MB | {:.1} MB | {:.1} MB | {:.2}x | {:.2}x |",
        bvh.memory_mb,
        cols[0].memory_mb,
        cols[1].memory_mb,
        cols[0].memory_mb / bvh.memory_mb,
        cols[1].memory_mb / bvh.memory_mb,
    ));
    out.push(String::new());
    out
}

/// An empty octree of looseness `k`.
fn with_looseness(k: f32) -> LooseOctree {
    LooseOctree::with_config(OctreeConfig::default().with_looseness(k)).expect("a valid looseness")
}

/// Runs this part of the suite into `report`.
pub fn run(quick: bool, report: &mut Report, progress: &mut Progress) {
    let n = if quick { 10_000 } else { 100_000 };
    let count = if quick { 200 } else { 1_000 };
    let boxes = scene(n, 1);
    let (frustum, _) = frustum_selecting(&boxes, 0.05);
    let mut rng = Rng::new(4);
    let queries = (0..count)
        .map(|_| Aabb::from_center_half_extents(rng.vec3a(-200.0, 200.0), Vec3A::splat(5.0)))
        .collect();
    let rays = incoherent_rays(count, 200.0, 5);
    let mut w = Workload {
        frames: frames(n),
        frustum,
        queries,
        rays,
        runs: if quick { 2 } else { 5 },
        want: Default::default(),
        boxes,
    };
    let (bvh, _) = built_tree(&w.boxes);
    w.want = (
        frustum_ids(&bvh, &w.boxes, &w.frustum),
        box_hits(&bvh, &w.boxes, &w.queries),
        ray_hits(&bvh, &w.boxes, &w.rays),
    );
    drop(bvh);
    let bvh = |name, upkeep: fn(&mut DynamicBvh), queries| Contender {
        name,
        make: DynamicBvh::new,
        load: DynamicBvh::rebuild,
        upkeep,
        queries,
    };
    progress.step("DynamicBvh");
    let bvh_maintain = measure(
        &bvh(
            "DynamicBvh",
            |t| {
                black_box(t.maintain());
            },
            true,
        ),
        &w,
        report,
    );
    progress.step("DynamicBvh refit only");
    let bvh_refit = measure(
        &bvh(
            "DynamicBvh refit only",
            |t| {
                black_box(DynamicIndex::maintain(t, Duration::ZERO));
            },
            false,
        ),
        &w,
        report,
    );
    let octree = |name, make: fn() -> LooseOctree| Contender {
        name,
        make,
        load: |t: &mut LooseOctree| {
            t.maintain();
        },
        upkeep: |t| {
            black_box(t.maintain());
        },
        queries: true,
    };
    progress.step("octree k = 2");
    let k2 = measure(&octree("octree k = 2", || with_looseness(2.0)), &w, report);
    progress.step("octree k = 1.5");
    let k15 = measure(
        &octree("octree k = 1.5", || with_looseness(1.5)),
        &w,
        report,
    );
    let grid = |name, make: fn() -> UniformGrid| Contender {
        name,
        make,
        load: |g: &mut UniformGrid| {
            g.maintain(Duration::ZERO);
        },
        upkeep: |g| {
            black_box(g.maintain(Duration::ZERO));
        },
        queries: true,
    };
    progress.step("grid auto");
    let auto = measure(&grid("grid auto", UniformGrid::new), &w, report);
    progress.step("grid cell 4");
    let small = measure(
        &grid("grid cell 4", || {
            UniformGrid::with_config(GridConfig::fixed(SMALL_CELL))
        }),
        &w,
        report,
    );
    shape_notes(&w, report);
    let scene = format!("{n} boxes, 10% of them moving a unit a frame");
    report.markdown.extend(table(
        &format!("Loose octree against DynamicBvh, {scene}"),
        &bvh_maintain,
        [&k2, &k15],
    ));
    report.markdown.extend(table(
        &format!("Uniform grid against DynamicBvh, {scene}"),
        &bvh_maintain,
        [&auto, &small],
    ));
    for f in [&k2, &k15, &auto, &small] {
        report.notes.push(format!(
            "{}: a frame takes {:.2}x the BVH's maintain, {:.2}x its refit alone ({:.3} ms)",
            f.name,
            f.frame / bvh_maintain.frame,
            f.frame / bvh_refit.frame,
            bvh_refit.frame
        ));
    }
}
