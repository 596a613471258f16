//! The general-purpose dynamic structures side by side: the loose octree and the uniform grid
//! against the dynamic BVH on one moving workload (`dynamic.rs`), and the quadtree against
//! `rstar`'s R*-tree on flat boxes (`quadtree.rs`). Every structure's answers are checked
//! against its peer's in the same run; a difference is a miss in the report's stress rows.

mod dynamic;
mod quadtree;

use crate::json::{Report, StressRow};
use crate::progress::Progress;

/// Seconds of `f`, what it returns dropped off the clock.
fn secs<R>(f: impl FnOnce() -> R) -> f64 {
    let t = std::time::Instant::now();
    let r = std::hint::black_box(f());
    let s = t.elapsed().as_secs_f64();
    drop(r);
    s
}

/// One stress row of an equal-answer check: `cases` answers compared, `differ` of them
/// different from the peer's.
fn check_row(structure: &str, query: &str, cases: usize, differ: usize) -> StressRow {
    StressRow {
        structure: structure.to_string(),
        query: query.to_string(),
        cases: cases as u64,
        misses: differ as u64,
        ..StressRow::default()
    }
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let quad = quadtree::Settings::new(quick);
    let mut progress = Progress::new("structures", dynamic::STEPS + quad.steps());
    let mut report = Report {
        suite: "structures".into(),
        quick,
        ..Report::default()
    };
    dynamic::run(quick, &mut report, &mut progress);
    quadtree::run(&quad, &mut report, &mut progress);
    progress.finish();
    report
}
