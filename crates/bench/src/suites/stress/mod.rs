//! The numerical-stability stress suite: every structure and query under hostile input,
//! each answer compared with the brute-force oracles of `spatial_accel::query`.
//!
//! - [`meshes`]: closed meshes far from the origin, huge and tiny, hit by rays from outside
//!   to inside (axis-parallel, grazing, through vertices and shared edges): every one must hit.
//! - [`boxes`]: the box structures on degenerate, far, huge and tiny scenes, every query.
//! - [`nonfinite`]: NaN and infinite values in every input of every query and edit.
//! - [`drift`]: long runs of moves, refits, removals and insertions, checked for lost or
//!   duplicated entries, bounds that no longer hold their entries, and memory growth.
//!
//! Each case runs under `catch_unwind`; the counts go to a [`Tally`].

mod boxes;
mod drift;
mod meshes;
mod nonfinite;
mod oracle;

use crate::json::{Report, StressRow};
use crate::progress::Progress;
use std::cell::Cell;
use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Arc;

/// The standard library's panic hook type.
type PanicHook = dyn Fn(&std::panic::PanicHookInfo<'_>) + Send + Sync + 'static;

thread_local! {
    /// Whether this thread is inside a [`Tally::guard`]ed case.
    static IN_CASE: Cell<bool> = const { Cell::new(false) };
}

/// At most this many failure messages are kept for the report.
const SAMPLES: usize = 60;

/// The counts per structure and query, and the first failure messages.
#[derive(Default)]
pub struct Tally {
    rows: Vec<StressRow>,
    index: HashMap<(String, String), usize>,
    samples: Vec<String>,
}

/// What went wrong in one case.
#[derive(Clone, Copy, Debug)]
pub enum Failure {
    /// The oracle found what the structure did not, or a must-hit ray missed.
    Miss,
    /// An entry lost, duplicated or stale; memory that grew.
    Leak,
    /// A NaN in an output.
    Nan,
}

impl Tally {
    /// The row of a structure and query, made on first use.
    pub fn row(&mut self, structure: &str, query: &str) -> &mut StressRow {
        let key = (structure.to_string(), query.to_string());
        let i = *self.index.entry(key).or_insert_with(|| {
            self.rows.push(StressRow {
                structure: structure.to_string(),
                query: query.to_string(),
                ..StressRow::default()
            });
            self.rows.len() - 1
        });
        &mut self.rows[i]
    }

    /// Counts one case.
    pub fn case(&mut self, structure: &str, query: &str) {
        self.row(structure, query).cases += 1;
    }

    /// Counts a failure; `what` describes it for the first few.
    pub fn fail(
        &mut self,
        structure: &str,
        query: &str,
        kind: Failure,
        what: impl FnOnce() -> String,
    ) {
        let row = self.row(structure, query);
        match kind {
            Failure::Miss => row.misses += 1,
            Failure::Leak => row.leaks += 1,
            Failure::Nan => row.nans += 1,
        }
        // One sample per row and kind, so that one frequent failure does not hide the rest.
        let first = match kind {
            Failure::Miss => row.misses == 1,
            Failure::Leak => row.leaks == 1,
            Failure::Nan => row.nans == 1,
        };
        if first && self.samples.len() < SAMPLES {
            let mut what = what();
            what.truncate(400);
            self.samples
                .push(format!("{structure} / {query}: {kind:?}: {what}"));
        }
    }

    /// Runs one case of `structure`/`query` under `catch_unwind`: a panic is counted, and
    /// `None` returned.
    pub fn guard<R>(
        &mut self,
        structure: &str,
        query: &str,
        f: impl FnOnce(&mut Tally) -> R,
    ) -> Option<R> {
        self.case(structure, query);
        let was = IN_CASE.replace(true);
        let result = catch_unwind(AssertUnwindSafe(|| f(self)));
        IN_CASE.set(was);
        match result {
            Ok(r) => Some(r),
            Err(payload) => {
                self.row(structure, query).panics += 1;
                if self.row(structure, query).panics == 1 && self.samples.len() < SAMPLES {
                    let msg = payload
                        .downcast_ref::<String>()
                        .cloned()
                        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                        .unwrap_or_default();
                    self.samples
                        .push(format!("{structure} / {query}: panic: {msg}"));
                }
                None
            }
        }
    }
}

/// Sizes of one run.
#[derive(Clone, Copy, Debug)]
pub struct Sizes {
    /// Rays per closed mesh, placement and ray family.
    pub mesh_rays: usize,
    /// Queries of each kind per box structure and scene.
    pub box_queries: usize,
    /// Random non-finite cases in all.
    pub nonfinite_cases: usize,
    /// Frames of each drift run.
    pub frames: usize,
    /// Entries of each drift run.
    pub entries: usize,
}

impl Sizes {
    fn new(quick: bool) -> Self {
        if quick {
            Self {
                mesh_rays: 24,
                box_queries: 12,
                nonfinite_cases: 30_000,
                frames: 60,
                entries: 300,
            }
        } else {
            Self {
                mesh_rays: 200,
                box_queries: 60,
                nonfinite_cases: 1_000_000,
                frames: 1_500,
                entries: 2_000,
            }
        }
    }
}

/// Runs every stress case and returns the counts.
pub fn run(quick: bool) -> Report {
    let sizes = Sizes::new(quick);
    let mut tally = Tally::default();
    let mut progress = Progress::new("stress", 4);
    // Panics inside a case are counted, not printed (the default hook would print every
    // one of them); a panic outside the cases still reports itself.
    let hook: Arc<PanicHook> = Arc::from(std::panic::take_hook());
    let outer = hook.clone();
    std::panic::set_hook(Box::new(move |info| {
        if !IN_CASE.get() {
            outer(info);
        }
    }));
    progress.step("closed meshes");
    meshes::run(&mut tally, &sizes);
    progress.step("box scenes");
    boxes::run(&mut tally, &sizes);
    progress.step("non-finite input");
    nonfinite::run(&mut tally, &sizes);
    progress.step("drift");
    drift::run(&mut tally, &sizes);
    let _ = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| hook(info)));
    progress.finish();
    Report {
        suite: "stress".into(),
        quick,
        stress: tally.rows,
        failure_samples: tally.samples,
        ..Report::default()
    }
}
