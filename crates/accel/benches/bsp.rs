//! The BSP tree on the Stanford bunny (3,674 triangles, as read):
//!
//! - `build`: the tree with the default `BspConfig` (8 candidate planes a node, priced on up
//!   to 128 triangles, splits weighted 4 against imbalance).
//! - `back_to_front`: one painter's order of every piece, from an eye outside the bunny.
//! - `rays_1000`: 1,000 closest-hit rays through the bunny's box (the watertight test on
//!   each reached piece's source), against `MeshBvh` on the same rays.
//!
//! Before timing, the tree is validated, the rays' hits are checked to be the mesh BVH's,
//! and the tree's shape (splits, nodes, depth, pieces per source) is printed.
//!
//! Run: `cargo bench -p accel --bench bsp -- --quick`

mod common;

use accel::bsp::BspTree;
use accel::mesh::MeshBvh;
use accel::query::TriangleQuery;
use accel::{Backfaces, Ray};
use criterion::Criterion;
use glam::Vec3A;
use std::hint::black_box;

fn main() {
    let bunny = accel_testkit::bunny();
    let (vertices, indices) = (bunny.positions(), bunny.flat_indices());
    let tree = BspTree::new(&vertices, &indices).unwrap();
    tree.validate().unwrap();
    let s = tree.stats();
    println!(
        "bunny: {} sources, {} splits, {} pieces ({:.3} per source, at most {}), {} nodes, \
         depth {}, {} degenerate",
        s.sources,
        s.splits,
        s.pieces,
        s.pieces_per_source(),
        s.max_pieces_per_source,
        s.nodes,
        s.depth,
        s.degenerate
    );
    let bounds = tree.bounds();
    let eye = bounds.center() + bounds.extent() * Vec3A::new(1.5, 0.8, 2.0);
    let extent = bounds.extent().max_element();
    let rays: Vec<Ray> = common::incoherent_rays(1000, extent * 0.5, 7)
        .into_iter()
        .map(|(o, d)| Ray::new(o + bounds.center(), d))
        .collect();
    let bvh = MeshBvh::new(&vertices, &indices).unwrap();
    let closest = |m: &dyn Fn(&Ray) -> Option<f32>| rays.iter().map(m).collect::<Vec<_>>();
    let want = closest(&|r| bvh.cast_ray(r, Backfaces::Include).map(|h| h.t));
    let got = closest(&|r| tree.cast_ray(r, Backfaces::Include).map(|h| h.t));
    assert_eq!(got, want, "the tree's hits are the mesh BVH's");
    println!(
        "{} of {} rays hit",
        want.iter().flatten().count(),
        rays.len()
    );

    let mut c = Criterion::default().configure_from_args();
    let mut g = c.benchmark_group("bsp_bunny");
    g.bench_function("build", |b| {
        b.iter(|| black_box(BspTree::new(&vertices, &indices).unwrap()))
    });
    let mut order = Vec::with_capacity(tree.pieces().len());
    g.bench_function("back_to_front", |b| {
        b.iter(|| {
            order.clear();
            tree.back_to_front(black_box(eye), &mut order);
            black_box(order.len())
        })
    });
    g.bench_function("rays_1000/bsp", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|r| tree.cast_ray(r, Backfaces::Include).is_some())
                .count()
        })
    });
    g.bench_function("rays_1000/mesh_bvh", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|r| bvh.cast_ray(r, Backfaces::Include).is_some())
                .count()
        })
    });
    g.finish();
    c.final_summary();
}
