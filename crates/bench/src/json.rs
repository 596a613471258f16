//! The report every suite returns, and its JSON form (`--json FILE`).

use serde::Serialize;
use std::path::Path;

/// One measurement: a method at one setting on one scene, its time and its error or quality
/// (both lower-is-better), as one point of a plot.
#[derive(Clone, Debug, Serialize)]
pub struct Point {
    /// The input it ran on; with `time_name` and `quality_name`, the plot it belongs to.
    pub scene: String,
    /// The method (a build strategy, a structure, a peer crate).
    pub method: String,
    /// The method's setting (an arity, a budget, a schedule).
    pub setting: String,
    /// What `time` measures, with its unit.
    pub time_name: String,
    /// The time.
    pub time: f64,
    /// What `quality` measures (lower is better).
    pub quality_name: String,
    /// The error or quality figure; `None` where the method has none (it is then left out
    /// of the plot, not drawn at zero).
    pub quality: Option<f64>,
    /// On the Pareto front of its plot (no other point is both faster and better).
    pub pareto: bool,
}

/// One row of failure counts: a structure and a query, the cases run and what went wrong. The
/// stress suite's rows, and the plugin suites' checks against Bevy (culling's false negatives,
/// picking's wrong mesh hits, as misses).
#[derive(Clone, Debug, Default, Serialize)]
pub struct StressRow {
    /// The structure under test.
    pub structure: String,
    /// The query or operation.
    pub query: String,
    /// The cases run.
    pub cases: u64,
    /// Answers that lacked what the brute-force oracle found (or a must-hit ray that missed).
    pub misses: u64,
    /// Entries lost, duplicated, stale or unaccounted for after edits; memory that grew
    /// without more entries.
    pub leaks: u64,
    /// Cases that panicked.
    pub panics: u64,
    /// NaN in an output (a hit distance, a bound, a statistic).
    pub nans: u64,
}

impl StressRow {
    /// Misses, leaks, panics and NaNs together.
    pub fn failures(&self) -> u64 {
        self.misses + self.leaks + self.panics + self.nans
    }
}

/// What one suite found.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    /// The suite's name.
    pub suite: String,
    /// Whether it ran at `--quick` sizes.
    pub quick: bool,
    /// Wall time of the suite.
    pub seconds: f64,
    /// Time against error or quality.
    pub points: Vec<Point>,
    /// A suite's own table in Markdown, one line each (the frame suite's, as the bench it
    /// absorbed printed it), for pasting into BENCHMARKS.md.
    pub markdown: Vec<String>,
    /// Figures derived from the points (ratios, speed-ups), one line each.
    pub notes: Vec<String>,
    /// The failure counts (the stress suite's, and the plugin suites' checks against Bevy).
    pub stress: Vec<StressRow>,
    /// Sample messages of what failed (the first few), to start debugging from.
    pub failure_samples: Vec<String>,
}

impl Report {
    /// Total failures (0 for the suites that only time).
    pub fn failures(&self) -> u64 {
        self.stress.iter().map(StressRow::failures).sum()
    }
}

/// Writes every report as one JSON array.
pub fn write(path: &Path, reports: &[Report]) -> std::io::Result<()> {
    let text = serde_json::to_string_pretty(reports).map_err(std::io::Error::other)?;
    std::fs::write(path, text)
}
