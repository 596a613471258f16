//! Contenders timed round by round: every round runs each contender once, in turn, so that a
//! ratio taken within one round compares two measurements made under the same load. The
//! machine these figures come from is shared and its memory system has fast and slow phases;
//! a ratio of two separately taken medians moves with them, a median of per-round ratios far
//! less. Used by the suites that report a peer's figure beside ours (`build`'s static builds,
//! `rays`, `meshes`).

use crate::progress::Progress;
use crate::timing::median;

/// One contender: its name, and one run of it, returning the figure of that run (seconds, or
/// rays per second: whatever the suite compares).
pub struct Contender<'a> {
    /// Its row's name.
    pub name: String,
    /// Runs it once and returns the run's figure.
    pub run: Box<dyn FnMut() -> f64 + 'a>,
}

impl<'a> Contender<'a> {
    /// A contender named `name`.
    pub fn new(name: impl Into<String>, run: impl FnMut() -> f64 + 'a) -> Self {
        Self {
            name: name.into(),
            run: Box::new(run),
        }
    }
}

/// Runs `rounds` rounds of every contender, stepping `progress` once per run; the figures,
/// one vector per contender in the contenders' order, one entry per round.
pub fn run_rounds(
    contenders: &mut [Contender<'_>],
    rounds: usize,
    progress: &mut Progress,
) -> Vec<Vec<f64>> {
    let mut samples = vec![Vec::with_capacity(rounds); contenders.len()];
    for round in 0..rounds {
        for (c, s) in contenders.iter_mut().zip(&mut samples) {
            progress.step(&format!("round {} {}", round + 1, c.name));
            s.push((c.run)());
        }
    }
    samples
}

/// The median over rounds of `numerator[i] / denominator[i]`: for times, the denominator's
/// speed-up over the numerator when the numerator is the peer's; for rates, the other way.
pub fn median_ratio(numerator: &[f64], denominator: &[f64]) -> f64 {
    median(
        numerator
            .iter()
            .zip(denominator)
            .map(|(a, b)| a / b)
            .collect(),
    )
}

/// Seconds taken by one call of `f`; what it returns is dropped after the clock stops.
pub fn seconds<R>(f: impl FnOnce() -> R) -> f64 {
    let start = std::time::Instant::now();
    let r = std::hint::black_box(f());
    let t = start.elapsed().as_secs_f64();
    drop(r);
    t
}
