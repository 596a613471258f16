//! The [`Quadtree`] against `rstar`'s R*-tree (0.14, 2D, `f32`) on the same flat boxes, for
//! issue 54's target "Quadtree: >= 1.0x rstar on updates and box queries".
//!
//! Scenes, in the world `[-1000, 1000]^2` (every box flat at z = 0; the quadtree places on x
//! and y only):
//! - `uniform`: centres uniform, half extents 0.1 to 1;
//! - `clustered`: 64 clusters (centres uniform in 90% of the world), boxes within 40 of a
//!   centre, half extents 0.05 to 0.5;
//! - `mixed`: centres uniform, half extents 0.1 to 1 (90%), 1 to 10 (9%), 10 to 100 (1%).
//!
//! For each scene and n, both contenders in the same run, repetitions alternating (and which
//! goes first alternating too); each row is the median over the repetitions and the ratio
//! `rstar / ours` (above 1: we win):
//! - `bulk load`: ours, the insert loop and one `maintain` (the tree has no bulk API); rstar,
//!   `RTree::bulk_load` (its input vector is made before the clock starts).
//! - `insert 1-by-1`: the same loop for ours; `RTree::insert` one by one for rstar.
//! - `update`: frames moving a tenth of the boxes by a step of up to 1 per axis (eight
//!   distinct frames, played forward then backward so nothing drifts); ours `update` by
//!   handle plus one `maintain` per frame, rstar `remove` + `insert`. Per moved object.
//! - `box query`: query boxes covering 0.1% of the world (half size 31.6), centred half at
//!   uniform places and half on random objects; ours `for_each_overlapping_aabb` with the
//!   exact box test in the callback, rstar `locate_in_envelope_intersecting`. Per query.
//! - `nearest`: the nearest box (squared distance 0 inside) to each query centre; ours
//!   `nearest_k(.., 1, ..)`, rstar `nearest_neighbor`. Per query.
//!
//! Before timing, and again after the update frames, every query's hit count and every
//! nearest distance is checked to be the same on both trees.
//!
//! Run: `CARGO_TARGET_DIR=/tmp/accel-target cargo bench -p accel --profile dev --bench
//! quadtree_rstar -- [--quick] [--n 10k,100k,1m] [--scene uniform,clustered,mixed]
//! [--reps R] [--queries Q]` (default: every scene at 10k, 100k and 1M, 5 repetitions, 10,000
//! queries; `--quick`: 10k and 100k, 3 repetitions, 2,000 queries).

use accel::octree::{OctreeConfig, OctreeHandle, Quadtree};
use accel::{Aabb, SpatialQuery};
use accel_testkit::Rng;
use core::ops::ControlFlow;
use glam::Vec3A;
use rstar::primitives::{GeomWithData, Rectangle};
use rstar::{AABB, RTree};
use std::hint::black_box;
use std::time::Instant;

/// Half the side of the square world.
const WORLD: f32 = 1000.0;
/// Half the side of a query box: its area is 0.1% of the world's.
const QUERY_HALF: f32 = 31.62;
/// Distinct frames of moves (played forward, then backward with the steps negated).
const FRAMES: usize = 8;
/// Frames played per timed repetition of the updates.
const FRAMES_PER_REP: usize = 4;

/// An object of the R*-tree: the box's rectangle and its index.
type Obj = GeomWithData<Rectangle<[f32; 2]>, u32>;
/// One frame: the objects moved and their steps.
type Frame = Vec<(usize, Vec3A)>;

#[derive(Clone, Copy, Debug)]
enum Scene {
    Uniform,
    Clustered,
    Mixed,
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
/// places, odd ones centred on a random object.
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
    let back = forward
        .iter()
        .map(|f| f.iter().map(|&(j, d)| (j, -d)).collect());
    let back: Vec<Frame> = back.collect();
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
    let mut tree = Quadtree::with_config(config).unwrap();
    let mut handles = Vec::with_capacity(boxes.len());
    for (i, b) in boxes.iter().enumerate() {
        handles.push(tree.insert(i as u32, *b).unwrap());
    }
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

fn all_hits_ours(tree: &Quadtree, boxes: &[Aabb], qs: &[Aabb]) -> usize {
    qs.iter().map(|q| count_ours(tree, boxes, q)).sum()
}

fn all_hits_rt(rt: &RTree<Obj>, envs: &[AABB<[f32; 2]>]) -> usize {
    envs.iter()
        .map(|e| rt.locate_in_envelope_intersecting(*e).count())
        .sum()
}

fn all_nearest_ours(tree: &Quadtree, boxes: &[Aabb], points: &[Vec3A]) -> f32 {
    points.iter().map(|&p| nearest_ours(tree, boxes, p)).sum()
}

fn all_nearest_rt(rt: &RTree<Obj>, points: &[Vec3A]) -> u32 {
    points
        .iter()
        .map(|p| rt.nearest_neighbor([p.x, p.y]).unwrap().data)
        .fold(0, u32::wrapping_add)
}

/// Every query's hit count and every nearest distance, the same on both trees; returns the
/// mean hits per query and the mean candidates our walk hands the callback.
fn check(tree: &Quadtree, boxes: &[Aabb], rt: &RTree<Obj>, qs: &[Aabb]) -> (f64, f64) {
    let (mut hits, mut candidates) = (0, 0);
    for (i, q) in qs.iter().enumerate() {
        let ours = count_ours(tree, boxes, q);
        let theirs = rt.locate_in_envelope_intersecting(envelope(q)).count();
        assert_eq!(ours, theirs, "query {i}: hit counts differ");
        hits += ours;
        tree.for_each_overlapping_aabb(q, |_| {
            candidates += 1;
            ControlFlow::Continue(())
        });
        let p = q.center();
        let (_, d2) = rt.nearest_neighbor_with_distance_2([p.x, p.y]).unwrap();
        let d2_ours = nearest_ours(tree, boxes, p);
        assert_eq!(d2_ours, d2, "query {i}: nearest distances differ");
    }
    let per_query = |c: usize| c as f64 / qs.len() as f64;
    (per_query(hits), per_query(candidates))
}

/// Seconds taken by `f`; what it returned is dropped off the clock.
fn secs<R>(f: impl FnOnce() -> R) -> f64 {
    let t = Instant::now();
    let r = black_box(f());
    let secs = t.elapsed().as_secs_f64();
    drop(r);
    secs
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// One untimed round of both contenders (allocations, caches, the first moves out of where
/// loading put the objects), then `reps` alternating repetitions (each returns the seconds it
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

struct Settings {
    sizes: Vec<usize>,
    scenes: Vec<Scene>,
    reps: usize,
    queries: usize,
}

/// `10000`, `100k` or `1m`.
fn parse_count(s: &str) -> usize {
    let (digits, mult) = match (s.strip_suffix(['k', 'K']), s.strip_suffix(['m', 'M'])) {
        (Some(d), _) => (d, 1000),
        (_, Some(d)) => (d, 1_000_000),
        _ => (s, 1),
    };
    digits
        .parse::<usize>()
        .expect("a count like 10000, 100k or 1m")
        * mult
}

fn scene_named(name: &str) -> Scene {
    match name {
        "uniform" => Scene::Uniform,
        "clustered" => Scene::Clustered,
        "mixed" => Scene::Mixed,
        _ => panic!("unknown scene {name} (uniform, clustered, mixed)"),
    }
}

fn settings() -> Settings {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let mut s = Settings {
        sizes: if quick {
            vec![10_000, 100_000]
        } else {
            vec![10_000, 100_000, 1_000_000]
        },
        scenes: vec![Scene::Uniform, Scene::Clustered, Scene::Mixed],
        reps: if quick { 3 } else { 5 },
        queries: if quick { 2_000 } else { 10_000 },
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || {
            it.next()
                .unwrap_or_else(|| panic!("{a} needs a value"))
                .clone()
        };
        match a.as_str() {
            "--n" => s.sizes = value().split(',').map(parse_count).collect(),
            "--scene" => s.scenes = value().split(',').map(scene_named).collect(),
            "--reps" => s.reps = value().parse().expect("--reps R"),
            "--queries" => s.queries = value().parse().expect("--queries Q"),
            // `cargo bench` passes `--bench`.
            "--quick" | "--bench" => {}
            other => panic!("unknown argument {other}"),
        }
    }
    s
}

/// One row of a scene's table.
fn row(n: usize, op: &str, (ours, theirs): (f64, f64)) -> String {
    format!(
        "| {n} | {op} | {ours:.3} | {theirs:.3} | {:.2}x |",
        theirs / ours
    )
}

/// Measures one scene at one size, printing what the trees look like; returns the table rows.
fn bench_scene(kind: Scene, n: usize, s: &Settings) -> Vec<String> {
    let boxes = scene(kind, n, 1);
    let world = boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
    let config = OctreeConfig::for_world(&world);
    let qs = queries(&boxes, s.queries, 2);
    let envs: Vec<AABB<[f32; 2]>> = qs.iter().map(envelope).collect();
    let points: Vec<Vec3A> = qs.iter().map(Aabb::center).collect();
    let objs: Vec<Obj> = boxes.iter().enumerate().map(|(i, b)| obj(b, i)).collect();

    let build = contest(
        s.reps,
        1e3,
        || secs(|| build_ours(config, &boxes)),
        || {
            let input = objs.clone();
            secs(|| RTree::bulk_load(input))
        },
    );
    let one_by_one = contest(
        s.reps,
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
    let (hits, candidates) = check(&tree, &boxes, &rt, &qs);
    let q_scale = 1e6 / qs.len() as f64;
    let box_query = contest(
        s.reps,
        q_scale,
        || secs(|| all_hits_ours(&tree, &boxes, &qs)),
        || secs(|| all_hits_rt(&rt, &envs)),
    );
    let nearest = contest(
        s.reps,
        q_scale,
        || secs(|| all_nearest_ours(&tree, &boxes, &points)),
        || secs(|| all_nearest_rt(&rt, &points)),
    );
    println!(
        "{kind:?} n={n}: quadtree {} octants, depth {}, {:.1} MB; {hits:.1} hits and \
         {candidates:.1} quadtree candidates per query",
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
                    changed_octant += usize::from(tree.update(handles[j], now_ours[j]).unwrap());
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
                        .expect("the object is in the tree");
                    now_rt[j] = moved(&now_rt[j], step);
                    rt.insert(obj(&now_rt[j], j));
                }
                i_rt += 1;
            }
        })
    };
    let per_move = 1e9 / (FRAMES_PER_REP * (n / 10)) as f64;
    let update = contest(s.reps, per_move, update_ours, update_rt);
    let total_moves = (s.reps + 1) * FRAMES_PER_REP * (n / 10);
    assert_eq!((i_ours, now_ours.as_slice()), (i_rt, now_rt.as_slice()));
    tree.validate().unwrap();
    check(&tree, &now_ours, &rt, &qs);
    println!(
        "  after {total_moves} moves ({:.1}% changed octant): counts and distances still agree",
        100.0 * changed_octant as f64 / total_moves as f64
    );

    vec![
        row(n, "bulk load (ms)", build),
        row(n, "insert 1-by-1 (ms)", one_by_one),
        row(n, "update (ns/moved object)", update),
        row(n, "box query (µs/query)", box_query),
        row(n, "nearest (µs/query)", nearest),
    ]
}

fn main() {
    let s = settings();
    for &kind in &s.scenes {
        let rows: Vec<String> = s
            .sizes
            .iter()
            .flat_map(|&n| bench_scene(kind, n, &s))
            .collect();
        println!(
            "\n## {kind:?} ({} repetitions, {} queries; ratio = rstar / ours)",
            s.reps, s.queries
        );
        println!("| n | operation | ours | rstar | ratio |");
        println!("|---:|---|---:|---:|---:|");
        rows.iter().for_each(|r| println!("{r}"));
    }
}
