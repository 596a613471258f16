//! spatial_accel's `DynamicBvh` against parry3d 0.31's `Bvh` on the workload of the bench tool's
//! dynamic BVH rows (`accel_testkit::dynamic_workload`): 100,000 boxes,
//! centres uniform in [-200, 200]^3, half extents 0.1-1.0, one thread, both trees in the same
//! process, each figure the best of several runs.
//!
//! - insert / remove: 1,000 operations on a tree of 100k leaves, per operation;
//! - move all: every leaf moved by 1 unit, then the tree brought up to date (ours: `update` x
//!   100k + `refit`; parry: `insert_or_update_partially` x 100k + `refit`), per leaf; once as
//!   the first frame after the build, once as a frame after one such frame;
//! - frame: 10% of the leaves (chosen at random) moved by a random step of up to 1 unit per
//!   axis, then the per-frame maintenance each library recommends (ours: `maintain`, which
//!   refits, optimises within its budget and rebuilds when the quality estimate says so;
//!   parry: `refit` then `optimize_incremental`), mean over 200 frames.
//!
//! `cargo run --release --manifest-path crates/bench/peers/parry/Cargo.toml`

use accel_testkit::Rng;
use accel_testkit::dynamic_workload::{built_tree as ours, scene};
use glam::Vec3A;
use parry3d::bounding_volume::Aabb as ParryAabb;
use parry3d::math::Vector;
use parry3d::partitioning::{Bvh, BvhWorkspace};
use spatial_accel::Aabb;
use std::time::Instant;

const N: usize = 100_000;

fn parry(b: &Aabb) -> ParryAabb {
    ParryAabb::new(
        Vector::new(b.min.x, b.min.y, b.min.z),
        Vector::new(b.max.x, b.max.y, b.max.z),
    )
}

fn shifted(b: &Aabb, d: Vec3A) -> Aabb {
    Aabb::new(b.min + d, b.max + d)
}

/// Seconds of the fastest of `runs` runs of `work`, each on a fresh `setup()`.
fn best_of<S>(runs: usize, mut setup: impl FnMut() -> S, mut work: impl FnMut(&mut S)) -> f64 {
    (0..runs)
        .map(|_| {
            let mut state = setup();
            let t = Instant::now();
            work(&mut state);
            let elapsed = t.elapsed().as_secs_f64();
            std::hint::black_box(&state);
            elapsed
        })
        .fold(f64::INFINITY, f64::min)
}

fn theirs(boxes: &[Aabb]) -> (Bvh, BvhWorkspace) {
    let leaves: Vec<ParryAabb> = boxes.iter().map(parry).collect();
    (
        Bvh::from_leaves(parry3d::partitioning::BvhBuildStrategy::Binned, &leaves),
        BvhWorkspace::default(),
    )
}

fn main() {
    let boxes = scene(N, 1);
    let extra = scene(1_000, 2);
    let us = |s: f64, n: usize| s * 1e6 / n as f64;
    let ns = |s: f64, n: usize| s * 1e9 / n as f64;

    println!("100,000 leaves, one thread; best of 5 runs (frames: mean of 200)");
    println!("| operation | accel | parry3d 0.31 | accel speed-up |");
    println!("|---|---:|---:|---:|");

    let a = best_of(
        5,
        || ours(&boxes),
        |(t, _)| {
            for (i, b) in extra.iter().enumerate() {
                t.insert((N + i) as u32, *b).expect("finite box");
            }
        },
    );
    let p = best_of(
        5,
        || theirs(&boxes),
        |(t, _)| {
            for (i, b) in extra.iter().enumerate() {
                t.insert(parry(b), (N + i) as u32);
            }
        },
    );
    println!(
        "| insert (per op) | {:.2} us | {:.2} us | {:.2}x |",
        us(a, 1000),
        us(p, 1000),
        p / a
    );

    let a = best_of(
        5,
        || ours(&boxes),
        |(t, hs)| {
            for h in &hs[..1000] {
                t.remove(*h).expect("live handle");
            }
        },
    );
    let p = best_of(
        5,
        || theirs(&boxes),
        |(t, _)| {
            for i in 0..1000u32 {
                t.remove(i);
            }
        },
    );
    println!(
        "| remove (per op) | {:.2} us | {:.2} us | {:.2}x |",
        us(a, 1000),
        us(p, 1000),
        p / a
    );

    // Each library moves every leaf once (the first refit after a build: ours compiles its
    // refit schedule there), then, in a second measure, a second time (a crowd that keeps
    // moving: the frames after the first).
    let one = Vec3A::splat(1.0 / 3f32.sqrt());
    for (label, warm_frames) in [("first frame after the build", 0), ("a later frame", 1)] {
        let a = best_of(
            3,
            || {
                let (mut t, hs) = ours(&boxes);
                for _ in 0..warm_frames {
                    for (h, b) in hs.iter().zip(&boxes) {
                        t.update(*h, shifted(b, -one)).expect("live handle");
                    }
                    t.refit();
                }
                (t, hs)
            },
            |(t, hs)| {
                for (h, b) in hs.iter().zip(&boxes) {
                    t.update(*h, shifted(b, one)).expect("live handle");
                }
                t.refit();
            },
        );
        let p = best_of(
            3,
            || {
                let (mut t, mut ws) = theirs(&boxes);
                for _ in 0..warm_frames {
                    for (i, b) in boxes.iter().enumerate() {
                        t.insert_or_update_partially(parry(&shifted(b, -one)), i as u32, 0.0);
                    }
                    t.refit(&mut ws);
                }
                (t, ws)
            },
            |(t, ws)| {
                for (i, b) in boxes.iter().enumerate() {
                    t.insert_or_update_partially(parry(&shifted(b, one)), i as u32, 0.0);
                }
                t.refit(ws);
            },
        );
        println!(
            "| all 100k moved 1 unit, update + refit, {label} (per leaf) | {:.0} ns | {:.0} ns | {:.2}x |",
            ns(a, N),
            ns(p, N),
            p / a
        );
    }

    // Frames: the same random walk for both.
    let frames = 200;
    let mut rng = Rng::new(3);
    let steps: Vec<Vec<(usize, Vec3A)>> = (0..frames)
        .map(|_| {
            (0..N / 10)
                .map(|_| (rng.below(N), rng.vec3a(-1.0, 1.0)))
                .collect()
        })
        .collect();
    let (mut t, hs) = ours(&boxes);
    let mut now = boxes.clone();
    let start = Instant::now();
    for frame in &steps {
        for &(i, d) in frame {
            now[i] = shifted(&now[i], d);
            t.update(hs[i], now[i]).expect("live handle");
        }
        t.maintain();
    }
    let a = start.elapsed().as_secs_f64() / frames as f64;
    let (mut pt, mut ws) = theirs(&boxes);
    let mut now = boxes.clone();
    let start = Instant::now();
    for frame in &steps {
        for &(i, d) in frame {
            now[i] = shifted(&now[i], d);
            pt.insert_or_update_partially(parry(&now[i]), i as u32, 0.0);
        }
        pt.refit(&mut ws);
        pt.optimize_incremental(&mut ws);
    }
    let p = start.elapsed().as_secs_f64() / frames as f64;
    println!(
        "| frame: 10% moved + maintenance (mean) | {:.2} ms | {:.2} ms | {:.2}x |",
        a * 1e3,
        p * 1e3,
        p / a
    );
}
