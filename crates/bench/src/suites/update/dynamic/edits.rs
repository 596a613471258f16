//! The dynamic BVH's edits and moves on its own workload, each beside obvhs's dynamic `Bvh2`
//! where obvhs has the same operation: insertions and removals at full size, every leaf moved
//! then refit, the whole-tree refit alone (its schedule compiled, and right after an edit of
//! links, when it compiles first; on one thread and on rayon's pool), and the machine's memory
//! floor that the refit's figures are read against.

use super::{Row, Section, built_tree, scene, to_obvhs};
use crate::suites::point;
use crate::timing::median;
use accel_testkit::Rng;
use glam::Vec3A;
use obvhs::bvh2::Bvh2;
use obvhs::faststack::HeapStack;
use spatial_accel::prefetch::prefetch;
use spatial_accel::{Aabb, DynamicBvhConfig};
use std::hint::black_box;
use std::time::Instant;

/// Edits timed per batch: this many insertions or removals on a tree of the full size.
const BATCH: usize = 1_000;

/// Seconds of the fastest of `runs` runs of `work`, each on a fresh `setup()` (not timed).
fn best_fresh<S>(runs: usize, mut setup: impl FnMut() -> S, mut work: impl FnMut(&mut S)) -> f64 {
    (0..runs.max(1))
        .map(|_| {
            let mut state = setup();
            let t = Instant::now();
            work(&mut state);
            let elapsed = t.elapsed().as_secs_f64();
            black_box(&state);
            elapsed
        })
        .fold(f64::INFINITY, f64::min)
}

/// obvhs's dynamic path over `boxes`: one insertion per box, as ours is inserted.
fn obvhs_tree(boxes: &[Aabb]) -> Bvh2 {
    let mut ob = Bvh2::default();
    let mut stack = HeapStack::new_with_capacity(1000);
    for (i, b) in boxes.iter().enumerate() {
        ob.insert_primitive(to_obvhs(b), i as u32, &mut stack);
    }
    ob
}

/// `b` moved by `d`.
fn shifted(b: &Aabb, d: Vec3A) -> Aabb {
    Aabb::new(b.min + d, b.max + d)
}

/// Insertions and removals, per operation, ours and obvhs's, on fresh copies of a built tree.
fn edits(s: &mut Section, boxes: &[Aabb], runs: usize) {
    let n = boxes.len();
    let extra = scene(BATCH, 9);
    let (tree, handles) = built_tree(boxes);
    let ob = obvhs_tree(boxes);
    let per_op = |secs: f64| secs * 1e6 / BATCH as f64;
    let ours = per_op(best_fresh(
        runs,
        || tree.clone(),
        |t| {
            for (i, b) in extra.iter().enumerate() {
                black_box(t.insert((n + i) as u32, *b).expect("a finite box"));
            }
        },
    ));
    let theirs = per_op(best_fresh(
        runs,
        || (ob.clone(), HeapStack::new_with_capacity(1000)),
        |(o, stack)| {
            for (i, b) in extra.iter().enumerate() {
                black_box(o.insert_primitive(to_obvhs(b), (n + i) as u32, stack));
            }
        },
    ));
    s.row(Row::peer(
        format!("insert, per op ({BATCH} at {n})"),
        (ours, theirs, "us", "obvhs"),
        Some((1.0, "1 us")),
    ));
    // The same leaves leave both trees: every `stride`-th of the workload.
    let stride = (n / BATCH).max(1);
    let ours = per_op(best_fresh(
        runs,
        || tree.clone(),
        |t| {
            for h in handles.iter().step_by(stride).take(BATCH) {
                black_box(t.remove(*h).expect("a live handle"));
            }
        },
    ));
    let theirs = per_op(best_fresh(
        runs,
        || ob.clone(),
        |o| {
            for i in (0..n).step_by(stride).take(BATCH) {
                o.remove_primitive(i as u32);
            }
        },
    ));
    s.row(Row::peer(
        format!("remove, per op ({BATCH} at {n})"),
        (ours, theirs, "us", "obvhs"),
        Some((0.5, "0.5 us")),
    ));
}

/// Every leaf moved by 0 or 1 unit per axis in turn, then the tree brought up to date: ours
/// by `update` and `refit`, obvhs's by setting every leaf's box and `refit_all` (its whole-tree
/// path) or by `resize_node` per leaf (its per-leaf path). Best of `runs` frames, ms.
fn all_moved_totals(s: &mut Section, boxes: &[Aabb], runs: usize) {
    let n = boxes.len();
    let frame_ms = |mut frame: Box<dyn FnMut(Vec3A) + '_>| {
        // Two frames first: the refit schedule compiles, the caches warm.
        (0..runs + 2)
            .filter_map(|round| {
                let d = Vec3A::splat((round % 2) as f32);
                let t = Instant::now();
                frame(d);
                (round >= 2).then(|| t.elapsed().as_secs_f64() * 1e3)
            })
            .fold(f64::INFINITY, f64::min)
    };
    let (mut tree, handles) = built_tree(boxes);
    let ours = frame_ms(Box::new(|d| {
        for (h, b) in handles.iter().zip(boxes) {
            tree.update(*h, shifted(b, d)).expect("a live handle");
        }
        black_box(tree.refit());
    }));
    let mut ob = obvhs_tree(boxes);
    let set_all = frame_ms(Box::new(|d| {
        for (i, b) in boxes.iter().enumerate() {
            let node = ob.primitives_to_nodes[i] as usize;
            ob.nodes[node].set_aabb(to_obvhs(&shifted(b, d)));
        }
        ob.refit_all();
    }));
    let resize = frame_ms(Box::new(|d| {
        for (i, b) in boxes.iter().enumerate() {
            let node = ob.primitives_to_nodes[i] as usize;
            ob.resize_node(node, to_obvhs(&shifted(b, d)));
        }
    }));
    s.row(Row::peer(
        format!("all moved: `update` x {n} + `refit()`"),
        (ours, set_all, "ms", "obvhs set all + `refit_all`"),
        None,
    ));
    s.row(Row::peer(
        "the same, against obvhs's per-leaf path".into(),
        (ours, resize, "ms", "obvhs `resize_node` per leaf"),
        None,
    ));
    s.points.push(point(
        &format!("{n} boxes, all moved"),
        "DynamicBvh",
        "update + refit",
        ("ms per frame", ours),
        ("quality", None),
    ));
    s.points.push(point(
        &format!("{n} boxes, all moved"),
        "obvhs Bvh2",
        "set all + refit_all",
        ("ms per frame", set_all),
        ("quality", None),
    ));
}

/// Every leaf moved by one unit (along the diagonal) then refit, per leaf: as the first frame
/// after the build (ours compiles its refit schedule there), and as a frame after one such
/// frame (a crowd that keeps moving).
fn first_and_later_frame(s: &mut Section, boxes: &[Aabb], runs: usize) {
    let n = boxes.len();
    let one = Vec3A::splat(1.0 / 3f32.sqrt());
    for (label, warm_frames) in [("first frame after the build", 0), ("a later frame", 1)] {
        let secs = best_fresh(
            runs,
            || {
                let (mut t, hs) = built_tree(boxes);
                for _ in 0..warm_frames {
                    for (h, b) in hs.iter().zip(boxes) {
                        t.update(*h, shifted(b, -one)).expect("a live handle");
                    }
                    t.refit();
                }
                (t, hs)
            },
            |(t, hs)| {
                for (h, b) in hs.iter().zip(boxes) {
                    t.update(*h, shifted(b, one)).expect("a live handle");
                }
                t.refit();
            },
        );
        s.row(Row::alone(
            format!("all moved 1 unit, update + refit per leaf, {label}"),
            secs * 1e9 / n as f64,
            "ns",
            None,
        ));
    }
}

/// Every leaf moved by 0 or 1 unit in turn, `rounds` times: the medians of (update, refit), ns
/// per leaf. `invalidate` edits the links before each refit (an insertion and its removal), so
/// the refit compiles its schedule first, as the first refit after any edit of links does.
fn refit_per_leaf(boxes: &[Aabb], invalidate: bool, rounds: usize, parallel: bool) -> (f64, f64) {
    let n = boxes.len() as f64;
    let (mut t, hs) = built_tree(boxes);
    t.set_config(DynamicBvhConfig {
        parallel_refit: parallel,
        ..*t.config()
    });
    let (mut updates, mut refits) = (Vec::new(), Vec::new());
    for round in 0..rounds + 2 {
        let d = Vec3A::splat((round % 2) as f32);
        let start = Instant::now();
        for (h, b) in hs.iter().zip(boxes) {
            t.update(*h, shifted(b, d)).expect("a live handle");
        }
        let update = start.elapsed().as_secs_f64();
        if invalidate {
            let h = t.insert(u32::MAX, boxes[0]).expect("a finite box");
            t.remove(h).expect("a live handle");
        }
        let start = Instant::now();
        t.refit();
        let refit = start.elapsed().as_secs_f64();
        // The first two rounds compile the schedule and warm the caches.
        if round >= 2 {
            updates.push(update * 1e9 / n);
            refits.push(refit * 1e9 / n);
        }
    }
    (median(updates), median(refits))
}

/// The whole-tree refit alone: compiled, on rayon's pool against one thread (alternated, so
/// that both see the same phases of the machine), and right after an edit of links.
fn refits(s: &mut Section, boxes: &[Aabb], rounds: usize) {
    let (update, compiled) = refit_per_leaf(boxes, false, rounds, false);
    s.row(Row::alone(
        "whole-tree refit alone, per leaf, schedule compiled".into(),
        compiled,
        "ns",
        Some((10.0, "10 ns")),
    ));
    let (mut parallel, mut serial) = (Vec::new(), Vec::new());
    for _ in 0..3 {
        parallel.push(refit_per_leaf(boxes, false, rounds, true).1);
        serial.push(refit_per_leaf(boxes, false, rounds, false).1);
    }
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    s.row(Row::peer(
        format!("the same on rayon's pool ({threads} threads)"),
        (
            median(parallel),
            median(serial),
            "ns",
            "one thread, alternated",
        ),
        None,
    ));
    let (_, invalidated) = refit_per_leaf(boxes, true, rounds.div_ceil(2), false);
    s.row(Row::alone(
        "the same, right after an edit of links (compiles first)".into(),
        invalidated,
        "ns",
        None,
    ));
    s.notes.push(format!(
        "all moved: `update` alone {update:.1} ns per leaf (medians of {rounds} rounds)"
    ));
}

/// ns per 64-byte line over an array the size of the tree's arena (two lines per leaf): read
/// in order, at random with a prefetch 16 reads ahead, and at random with each address
/// depending on the last read. The refit's figures move with these between the machine's
/// memory phases.
fn memory_floor(s: &mut Section, leaves: usize) {
    #[derive(Clone, Copy)]
    #[repr(C, align(64))]
    struct Line([u32; 16]);
    let n = 2 * leaves;
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut rng = Rng::new(7);
    for i in (1..n).rev() {
        order.swap(i, rng.below(i + 1));
    }
    // Each line names the next one of a random cycle, for the dependent chain.
    let mut lines = vec![Line([0; 16]); n];
    for k in 0..n {
        lines[order[k] as usize].0[0] = order[(k + 1) % n];
    }
    let per_line = |start: Instant| start.elapsed().as_secs_f64() * 1e9 / n as f64;
    let start = Instant::now();
    let in_order: u32 = lines.iter().fold(0, |a, l| a ^ l.0[1]);
    let t_order = per_line(start);
    let start = Instant::now();
    let mut prefetched = 0u32;
    for k in 0..n {
        if let Some(&ahead) = order.get(k + 16) {
            prefetch(&lines[ahead as usize]);
        }
        prefetched ^= lines[order[k] as usize].0[1];
    }
    let t_prefetched = per_line(start);
    let start = Instant::now();
    let mut at = 0u32;
    for _ in 0..n {
        at = lines[at as usize].0[0];
    }
    let t_chain = per_line(start);
    black_box((in_order, prefetched, at));
    s.notes.push(format!(
        "memory floor, ns per 64-byte line over {:.1} MB: in order {t_order:.1}, random \
         prefetched {t_prefetched:.1}, dependent chain {t_chain:.1}",
        (n * 64) as f64 / 1e6
    ));
}

/// Runs this part on `boxes`: `runs` best-of runs, `rounds` median rounds.
pub fn run(s: &mut Section, boxes: &[Aabb], runs: usize, rounds: usize) {
    s.step("memory floor");
    memory_floor(s, boxes.len());
    s.step("insert and remove");
    edits(s, boxes, runs);
    s.step("all moved");
    all_moved_totals(s, boxes, runs);
    first_and_later_frame(s, boxes, runs.min(3));
    s.step("refit alone");
    refits(s, boxes, rounds);
}
