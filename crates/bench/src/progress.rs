//! A progress line on stderr for the long suites: the step, how far, and the time so far.

use std::io::Write;
use std::time::{Duration, Instant};

/// Progress through a suite's steps; redraws at most a few times a second.
pub struct Progress {
    suite: &'static str,
    total: usize,
    done: usize,
    started: Instant,
    last_draw: Option<Instant>,
}

impl Progress {
    /// A suite of `total` steps.
    pub fn new(suite: &'static str, total: usize) -> Self {
        Self {
            suite,
            total,
            done: 0,
            started: Instant::now(),
            last_draw: None,
        }
    }

    /// One more step done; `label` says what runs next.
    pub fn step(&mut self, label: &str) {
        self.done += 1;
        let now = Instant::now();
        if self
            .last_draw
            .is_some_and(|t| now - t < Duration::from_millis(250))
            && self.done < self.total
        {
            return;
        }
        self.last_draw = Some(now);
        let mut err = std::io::stderr().lock();
        let _ = write!(
            err,
            "\r\x1b[2K[{}] {}/{} {:.1}s {}",
            self.suite,
            self.done.min(self.total),
            self.total,
            self.started.elapsed().as_secs_f64(),
            label
        );
        let _ = err.flush();
    }

    /// Ends the line.
    pub fn finish(&mut self) {
        eprintln!(
            "\r\x1b[2K[{}] done in {:.1}s",
            self.suite,
            self.started.elapsed().as_secs_f64()
        );
    }
}
