//! Ray traversal of wide nodes: all child boxes of a node tested at once, four lanes per
//! SIMD register.

use super::{WideBvh, WideNode};
use crate::query::TraversalStack;
use crate::{Ray, SLAB_WIDENING};
use core::ops::ControlFlow;
use glam::Vec4;

/// A ray splatted across four lanes, with the slab-plane choice made once per ray: a ray's
/// direction signs decide which face of every box it enters by, so the per-node test needs no
/// per-lane select.
struct RayLanes {
    origin: [Vec4; 3],
    inv_direction: [Vec4; 3],
    negative: [bool; 3],
    t_min: Vec4,
}

impl RayLanes {
    fn new(ray: &Ray) -> Self {
        let o = ray.origin;
        let inv = ray.inv_direction;
        Self {
            origin: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            inv_direction: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            negative: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0],
            t_min: Vec4::splat(ray.t_min),
        }
    }
}

/// `max(candidate, acc)` that returns `acc` when `candidate` is NaN.
///
/// A ray parallel to a slab and starting on its plane computes `0 * inf = NaN` there; that axis
/// must then not constrain the ray (see [`Ray::slab_interval`]). SSE's `maxps` returns its
/// second operand when either is NaN, and so does the scalar `f32::max`, so putting the
/// candidate first gets the rule for free; other back ends pay for an explicit select.
#[inline(always)]
fn max_ignoring_nan(candidate: Vec4, acc: Vec4) -> Vec4 {
    if cfg!(any(target_arch = "x86", target_arch = "x86_64")) {
        candidate.max(acc)
    } else {
        Vec4::select(candidate.is_nan_mask(), acc, candidate.max(acc))
    }
}

/// `min(candidate, acc)` that returns `acc` when `candidate` is NaN (see [`max_ignoring_nan`]).
#[inline(always)]
fn min_ignoring_nan(candidate: Vec4, acc: Vec4) -> Vec4 {
    if cfg!(any(target_arch = "x86", target_arch = "x86_64")) {
        candidate.min(acc)
    } else {
        Vec4::select(candidate.is_nan_mask(), acc, candidate.min(acc))
    }
}

#[inline(always)]
fn lanes<const N: usize>(a: &[f32; N], chunk: usize) -> Vec4 {
    Vec4::from_slice(&a[chunk * 4..chunk * 4 + 4])
}

/// Tests the ray against every child box of a node: returns the hit mask (bit i = slot i) and
/// each slot's entry distance. The same conservative, widened slab test as
/// [`Ray::intersect_aabb`], lane by lane.
#[inline(always)]
fn test_children<const N: usize>(node: &WideNode<N>, r: &RayLanes, t_max: f32) -> (u32, [f32; N]) {
    let mut mask = 0u32;
    let mut entry_t = [0.0f32; N];
    let t_max = Vec4::splat(t_max);
    let widen = Vec4::splat(SLAB_WIDENING);
    for chunk in 0..N / 4 {
        let mins = [
            lanes(&node.min_x, chunk),
            lanes(&node.min_y, chunk),
            lanes(&node.min_z, chunk),
        ];
        let maxs = [
            lanes(&node.max_x, chunk),
            lanes(&node.max_y, chunk),
            lanes(&node.max_z, chunk),
        ];
        let mut near = Vec4::NEG_INFINITY;
        let mut far = Vec4::INFINITY;
        for axis in 0..3 {
            let (enter, exit) = if r.negative[axis] {
                (maxs[axis], mins[axis])
            } else {
                (mins[axis], maxs[axis])
            };
            near = max_ignoring_nan((enter - r.origin[axis]) * r.inv_direction[axis], near);
            far = min_ignoring_nan((exit - r.origin[axis]) * r.inv_direction[axis], far);
        }
        // Widened additively: an infinite distance (a miss on a parallel axis) becomes
        // inf - inf = NaN, and every comparison below is false for NaN, so it stays a miss.
        let near = near - near.abs() * widen;
        let far = far + far.abs() * widen;
        let hit = near.cmple(far) & near.cmple(t_max) & far.cmpge(r.t_min);
        mask |= hit.bitmask() << (chunk * 4);
        let t = near.max(r.t_min).to_array();
        entry_t[chunk * 4..chunk * 4 + 4].copy_from_slice(&t);
    }
    (mask, entry_t)
}

/// Visits the leaves the ray reaches, nearer children first, skipping anything that starts
/// beyond `ray.t_max` (which the visitor may shrink).
pub(super) fn visit_ray<const N: usize, F>(tree: &WideBvh<N>, ray: &mut Ray, mut visit: F)
where
    F: FnMut(u32, &mut Ray) -> ControlFlow<()>,
{
    if tree.nodes.is_empty() || !ray.hits_aabb(&tree.bounds) {
        return;
    }
    let lanes = RayLanes::new(ray);
    let mut stack: TraversalStack<(u32, f32)> = TraversalStack::new();
    stack.push((0, ray.t_min));
    while let Some((node_index, t_enter)) = stack.pop() {
        if t_enter > ray.t_max {
            continue;
        }
        let node = &tree.nodes[node_index as usize];
        let (mut mask, entry_t) = test_children(node, &lanes, ray.t_max);
        // Gather the hit slots and sort them by entry distance (insertion sort: at most N).
        let mut order = [(0.0f32, 0usize); N];
        let mut hits = 0;
        while mask != 0 {
            let slot = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let item = (entry_t[slot], slot);
            let mut j = hits;
            while j > 0 && order[j - 1].0 > item.0 {
                order[j] = order[j - 1];
                j -= 1;
            }
            order[j] = item;
            hits += 1;
        }
        // Leaves now, nearest first, so their hits shrink the range before any subtree is
        // entered; subtrees pushed farthest first, so the nearest is popped next.
        for &(t, slot) in &order[..hits] {
            if node.is_leaf(slot) && t <= ray.t_max {
                let first = node.child[slot] as usize;
                for &p in &tree.primitive_indices[first..first + node.count[slot] as usize] {
                    if visit(p, ray).is_break() {
                        return;
                    }
                }
            }
        }
        for &(t, slot) in order[..hits].iter().rev() {
            if !node.is_leaf(slot) && t <= ray.t_max {
                stack.push((node.child[slot], t));
            }
        }
    }
}
