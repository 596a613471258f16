//! Splits the dynamic BVH's per-frame cost into its parts on the 100k-leaf workload of
//! `benches/dynamic_bvh.rs`, where criterion only sees totals:
//!
//! - every leaf moved: `update` per leaf, then the whole-tree refit per leaf, both with the
//!   refit schedule already compiled and with it invalidated by an edit first (as the first
//!   refit after an insertion, removal or optimiser step runs);
//! - 10% of the leaves moved at random by up to 1 unit per axis: `update`, the partial
//!   `refit()` and the rest of `maintain()` per frame;
//! - the tree's depth, by a walk of the tree (`stats`) and read from the root (`height`);
//! - the 8-wide copy of the tree that rays walk while it holds still
//!   (`StaticDynamicPair::snapshot_dynamic_for_rays`);
//! - the machine's floor: what one 64-byte line costs over an array the size of the tree's
//!   arena, read in order, at random with a prefetch, and in a chain of dependent loads.
//!
//! `cargo run --release -p accel --example dynamic_timing` (add `--features rayon` for the
//! parallel whole-tree refit beside the one-thread one). Medians over the rounds: this
//! machine's noise moves single rounds by tens of percent.

#[path = "../benches/common/dynamic_workload.rs"]
mod dynamic_workload;

use accel::{Aabb, BuildConfig, DynamicBvhConfig, SplitStrategy};
use accel_testkit::Rng;
use dynamic_workload::{built_tree as tree, scene};
use glam::Vec3A;
use std::time::{Duration, Instant};

/// How the ray snapshot is built: with PLOC, as the plugin builds it.
fn snapshot_config() -> BuildConfig {
    BuildConfig::with_split(SplitStrategy::PLOC_FASTEST)
}

const N: usize = 100_000;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Every leaf moved by 0 or 1 unit in turn, `rounds` times: (update, refit) ns per leaf.
/// `parallel` sets [`DynamicBvhConfig::parallel_refit`] (which needs the `rayon` feature).
fn all_moved(boxes: &[Aabb], invalidate: bool, rounds: usize, parallel: bool) -> (f64, f64) {
    let (mut t, hs) = tree(boxes);
    t.set_config(DynamicBvhConfig {
        parallel_refit: parallel,
        ..*t.config()
    });
    let (mut updates, mut refits) = (Vec::new(), Vec::new());
    for round in 0..rounds + 2 {
        let d = Vec3A::splat((round % 2) as f32);
        let s = Instant::now();
        for (h, b) in hs.iter().zip(boxes) {
            t.update(*h, Aabb::new(b.min + d, b.max + d))
                .expect("live handle");
        }
        let update = s.elapsed();
        if invalidate {
            let h = t.insert(u32::MAX, boxes[0]).expect("finite box");
            t.remove(h).expect("live handle");
        }
        let s = Instant::now();
        t.refit();
        let refit = s.elapsed();
        // The first two rounds compile the schedule and warm the caches.
        if round >= 2 {
            updates.push(update.as_nanos() as f64 / N as f64);
            refits.push(refit.as_nanos() as f64 / N as f64);
        }
    }
    (median(updates), median(refits))
}

/// ns per 64-byte line over 200k lines (the arena of 100k leaves): in order, at random with a
/// prefetch 16 reads ahead, and at random with each address depending on the last read.
fn memory_floor() -> (f64, f64, f64) {
    #[derive(Clone, Copy)]
    #[repr(C, align(64))]
    struct Line([u32; 16]);
    let n = 2 * N;
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
    let per_line = |d: Duration| d.as_nanos() as f64 / n as f64;
    let s = Instant::now();
    let in_order: u32 = lines.iter().fold(0, |a, l| a ^ l.0[1]);
    let t_order = per_line(s.elapsed());
    let s = Instant::now();
    let mut prefetched = 0u32;
    for k in 0..n {
        if let Some(&ahead) = order.get(k + 16) {
            prefetch(&lines[ahead as usize]);
        }
        prefetched ^= lines[order[k] as usize].0[1];
    }
    let t_prefetched = per_line(s.elapsed());
    let s = Instant::now();
    let mut at = 0u32;
    for _ in 0..n {
        at = lines[at as usize].0[0];
    }
    let t_chain = per_line(s.elapsed());
    std::hint::black_box((in_order, prefetched, at));
    (t_order, t_prefetched, t_chain)
}

#[inline(always)]
fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint that never faults.
    unsafe {
        use core::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>((x as *const T).cast());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

fn main() {
    let boxes = scene(N, 1);
    println!("100,000 leaves, one thread");
    let (o, p, c) = memory_floor();
    println!(
        "floor, ns per 64-byte line over 12.8 MB: in order {o:.1}, random prefetched {p:.1}, dependent chain {c:.1}"
    );
    {
        let (t, _) = tree(&boxes);
        let mut pair = accel::dynamic::StaticDynamicPair::new(accel::Bvh::default(), t);
        let mut times = Vec::new();
        for _ in 0..9 {
            pair.dynamic_mut();
            let s = Instant::now();
            assert!(pair.snapshot_dynamic_for_rays(&snapshot_config()));
            times.push(s.elapsed().as_secs_f64() * 1e3);
        }
        println!(
            "8-wide ray snapshot of the dynamic tree: {:.1} ms (median of 9)",
            median(times)
        );
        let (mut starts, mut totals) = (Vec::new(), Vec::new());
        for _ in 0..9 {
            pair.dynamic_mut();
            let s = Instant::now();
            assert!(pair.start_dynamic_ray_snapshot(&snapshot_config()));
            starts.push(s.elapsed().as_secs_f64() * 1e3);
            while !pair.poll_dynamic_ray_snapshot() {
                std::thread::yield_now();
            }
            totals.push(s.elapsed().as_secs_f64() * 1e3);
        }
        println!(
            "  on a background thread: {:.2} ms on the caller's thread, {:.1} ms until installed (medians of 9)",
            median(starts),
            median(totals)
        );
    }
    {
        let (t, _) = tree(&boxes);
        let s = Instant::now();
        let depth = t.stats(&t.config().sah).max_depth;
        let walk = s.elapsed();
        let s = Instant::now();
        let height = std::hint::black_box(&t).height();
        let read = s.elapsed();
        assert_eq!(depth, height);
        println!("depth {depth}: stats() walk {walk:?}, height() {read:?}");
    }
    let (u, r) = all_moved(&boxes, false, 40, false);
    println!(
        "all moved, schedule compiled: update {u:.1} ns/leaf, whole-tree refit {r:.1} ns/leaf"
    );
    // With `--features rayon`: the same refit on rayon's pool, alternated with the one-thread
    // refit so both see the same phases of a noisy machine.
    #[cfg(feature = "rayon")]
    for _ in 0..3 {
        let (_, parallel) = all_moved(&boxes, false, 40, true);
        let (_, serial) = all_moved(&boxes, false, 40, false);
        println!(
            "all moved, schedule compiled, whole-tree refit on {} threads: {parallel:.1} ns/leaf \
             (one thread, next: {serial:.1} ns/leaf)",
            rayon::current_num_threads()
        );
    }
    let (u, r) = all_moved(&boxes, true, 20, false);
    println!(
        "all moved, schedule invalidated: update {u:.1} ns/leaf, whole-tree refit {r:.1} ns/leaf"
    );

    let mut moving = boxes.clone();
    let (mut t, hs) = tree(&boxes);
    let mut rng = Rng::new(2);
    let (mut updates, mut refits, mut rests) = (Vec::new(), Vec::new(), Vec::new());
    let mut rebuilds = 0;
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    for _ in 0..200 {
        let s = Instant::now();
        for _ in 0..N / 10 {
            let i = rng.below(N);
            let d = rng.vec3a(-1.0, 1.0);
            moving[i] = Aabb::new(moving[i].min + d, moving[i].max + d);
            t.update(hs[i], moving[i]).expect("live handle");
        }
        updates.push(ms(s.elapsed()));
        let s = Instant::now();
        t.refit();
        refits.push(ms(s.elapsed()));
        let s = Instant::now();
        rebuilds += usize::from(t.maintain().rebuilt);
        rests.push(ms(s.elapsed()));
    }
    println!(
        "10% moved, per frame (medians of 200): update {:.2} ms, refit {:.2} ms, rest of maintain {:.2} ms ({rebuilds} rebuilds)",
        median(updates),
        median(refits),
        median(rests)
    );
}
