//! The BSP tree (`spatial_accel::bsp`) on the Stanford bunny as read (3,674 triangles): its build
//! with the default `BspConfig` (8 candidate planes a node, priced on up to 128 triangles,
//! splits weighted 4 against imbalance), one painter's order of every piece from an eye
//! outside the bunny, and 1,000 closest-hit rays through the bunny's box (the watertight test
//! on each reached piece's source) against `MeshBvh` on the same rays.
//!
//! The tree is validated and every ray's closest distance checked equal to the mesh BVH's
//! (stress rows); the tree's shape (splits, pieces, nodes, depth) goes into the table. The
//! plot: build time against ray time, the BSP tree and the mesh BVH.

use super::TestMesh;
use crate::json::{Report, StressRow};
use crate::suites::{incoherent_rays, point};
use crate::timing::{best_of, median};
use glam::Vec3A;
use spatial_accel::bsp::BspTree;
use spatial_accel::mesh::MeshBvh;
use spatial_accel::query::TriangleQuery;
use spatial_accel::{Backfaces, Ray};
use std::time::Instant;

/// Rays through the bunny's box.
const RAYS: usize = 1_000;

/// The median seconds of `reps` calls of `f`, and its last result.
fn median_of<R>(reps: usize, mut f: impl FnMut() -> R) -> (f64, R) {
    let mut times = Vec::new();
    let mut out = None;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        out = Some(std::hint::black_box(f()));
        times.push(t.elapsed().as_secs_f64());
    }
    (median(times), out.expect("at least one run"))
}

/// Runs this part of the suite into `report`.
pub fn run(quick: bool, report: &mut Report) {
    let reps = if quick { 2 } else { 7 };
    let TestMesh { vertices, indices } = super::bunny();
    let (build_s, tree) = median_of(reps, || {
        BspTree::new(&vertices, &indices).expect("a triangle list")
    });
    report.stress.push(StressRow {
        structure: "BspTree".into(),
        query: "validate, the bunny".into(),
        cases: 1,
        misses: u64::from(tree.validate().is_err()),
        ..StressRow::default()
    });
    let s = tree.stats();
    let bounds = tree.bounds();
    let eye = bounds.center() + bounds.extent() * Vec3A::new(1.5, 0.8, 2.0);
    let extent = bounds.extent().max_element();
    let rays: Vec<Ray> = (incoherent_rays(RAYS, extent * 0.5, 7).into_iter())
        .map(|r| Ray::new(r.origin + bounds.center(), r.direction))
        .collect();
    let (bvh_s, bvh) = median_of(reps, || {
        MeshBvh::new(&vertices, &indices).expect("a triangle list")
    });
    let closest = |m: &dyn Fn(&Ray) -> Option<f32>| rays.iter().map(m).collect::<Vec<_>>();
    let want = closest(&|r| bvh.cast_ray(r, Backfaces::Include).map(|h| h.t));
    let got = closest(&|r| tree.cast_ray(r, Backfaces::Include).map(|h| h.t));
    report.stress.push(StressRow {
        structure: "BspTree".into(),
        query: "closest t = MeshBvh's, the bunny".into(),
        cases: rays.len() as u64,
        misses: got.iter().zip(&want).filter(|(a, b)| a != b).count() as u64,
        ..StressRow::default()
    });
    let hits = want.iter().flatten().count();
    let mut order = Vec::with_capacity(tree.pieces().len());
    let (order_s, _) = best_of(reps * 5, || {
        order.clear();
        tree.back_to_front(std::hint::black_box(eye), &mut order);
        order.len()
    });
    let count = |trace: &dyn Fn(&Ray) -> bool| rays.iter().filter(|r| trace(r)).count();
    let (bsp_rays_s, _) = best_of(reps, || {
        count(&|r| tree.cast_ray(r, Backfaces::Include).is_some())
    });
    let (bvh_rays_s, _) = best_of(reps * 5, || {
        count(&|r| bvh.cast_ray(r, Backfaces::Include).is_some())
    });
    let scene = format!("bunny, {RAYS} rays in its box");
    for (method, build, ray) in [
        ("BspTree", build_s, bsp_rays_s),
        ("MeshBvh", bvh_s, bvh_rays_s),
    ] {
        report.points.push(point(
            &scene,
            method,
            "",
            ("build ms", build * 1e3),
            ("ns per ray", Some(ray * 1e9 / rays.len() as f64)),
        ));
    }
    report.markdown.extend([
        format!("BSP tree on the bunny ({} triangles):", s.sources),
        String::new(),
        "| figure | value |".into(),
        "|---|---:|".into(),
        format!(
            "| splits / pieces / nodes / depth | {} / {} / {} / {} |",
            s.splits, s.pieces, s.nodes, s.depth
        ),
        format!(
            "| pieces per source triangle | {:.2} mean, {} max |",
            s.pieces_per_source(),
            s.max_pieces_per_source
        ),
        format!("| build (MeshBvh {:.2} ms) | {:.1} ms |", bvh_s * 1e3, build_s * 1e3),
        format!("| one back-to-front order | {:.0} µs |", order_s * 1e6),
        format!(
            "| {RAYS} closest-hit rays ({hits} hit): BSP / MeshBvh | {:.2} ms / {:.3} ms ({:.0}x) |",
            bsp_rays_s * 1e3,
            bvh_rays_s * 1e3,
            bsp_rays_s / bvh_rays_s
        ),
        String::new(),
    ]);
}
