//! The dynamic-tree workload shared by `benches/dynamic_bvh.rs` and the parry peer package
//! (`peers/parry`, which includes this file by path): 100,000 boxes, centres uniform in
//! [-200, 200]^3, half extents 0.1-1.0, and the random numbers that move them.
#![allow(dead_code)]

use accel::Aabb;
use accel::dynamic::{DynamicBvh, LeafHandle};
use glam::Vec3A;

/// A 64-bit LCG: reproducible and dependency-free.
pub struct Rng(pub u64);
impl Rng {
    pub fn f(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }
    pub fn v(&mut self, lo: f32, hi: f32) -> Vec3A {
        Vec3A::new(
            lo + (hi - lo) * self.f(),
            lo + (hi - lo) * self.f(),
            lo + (hi - lo) * self.f(),
        )
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.f() * n as f32) as usize % n
    }
}

/// `n` boxes of the workload.
pub fn scene(n: usize, seed: u64) -> Vec<Aabb> {
    let mut r = Rng(seed);
    (0..n)
        .map(|_| Aabb::from_center_half_extents(r.v(-200.0, 200.0), r.v(0.1, 1.0)))
        .collect()
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
