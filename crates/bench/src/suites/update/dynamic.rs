//! The dynamic BVH at full size (100,000 boxes of the shared dynamic workload, centres
//! uniform in [-200, 200]^3, half extents 0.1-1.0; 10,000 with `--quick`), one thread unless
//! a row says otherwise, beside obvhs 0.3.3's dynamic `Bvh2` on the same boxes: edits, moves
//! and refits ([`edits`]), then busy frames, the quality they leave, the empty frame and the
//! ray snapshot ([`frames`]). Its Markdown table is BENCHMARKS.md's "Dynamic BVH" table.
//!
//! The parry3d peer is a package of its own (`crates/bench/peers/parry`): its dependencies
//! would add crates and versions to the workspace's lock file.

mod edits;
mod frames;

use crate::json::{Point, Report, StressRow};
use crate::progress::Progress;
use accel_testkit::dynamic_workload::{built_tree, scene};
use spatial_accel::Aabb;

/// Our box as obvhs's.
fn to_obvhs(b: &Aabb) -> obvhs::aabb::Aabb {
    obvhs::aabb::Aabb::new(b.min, b.max)
}

/// A figure in three significant digits or so, with its unit.
fn fig(x: f64, unit: &str) -> String {
    let digits = match x.abs() {
        x if x >= 100.0 => 0,
        x if x >= 10.0 => 1,
        x if x >= 1.0 => 2,
        _ => 3,
    };
    format!("{x:.digits$} {unit}")
}

/// One line of the section's table.
pub struct Row {
    /// What is measured.
    figure: String,
    /// Our figure.
    accel: String,
    /// The peer and its figure from the same run, or empty.
    peer: String,
    /// The peer's time over ours, or empty.
    speedup: String,
    /// The target for our figure and whether it is met, or empty.
    target: String,
}

impl Row {
    /// "met" or "missed" for `ours` against an upper bound `(bound, as written)`.
    fn target(ours: f64, target: Option<(f64, &str)>) -> String {
        target.map_or_else(String::new, |(bound, text)| {
            format!("{text}: {}", if ours <= bound { "met" } else { "missed" })
        })
    }

    /// Our time beside a peer's, both in `unit` (lower is better).
    fn peer(
        figure: String,
        (ours, theirs, unit, peer): (f64, f64, &str, &str),
        target: Option<(f64, &str)>,
    ) -> Self {
        Self {
            figure,
            accel: fig(ours, unit),
            peer: format!("{peer} {}", fig(theirs, unit)),
            speedup: format!("{:.2}x", theirs / ours),
            target: Self::target(ours, target),
        }
    }

    /// Our time without a peer.
    fn alone(figure: String, ours: f64, unit: &str, target: Option<(f64, &str)>) -> Self {
        Self {
            figure,
            accel: fig(ours, unit),
            peer: String::new(),
            speedup: String::new(),
            target: Self::target(ours, target),
        }
    }

    /// A row whose cells are written by the caller (ratios, pairs of figures).
    fn text(figure: String, accel: String, peer: String, target: String) -> Self {
        Self {
            figure,
            accel,
            peer,
            speedup: String::new(),
            target,
        }
    }
}

/// What the section's parts add to the report as they run.
pub struct Section {
    /// The table's lines.
    rows: Vec<Row>,
    /// Time against quality.
    points: Vec<Point>,
    /// Figures the table leaves out.
    notes: Vec<String>,
    /// Self-checks: our answers against a brute-force scan, the peer's tree against its boxes.
    stress: Vec<StressRow>,
    /// The first few failures' messages.
    samples: Vec<String>,
    /// Progress through the parts.
    progress: Progress,
}

impl Section {
    /// Adds a line of the table.
    fn row(&mut self, row: Row) {
        self.rows.push(row);
    }

    /// One more part done; `label` says what runs next.
    fn step(&mut self, label: &str) {
        self.progress.step(label);
    }

    /// Records a self-check of `cases` cases with `misses` wrong answers.
    fn check(&mut self, structure: &str, query: &str, cases: u64, misses: Vec<String>) {
        self.stress.push(StressRow {
            structure: structure.into(),
            query: query.into(),
            cases,
            misses: misses.len() as u64,
            ..StressRow::default()
        });
        self.samples.extend(misses.into_iter().take(3));
    }
}

/// Runs the section and adds it to `report`.
pub fn run(quick: bool, report: &mut Report) {
    let n = if quick { 10_000 } else { 100_000 };
    let boxes = scene(n, 1);
    // Best-of runs of the timed edits; median rounds of the refit; busy frames.
    let (runs, rounds, frame_count) = if quick { (2, 4, 50) } else { (5, 40, 1_000) };
    let mut s = Section {
        rows: Vec::new(),
        points: Vec::new(),
        notes: Vec::new(),
        stress: Vec::new(),
        samples: Vec::new(),
        progress: Progress::new("update: dynamic BVH", 9),
    };
    edits::run(&mut s, &boxes, runs, rounds);
    frames::run(&mut s, &boxes, frame_count, if quick { 3 } else { 9 });
    s.step("done");
    s.progress.finish();

    report.markdown.push(format!(
        "| figure ({n} boxes) | accel | peer, same run | accel speed-up | issue target |"
    ));
    report.markdown.push("|---|---:|---|---:|---|".into());
    for r in &s.rows {
        report.markdown.push(format!(
            "| {} | {} | {} | {} | {} |",
            r.figure, r.accel, r.peer, r.speedup, r.target
        ));
    }
    report.markdown.push(String::new());
    report.points.append(&mut s.points);
    report.notes.append(&mut s.notes);
    report.stress.append(&mut s.stress);
    report.failure_samples.append(&mut s.samples);
}
