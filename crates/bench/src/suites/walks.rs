//! What the shared walks of `spatial_accel::query::walks` and `spatial_accel::query::views` cost per query,
//! through every tree they serve: the static binary `Bvh`, the `DynamicBvh`, the 8-wide `Bvh8`
//! and the `SphereBvh` over one box scene, with closest-hit rays, single frusta, six views at
//! once (a point light's faces), box overlap and the 8 nearest. Every query but the wide
//! tree's rays runs the shared code; the wide tree's own SIMD ray walk is set against the
//! shared walk over the same tree, and a linear scan (`BruteForceIndex`) is every tree's peer
//! and oracle: any answer that differs from the scan's is a miss.
//!
//! The scene: N boxes of half extent 1.5, one per 64 cubic units, centres from a fixed
//! 64-bit LCG (100,000 boxes; 10,000 with `--quick`); 4,096 rays, 64 frusta, ten six-view
//! groups, 1,024 box queries and 1,024 8-nearest queries. Median of 7 rounds, ns per query
//! (the scan: one round).
//!
//! This replaces `crates/spatial_accel/examples/walk_timing.rs`; its table is BENCHMARKS.md's
//! "Shared walks".

use super::point;
use crate::json::{Report, StressRow};
use crate::progress::Progress;
use crate::timing::median;
use core::ops::ControlFlow;
use glam::{Mat4, Vec3, Vec3A};
use spatial_accel::bvh::SphereBvh;
use spatial_accel::bvh::wide::Bvh8;
use spatial_accel::query::views::ViewClassification;
use spatial_accel::query::{BoundingTree, BruteForceIndex, RayWalk, ray_walk, walks};
use spatial_accel::{
    Aabb, BuildConfig, Bvh, Containment, DynamicBvh, Frustum, Ray, SpatialQuery, SplitStrategy,
};
use std::hint::black_box;
use std::time::Instant;

/// The queries, in the table's column order.
const QUERIES: [&str; 5] = ["rays", "frustum", "six views", "boxes", "8 nearest"];

/// One tree's timing and answers, run when its turn comes.
type Measure<'a> = dyn Fn() -> ([f64; 5], Answers) + 'a;

/// The peer's name in the table and plots.
const SCAN: &str = "a linear scan (BruteForceIndex)";

/// The inputs every tree is asked.
struct Workload {
    boxes: Vec<Aabb>,
    rays: Vec<Ray>,
    frusta: Vec<Frustum>,
    centers: Vec<Vec3A>,
}

/// The scene and queries of `n` boxes, from a fixed stream of floats in [0, 1) (a 64-bit
/// LCG's high bits), so that every build compared sees the same ones.
fn workload(n: usize) -> Workload {
    let mut state = 0x853c_49e6_748f_ea9bu64;
    let mut next = move || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let half = (n as f32 * 64.0).cbrt() / 2.0;
    let mut point = || (Vec3A::new(next(), next(), next()) * 2.0 - 1.0) * half;
    let boxes = (0..n)
        .map(|_| Aabb::from_center_half_extents(point(), Vec3A::splat(1.5)))
        .collect();
    let rays = (0..4096)
        .map(|_| Ray::new(point(), (point() - point()).normalize_or(Vec3A::X)))
        .collect();
    let centers: Vec<Vec3A> = (0..1024).map(|_| point()).collect();
    let frusta = (0..64)
        .map(|i| {
            let eye = Vec3::from(centers[i]);
            let view = Mat4::look_at_rh(eye, Vec3::from(centers[i + 64]), Vec3::Y);
            let proj = Mat4::perspective_rh(0.6, 1.5, 0.1, half * 0.5);
            Frustum::from_clip_from_world(&(proj * view))
        })
        .collect();
    Workload {
        boxes,
        rays,
        frusta,
        centers,
    }
}

/// A tree's rays through the shared front-to-back walk over its `BoundingTree` view, whatever
/// walk of its own it has: the wide tree's peer of its SIMD walk.
struct SharedRayWalk<'a, T>(&'a T);

impl<T: BoundingTree> RayWalk for SharedRayWalk<'_, T> {
    fn walk_ray<V>(&self, ray: &mut Ray, visit: V)
    where
        V: FnMut(u32, &mut Ray) -> ControlFlow<()>,
    {
        walks::visit_ray_front_to_back(self.0, ray, visit)
    }
}

/// What a tree answered, for the check against the scan.
struct Answers {
    /// Each ray's closest hit distance.
    rays: Vec<Option<f32>>,
    /// Each query's count of boxes passing the exact test (frusta; six views, one per box and
    /// view; boxes), and each 8-nearest query's squared distances.
    frustum: Vec<usize>,
    views: Vec<usize>,
    overlap: Vec<usize>,
    nearest: Vec<Vec<f32>>,
}

/// One of each query on `tree`, returning its answer.
struct Queries<'a, T> {
    tree: &'a T,
    w: &'a Workload,
}

impl<T: SpatialQuery> Queries<'_, T> {
    fn ray(&self, ray: &Ray) -> Option<f32> {
        let boxes = &self.w.boxes;
        self.tree
            .cast_ray(ray, |i, r| r.intersect_aabb(&boxes[i as usize]))
            .map(|h| h.t)
    }

    fn frustum(&self, f: &Frustum) -> usize {
        let mut seen = 0;
        self.tree.for_each_in_frustum(f, |i, c| {
            if c == Containment::Inside || f.intersects_aabb(&self.w.boxes[i as usize]) {
                seen += 1;
            }
        });
        seen
    }

    /// Six views at once, as a point light's cube faces are walked.
    fn views(&self, six: &[Frustum]) -> usize {
        let classify = |b: &Aabb, undecided: u32| {
            let mut c = ViewClassification::default();
            for (v, f) in six
                .iter()
                .enumerate()
                .filter(|(v, _)| undecided & (1 << v) != 0)
            {
                match f.classify_aabb(b) {
                    Containment::Inside => c.inside |= 1 << v,
                    Containment::Outside => c.outside |= 1 << v,
                    Containment::Intersecting => {}
                }
            }
            c
        };
        let mut seen = 0;
        self.tree.for_each_in_views(0b11_1111, classify, |i, m| {
            let b = &self.w.boxes[i as usize];
            for (v, f) in six.iter().enumerate() {
                let bit = 1 << v;
                if m.inside & bit != 0 || (m.crossing & bit != 0 && f.intersects_aabb(b)) {
                    seen += 1;
                }
            }
        });
        seen
    }

    fn overlap(&self, c: Vec3A) -> usize {
        let q = Aabb::from_center_half_extents(c, Vec3A::splat(8.0));
        let mut seen = 0;
        self.tree.for_each_overlapping_aabb(&q, |i| {
            seen += usize::from(self.w.boxes[i as usize].intersects_aabb(&q));
            ControlFlow::Continue(())
        });
        seen
    }

    fn nearest(&self, c: Vec3A) -> Vec<f32> {
        let boxes = &self.w.boxes;
        self.tree
            .nearest_k(c, 8, |i| boxes[i as usize].distance_squared_to_point(c))
            .into_iter()
            .map(|(_, d)| d)
            .collect()
    }

    /// Every query once, untimed.
    fn answers(&self) -> Answers {
        let w = self.w;
        Answers {
            rays: w.rays.iter().map(|r| self.ray(r)).collect(),
            frustum: w.frusta.iter().map(|f| self.frustum(f)).collect(),
            views: w.frusta.chunks_exact(6).map(|s| self.views(s)).collect(),
            overlap: w.centers.iter().map(|&c| self.overlap(c)).collect(),
            nearest: w.centers.iter().map(|&c| self.nearest(c)).collect(),
        }
    }

    /// ns per query of each kind, in [`QUERIES`] order: the median of `rounds` rounds after
    /// one to warm up (none for a single round).
    fn times(&self, rounds: usize) -> [f64; 5] {
        let w = self.w;
        let groups = w.frusta.len() / 6;
        [
            median_ns(rounds, w.rays.len(), || {
                w.rays.iter().for_each(|r| {
                    black_box(self.ray(r));
                })
            }),
            median_ns(rounds, w.frusta.len(), || {
                w.frusta.iter().for_each(|f| {
                    black_box(self.frustum(f));
                })
            }),
            median_ns(rounds, groups, || {
                w.frusta.chunks_exact(6).for_each(|s| {
                    black_box(self.views(s));
                })
            }),
            median_ns(rounds, w.centers.len(), || {
                w.centers.iter().for_each(|&c| {
                    black_box(self.overlap(c));
                })
            }),
            median_ns(rounds, w.centers.len(), || {
                w.centers.iter().for_each(|&c| {
                    black_box(self.nearest(c));
                })
            }),
        ]
    }
}

/// The median over `rounds` rounds of one round's time per query, ns.
fn median_ns(rounds: usize, queries: usize, mut round: impl FnMut()) -> f64 {
    if rounds > 1 {
        round();
    }
    let times = (0..rounds.max(1))
        .map(|_| {
            let start = Instant::now();
            round();
            start.elapsed().as_nanos() as f64 / queries.max(1) as f64
        })
        .collect();
    median(times)
}

/// The messages of the queries where `ours` differs from the scan's `truth`, per query kind.
fn differences(name: &str, ours: &Answers, truth: &Answers) -> [Vec<String>; 5] {
    fn diff<T: PartialEq + std::fmt::Debug>(
        name: &str,
        query: &str,
        a: &[T],
        b: &[T],
    ) -> Vec<String> {
        a.iter()
            .zip(b)
            .enumerate()
            .filter(|(_, (x, y))| x != y)
            .map(|(k, (x, y))| format!("{name} {query} {k}: {x:?}, a scan finds {y:?}"))
            .collect()
    }
    [
        diff(name, "ray", &ours.rays, &truth.rays),
        diff(name, "frustum", &ours.frustum, &truth.frustum),
        diff(name, "six views", &ours.views, &truth.views),
        diff(name, "box", &ours.overlap, &truth.overlap),
        diff(name, "8 nearest", &ours.nearest, &truth.nearest),
    ]
}

/// A cell of ns per query.
fn ns(x: f64) -> String {
    let whole = x.round() as u64;
    let digits = whole.to_string();
    let mut out = String::new();
    for (i, ch) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let n = if quick { 10_000 } else { 100_000 };
    let rounds = if quick { 3 } else { 7 };
    let w = workload(n);
    let mut progress = Progress::new("walks", 8);
    progress.step("builds");
    let config = BuildConfig {
        split: SplitStrategy::PLOC_FASTEST,
        max_leaf_size: 4,
        ..BuildConfig::default()
    };
    let bvh = Bvh::build(&w.boxes, &config);
    let wide = Bvh8::from_bvh(&bvh);
    let spheres = SphereBvh::from_bvh(&bvh, &w.boxes);
    let mut dynamic = DynamicBvh::new();
    for (i, b) in w.boxes.iter().enumerate() {
        dynamic.insert(i as u32, *b).expect("a finite box");
    }
    dynamic.maintain();
    let scan = BruteForceIndex::from_boxes(&w.boxes);

    progress.step("a linear scan");
    let scan_q = Queries { tree: &scan, w: &w };
    let truth = scan_q.answers();
    let scan_times = scan_q.times(1);
    let scan_bytes = size_of_val(scan.boxes()) + size_of_val(scan.ids());

    let mut report = Report {
        suite: "walks".into(),
        quick,
        ..Report::default()
    };
    let scene = format!("{n} entity boxes");
    let mut rows: Vec<(String, [f64; 5], usize)> = Vec::new();
    // The scan is the oracle: its own row has no answers to check.
    let mut measure = |name: &str, times: [f64; 5], answers: Option<Answers>, bytes: usize| {
        let checked = answers.map(|a| differences(name, &a, &truth));
        for (k, wrong) in checked.into_iter().flatten().enumerate() {
            report.stress.push(StressRow {
                structure: name.into(),
                query: format!("{} vs a scan", QUERIES[k]),
                cases: [
                    truth.rays.len(),
                    truth.frustum.len(),
                    truth.views.len(),
                    truth.overlap.len(),
                    truth.nearest.len(),
                ][k] as u64,
                misses: wrong.len() as u64,
                ..StressRow::default()
            });
            report.failure_samples.extend(wrong.into_iter().take(2));
        }
        for (k, &t) in times.iter().enumerate() {
            report.points.push(point(
                &format!("{scene}, {}", QUERIES[k]),
                name,
                if name == SCAN {
                    "-"
                } else {
                    "PLOC, leaves of 4"
                },
                ("ns per query", t),
                ("bytes per box", Some(bytes as f64 / n as f64)),
            ));
        }
        rows.push((name.to_string(), times, bytes));
    };
    let trees: [(&str, &Measure, usize); 4] = [
        (
            "Bvh",
            &|| {
                let q = Queries { tree: &bvh, w: &w };
                (q.times(rounds), q.answers())
            },
            bvh.memory_bytes(),
        ),
        (
            "DynamicBvh",
            &|| {
                let q = Queries {
                    tree: &dynamic,
                    w: &w,
                };
                (q.times(rounds), q.answers())
            },
            dynamic.memory_bytes(),
        ),
        (
            "Bvh8",
            &|| {
                let q = Queries { tree: &wide, w: &w };
                (q.times(rounds), q.answers())
            },
            wide.memory_bytes(),
        ),
        (
            "SphereBvh",
            &|| {
                let q = Queries {
                    tree: &spheres,
                    w: &w,
                };
                (q.times(rounds), q.answers())
            },
            spheres.memory_bytes(),
        ),
    ];
    for (name, go, bytes) in trees {
        progress.step(name);
        let (times, answers) = go();
        measure(name, times, Some(answers), bytes);
    }
    measure(SCAN, scan_times, None, scan_bytes);

    progress.step("Bvh8 rays by the shared walk");
    let shared = SharedRayWalk(&wide);
    let shared_ray = |r: &Ray| {
        ray_walk::closest_hit(&shared, r, |i, ray| {
            ray.intersect_aabb(&w.boxes[i as usize])
        })
        .map(|h| h.t)
    };
    let shared_ns = median_ns(rounds, w.rays.len(), || {
        w.rays.iter().for_each(|r| {
            black_box(shared_ray(r));
        })
    });
    let shared_answers: Vec<Option<f32>> = w.rays.iter().map(shared_ray).collect();
    let wrong: Vec<String> = shared_answers
        .iter()
        .zip(&truth.rays)
        .enumerate()
        .filter(|(_, (a, b))| a != b)
        .map(|(k, (a, b))| format!("Bvh8 shared walk ray {k}: {a:?}, a scan finds {b:?}"))
        .collect();
    report.stress.push(StressRow {
        structure: "Bvh8, shared ray walk".into(),
        query: "rays vs a scan".into(),
        cases: w.rays.len() as u64,
        misses: wrong.len() as u64,
        ..StressRow::default()
    });
    report.failure_samples.extend(wrong.into_iter().take(2));
    report.points.push(point(
        &format!("{scene}, rays"),
        "Bvh8, shared walk",
        "PLOC, leaves of 4",
        ("ns per query", shared_ns),
        ("bytes per box", Some(wide.memory_bytes() as f64 / n as f64)),
    ));
    progress.step("done");
    progress.finish();

    report.markdown.push(format!(
        "| tree ({n} boxes) | rays | frustum | six views | boxes | 8 nearest | bytes per box |"
    ));
    report
        .markdown
        .push("|---|---:|---:|---:|---:|---:|---:|".into());
    for (name, times, bytes) in &rows {
        let cells: Vec<String> = times.iter().map(|&t| ns(t)).collect();
        report.markdown.push(format!(
            "| {} | {} | {:.1} |",
            if *name == SCAN {
                name.to_string()
            } else {
                format!("`{name}`")
            },
            cells.join(" | "),
            *bytes as f64 / n as f64
        ));
    }
    let bvh8 = rows.iter().find(|r| r.0 == "Bvh8").map_or(0.0, |r| r.1[0]);
    report.markdown.push(format!(
        "| `Bvh8`, rays by the shared walk instead of its SIMD walk | {} | | | | | |",
        ns(shared_ns)
    ));
    report.markdown.push(String::new());
    report.notes.push(format!(
        "Bvh8 rays: its own SIMD walk {:.2}x faster than the shared walk over its view",
        shared_ns / bvh8
    ));
    if let Some((_, base, _)) = rows.iter().find(|r| r.0 == "Bvh") {
        for (name, times, _) in rows.iter().filter(|r| r.0 != "Bvh") {
            let ratios: Vec<String> = QUERIES
                .iter()
                .zip(times.iter().zip(base))
                .map(|(q, (t, b))| format!("{q} {:.2}x", t / b))
                .collect();
            report
                .notes
                .push(format!("{name} / Bvh: {}", ratios.join(", ")));
        }
    }
    report
}
