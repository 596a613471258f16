//! Prints what a rebuild of the plugin's static entity tree costs: the build under each
//! split strategy with the plugin's stopping rules and SAH costs (with the tree's SAH cost),
//! then the collapse of the PLOC tree to the wide layouts (the 16-wide one with ids inlined is
//! the step that follows every static-tree build and every ray snapshot of the dynamic tree;
//! `Bvh8` and `QBvh8` for comparison). Random boxes, best of 5.
//! `cargo run --release -p accel --example entity_tree_timing -- 1000000`.

use accel::bvh::wide::{Bvh8, Bvh16, QBvh8};
use accel::{Aabb, BuildConfig, Bvh, SahCosts, SplitStrategy};
use glam::Vec3A;
use std::time::{Duration, Instant};

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1_000_000);
    let mut rng = accel_testkit::Rng::new(7);
    let mut next = move || rng.f32();
    // One entity per 64 cubic units, as in the plugin's picking bench.
    let half = (n as f32 * 64.0).cbrt() / 2.0;
    let boxes: Vec<Aabb> = (0..n)
        .map(|_| {
            let c = (Vec3A::new(next(), next(), next()) * 2.0 - 1.0) * half;
            Aabb::from_center_half_extents(c, Vec3A::splat(1.5))
        })
        .collect();
    let config = BuildConfig {
        split: SplitStrategy::PLOC_FASTEST,
        max_leaf_size: 4,
        sah: SahCosts {
            traversal: 1.0,
            intersection: 4.0,
        },
        ..BuildConfig::default()
    };
    let best_of = |f: &mut dyn FnMut() -> usize| {
        let mut best = Duration::MAX;
        let mut nodes = 0;
        for _ in 0..5 {
            let t = Instant::now();
            nodes = f();
            best = best.min(t.elapsed());
        }
        (best, nodes)
    };
    for split in [
        SplitStrategy::BinnedSah { bins: 16 },
        SplitStrategy::PLOC_FASTEST,
        SplitStrategy::Lbvh,
    ] {
        let config = BuildConfig { split, ..config };
        let (time, nodes) = best_of(&mut || Bvh::build(&boxes, &config).nodes().len());
        let sah = Bvh::build(&boxes, &config).stats(&config.sah).sah_cost;
        println!("{n} boxes, {split:?}: build {time:?}, SAH {sah:.2}, {nodes} nodes");
    }
    let bvh = Bvh::build(&boxes, &config);
    let (wide, wide_nodes) = best_of(&mut || Bvh8::from_bvh(&bvh).nodes().len());
    let (quantized, _) = best_of(&mut || QBvh8::from_bvh(&bvh).nodes().len());
    // What the plugin makes for rays after each static build.
    let (wide16, wide16_nodes) = best_of(&mut || {
        let mut wide = Bvh16::from_bvh(&bvh);
        wide.inline_single_leaves();
        wide.nodes().len()
    });
    println!(
        "{n} boxes, {} binary nodes: Bvh8 {wide:?}, QBvh8 {quantized:?} ({wide_nodes} wide \
         nodes), Bvh16 with ids inlined {wide16:?} ({wide16_nodes} nodes); best of 5",
        bvh.nodes().len()
    );
}
