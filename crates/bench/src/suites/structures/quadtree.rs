//! The [`Quadtree`] against `rstar`'s R*-tree (0.14, 2D, `f32`) on the same flat boxes, for
//! issue 54's target "Quadtree: >= 1.0x rstar on updates and box queries".
//!
//! Scenes, in the world `[-1000, 1000]^2` (every box flat at z = 0; the quadtree places on x
//! and y only): `uniform` (centres uniform, half extents 0.1 to 1), `clustered` (64 clusters
//! with centres uniform in 90% of the world, boxes within 40 of a centre, half extents 0.05
//! to 0.5) and `mixed` (centres uniform, half extents 0.1 to 1 for 90%, 1 to 10 for 9%, 10 to
//! 100 for 1%); 10k, 100k and 1M boxes (10k at `--quick`).
//!
//! Both contenders run in the same run, repetitions alternating (and which goes first
//! alternating too); each figure is the median over the repetitions, the ratio `rstar / ours`
//! (above 1: we win):
//! - bulk load: ours, the insert loop and one `maintain` (the tree has no bulk build);
//!   rstar, `RTree::bulk_load` (its input vector made before the clock starts);
//! - insert 1-by-1: the same loop for ours; `RTree::insert` one by one for rstar;
//! - update: frames moving a tenth of the boxes by up to 1 per axis (eight distinct frames,
//!   played forward then backward so nothing drifts); ours `update` by handle plus one
//!   `maintain` a frame, rstar `remove` + `insert`. Per moved box;
//! - box query: query boxes covering 0.1% of the world (half size 31.6), half at uniform
//!   places and half on random boxes; ours with the exact box test in the callback, rstar
//!   `locate_in_envelope_intersecting`. Per query;
//! - nearest: the nearest box (squared distance 0 inside) to each query centre; ours
//!   `nearest_k(.., 1, ..)`, rstar `nearest_neighbor`. Per query.
//!
//! Before the timing, and again after the update frames, every query's hit count and every
//! nearest distance is checked equal on both trees (the report's stress rows).

use super::{check_row, secs};
use crate::json::Report;
use crate::progress::Progress;
use crate::suites::point;
use crate::timing::median;
use accel_testkit::Rng;
use core::ops::ControlFlow;
use glam::Vec3A;
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{AABB, RTree};
use spatial_accel::octree::{OctreeConfig, OctreeHandle, Quadtree};
use spatial_accel::{Aabb, SpatialQuery};

/// Half the side of the square world.
const WORLD: f32 = 1000.0;
/// The quadtree's `OctreeConfig::target_occupancy` here.
const QUADTREE_OCCUPANCY: u32 = 32;
/// Half the side of a query box: its area is 0.1% of the world's.
const QUERY_HALF: f32 = 31.62;
/// Distinct frames of moves (played forward, then backward with the steps negated).
const FRAMES: usize = 8;
/// Frames played per timed repetition of the updates.
const FRAMES_PER_REP: usize = 4;

/// An object of the R*-tree: the box's rectangle and its index.
type Obj = GeomWithData<Rectangle<[f32; 2]>, u32>;
/// One frame: the boxes moved and their steps.
type Frame = Vec<(usize, Vec3A)>;

/// The scenes' box distributions.
#[derive(Clone, Copy, Debug)]
enum Scene {
    Uniform,
    Clustered,
    Mixed,
}

/// What this part measures; `--quick` shrinks it.
pub struct Settings {
    sizes: Vec<usize>,
    reps: usize,
    queries: usize,
}

impl Settings {
    /// The full run's settings, or the quick run's.
    pub fn new(quick: bool) -> Self {
        if quick {
            Self {
                sizes: vec![10_000],
                reps: 3,
                queries: 1_000,
            }
        } else {
            Self {
                sizes: vec![10_000, 100_000, 1_000_000],
                reps: 5,
                queries: 10_000,
            }
        }
    }

    /// Progress steps: one per scene and size.
    pub fn steps(&self) -> usize {
        3 * self.sizes.len()
    }
}

/// A flat box at z = 0.
fn flat(cx: f32, cy: f32, hx: f32, hy: f32) -> Aabb {
    Aabb::new(
        Vec3A::new(cx - hx, cy - hy, 0.0),
        Vec3A::new(cx + hx, cy + hy, 0.0),
    )
}

fn scene(kind: Scene, n: usize, seed: u64) -> Vec<Aabb> {
    let mut rng = Rng::new(seed);
    let clusters: Vec<(f32, f32)> = (0..64)
        .map(|_| (rng.range(-0.9, 0.9) * WORLD, rng.range(-0.9, 0.9) * WORLD))
        .collect();
    (0..n)
        .map(|_| match kind {
            Scene::Uniform => {
                let (x, y) = (rng.range(-WORLD, WORLD), rng.range(-WORLD, WORLD));
                flat(x, y, rng.range(0.1, 1.0), rng.range(0.1, 1.0))
            }
            Scene::Clustered => {
                let (cx, cy) = clusters[rng.below(64)];
                let (x, y) = (cx + rng.range(-40.0, 40.0), cy + rng.range(-40.0, 40.0));
                flat(x, y, rng.range(0.05, 0.5), rng.range(0.05, 0.5))
            }
            Scene::Mixed => {
                let (x, y) = (rng.range(-WORLD, WORLD), rng.range(-WORLD, WORLD));
                let u = rng.f32();
                let tier = usize::from(u >= 0.9) + usize::from(u >= 0.99);
                let (lo, hi) = [(0.1, 1.0), (1.0, 10.0), (10.0, 100.0)][tier];
                flat(x, y, rng.range(lo, hi), rng.range(lo, hi))
            }
        })
        .collect()
}

/// Query boxes (z from -1 to 1, so every flat box can meet them): even ones at uniform
/// places, odd ones centred on a random box.
fn queries(boxes: &[Aabb], count: usize, seed: u64) -> Vec<Aabb> {
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|i| {
            let c = if i % 2 == 0 {
                Vec3A::new(rng.range(-WORLD, WORLD), rng.range(-WORLD, WORLD), 0.0)
            } else {
                boxes[rng.below(boxes.len())].center()
            };
            Aabb::from_center_half_extents(c, Vec3A::new(QUERY_HALF, QUERY_HALF, 1.0))
        })
        .collect()
}

/// The cycle of frames: `FRAMES` random ones, then the same with the steps negated.
fn frames(n: usize, seed: u64) -> Vec<Frame> {
    let mut rng = Rng::new(seed);
    let forward: Vec<Frame> = (0..FRAMES)
        .map(|_| {
            (0..n / 10)
                .map(|_| {
                    let step = Vec3A::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0);
                    (rng.below(n), step)
                })
                .collect()
        })
        .collect();
    let back: Vec<Frame> = forward
        .iter()
        .map(|f| f.iter().map(|&(j, d)| (j, -d)).collect())
        .collect();
    forward.into_iter().chain(back).collect()
}

fn moved(b: &Aabb, step: Vec3A) -> Aabb {
    Aabb::new(b.min + step, b.max + step)
}

fn envelope(b: &Aabb) -> AABB<[f32; 2]> {
    AABB::from_corners([b.min.x, b.min.y], [b.max.x, b.max.y])
}

fn obj(b: &Aabb, id: usize) -> Obj {
    Obj::new(Rectangle::from_aabb(envelope(b)), id as u32)
}

/// Our tree: the insert loop (ids the indices) and the refit queries need.
fn build_ours(config: OctreeConfig, boxes: &[Aabb]) -> (Quadtree, Vec<OctreeHandle>) {
    let mut tree = Quadtree::with_config(config).expect("a valid configuration");
    let handles = (boxes.iter().enumerate())
        .map(|(i, b)| tree.insert(i as u32, *b).expect("a finite box"))
        .collect();
    tree.maintain();
    (tree, handles)
}

fn count_ours(tree: &Quadtree, boxes: &[Aabb], q: &Aabb) -> usize {
    let mut hits = 0;
    tree.for_each_overlapping_aabb(q, |id| {
        hits += usize::from(boxes[id as usize].intersects_aabb(q));
        ControlFlow::Continue(())
    });
    hits
}

fn nearest_ours(tree: &Quadtree, boxes: &[Aabb], p: Vec3A) -> f32 {
    tree.nearest_k(p, 1, |id| boxes[id as usize].distance_squared_to_point(p))[0].1
}

/// Compares every query's hit count and nearest distance on both trees into stress rows;
/// returns the mean hits per query and the mean candidates our walk hands the callback.
fn check(
    (tree, boxes): (&Quadtree, &[Aabb]),
    rt: &RTree<Obj>,
    qs: &[Aabb],
    label: &str,
    report: &mut Report,
) -> (f64, f64) {
    let (mut hits, mut candidates, mut wrong_hits, mut wrong_nearest) = (0, 0, 0, 0);
    for q in qs {
        let ours = count_ours(tree, boxes, q);
        wrong_hits += usize::from(ours != rt.locate_in_envelope_intersecting(envelope(q)).count());
        hits += ours;
        tree.for_each_overlapping_aabb(q, |_| {
            candidates += 1;
            ControlFlow::Continue(())
        });
        let p = q.center();
        let theirs = rt
            .nearest_neighbor_with_distance_2([p.x, p.y])
            .map(|(_, d2)| d2);
        wrong_nearest += usize::from(Some(nearest_ours(tree, boxes, p)) != theirs);
    }
    let structure = format!("Quadtree {label}");
    report.stress.push(check_row(
        &structure,
        "box query hit counts = rstar's",
        qs.len(),
        wrong_hits,
    ));
    report.stress.push(check_row(
        &structure,
        "nearest distances = rstar's",
        qs.len(),
        wrong_nearest,
    ));
    let per_query = |c: usize| c as f64 / qs.len() as f64;
    (per_query(hits), per_query(candidates))
}

/// One untimed round of both contenders (allocations, caches, the first moves out of where
/// loading put the boxes), then `reps` alternating repetitions (each returns the seconds it
/// measured; the first to go alternates too): the median of each, scaled by `scale`.
fn contest(
    reps: usize,
    scale: f64,
    mut ours: impl FnMut() -> f64,
    mut theirs: impl FnMut() -> f64,
) -> (f64, f64) {
    ours();
    theirs();
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for rep in 0..reps {
        if rep % 2 == 0 {
            a.push(ours());
            b.push(theirs());
        } else {
            b.push(theirs());
            a.push(ours());
        }
    }
    (median(a) * scale, median(b) * scale)
}

/// One scene at one size: (ours, rstar) for bulk load (ms), insert 1-by-1 (ms), update (ns
/// per moved box), box query and nearest (µs per query).
type Figures = [(f64, f64); 5];

/// Measures one scene at one size, adding its checks and notes to `report`.
fn bench_scene(kind: Scene, n: usize, s: &Settings, report: &mut Report) -> Figures {
    let reps = if n >= 1_000_000 { 3 } else { s.reps };
    let label = format!("{kind:?} {n}");
    let boxes = scene(kind, n, 1);
    let world = boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
    // Several boxes per deepest octant (`target_occupancy`): how a 2D game that asks for
    // boxes more than rays would set it (the default, 0, keeps one octant per small box).
    let config = OctreeConfig {
        target_occupancy: QUADTREE_OCCUPANCY,
        ..OctreeConfig::for_world(&world)
    };
    let qs = queries(&boxes, s.queries, 2);
    let envs: Vec<AABB<[f32; 2]>> = qs.iter().map(envelope).collect();
    let centres: Vec<Vec3A> = qs.iter().map(Aabb::center).collect();
    let objs: Vec<Obj> = boxes.iter().enumerate().map(|(i, b)| obj(b, i)).collect();

    let build = contest(
        reps,
        1e3,
        || secs(|| build_ours(config, &boxes)),
        || {
            let input = objs.clone();
            secs(|| RTree::bulk_load(input))
        },
    );
    let one_by_one = contest(
        reps,
        1e3,
        || secs(|| build_ours(config, &boxes)),
        || {
            secs(|| {
                let mut t = RTree::new();
                objs.iter().for_each(|o| t.insert(*o));
                t
            })
        },
    );

    let (mut tree, handles) = build_ours(config, &boxes);
    let mut rt = RTree::bulk_load(objs.clone());
    let (hits, candidates) = check((&tree, &boxes), &rt, &qs, &label, report);
    let q_scale = 1e6 / qs.len() as f64;
    let box_query = contest(
        reps,
        q_scale,
        || {
            secs(|| {
                qs.iter()
                    .map(|q| count_ours(&tree, &boxes, q))
                    .sum::<usize>()
            })
        },
        || {
            secs(|| {
                (envs.iter())
                    .map(|e| rt.locate_in_envelope_intersecting(*e).count())
                    .sum::<usize>()
            })
        },
    );
    let nearest = contest(
        reps,
        q_scale,
        || {
            secs(|| {
                (centres.iter())
                    .map(|&p| nearest_ours(&tree, &boxes, p))
                    .sum::<f32>()
            })
        },
        || {
            secs(|| {
                (centres.iter())
                    .map(|p| rt.nearest_neighbor([p.x, p.y]).map_or(0, |o| o.data))
                    .fold(0, u32::wrapping_add)
            })
        },
    );
    let shape = format!(
        "quadtree {label}: {} octants, depth {}, {:.1} MB; {hits:.1} hits and {candidates:.1} \
         candidates per query",
        tree.octant_count(),
        tree.depth(),
        tree.memory_bytes() as f64 / 1e6,
    );

    let moves = frames(n, 3);
    let (mut now_ours, mut now_rt) = (boxes.clone(), boxes.clone());
    let (mut i_ours, mut i_rt) = (0, 0);
    let mut changed_octant = 0usize;
    let update_ours = || {
        secs(|| {
            for _ in 0..FRAMES_PER_REP {
                for &(j, step) in &moves[i_ours % moves.len()] {
                    now_ours[j] = moved(&now_ours[j], step);
                    let changed = tree.update(handles[j], now_ours[j]).expect("a finite box");
                    changed_octant += usize::from(changed);
                }
                tree.maintain();
                i_ours += 1;
            }
        })
    };
    let update_rt = || {
        secs(|| {
            for _ in 0..FRAMES_PER_REP {
                for &(j, step) in &moves[i_rt % moves.len()] {
                    rt.remove(&obj(&now_rt[j], j))
                        .expect("the box is in the tree");
                    now_rt[j] = moved(&now_rt[j], step);
                    rt.insert(obj(&now_rt[j], j));
                }
                i_rt += 1;
            }
        })
    };
    let per_move = 1e9 / (FRAMES_PER_REP * (n / 10)) as f64;
    let update = contest(reps, per_move, update_ours, update_rt);
    let total_moves = (reps + 1) * FRAMES_PER_REP * (n / 10);
    report.stress.push(check_row(
        &format!("Quadtree {label}"),
        "validate after the moves",
        1,
        usize::from(tree.validate().is_err()),
    ));
    check(
        (&tree, &now_ours),
        &rt,
        &qs,
        &format!("{label} after the moves"),
        report,
    );
    report.notes.push(format!(
        "{shape}; {:.1}% of {total_moves} moves changed octant",
        100.0 * changed_octant as f64 / total_moves as f64
    ));
    [build, one_by_one, update, box_query, nearest]
}

/// Runs this part of the suite into `report`.
pub fn run(s: &Settings, report: &mut Report, progress: &mut Progress) {
    report.markdown.extend([
        format!(
            "Quadtree against rstar, ratio rstar / ours ({} queries; above 1 we win):",
            s.queries
        ),
        String::new(),
        "| scene, n | bulk load | insert one by one | update (per moved box) | box query | nearest |"
            .into(),
        "|---|---:|---:|---:|---:|---:|".into(),
    ]);
    const UNITS: [&str; 5] = ["ms", "ms", "ns/move", "µs/query", "µs/query"];
    for kind in [Scene::Uniform, Scene::Clustered, Scene::Mixed] {
        for &n in &s.sizes {
            progress.step(&format!("quadtree {kind:?} {n}"));
            let f = bench_scene(kind, n, s, report);
            let ratios: Vec<String> = f.iter().map(|(o, t)| format!("{:.2}x", t / o)).collect();
            report.markdown.push(format!(
                "| {} {n} | {} |",
                format!("{kind:?}").to_lowercase(),
                ratios.join(" | ")
            ));
            let cells: Vec<String> = (f.iter().zip(UNITS))
                .map(|((o, t), u)| format!("{o:.3} / {t:.3} {u}"))
                .collect();
            report.notes.push(format!(
                "{kind:?} {n}, ours / rstar: bulk {}, 1-by-1 {}, update {}, box {}, nearest {}",
                cells[0], cells[1], cells[2], cells[3], cells[4]
            ));
            let scene = format!("quadtree vs rstar, {kind:?} {n}");
            for (method, pick) in [("Quadtree", 0), ("rstar 0.14", 1)] {
                let get = |(o, t): (f64, f64)| if pick == 0 { o } else { t };
                report.points.push(point(
                    &scene,
                    method,
                    "",
                    ("ns per moved box", get(f[2])),
                    ("µs per box query", Some(get(f[3]))),
                ));
                report.points.push(point(
                    &scene,
                    method,
                    "",
                    ("ns per moved box", get(f[2])),
                    ("µs per nearest query", Some(get(f[4]))),
                ));
            }
        }
    }
    report.markdown.push(String::new());
}
