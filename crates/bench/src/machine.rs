//! What the machine itself gives: the speed-up of a loop that touches no memory when it runs
//! on two threads instead of one. A suite's own speed-up on two threads reads against it: on a
//! virtual machine whose two vCPUs share a physical core, or whose host steals time, even
//! this loop falls short of 2x, and no tracer can do better than the machine.

use std::hint::black_box;
use std::time::Instant;

/// Steps of the register-only loop in one unit of work (a few tens of milliseconds).
const UNIT: u64 = 40_000_000;

/// One unit: a xorshift chain, kept in registers, its end value returned so that it cannot
/// be folded away.
fn unit(seed: u64) -> u64 {
    let mut x = seed | 1;
    for _ in 0..UNIT {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
    }
    x
}

/// Seconds for `units` units shared out among `threads` threads.
fn timed(units: usize, threads: usize) -> f64 {
    let start = Instant::now();
    std::thread::scope(|s| {
        for t in 0..threads {
            s.spawn(move || {
                for u in (t..units).step_by(threads) {
                    black_box(unit(black_box(u as u64 + 1)));
                }
            });
        }
    });
    start.elapsed().as_secs_f64()
}

/// The register-only loop's speed-up on `threads` threads over one, the best of `runs`
/// alternated rounds (noise only ever adds time).
pub fn alu_speedup(threads: usize, runs: usize) -> f64 {
    let units = 2 * threads.max(1);
    let (mut one, mut many) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..runs.max(1) {
        one = one.min(timed(units, 1));
        many = many.min(timed(units, threads));
    }
    one / many
}
