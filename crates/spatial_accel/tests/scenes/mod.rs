//! Query inputs and brute-force checks for the tree tests; the box scenes themselves are
//! `accel_testkit`'s.
#![allow(dead_code)]

use accel_testkit::Rng;
use core::ops::ControlFlow;
use glam::{Mat4, Vec3, Vec3A};
use spatial_accel::dynamic::{DynamicBvh, LeafHandle};
use spatial_accel::{Aabb, Containment, Frustum, Ray, SpatialQuery};
use std::collections::HashMap;

/// Rays from around the scene through it, in random directions, plus axis-parallel ones.
pub fn rays(n: usize, seed: u64, extent: f32) -> Vec<Ray> {
    let mut rng = Rng::new(seed ^ 0x9e37_79b9);
    (0..n)
        .map(|i| {
            let o = rng.vec3a(-extent, extent);
            let mut d = rng.unit_vector();
            if i % 5 == 0 {
                // Axis-parallel, with the sign of zero varied: the slab test's hard case.
                let axis = rng.below(3);
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
    let eye = rng.vec3(-extent, extent);
    let target = rng.vec3(-extent * 0.3, extent * 0.3);
    let view = Mat4::look_at_rh(eye, target, Vec3::Y);
    let fov = rng.range(0.3, 1.5);
    let proj = if rng.below(2) == 0 {
        Mat4::perspective_infinite_reverse_rh(fov, rng.range(0.5, 2.0), 0.1)
    } else {
        Mat4::perspective_rh(fov, rng.range(0.5, 2.0), 0.1, extent * 2.0)
    };
    Frustum::from_clip_from_world(&(proj * view))
}

/// A random box as the dynamic-tree tests move them: centre within `extent` of the origin,
/// half extents 0.05 to 1.5.
pub fn random_box(rng: &mut Rng, extent: f32) -> Aabb {
    accel_testkit::random_box(rng, extent, 0.05..1.5)
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
        let q = Aabb::from_center_half_extents(
            rng.vec3a(-extent, extent),
            rng.vec3a(0.0, extent * 0.2),
        );
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
