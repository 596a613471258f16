//! How much to trace in a frame: an estimate of the tracer's speed from the frames before.

use std::time::Duration;

/// Turns a time budget into rows to trace, from the speed measured on earlier frames.
///
/// Two ways to keep a frame's tracing within budget: loop over small tiles until the
/// deadline passes (the simplest, and exact, where one thread or a shared tile counter
/// decides), or decide the work before it starts, as a task pool scope given a fixed set of
/// tasks must. This helper is for the second: record what each frame traced and how long it
/// took, and ask for the next frame's rows. The estimate is an exponential moving average
/// of the time per pixel sample, so a heavier view (more bounces, a costlier part of the
/// scene in the rows reached) corrects it within a few frames.
///
/// ```
/// use spatial_accel::preview::FrameBudget;
/// use std::time::Duration;
/// let mut budget = FrameBudget::default();
/// // No measurement yet: one row, to take one.
/// assert_eq!(budget.rows_for(Duration::from_millis(8), 640, 1), 1);
/// budget.record(640 * 10, Duration::from_millis(4));
/// // 10 rows took 4 ms, so 8 ms buys 20 rows on one thread, 40 on two.
/// assert_eq!(budget.rows_for(Duration::from_millis(8), 640, 1), 20);
/// assert_eq!(budget.rows_for(Duration::from_millis(8), 640, 2), 40);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameBudget {
    /// Seconds per pixel sample on one thread, smoothed; `None` before the first record.
    seconds_per_sample: Option<f64>,
}

impl FrameBudget {
    /// The weight of the newest frame in the average: enough to follow a change of view
    /// within a few frames, little enough that one frame's hiccup (a page fault, the OS
    /// taking the core) does not halve the next frame's work.
    pub const SMOOTHING: f64 = 0.25;

    /// Records that `pixel_samples` pixel samples took `thread_time` of one thread's time
    /// (the sum over threads, for work split across several). Empty or non-finite records
    /// are ignored.
    pub fn record(&mut self, pixel_samples: u64, thread_time: Duration) {
        if pixel_samples == 0 {
            return;
        }
        let per = thread_time.as_secs_f64() / pixel_samples as f64;
        if !per.is_finite() {
            return;
        }
        self.seconds_per_sample = Some(match self.seconds_per_sample {
            None => per,
            Some(old) => old + Self::SMOOTHING * (per - old),
        });
    }

    /// The measured seconds per pixel sample on one thread, once something was recorded.
    pub fn seconds_per_sample(&self) -> Option<f64> {
        self.seconds_per_sample
    }

    /// Rows of `width` pixels (at least one) that `budget` of wall time buys on `threads`
    /// threads; one row before any measurement, to get one.
    pub fn rows_for(&self, budget: Duration, width: u32, threads: u32) -> u32 {
        let Some(per) = self.seconds_per_sample.filter(|&p| p > 0.0) else {
            return 1;
        };
        let samples = budget.as_secs_f64() * f64::from(threads.max(1)) / per;
        let rows = samples / f64::from(width.max(1));
        // `as` saturates: a vast budget asks for every row there is, and more.
        (rows.round() as u32).max(1)
    }
}
