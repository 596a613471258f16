//! The table of BENCHMARKS.md's "Static BVH builds", as part of the `build` suite:
//! single-threaded builds of `spatial_accel::Bvh` over the 1M triangles (a triangle build's time
//! includes making the triangle boxes, as obvhs' `*_from_tris` does) and over the 100k entity
//! boxes, round by round against obvhs 0.3.3's BVH2 (and, when `TINYBVH_PEER` names the binary
//! that `crates/bench/peers/tinybvh/tinybvh.sh` builds, tinybvh's single-threaded
//! `BVH::BuildAVX`); the plugin's static entity tree (its build under the plugin's rules and
//! its 16-wide ray copy with ids inlined); and a frustum query over 1M entity boxes against a
//! flat loop. SAH costs are ours for every tree (`SahCosts::default()`: traversal 2,
//! intersection 1, over the root's area), the peers' binary trees included.

use super::common::peers::{self, BvhCrateTree, BvhShape, ObvhsBvh2};
use super::common::tinybvh::TinyBvh;
use super::point;
use super::rounds::{Contender, median_ratio, run_rounds, seconds};
use crate::json::{Point, Report, StressRow};
use crate::progress::Progress;
use crate::timing::median;
use accel_testkit::{entity_boxes, triangle_scene};
use glam::Vec3A;
use obvhs::BvhBuildParams;
use spatial_accel::bvh::stats::tree_stats;
use spatial_accel::bvh::wide::{Bvh8, Bvh16};
use spatial_accel::query::BoundingTree;
use spatial_accel::{
    Aabb, BuildConfig, Bvh, Containment, SahCosts, SpatialQuery, SplitStrategy, Triangle,
};
use std::time::Duration;

/// Our strategies in the table's triangle rows, in its order.
const TRI_SPLITS: [(&str, SplitStrategy); 5] = [
    ("binned SAH, 8 bins", SplitStrategy::BinnedSah { bins: 8 }),
    ("binned SAH, 16 bins", SplitStrategy::BinnedSah { bins: 16 }),
    ("PLOC fastest", SplitStrategy::PLOC_FASTEST),
    ("`SplitStrategy::PLOC`", SplitStrategy::PLOC),
    ("LBVH", SplitStrategy::Lbvh),
];

/// Our strategies in the table's box rows, in its order.
const BOX_SPLITS: [(&str, SplitStrategy); 4] = [
    ("LBVH", SplitStrategy::Lbvh),
    ("PLOC fastest", SplitStrategy::PLOC_FASTEST),
    ("binned SAH, 8 bins", SplitStrategy::BinnedSah { bins: 8 }),
    ("binned SAH, 16 bins", SplitStrategy::BinnedSah { bins: 16 }),
];

/// The table's header; the rows follow it.
const HEADER: [&str; 2] = [
    "| what | accel | peer, same run | accel speed-up | SAH, ours / peer's |",
    "|---|---:|---|---:|---:|",
];

/// Our SAH cost of a binary tree.
fn sah<T: BoundingTree<Volume = Aabb>>(tree: &T) -> f64 {
    tree_stats(tree, &SahCosts::default()).sah_cost as f64
}

/// `n` in the tables' short form: 1M, 100k, 20k.
fn short(n: usize) -> String {
    if n >= 1_000_000 && n.is_multiple_of(1_000_000) {
        format!("{}M", n / 1_000_000)
    } else if n >= 1_000 {
        format!("{}k", n / 1_000)
    } else {
        n.to_string()
    }
}

/// A build time with its rate, as `<ms> ms (<millions per second> M/s)`.
fn ms_rate(s: f64, n: usize) -> String {
    format!("{:.1} ms ({:.2} M/s)", s * 1e3, n as f64 / s / 1e6)
}

/// What one part of the table adds to the report.
struct Part {
    points: Vec<Point>,
    markdown: Vec<String>,
    notes: Vec<String>,
}

/// The triangle rows: ours, obvhs BVH2 fastest and tinybvh `BuildAVX`, round by round.
fn triangles(quick: bool, progress: &mut Progress) -> Part {
    let tris = triangle_scene(if quick { 50_000 } else { 1_000_000 }, 2);
    let n = tris.len();
    let rounds = if quick { 3 } else { 9 };
    let scene = format!("{} triangles (build rounds)", short(n));
    let ot: Vec<obvhs::triangle::Triangle> = tris.iter().map(peers::to_obvhs_tri).collect();
    let mut peer = TinyBvh::from_env(&tris);
    let mut notes = Vec::new();
    let mut contenders: Vec<Contender<'_>> = TRI_SPLITS
        .iter()
        .map(|&(name, split)| {
            let cfg = BuildConfig::with_split(split);
            let tris = &tris;
            Contender::new(name, move || {
                seconds(|| {
                    let boxes: Vec<Aabb> = tris.iter().map(Triangle::aabb).collect();
                    Bvh::build(&boxes, &cfg)
                })
            })
        })
        .collect();
    contenders.push(Contender::new("obvhs BVH2 fastest", || {
        seconds(|| {
            obvhs::bvh2::builder::build_bvh2_from_tris(
                &ot,
                BvhBuildParams::fastest_build(),
                &mut Duration::default(),
            )
        })
    }));
    let version = peer.as_ref().map(|p| p.version.clone());
    match &mut peer {
        Some(p) => {
            let own_sah = p.build_avx().1;
            notes.push(format!(
                "{} BuildAVX over {n} triangles: tinybvh's own SAH cost {own_sah:.2} (its \
                 constants, not ours)",
                p.version
            ));
            contenders.push(Contender::new("tinybvh BuildAVX", || p.build_avx().0));
        }
        None => notes.push(
            "tinybvh: TINYBVH_PEER is unset, so its BuildAVX column is skipped (set it to the \
             path crates/bench/peers/tinybvh/tinybvh.sh prints)"
                .into(),
        ),
    }
    let samples = run_rounds(&mut contenders, rounds, progress);
    drop(contenders);
    // The trees' shapes, from one more build each, outside the timing.
    let boxes: Vec<Aabb> = tris.iter().map(Triangle::aabb).collect();
    let ours_sah: Vec<f64> = TRI_SPLITS
        .iter()
        .map(|&(_, split)| sah(&Bvh::build(&boxes, &BuildConfig::with_split(split))))
        .collect();
    let peer_sah = |params| {
        sah(&ObvhsBvh2(&obvhs::bvh2::builder::build_bvh2_from_tris(
            &ot,
            params,
            &mut Duration::default(),
        )))
    };
    let (fastest_sah, medium_sah) = (
        peer_sah(BvhBuildParams::fastest_build()),
        peer_sah(BvhBuildParams::medium_build()),
    );
    let obvhs_s = &samples[TRI_SPLITS.len()];
    let tiny_s = version.as_ref().map(|_| &samples[TRI_SPLITS.len() + 1]);
    let mut peer_cell = format!("obvhs BVH2 fastest {}", ms_rate(median(obvhs_s.clone()), n));
    if let (Some(v), Some(t)) = (&version, tiny_s) {
        peer_cell = format!(
            "{v} `BuildAVX` {}; {peer_cell}",
            ms_rate(median(t.clone()), n)
        );
    }
    let mut markdown = Vec::new();
    let mut points = Vec::new();
    for (i, &(name, split)) in TRI_SPLITS.iter().enumerate() {
        let t = median(samples[i].clone());
        let mut speedup = format!("{:.2}x obvhs", median_ratio(obvhs_s, &samples[i]));
        if let Some(ts) = tiny_s {
            speedup = format!("{:.2}x tinybvh, {speedup}", median_ratio(ts, &samples[i]));
        }
        // PLOC with reinsertion aims at obvhs medium's tree, in about its fastest's time.
        let sah_cell = if split == SplitStrategy::PLOC {
            format!("{:.2} / {medium_sah:.2} (medium)", ours_sah[i])
        } else {
            format!("{:.2} / {fastest_sah:.2}", ours_sah[i])
        };
        markdown.push(format!(
            "| {} triangles, {name} | {} | {} | {speedup} | {sah_cell} |",
            short(n),
            ms_rate(t, n),
            if i == 0 {
                peer_cell.as_str()
            } else {
                "as above"
            },
        ));
        points.push(point(
            &scene,
            &format!("accel {name}"),
            "binary",
            ("build ms", t * 1e3),
            ("SAH cost", Some(ours_sah[i])),
        ));
    }
    points.push(point(
        &scene,
        "obvhs BVH2 fastest",
        "binary",
        ("build ms", median(obvhs_s.clone()) * 1e3),
        ("SAH cost", Some(fastest_sah)),
    ));
    if let Some(ts) = tiny_s {
        // tinybvh's tree is not read back, so it has no SAH cost of ours.
        points.push(point(
            &scene,
            "tinybvh BuildAVX",
            "binned 8",
            ("build ms", median(ts.clone()) * 1e3),
            ("SAH cost", None),
        ));
    }
    Part {
        points,
        markdown,
        notes,
    }
}

/// The box rows: ours against obvhs BVH2 fastest and the `bvh` crate over the entity boxes.
fn boxes(quick: bool, progress: &mut Progress) -> Part {
    let boxes = entity_boxes(if quick { 20_000 } else { 100_000 }, 1);
    let n = boxes.len();
    let rounds = if quick { 3 } else { 9 };
    let scene = format!("{} entity boxes (build rounds)", short(n));
    let ob: Vec<obvhs::aabb::Aabb> = boxes.iter().map(peers::to_obvhs_aabb).collect();
    let mut shapes: Vec<BvhShape> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| BvhShape::new(i, b))
        .collect();
    let mut contenders: Vec<Contender<'_>> = BOX_SPLITS
        .iter()
        .map(|&(name, split)| {
            let cfg = BuildConfig::with_split(split);
            let boxes = &boxes;
            Contender::new(name, move || seconds(|| Bvh::build(boxes, &cfg)))
        })
        .collect();
    contenders.push(Contender::new("obvhs BVH2 fastest", || {
        seconds(|| {
            obvhs::bvh2::builder::build_bvh2(
                &ob,
                BvhBuildParams::fastest_build(),
                &mut Duration::default(),
            )
        })
    }));
    // The crate only writes each shape's node index, so the shapes are reused.
    contenders.push(Contender::new("bvh 0.13", || {
        seconds(|| bvh::bvh::Bvh::build(&mut shapes))
    }));
    let samples = run_rounds(&mut contenders, rounds, progress);
    drop(contenders);
    let ours_sah: Vec<f64> = BOX_SPLITS
        .iter()
        .map(|&(_, split)| sah(&Bvh::build(&boxes, &BuildConfig::with_split(split))))
        .collect();
    let obvhs_sah = sah(&ObvhsBvh2(&obvhs::bvh2::builder::build_bvh2(
        &ob,
        BvhBuildParams::fastest_build(),
        &mut Duration::default(),
    )));
    let bvh_sah = sah(&BvhCrateTree::new(&bvh::bvh::Bvh::build(&mut shapes)));
    let (obvhs_s, bvh_s) = (&samples[BOX_SPLITS.len()], &samples[BOX_SPLITS.len() + 1]);
    let mut markdown = Vec::new();
    let mut points = Vec::new();
    let mut notes = Vec::new();
    for (i, &(name, _)) in BOX_SPLITS.iter().enumerate() {
        let t = median(samples[i].clone());
        markdown.push(format!(
            "| {} boxes, {name} | {:.2} ms | obvhs BVH2 fastest {:.2} ms | {:.2}x | \
             {:.2} / {obvhs_sah:.2} |",
            short(n),
            t * 1e3,
            median(obvhs_s.clone()) * 1e3,
            median_ratio(obvhs_s, &samples[i]),
            ours_sah[i],
        ));
        notes.push(format!(
            "{} boxes, {name}: {:.1}x the bvh 0.13 build's speed (its SAH {bvh_sah:.2})",
            short(n),
            median_ratio(bvh_s, &samples[i]),
        ));
        points.push(point(
            &scene,
            &format!("accel {name}"),
            "binary",
            ("build ms", t * 1e3),
            ("SAH cost", Some(ours_sah[i])),
        ));
    }
    for (method, s, q) in [
        ("obvhs BVH2 fastest", obvhs_s, obvhs_sah),
        ("bvh 0.13", bvh_s, bvh_sah),
    ] {
        points.push(point(
            &scene,
            method,
            "binary",
            ("build ms", median(s.clone()) * 1e3),
            ("SAH cost", Some(q)),
        ));
    }
    Part {
        points,
        markdown,
        notes,
    }
}

/// The plugin's static entity tree: random boxes at the plugin's picking-bench density,
/// built under the plugin's rules (PLOC fastest, leaves of up to 4, an entity costed at four
/// node visits: `entity_tree_config` in `src/scenery.rs`), then its 16-wide ray copy with ids
/// inlined; binned SAH under the same rules and the `Bvh8` copy for comparison.
fn entity_tree(n: usize, quick: bool, progress: &mut Progress) -> Part {
    let mut rng = accel_testkit::Rng::new(7);
    // One entity per 64 cubic units, as in the plugin's picking bench.
    let half = (n as f32 * 64.0).cbrt() / 2.0;
    let boxes: Vec<Aabb> = (0..n)
        .map(|_| {
            let c = (Vec3A::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0) * half;
            Aabb::from_center_half_extents(c, Vec3A::splat(1.5))
        })
        .collect();
    let plugin = BuildConfig {
        split: SplitStrategy::PLOC_FASTEST,
        max_leaf_size: 4,
        sah: SahCosts {
            traversal: 1.0,
            intersection: 4.0,
        },
        ..BuildConfig::default()
    };
    let binned = BuildConfig {
        split: SplitStrategy::BinnedSah { bins: 16 },
        ..plugin
    };
    let bvh = Bvh::build(&boxes, &plugin);
    let mut contenders = vec![
        Contender::new("PLOC fastest build", || {
            seconds(|| Bvh::build(&boxes, &plugin))
        }),
        Contender::new("binned16 build", || seconds(|| Bvh::build(&boxes, &binned))),
        Contender::new("16-wide copy, ids inlined", || {
            seconds(|| {
                let mut wide = Bvh16::from_bvh(&bvh);
                wide.inline_single_leaves();
                wide
            })
        }),
        Contender::new("Bvh8 copy", || seconds(|| Bvh8::from_bvh(&bvh))),
    ];
    let samples = run_rounds(&mut contenders, if quick { 2 } else { 5 }, progress);
    drop(contenders);
    let t: Vec<f64> = samples.iter().map(|s| median(s.clone()) * 1e3).collect();
    let (ploc_sah, binned_sah) = (sah(&bvh), sah(&Bvh::build(&boxes, &binned)));
    let scene = format!("plugin static tree, {} boxes", short(n));
    Part {
        points: vec![
            point(
                &scene,
                "PLOC fastest",
                "plugin rules",
                ("build ms", t[0]),
                ("SAH cost", Some(ploc_sah)),
            ),
            point(
                &scene,
                "binned16",
                "plugin rules",
                ("build ms", t[1]),
                ("SAH cost", Some(binned_sah)),
            ),
        ],
        markdown: vec![
            format!(
                "| {scene}: PLOC fastest build | {:.1} ms | binned SAH 16 under the same rules \
                 {:.1} ms | {:.2}x | {ploc_sah:.2} / {binned_sah:.2} (binned) |",
                t[0],
                t[1],
                median_ratio(&samples[1], &samples[0]),
            ),
            format!(
                "| {scene}: 16-wide ray copy (collapse, ids inlined) | {:.1} ms (`Bvh8`: {:.1} \
                 ms) | none | | |",
                t[2], t[3],
            ),
        ],
        notes: vec![format!(
            "a rebuild of the plugin's static tree at {} entities (build, then the 16-wide \
             copy): {:.1} ms",
            short(n),
            t[0] + t[2]
        )],
    }
}

/// The frustum query: a binned-16 tree over 1M entity boxes against a flat loop, with ~5% of
/// the boxes not outside; both must find the same boxes (a difference is a stress miss).
fn frustum(quick: bool, progress: &mut Progress) -> (Part, StressRow) {
    let boxes = entity_boxes(if quick { 100_000 } else { 1_000_000 }, 4);
    let n = boxes.len();
    let (f, visible) = super::common::frustum_selecting(&boxes, 0.05);
    let bvh = Bvh::build(&boxes, &BuildConfig::default());
    let flat = |out: &mut Vec<u32>| {
        out.extend((0..n as u32).filter(|&i| f.intersects_aabb(&boxes[i as usize])));
    };
    let tree = |out: &mut Vec<u32>| {
        bvh.for_each_in_frustum(&f, |p, how| {
            if how == Containment::Inside || f.intersects_aabb(&boxes[p as usize]) {
                out.push(p);
            }
        });
    };
    let (mut want, mut got) = (Vec::new(), Vec::new());
    flat(&mut want);
    tree(&mut got);
    want.sort_unstable();
    got.sort_unstable();
    let misses = want
        .iter()
        .filter(|i| got.binary_search(i).is_err())
        .count()
        + got
            .iter()
            .filter(|i| want.binary_search(i).is_err())
            .count();
    let mut out = Vec::with_capacity(visible);
    let mut contenders = vec![
        Contender::new("flat loop", || {
            out.clear();
            seconds(|| flat(&mut out))
        }),
        Contender::new("binned16 tree", || {
            got.clear();
            seconds(|| tree(&mut got))
        }),
    ];
    let samples = run_rounds(&mut contenders, if quick { 3 } else { 9 }, progress);
    drop(contenders);
    let (t_flat, t_tree) = (median(samples[0].clone()), median(samples[1].clone()));
    let scene = format!("frustum over {} boxes", short(n));
    let share = 100.0 * visible as f64 / n as f64;
    let part = Part {
        points: vec![
            point(
                &scene,
                "flat loop",
                "-",
                ("ms per query", t_flat * 1e3),
                ("SAH cost", None),
            ),
            point(
                &scene,
                "binned16 tree",
                "binary",
                ("ms per query", t_tree * 1e3),
                ("SAH cost", Some(sah(&bvh))),
            ),
        ],
        markdown: vec![format!(
            "| query: frustum over {} boxes, {share:.0}% visible, binned16 tree | {:.2} ms | a \
             flat loop of `Frustum::intersects_aabb`, {:.1} ms | {:.1}x | |",
            short(n),
            t_tree * 1e3,
            t_flat * 1e3,
            median_ratio(&samples[0], &samples[1]),
        )],
        notes: Vec::new(),
    };
    let row = StressRow {
        structure: "Bvh (binned16)".into(),
        query: "frustum, against a flat loop".into(),
        cases: want.len() as u64,
        misses: misses as u64,
        ..StressRow::default()
    };
    (part, row)
}

/// Runs every part of the table and adds it to `report`: points, the Markdown table, notes
/// and the frustum check's stress row.
pub fn add(quick: bool, report: &mut Report) {
    let sizes: &[usize] = if quick {
        &[50_000, 10_000]
    } else {
        &[1_000_000, 100_000]
    };
    let tri_runs = (TRI_SPLITS.len() + 2) * if quick { 3 } else { 9 };
    let box_runs = (BOX_SPLITS.len() + 2) * if quick { 3 } else { 9 };
    let tree_runs = sizes.len() * 4 * if quick { 2 } else { 5 };
    let frustum_runs = 2 * if quick { 3 } else { 9 };
    let mut progress = Progress::new("build", tri_runs + box_runs + tree_runs + frustum_runs);
    let mut parts = vec![triangles(quick, &mut progress), boxes(quick, &mut progress)];
    for &n in sizes {
        parts.push(entity_tree(n, quick, &mut progress));
    }
    let (query, row) = frustum(quick, &mut progress);
    parts.push(query);
    progress.finish();
    report.markdown.extend(HEADER.map(String::from));
    for part in parts {
        report.points.extend(part.points);
        report.markdown.extend(part.markdown);
        report.notes.extend(part.notes);
    }
    report.stress.push(row);
}
