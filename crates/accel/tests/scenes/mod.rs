//! Random scenes and query inputs for the tree tests: uniform, clustered and degenerate.
#![allow(dead_code)]

use accel::dynamic::{DynamicBvh, LeafHandle};
use accel::{Aabb, Containment, Frustum, Ray, SpatialQuery};
use core::ops::ControlFlow;
use glam::{Mat4, Vec3, Vec3A};
use std::collections::HashMap;

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

/// A random box: centre within `extent` of the origin, half extents 0.05 to 1.5.
pub fn random_box(rng: &mut Rng, extent: f32) -> Aabb {
    Aabb::from_center_half_extents(rng.vec3(-extent, extent), rng.vec3(0.05, 1.5))
}

/// Compares every query with brute force over `model` (id -> tight box).
pub fn check_queries<T: SpatialQuery>(
    tree: &T,
    model: &HashMap<u32, Aabb>,
    rng: &mut Rng,
    extent: f32,
    n: usize,
) {
    let boxes: Vec<(u32, Aabb)> = model.iter().map(|(&i, &b)| (i, b)).collect();
    for ray in rays(n, u64::from(rng.next_u32()), extent * 1.2) {
        let want = boxes
            .iter()
            .filter_map(|(_, b)| ray.intersect_aabb(b))
            .min_by(f32::total_cmp);
        let got = tree.cast_ray(&ray, |i, r| r.intersect_aabb(&model[&i]));
        assert_eq!(got.map(|h| h.t), want, "closest hit, ray {ray:?}");
        let any = tree.cast_ray_any(&ray, |i, r| r.hits_aabb(&model[&i]));
        assert_eq!(any.is_some(), want.is_some(), "any hit");
    }
    for _ in 0..n {
        let q =
            Aabb::from_center_half_extents(rng.vec3(-extent, extent), rng.vec3(0.0, extent * 0.2));
        let mut got = Vec::new();
        tree.for_each_overlapping_aabb(&q, |i| {
            if model[&i].intersects_aabb(&q) {
                got.push(i);
            }
            ControlFlow::Continue(())
        });
        got.sort_unstable();
        let mut want: Vec<u32> = boxes
            .iter()
            .filter(|(_, b)| b.intersects_aabb(&q))
            .map(|&(i, _)| i)
            .collect();
        want.sort_unstable();
        assert_eq!(got, want, "box overlap");

        let f = random_frustum(rng, extent);
        let got = frustum_hits(tree, &f, |i| model[&i]);
        let mut want: Vec<u32> = boxes
            .iter()
            .filter(|(_, b)| f.intersects_aabb(b))
            .map(|&(i, _)| i)
            .collect();
        want.sort_unstable();
        assert_eq!(got, want, "frustum");
    }
}

/// The tree's ids equal the model's, each exactly once, and every handle is live.
pub fn check_ids(
    tree: &DynamicBvh,
    model: &HashMap<u32, Aabb>,
    handles: &HashMap<u32, LeafHandle>,
) {
    assert_eq!(tree.len(), model.len());
    // Ids are small and dense: a flag per id is much cheaper than a set at 100k leaves, which
    // matters when this runs after every frame.
    let mut seen = vec![false; model.keys().max().map_or(0, |&m| m as usize + 1)];
    let mut count = 0;
    for (h, id, tight) in tree.leaves() {
        let slot = seen.get_mut(id as usize);
        assert!(
            slot.as_ref().is_some_and(|s| !**s),
            "id {id} duplicated or unknown"
        );
        if let Some(s) = slot {
            *s = true;
        }
        count += 1;
        assert_eq!(
            model.get(&id),
            Some(&tight),
            "id {id} not in the model, or its box differs"
        );
        assert_eq!(handles[&id], h, "id {id} has another handle");
    }
    assert_eq!(count, model.len(), "an id was lost");
}

/// What a frustum query reports once each candidate gets the exact test (sorted), asserting
/// on the way that a subtree accepted as inside never holds a primitive that is not.
pub fn frustum_hits<T: SpatialQuery>(
    tree: &T,
    f: &Frustum,
    bounds: impl Fn(u32) -> Aabb,
) -> Vec<u32> {
    let mut got = Vec::new();
    tree.for_each_in_frustum(f, |i, c| {
        let exact = f.classify_aabb(&bounds(i));
        if c == Containment::Inside {
            assert_eq!(
                exact,
                Containment::Inside,
                "subtree accepted but primitive not inside"
            );
        }
        if exact != Containment::Outside {
            got.push(i);
        }
    });
    got.sort_unstable();
    got
}
