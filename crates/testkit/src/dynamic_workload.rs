//! The dynamic-tree workload shared by the bench tool's dynamic BVH rows (`accel-bench update`
//! and `structures`) and the parry peer package (`crates/bench/peers/parry`): 100,000 boxes,
//! centres uniform in [-200, 200]^3, half extents 0.1-1.0 (made by [`Rng`], which also makes
//! the random numbers that move them).

use crate::{Rng, uniform_boxes};
use spatial_accel::Aabb;
use spatial_accel::dynamic::{DynamicBvh, LeafHandle};

/// `n` boxes of the workload.
pub fn scene(n: usize, seed: u64) -> Vec<Aabb> {
    uniform_boxes(&mut Rng::new(seed), n, 200.0, 0.1..1.0)
}

/// A dynamic tree over `boxes` (leaf ids are the indices), inserted one by one and then
/// rebuilt, as a game's tree looks after loading; with the handles in box order.
pub fn built_tree(boxes: &[Aabb]) -> (DynamicBvh, Vec<LeafHandle>) {
    let mut t = DynamicBvh::new();
    let hs = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| t.insert(i as u32, *b).expect("finite box"))
        .collect();
    t.rebuild();
    (t, hs)
}
