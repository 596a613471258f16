//! A progress bar on stderr for the long suites: the step, how far, and the time so far.
//! indicatif draws it only where stderr is a terminal; the closing line is printed either way.

use indicatif::{ProgressBar, ProgressState, ProgressStyle};
use std::fmt::Write;
use std::time::Instant;

/// Progress through a suite's steps; redrawn at the steps only (no ticking thread while a
/// suite measures).
pub struct Progress {
    suite: &'static str,
    started: Instant,
    bar: ProgressBar,
}

impl Progress {
    /// A suite of `total` steps.
    pub fn new(suite: &'static str, total: usize) -> Self {
        let style = ProgressStyle::with_template("[{prefix}] {pos}/{len} {seconds} {wide_msg}")
            .expect("a valid template")
            .with_key("seconds", |state: &ProgressState, w: &mut dyn Write| {
                let _ = write!(w, "{:.1}s", state.elapsed().as_secs_f64());
            });
        let bar = ProgressBar::new(total as u64)
            .with_style(style)
            .with_prefix(suite);
        Self {
            suite,
            started: Instant::now(),
            bar,
        }
    }

    /// One more step done; `label` says what runs next.
    pub fn step(&mut self, label: &str) {
        if self.bar.position() < self.bar.length().unwrap_or(u64::MAX) {
            self.bar.inc(1);
        }
        self.bar.set_message(label.to_string());
    }

    /// Clears the bar and says how long the suite took.
    pub fn finish(&mut self) {
        self.bar.finish_and_clear();
        eprintln!(
            "[{}] done in {:.1}s",
            self.suite,
            self.started.elapsed().as_secs_f64()
        );
    }
}
