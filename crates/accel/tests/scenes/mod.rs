//! Random scenes and query inputs for the tree tests: uniform, clustered and degenerate.
#![allow(dead_code)]

use accel::{Aabb, Frustum, Ray};
use glam::{Mat4, Vec3, Vec3A};

/// A small, fast, seedable generator (PCG32): the tests need reproducible streams, not
/// cryptographic ones, and no dependency.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        let mut r = Rng(seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407));
        r.next_u32();
        r
    }
    pub fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }
    /// Uniform in [0, 1).
    pub fn f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }
    pub fn vec3(&mut self, lo: f32, hi: f32) -> Vec3A {
        Vec3A::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
    pub fn unit_vector(&mut self) -> Vec3A {
        loop {
            let v = self.vec3(-1.0, 1.0);
            let l = v.length_squared();
            if l > 1e-4 && l <= 1.0 {
                return v / l.sqrt();
            }
        }
    }
}

/// The kinds of scene the oracles are run on.
#[derive(Clone, Copy, Debug)]
pub enum SceneKind {
    /// Boxes of varied size spread uniformly.
    Uniform,
    /// Dense clusters far apart: the case where midpoint splits do badly.
    Clustered,
    /// Everything at one point, zero-size and flat boxes, duplicates.
    Degenerate,
}

pub fn scene(kind: SceneKind, n: usize, seed: u64) -> Vec<Aabb> {
    let mut rng = Rng::new(seed);
    match kind {
        SceneKind::Uniform => (0..n)
            .map(|_| {
                let c = rng.vec3(-100.0, 100.0);
                let h = rng.vec3(0.01, 2.0);
                Aabb::from_center_half_extents(c, h)
            })
            .collect(),
        SceneKind::Clustered => {
            let centers: Vec<Vec3A> = (0..8).map(|_| rng.vec3(-1000.0, 1000.0)).collect();
            (0..n)
                .map(|_| {
                    let c = centers[rng.below(8) as usize] + rng.vec3(-5.0, 5.0);
                    Aabb::from_center_half_extents(c, rng.vec3(0.01, 0.5))
                })
                .collect()
        }
        SceneKind::Degenerate => (0..n)
            .map(|i| match i % 4 {
                0 => Aabb::from_point(Vec3A::splat(1.0)),
                1 => Aabb::new(Vec3A::new(0.0, 0.0, 1.0), Vec3A::new(2.0, 2.0, 1.0)),
                2 => Aabb::new(Vec3A::ZERO, Vec3A::splat(2.0)),
                _ => Aabb::from_point(rng.vec3(0.0, 2.0)),
            })
            .collect(),
    }
}

/// Rays from around the scene through it, in random directions, plus axis-parallel ones.
pub fn rays(n: usize, seed: u64, extent: f32) -> Vec<Ray> {
    let mut rng = Rng::new(seed ^ 0x9e37_79b9);
    (0..n)
        .map(|i| {
            let o = rng.vec3(-extent, extent);
            let mut d = rng.unit_vector();
            if i % 5 == 0 {
                // Axis-parallel, with the sign of zero varied: the slab test's hard case.
                let axis = rng.below(3) as usize;
                let s = if rng.below(2) == 0 { 1.0 } else { -1.0 };
                d = Vec3A::ZERO;
                d[axis] = s;
                if rng.below(2) == 0 {
                    d[(axis + 1) % 3] = -0.0;
                }
            }
            Ray::new(o, d)
        })
        .collect()
}

/// A perspective view from a random point towards the scene centre.
pub fn random_frustum(rng: &mut Rng, extent: f32) -> Frustum {
    let eye: Vec3 = rng.vec3(-extent, extent).into();
    let target: Vec3 = rng.vec3(-extent * 0.3, extent * 0.3).into();
    let view = Mat4::look_at_rh(eye, target, Vec3::Y);
    let fov = rng.range(0.3, 1.5);
    let proj = if rng.below(2) == 0 {
        Mat4::perspective_infinite_reverse_rh(fov, rng.range(0.5, 2.0), 0.1)
    } else {
        Mat4::perspective_rh(fov, rng.range(0.5, 2.0), 0.1, extent * 2.0)
    };
    Frustum::from_clip_from_world(&(proj * view))
}
