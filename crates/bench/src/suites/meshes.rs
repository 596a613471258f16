//! Mesh BVH builds and refits: the build and refit rows of BENCHMARKS.md's "Mesh builds and
//! instanced scenes". On the UV sphere (about a million triangles; a small one with
//! `--quick`), `MeshBvh::new` and two other builds against obvhs 0.3.3's BVH2 (fastest and
//! medium presets) and CWBVH (medium) from the same triangles, and `MeshBvh::refit` after
//! every vertex moved against an obvhs BVH2 refit doing the same work (new triangles, leaf
//! boxes, `refit_all`). On the 1M-triangle bunny-copies scene, the spatial-split build
//! (`MeshBvh::with_spatial_splits`) against `MeshBvh::new` and, when `TINYBVH_PEER` names the
//! binary that `crates/bench/peers/tinybvh/tinybvh.sh` builds, tinybvh's `BuildHQ` with its
//! `BVH8_CPU` conversion; and each tree's memory per triangle. Every contender runs once per
//! round; times are medians over rounds, speed-ups medians of per-round ratios. Builds rate
//! by our SAH cost (`SahCosts::default()`), refits by the refitted tree's.
//!
//! Replaces `examples/mesh_timing.rs`, and the build lines `examples/ray_timing.rs` printed
//! (build time and memory of the spatial-split tree).

use super::common::peers::ObvhsBvh2;
use super::common::tinybvh::TinyBvh;
use super::point;
use super::rounds::{Contender, median_ratio, run_rounds, seconds};
use crate::json::{Point, Report};
use crate::progress::Progress;
use crate::timing::median;
use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use spatial_accel::bvh::stats::tree_stats;
use spatial_accel::mesh::{MeshBvh, SpatialSplits};
use spatial_accel::query::BoundingTree;
use spatial_accel::{Aabb, BuildConfig, SahCosts, SplitStrategy};
use std::time::Duration;

/// The target for a refit, in ns per triangle.
const REFIT_TARGET_NS: f64 = 20.0;

/// Our SAH cost of a binary tree.
fn sah<T: BoundingTree<Volume = Aabb> + ?Sized>(tree: &T) -> f64 {
    tree_stats(tree, &SahCosts::default()).sah_cost as f64
}

/// obvhs triangles of an indexed mesh.
fn obvhs_tris(vertices: &[Vec3], indices: &[u32]) -> Vec<obvhs::triangle::Triangle> {
    indices
        .chunks_exact(3)
        .map(|t| obvhs::triangle::Triangle {
            v0: Vec3A::from(vertices[t[0] as usize]),
            v1: Vec3A::from(vertices[t[1] as usize]),
            v2: Vec3A::from(vertices[t[2] as usize]),
        })
        .collect()
}

/// What one part adds to the report.
struct Part {
    points: Vec<Point>,
    markdown: Vec<String>,
    notes: Vec<String>,
}

/// The sphere's builds and refits.
fn sphere(quick: bool, progress: &mut Progress) -> Part {
    let side = if quick { 100 } else { 708 };
    let mesh = accel_testkit::shapes::uv_sphere(side, side, 10.0);
    let (vertices, indices) = (mesh.positions(), mesh.flat_indices());
    let n = indices.len() / 3;
    let scene = format!("the sphere, {n} triangles");
    let tris = obvhs_tris(&vertices, &indices);
    let ours = |config: Option<BuildConfig>| {
        let (v, i) = (&vertices, &indices);
        move || {
            seconds(|| match &config {
                Some(c) => MeshBvh::with_config(v, i, c),
                None => MeshBvh::new(v, i),
            })
        }
    };
    let obvhs_build = |params: BvhBuildParams, wide: bool| {
        let tris = &tris;
        move || {
            if wide {
                seconds(|| {
                    obvhs::cwbvh::builder::build_cwbvh_from_tris(
                        tris,
                        params,
                        &mut Duration::default(),
                    )
                })
            } else {
                seconds(|| {
                    obvhs::bvh2::builder::build_bvh2_from_tris(
                        tris,
                        params,
                        &mut Duration::default(),
                    )
                })
            }
        }
    };
    let ploc = BuildConfig::with_split(SplitStrategy::PLOC_FASTEST);
    let binned = BuildConfig::with_split(SplitStrategy::BinnedSah { bins: 16 });
    let mut builds = vec![
        Contender::new("MeshBvh::new", ours(None)),
        Contender::new("MeshBvh PLOC fastest", ours(Some(ploc))),
        Contender::new("MeshBvh binned16", ours(Some(binned))),
        Contender::new(
            "obvhs BVH2 fastest",
            obvhs_build(BvhBuildParams::fastest_build(), false),
        ),
        Contender::new(
            "obvhs BVH2 medium",
            obvhs_build(BvhBuildParams::medium_build(), false),
        ),
        Contender::new(
            "obvhs CWBVH medium",
            obvhs_build(BvhBuildParams::medium_build(), true),
        ),
    ];
    let build_s = run_rounds(&mut builds, if quick { 2 } else { 3 }, progress);
    let names: Vec<String> = builds.iter().map(|c| c.name.clone()).collect();
    drop(builds);
    let mesh_of = |c: Option<&BuildConfig>| {
        match c {
            Some(c) => MeshBvh::with_config(&vertices, &indices, c),
            None => MeshBvh::new(&vertices, &indices),
        }
        .expect("a valid mesh")
    };
    let bvh2_of = |params| {
        obvhs::bvh2::builder::build_bvh2_from_tris(&tris, params, &mut Duration::default())
    };
    let costs = [
        Some(sah(mesh_of(None).tree())),
        Some(sah(mesh_of(Some(&ploc)).tree())),
        Some(sah(mesh_of(Some(&binned)).tree())),
        Some(sah(&ObvhsBvh2(&bvh2_of(BvhBuildParams::fastest_build())))),
        Some(sah(&ObvhsBvh2(&bvh2_of(BvhBuildParams::medium_build())))),
        // A CWBVH is 8-wide: no binary SAH cost.
        None,
    ];
    let mut points: Vec<Point> = names
        .iter()
        .zip(&build_s)
        .zip(costs)
        .map(|((name, s), q)| {
            point(
                &scene,
                name,
                "build",
                ("build ms", median(s.clone()) * 1e3),
                ("SAH cost", q),
            )
        })
        .collect();
    let rate = |s: &[f64]| n as f64 / median(s.to_vec()) / 1e6;

    // A skinned-like pose: every vertex displaced a little.
    let moved: Vec<Vec3> = vertices
        .iter()
        .enumerate()
        .map(|(i, v)| *v * (1.0 + 0.01 * (i % 7) as f32))
        .collect();
    let mut ours_mesh = mesh_of(None);
    let mut bvh2 = bvh2_of(BvhBuildParams::medium_build());
    let mut theirs = tris.clone();
    let mut refits = vec![
        Contender::new("MeshBvh::refit", || {
            seconds(|| ours_mesh.refit(&moved).expect("the same vertex count"))
        }),
        Contender::new("obvhs BVH2 refit", || {
            seconds(|| {
                for (tri, t) in theirs.iter_mut().zip(indices.chunks_exact(3)) {
                    *tri = obvhs::triangle::Triangle {
                        v0: Vec3A::from(moved[t[0] as usize]),
                        v1: Vec3A::from(moved[t[1] as usize]),
                        v2: Vec3A::from(moved[t[2] as usize]),
                    };
                }
                for node in bvh2.nodes.iter_mut().filter(|n| n.is_leaf()) {
                    let (first, count) = (node.first_index as usize, node.prim_count as usize);
                    let b = bvh2.primitive_indices[first..first + count]
                        .iter()
                        .fold(obvhs::aabb::Aabb::INVALID, |acc, &p| {
                            acc.union(&theirs[p as usize].aabb())
                        });
                    node.set_aabb(b);
                }
                bvh2.refit_all();
            })
        }),
    ];
    let refit_s = run_rounds(&mut refits, if quick { 3 } else { 5 }, progress);
    drop(refits);
    let ns = |s: &[f64]| median(s.to_vec()) * 1e9 / n as f64;
    points.push(point(
        &scene,
        "MeshBvh::refit",
        "every vertex moved",
        ("ns per triangle", ns(&refit_s[0])),
        ("SAH cost", Some(sah(ours_mesh.tree()))),
    ));
    points.push(point(
        &scene,
        "obvhs BVH2 refit",
        "every vertex moved",
        ("ns per triangle", ns(&refit_s[1])),
        ("SAH cost", Some(sah(&ObvhsBvh2(&bvh2)))),
    ));
    let refit_ns = ns(&refit_s[0]);
    let met = if refit_ns <= REFIT_TARGET_NS {
        "met"
    } else {
        "**not met**"
    };
    let markdown = vec![
        format!(
            "| `MeshBvh::refit`, per triangle (the sphere) | {refit_ns:.1} ns | obvhs BVH2 refit \
             (new triangles, leaf boxes, `refit_all`) {:.1} ns | {:.2}x | issue target \
             {REFIT_TARGET_NS} ns: {met} |",
            ns(&refit_s[1]),
            median_ratio(&refit_s[1], &refit_s[0]),
        ),
        format!(
            "| `MeshBvh::new` build (the sphere) | {:.2} M tris/s | obvhs CWBVH medium {:.2} M/s; \
             obvhs BVH2 fastest (binary, no wide collapse) {:.2} M/s | {:.2}x CWBVH, {:.2}x BVH2 \
             | |",
            rate(&build_s[0]),
            rate(&build_s[5]),
            rate(&build_s[3]),
            median_ratio(&build_s[5], &build_s[0]),
            median_ratio(&build_s[3], &build_s[0]),
        ),
    ];
    let notes = names
        .iter()
        .zip(&build_s)
        .map(|(name, s)| {
            format!(
                "the sphere ({n} triangles), {name}: {:.2} M tris/s (including the triangle \
                 boxes), {:.2}x MeshBvh::new's time",
                rate(s),
                median_ratio(s, &build_s[0])
            )
        })
        .collect();
    Part {
        points,
        markdown,
        notes,
    }
}

/// The spatial-split build on the bunny-copies scene, against `MeshBvh::new` and tinybvh's
/// `BuildHQ`, and both trees' memory.
fn spatial_splits(quick: bool, progress: &mut Progress) -> Part {
    let tris = accel_testkit::triangle_scene(if quick { 60_000 } else { 1_000_000 }, 2);
    let n = tris.len();
    let vertices: Vec<Vec3> = tris
        .iter()
        .flat_map(|t| t.vertices.map(Vec3::from))
        .collect();
    let indices: Vec<u32> = (0..vertices.len() as u32).collect();
    let sbvh = || {
        MeshBvh::with_spatial_splits(
            &vertices,
            &indices,
            &BuildConfig::default(),
            &SpatialSplits::default(),
        )
        .expect("a triangle list")
    };
    let new = || MeshBvh::new(&vertices, &indices).expect("a triangle list");
    let mut peer = TinyBvh::from_env(&tris);
    let version = peer.as_ref().map(|p| p.version.clone());
    let mut contenders = vec![
        Contender::new("MeshBvh::with_spatial_splits", || seconds(sbvh)),
        Contender::new("MeshBvh::new", || seconds(new)),
    ];
    if let Some(p) = &mut peer {
        contenders.push(Contender::new("tinybvh BuildHQ", || {
            p.layout("bvh8_cpu_hq")
        }));
    }
    let s = run_rounds(&mut contenders, if quick { 1 } else { 3 }, progress);
    drop(contenders);
    drop(peer);
    let (split_tree, new_tree) = (sbvh(), new());
    let bytes = |m: &MeshBvh| m.memory_bytes() as f64 / n as f64;
    let scene = format!("{} bunny-copies triangles", n);
    let mut points = Vec::new();
    for (name, tree, t) in [
        ("MeshBvh sbvh", &split_tree, &s[0]),
        ("MeshBvh::new", &new_tree, &s[1]),
    ] {
        let time = ("build s", median(t.clone()));
        points.push(point(
            &scene,
            name,
            "16-wide",
            time,
            ("SAH cost", Some(sah(tree.tree()))),
        ));
        points.push(point(
            &scene,
            name,
            "16-wide",
            time,
            ("bytes per triangle", Some(bytes(tree))),
        ));
    }
    let (peer_cell, speedup, notes) = match (&version, s.get(2)) {
        (Some(v), Some(hq)) => {
            points.push(point(
                &scene,
                "tinybvh BuildHQ + BVH8_CPU",
                "8-wide",
                ("build s", median(hq.clone())),
                ("SAH cost", None),
            ));
            (
                format!(
                    "{v} `BuildHQ` with its `BVH8_CPU` conversion {:.2} s",
                    median(hq.clone())
                ),
                format!("{:.2}x", median_ratio(hq, &s[0])),
                Vec::new(),
            )
        }
        _ => (
            "tinybvh skipped (TINYBVH_PEER unset)".to_string(),
            String::new(),
            vec![
                "tinybvh: TINYBVH_PEER is unset, so its BuildHQ is skipped (set it to the path \
                 crates/bench/peers/tinybvh/tinybvh.sh prints)"
                    .to_string(),
            ],
        ),
    };
    let short = if n.is_multiple_of(1_000_000) {
        format!("{}M", n / 1_000_000)
    } else {
        format!("{}k", n / 1_000)
    };
    Part {
        points,
        markdown: vec![
            format!(
                "| `MeshBvh::with_spatial_splits` build ({short} triangles) | {:.2} s | \
                 {peer_cell} | {speedup} | `MeshBvh::new` {:.2} s |",
                median(s[0].clone()),
                median(s[1].clone()),
            ),
            format!(
                "| memory per triangle (tree, packets with ids, vertex indices) | {:.1} B \
                 (`new`), {:.1} B (SBVH) | | | |",
                bytes(&new_tree),
                bytes(&split_tree),
            ),
        ],
        notes,
    }
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let runs = if quick {
        6 * 2 + 2 * 3 + 3
    } else {
        6 * 3 + 2 * 5 + 3 * 3
    };
    let mut progress = Progress::new("meshes", runs);
    let parts = [
        sphere(quick, &mut progress),
        spatial_splits(quick, &mut progress),
    ];
    progress.finish();
    let mut report = Report {
        suite: "meshes".into(),
        quick,
        markdown: vec![
            "| figure | accel | peer, same run | accel speed-up | note |".into(),
            "|---|---:|---|---:|---|".into(),
        ],
        ..Report::default()
    };
    for part in parts {
        report.points.extend(part.points);
        report.markdown.extend(part.markdown);
        report.notes.extend(part.notes);
    }
    report
}
