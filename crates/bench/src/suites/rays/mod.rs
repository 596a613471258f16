//! Ray time against error on triangles, and the tables of BENCHMARKS.md's "Rays on meshes":
//! primary (a camera's pixel grid), shadow (any hit), diffuse (one cosine-weighted bounce)
//! and incoherent rays through the bunny-copies scene, as mesh BVHs (the spatial-split build,
//! `MeshBvh::new`, the build over whole triangles), as a two-level `InstancedScene`, as box
//! trees with the watertight test in the callback, and through the peers obvhs 0.3.3 (CWBVH,
//! BVH2), bvh 0.13 and, when `TINYBVH_PEER` names the binary that
//! `crates/bench/peers/tinybvh/tinybvh.sh` builds, tinybvh's `BVH8_CPU` over its binned build
//! and over its SBVH. Every contender traces every ray set once per round, and each figure is
//! the median over rounds, beside the median of the per-round ratios to obvhs' CWBVH. The
//! error is the share of checked rays whose answer differs from `BruteForceMesh` (hit or
//! miss, or the distance by more than 1e-4 relative); differences beyond what two triangle
//! tests may disagree on are stress misses.

mod sets;
mod tracers;

use super::common::tinybvh::{PeerRays, TinyBvh};
use super::point;
use super::rounds::{Contender, median_ratio, run_rounds};
use crate::json::{Point, Report, StressRow};
use crate::progress::Progress;
use crate::timing::median;
use accel_testkit::instanced_triangle_scene;
use sets::{RaySet, ray_sets};
use spatial_accel::query::{BruteForceMesh, TriangleQuery};
use spatial_accel::{Aabb, Backfaces, Triangle};
use std::cell::RefCell;
use std::time::Instant;
use tracers::{BuildNote, MeshBuild, Traced, build_mesh, contenders, triangle_list};

/// tinybvh's layouts in the table: its 8-wide CPU layout over its default (binned) build and
/// over its SBVH (`BuildHQ`), with the table's names.
const LAYOUTS: [(&str, &str); 2] = [("bvh8_cpu", "binned"), ("bvh8_cpu_hq", "its SBVH")];

/// Rays per second of one pass of `trace` over `set`.
fn rays_per_second(t: &Traced<'_>, set: &RaySet) -> f64 {
    let start = Instant::now();
    let hits = (0..set.ours.len())
        .filter(|&i| (t.trace)(set, i).is_some())
        .count();
    std::hint::black_box(hits);
    set.ours.len() as f64 / start.elapsed().as_secs_f64()
}

/// Whether `got` differs from the oracle's `want` (any-hit rays only say blocked or not).
fn wrong(got: Option<f32>, want: Option<f32>, any_hit: bool) -> bool {
    match (got, want) {
        (Some(a), Some(b)) => !any_hit && (a - b).abs() > 1e-4 * b.abs().max(1.0),
        (a, b) => a.is_some() != b.is_some(),
    }
}

/// One column of the results: a contender's (or a tinybvh layout's) figures on every set.
struct Column {
    name: String,
    /// Its triangle test is not ours, so some edge rays may differ (see [`allowed`]).
    other_test: bool,
    /// Rays per second, per set, per round.
    rates: Vec<Vec<f64>>,
    /// Wrong answers among the checked rays, per set.
    wrong: Vec<usize>,
}

/// Differences from the oracle a contender with another triangle test may have on `checked`
/// rays without failing: one in a thousand (a ray through an edge two triangles share may hit
/// either; the old `ray_timing` allowed two in 2,000 against obvhs). None for ours, which run
/// the oracle's own watertight test.
fn allowed(other_test: bool, checked: usize) -> usize {
    if other_test {
        checked.div_ceil(1000)
    } else {
        0
    }
}

/// "4.48 M (4.20x)": the median rate and the median per-round ratio to `reference`.
fn cell(rates: &[f64], reference: &[f64]) -> String {
    format!(
        "{:.2} M ({:.2}x)",
        median(rates.to_vec()) / 1e6,
        median_ratio(rates, reference)
    )
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let (target, n_rays, checked, rounds) = if quick {
        (60_000, 4_000, 150, 3)
    } else {
        (1_000_000, 20_000, 400, 11)
    };
    let parts = instanced_triangle_scene(target, 2);
    let tris = parts.flatten();
    let boxes: Vec<Aabb> = tris.iter().map(Triangle::aabb).collect();
    let (vertices, indices) = triangle_list(&tris);
    let oracle = BruteForceMesh::new(&vertices, &indices).expect("a triangle list");
    let started = Instant::now();
    let new_mesh = build_mesh(&tris, MeshBuild::New);
    let new_note = BuildNote {
        name: "MeshBvh new".into(),
        seconds: started.elapsed().as_secs_f64(),
        bytes_per_triangle: new_mesh.memory_bytes() as f64 / tris.len() as f64,
    };
    let sets = ray_sets(n_rays, &new_mesh);
    let (traced, builds) = contenders(&tris, &boxes, &parts, new_note, new_mesh);
    let mut notes: Vec<String> = builds
        .iter()
        .map(|b| {
            format!(
                "{}: built in {:.2} s, {:.1} bytes per triangle",
                b.name, b.seconds, b.bytes_per_triangle
            )
        })
        .collect();
    let peer = TinyBvh::from_env(&tris).map(RefCell::new);
    let peer_sets: Vec<PeerRays> = match &peer {
        Some(p) => {
            let mut p = p.borrow_mut();
            for (layout, _) in LAYOUTS {
                let s = p.layout(layout);
                notes.push(format!("{} {layout}: built in {s:.2} s", p.version));
            }
            sets.iter()
                .map(|s| p.rays(s.name, &s.for_peer(), s.any_hit))
                .collect()
        }
        None => {
            notes.push(
                "tinybvh: TINYBVH_PEER is unset, so its columns are skipped (set it to the \
                 path crates/bench/peers/tinybvh/tinybvh.sh prints)"
                    .into(),
            );
            Vec::new()
        }
    };
    let version = peer.as_ref().map(|p| p.borrow().version.clone());
    let mut columns: Vec<Column> = traced
        .iter()
        .map(|t| Column {
            name: format!("{}, {}", t.method, t.setting),
            other_test: t.other_test,
            rates: Vec::new(),
            wrong: Vec::new(),
        })
        .collect();
    if let Some(v) = &version {
        columns.extend(LAYOUTS.iter().map(|(layout, _)| Column {
            name: format!("{v} {layout}"),
            other_test: true,
            rates: Vec::new(),
            wrong: Vec::new(),
        }));
    }
    let runs = columns.len() * rounds * sets.len();
    let mut progress = Progress::new("rays", runs);
    let step = (n_rays / checked).max(1);
    let mut hit_shares = Vec::new();
    for (k, set) in sets.iter().enumerate() {
        let sample: Vec<usize> = (0..set.ours.len()).step_by(step).collect();
        let want: Vec<Option<f32>> = sample
            .iter()
            .map(|&i| {
                let r = &set.ours[i];
                if set.any_hit {
                    oracle.cast_ray_any(r, Backfaces::Include).then_some(0.0)
                } else {
                    oracle.cast_ray(r, Backfaces::Include).map(|h| h.t)
                }
            })
            .collect();
        hit_shares.push(want.iter().filter(|w| w.is_some()).count() as f64 / want.len() as f64);
        let count_wrong = |answer: &dyn Fn(usize) -> Option<f32>| {
            sample
                .iter()
                .zip(&want)
                .filter(|&(&i, &w)| wrong(answer(i), w, set.any_hit))
                .count()
        };
        for (t, c) in traced.iter().zip(&mut columns) {
            c.wrong.push(count_wrong(&|i| (t.trace)(set, i)));
        }
        if let Some(p) = &peer {
            for (l, (layout, _)) in LAYOUTS.iter().enumerate() {
                let theirs = p.borrow_mut().hits(peer_sets[k], set.ours.len(), layout);
                columns[traced.len() + l]
                    .wrong
                    .push(count_wrong(&|i| theirs[i]));
            }
        }
        let mut runners: Vec<Contender<'_>> = traced
            .iter()
            .map(|t| {
                Contender::new(format!("{} {}", set.name, t.method), move || {
                    rays_per_second(t, set)
                })
            })
            .collect();
        if let Some(p) = &peer {
            let id = peer_sets[k];
            for (layout, _) in LAYOUTS {
                runners.push(Contender::new(format!("{} tinybvh", set.name), move || {
                    p.borrow_mut().trace(id, layout)
                }));
            }
        }
        for (c, s) in columns
            .iter_mut()
            .zip(run_rounds(&mut runners, rounds, &mut progress))
        {
            c.rates.push(s);
        }
    }
    progress.finish();
    drop(peer);
    let report = summarise(&sets, &columns, &hit_shares, sample_len(n_rays, step));
    Report {
        suite: "rays".into(),
        quick,
        notes: notes.into_iter().chain(report.notes).collect(),
        ..report
    }
}

/// How many rays of a set of `n` are checked at every `step`-th.
fn sample_len(n: usize, step: usize) -> usize {
    n.div_ceil(step)
}

/// The index of the column named `name`.
fn find(columns: &[Column], name: &str) -> Option<usize> {
    columns.iter().position(|c| c.name == name)
}

/// The report from the measured columns: points, both tables, the ratio notes and the
/// checks' stress rows.
fn summarise(sets: &[RaySet], columns: &[Column], hit_shares: &[f64], checked: usize) -> Report {
    let reference = find(columns, "obvhs cwbvh, medium").expect("obvhs is always run");
    let scene = "bunny copies";
    let mut points: Vec<Point> = Vec::new();
    let mut stress = Vec::new();
    for c in columns {
        let (method, setting) = c.name.split_once(", ").unwrap_or((c.name.as_str(), "-"));
        for (k, set) in sets.iter().enumerate() {
            points.push(point(
                &format!("{scene}, {}", set.name),
                method,
                setting,
                ("ns per ray", 1e9 / median(c.rates[k].clone())),
                (
                    "share of rays wrong",
                    Some(c.wrong[k] as f64 / checked as f64),
                ),
            ));
        }
        let allowance = allowed(c.other_test, checked);
        stress.push(StressRow {
            structure: c.name.clone(),
            query: "4 ray kinds against BruteForceMesh".into(),
            cases: (checked * sets.len()) as u64,
            misses: c
                .wrong
                .iter()
                .map(|&w| w.saturating_sub(allowance))
                .sum::<usize>() as u64,
            ..StressRow::default()
        });
    }
    let cw = &columns[reference].rates;
    let main = [
        find(columns, "MeshBvh, sbvh"),
        find(columns, "MeshBvh, new"),
        find(columns, "InstancedScene, sbvh meshes"),
        columns.iter().position(|c| c.name.ends_with("bvh8_cpu")),
        columns.iter().position(|c| c.name.ends_with("bvh8_cpu_hq")),
    ];
    let mut markdown = vec![
        "| rays | `MeshBvh` (SBVH) | `MeshBvh::new` | `InstancedScene` (SBVH meshes) | tinybvh \
         `BVH8_CPU`, binned | tinybvh `BVH8_CPU`, its SBVH | our SBVH / tinybvh's SBVH |"
            .to_string(),
        "|---|---:|---:|---:|---:|---:|---:|".to_string(),
    ];
    for (k, set) in sets.iter().enumerate() {
        let cells: Vec<String> = main
            .iter()
            .map(|c| c.map_or("-".into(), |c| cell(&columns[c].rates[k], &cw[k])))
            .collect();
        let versus = match (main[0], main[4]) {
            (Some(ours), Some(theirs)) => format!(
                "{:.2}",
                median_ratio(&columns[ours].rates[k], &columns[theirs].rates[k])
            ),
            _ => "-".into(),
        };
        markdown.push(format!(
            "| {} | {} | {versus} |",
            set.name,
            cells.join(" | ")
        ));
    }
    markdown.push(String::new());
    markdown.push(format!(
        "| contender | {} |",
        sets.iter().map(|s| s.name).collect::<Vec<_>>().join(" | ")
    ));
    markdown.push(format!("|---|{}", "---:|".repeat(sets.len())));
    for c in columns {
        let cells: Vec<String> = (0..sets.len()).map(|k| cell(&c.rates[k], &cw[k])).collect();
        markdown.push(format!("| {} | {} |", c.name, cells.join(" | ")));
    }
    let mut notes = Vec::new();
    let ours = find(columns, "MeshBvh, sbvh").expect("always run");
    let bvh = find(columns, "bvh 0.13 + watertight, default").expect("always run");
    for (k, set) in sets.iter().enumerate() {
        let mut line = format!(
            "{} rays ({:.1}% of the checked ones hit): MeshBvh sbvh {:.2}x obvhs cwbvh, {:.1}x \
             bvh 0.13",
            set.name,
            100.0 * hit_shares[k],
            median_ratio(&columns[ours].rates[k], &cw[k]),
            median_ratio(&columns[ours].rates[k], &columns[bvh].rates[k]),
        );
        for c in main[3..].iter().flatten() {
            line.push_str(&format!(
                ", {:.2}x {}",
                median_ratio(&columns[ours].rates[k], &columns[*c].rates[k]),
                columns[*c].name
            ));
        }
        notes.push(line + " (medians of per-round ratios)");
    }
    Report {
        points,
        markdown,
        notes,
        stress,
        ..Report::default()
    }
}
