//! Rays through the tree: front to back over the leaves a ray crosses, each subtree with the
//! ray's parameter interval inside it (the recursive traversal of Havran's thesis, section
//! 4.2, with an explicit stack).

use super::KdTree;
use super::node::KdNodeKind;
use crate::query::TraversalStack;
use crate::{Ray, SLAB_WIDENING};
use core::ops::{ControlFlow, Range};

/// Relative widening of the parameter where a ray crosses a split plane, and so of every
/// leaf's interval.
///
/// The crossing `(position - origin) * inv_direction` is rounded three times, like a slab
/// distance ([`SLAB_WIDENING`]). A leaf is skipped when its interval starts past the closest
/// hit, and that hit's `t` comes from the triangle test, rounded in its own way: a hit a few
/// ulps inside the next leaf could then be cut off by a closer-looking one. Sixteen times the
/// slab's margin covers both roundings; it costs a few extra leaf visits at most.
const PLANE_WIDENING: f32 = 16.0 * SLAB_WIDENING;

/// `t` moved towards zero and away from it by [`PLANE_WIDENING`]: `(low, high)`. Scaling (not
/// adding) keeps infinities infinite instead of making them NaN.
#[inline]
fn widen(t: f32) -> (f32, f32) {
    let w = PLANE_WIDENING.copysign(t);
    (t * (1.0 - w), t * (1.0 + w))
}

impl KdTree {
    /// Visits the leaves the ray crosses within its range, front to back, as runs of
    /// [`KdTree::leaf_references`]. `leaf` returns the distance past which the caller wants
    /// no more leaves (the closest hit so far, or the ray's end), or breaks to stop.
    ///
    /// A leaf is visited when its interval (widened, see [`PLANE_WIDENING`]) starts at or
    /// before that distance: any hit the caller has not yet seen and that could be closer
    /// lies in such a leaf, because every point of a triangle is in a leaf that holds it.
    ///
    /// Axis-parallel rays: a zero direction component (either sign) gives an infinite
    /// reciprocal, so the ray never crosses that axis's planes and stays on its origin's
    /// side; an origin exactly on the plane makes `0 * inf = NaN`, and then both children
    /// are visited over the whole interval, since the ray lies in the plane. A degenerate ray
    /// (NaN or infinite input) has an empty range and visits nothing.
    #[inline]
    #[expect(
        clippy::neg_cmp_op_on_partial_ord,
        reason = "a NaN interval must read as a miss"
    )]
    pub(super) fn walk_ray(
        &self,
        ray: &Ray,
        mut leaf: impl FnMut(Range<usize>) -> ControlFlow<(), f32>,
    ) {
        let (t0, t1) = ray.slab_interval(self.bounds.min, self.bounds.max);
        if !(t0 <= t1) {
            return;
        }
        let origin = ray.origin.to_array();
        let inv = ray.inv_direction.to_array();
        let mut limit = ray.t_max;
        let mut stack: TraversalStack<(u32, f32, f32)> = TraversalStack::new();
        stack.push((0, t0, t1));
        while let Some((mut node, mut t_near, mut t_far)) = stack.pop() {
            // Front to back: a subtree that starts beyond the closest hit holds none closer.
            if t_near > limit {
                continue;
            }
            t_far = t_far.min(limit);
            loop {
                match self.nodes[node as usize].kind() {
                    KdNodeKind::Interior {
                        axis,
                        position,
                        above,
                    } => {
                        let below = node + 1;
                        // The side the ray starts in is crossed first (by the sign of the
                        // reciprocal, so -0 counts as negative, as in the slab test).
                        let (near, far) = if inv[axis].is_sign_negative() {
                            (above, below)
                        } else {
                            (below, above)
                        };
                        let t = (position - origin[axis]) * inv[axis];
                        if t.is_nan() {
                            // In the plane: both sides, over the whole interval.
                            stack.push((far, t_near, t_far));
                            node = near;
                            continue;
                        }
                        let (t_low, t_high) = widen(t);
                        match (t_near <= t_high, t_low <= t_far) {
                            (true, true) => {
                                stack.push((far, t_near.max(t_low), t_far));
                                node = near;
                                t_far = t_far.min(t_high);
                            }
                            (true, false) => node = near,
                            (false, true) => {
                                node = far;
                                t_near = t_near.max(t_low);
                            }
                            (false, false) => break,
                        }
                    }
                    KdNodeKind::Leaf { first, count } => {
                        let run = first as usize..(first + count) as usize;
                        match leaf(run) {
                            ControlFlow::Continue(l) => limit = l,
                            ControlFlow::Break(()) => return,
                        }
                        break;
                    }
                }
            }
        }
    }
}
