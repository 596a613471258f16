//! Prints BVH build times and SAH costs for each split strategy over random boxes: a quick
//! look before running the criterion benches. `cargo run --release -p accel --example
//! build_timing -- 100000`.

use accel::{Aabb, BuildConfig, Bvh, SplitStrategy};
use glam::Vec3A;
use std::time::Instant;

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(100_000);
    let mut rng = accel_testkit::Rng::new(0x2545_f491_4f6c_dd1d);
    let mut next = move || rng.f32();
    let boxes: Vec<Aabb> = (0..n)
        .map(|_| {
            let c = Vec3A::new(next(), next(), next()) * 200.0 - 100.0;
            Aabb::from_center_half_extents(c, Vec3A::new(next(), next(), next()) * 2.0 + 0.01)
        })
        .collect();
    for split in [
        SplitStrategy::Lbvh,
        SplitStrategy::Midpoint,
        SplitStrategy::Median,
        SplitStrategy::BinnedSah { bins: 8 },
        SplitStrategy::BinnedSah { bins: 16 },
        SplitStrategy::PLOC_FASTEST,
        SplitStrategy::Ploc {
            search_radius: 4,
            reinsert_per_mille: 0,
        },
        SplitStrategy::PLOC,
    ] {
        let cfg = BuildConfig::with_split(split);
        let mut best = f64::INFINITY;
        let mut bvh = Bvh::default();
        for _ in 0..5 {
            let t = Instant::now();
            bvh = Bvh::build(&boxes, &cfg);
            best = best.min(t.elapsed().as_secs_f64());
        }
        let stats = bvh.stats(&cfg.sah);
        println!(
            "{split:?}: {:.2} ms ({:.1} M prims/s), SAH {:.2}, {} leaves, max leaf {}",
            best * 1e3,
            n as f64 / best / 1e6,
            stats.sah_cost,
            stats.leaves,
            stats.max_leaf_size
        );
    }
}
