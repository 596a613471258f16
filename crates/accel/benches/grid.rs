//! The uniform grid against the dynamic BVH on the dynamic workload at 100,000 boxes
//! (`common/dynamic_workload.rs`: centres uniform in [-200, 200]^3, half extents 0.1 to 1):
//!
//! - `frame_10pct_moved`: a frame in which a tenth of the boxes take a random step of up to
//!   one unit per axis (the same steps for every contender), then the per-frame upkeep. The
//!   dynamic BVH runs twice: with its configured `maintain` (refit, then its optimiser's
//!   budget) and with `DynamicIndex::maintain(Duration::ZERO)` (refit only).
//! - `frustum`: a camera frustum with about 5% of the boxes not outside; candidates that
//!   cross a plane get the exact box test.
//! - `box_query_1000`: 1,000 query boxes of half size 5 at random places, exact box test.
//! - `rays_1000`: 1,000 incoherent closest-hit rays, the slab test of each box in the
//!   callback.
//!
//! The grid runs at its automatic cell size and at a fixed smaller one, four times the
//! largest box's half extent (more cells per box and per ray, fewer candidates per cell). Before timing, every query's answer is
//! checked to be the same on every contender.
//!
//! Run: `cargo bench -p accel --bench grid -- --quick`

mod common;
#[path = "common/dynamic_workload.rs"]
mod dynamic_workload;
#[path = "common/index_contest.rs"]
mod index_contest;
use index_contest::{bench_dynamic_bvh_frames, box_hits, frames, frustum_ids, play, ray_hits};

use accel::grid::{GridConfig, GridHandle, UniformGrid};
use accel::query::DynamicIndex;
use accel::{Aabb, Ray};
use accel_testkit::Rng;
use criterion::Criterion;
use glam::Vec3A;
use std::hint::black_box;
use std::time::Duration;

const N: usize = 100_000;
/// The fixed cell side of the second grid, in world units.
const SMALL_CELL: f32 = 4.0;

/// The grids benchmarked: a name and the settings.
fn configs() -> [(&'static str, GridConfig); 2] {
    [
        ("grid_auto", GridConfig::default()),
        ("grid_cell_4", GridConfig::fixed(SMALL_CELL)),
    ]
}

/// A grid over the workload's boxes, ids the indices, inserted one by one and then
/// maintained (which sizes the automatic grid), as a game's grid looks after loading.
fn grid(boxes: &[Aabb], config: GridConfig) -> (UniformGrid, Vec<GridHandle>) {
    let mut grid = UniformGrid::with_config(config);
    let handles = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| grid.insert(i as u32, *b).unwrap())
        .collect();
    grid.maintain(Duration::ZERO);
    (grid, handles)
}

fn frame_benches(c: &mut Criterion, boxes: &[Aabb]) {
    let frames = frames();
    let mut g = c.benchmark_group("grid_100k/frame_10pct_moved");
    for (name, config) in configs() {
        let (mut grid, handles) = grid(boxes, config);
        let mut now = boxes.to_vec();
        let mut i = 0;
        g.bench_function(name, |b| {
            b.iter(|| {
                play(&frames, i, &mut now, |j, bx| {
                    black_box(grid.update(handles[j], bx).unwrap());
                });
                i += 1;
                black_box(grid.maintain(Duration::ZERO))
            })
        });
        grid.validate().unwrap();
        let stats = grid.index_stats();
        println!(
            "{name}: cell size {}, {} cells, {} oversize, {} MiB",
            grid.cell_size(),
            stats.nodes,
            grid.oversize_count(),
            stats.memory_bytes >> 20
        );
    }
    bench_dynamic_bvh_frames(&mut g, boxes, &frames);
    g.finish();
}

fn query_benches(c: &mut Criterion, boxes: &[Aabb]) {
    let (frustum, visible) = common::frustum_selecting(boxes, 0.05);
    let mut rng = Rng::new(4);
    let queries: Vec<Aabb> = (0..1000)
        .map(|_| Aabb::from_center_half_extents(rng.vec3a(-200.0, 200.0), Vec3A::splat(5.0)))
        .collect();
    let rays: Vec<Ray> = common::incoherent_rays(1000, 200.0, 5)
        .into_iter()
        .map(|(o, d)| Ray::new(o, d))
        .collect();
    let (bvh, _) = dynamic_workload::built_tree(boxes);
    let grids = configs().map(|(name, config)| (name, grid(boxes, config).0));
    let want = (
        frustum_ids(&bvh, boxes, &frustum),
        box_hits(&bvh, boxes, &queries),
        ray_hits(&bvh, boxes, &rays),
    );
    assert!(want.0.len() >= visible / 2, "the frustum sees the boxes");
    for (name, grid) in &grids {
        assert_eq!(
            frustum_ids(grid, boxes, &frustum),
            want.0,
            "{name}: frustum"
        );
        assert_eq!(box_hits(grid, boxes, &queries), want.1, "{name}: boxes");
        assert_eq!(ray_hits(grid, boxes, &rays), want.2, "{name}: rays");
    }
    let mut g = c.benchmark_group("grid_100k/frustum");
    g.bench_function("dynamic_bvh", |b| {
        b.iter(|| black_box(frustum_ids(&bvh, boxes, &frustum)))
    });
    for (name, grid) in &grids {
        g.bench_function(*name, |b| {
            b.iter(|| black_box(frustum_ids(grid, boxes, &frustum)))
        });
    }
    g.finish();
    let mut g = c.benchmark_group("grid_100k/box_query_1000");
    g.bench_function("dynamic_bvh", |b| {
        b.iter(|| black_box(box_hits(&bvh, boxes, &queries)))
    });
    for (name, grid) in &grids {
        g.bench_function(*name, |b| {
            b.iter(|| black_box(box_hits(grid, boxes, &queries)))
        });
    }
    g.finish();
    let mut g = c.benchmark_group("grid_100k/rays_1000");
    g.bench_function("dynamic_bvh", |b| {
        b.iter(|| black_box(ray_hits(&bvh, boxes, &rays)))
    });
    for (name, grid) in &grids {
        g.bench_function(*name, |b| {
            b.iter(|| black_box(ray_hits(grid, boxes, &rays)))
        });
    }
    g.finish();
}

fn main() {
    let boxes = dynamic_workload::scene(N, 1);
    let mut c = Criterion::default().configure_from_args();
    frame_benches(&mut c, &boxes);
    query_benches(&mut c, &boxes);
    c.final_summary();
}
