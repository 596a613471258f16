//! Timing helpers: the best of several runs (a shared machine's noise only ever adds time),
//! and the median of per-frame figures.

use std::time::Instant;

/// Runs `f` `runs` times and returns the shortest time in seconds and the last result.
pub fn best_of<R>(runs: usize, mut f: impl FnMut() -> R) -> (f64, R) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(std::hint::black_box(r));
    }
    (best, out.expect("at least one run"))
}

/// Seconds per item: the best of `runs` passes over `n` items, each `f(i)`.
pub fn per_item<R>(runs: usize, n: usize, mut f: impl FnMut(usize) -> R) -> f64 {
    let (t, _) = best_of(runs, || {
        for i in 0..n {
            std::hint::black_box(f(i));
        }
    });
    t / n.max(1) as f64
}

/// The median of `values` (the mean of the middle two of an even count; 0 for none): for
/// figures over frames, where one frame's stall (a rebuild installed, the machine's other
/// tenants) must not move the figure the way it would move a mean.
pub fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let mid = values.len() / 2;
    match values.len() {
        0 => 0.0,
        len if len % 2 == 1 => values[mid],
        _ => (values[mid - 1] + values[mid]) / 2.0,
    }
}
