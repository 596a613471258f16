//! The conservative ray/box slab test that every tree traversal is built on.

use crate::{Aabb, Ray};
use glam::Vec3A;

/// Relative widening of the slab interval: `2 * gamma(3)` with `gamma(n) = n u / (1 - n u)` and
/// `u = 2^-24`, as pbrt-v4 derives it. Each slab distance `(bound - origin) * inv_direction` has
/// at most three roundings (the subtraction, the reciprocal, the product), so widening both
/// ends of the interval by this factor keeps every box the exact ray touches (Ize 2013, "Robust
/// BVH ray traversal", JCGT 2(2)). Without it, rays slip between boxes that share a face.
pub const SLAB_WIDENING: f32 = 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

impl Ray {
    /// Entry distance into the box, clamped to the ray's range, or `None` when the ray misses.
    ///
    /// Conservative: a box the exact ray touches is never missed, including boxes of zero
    /// thickness, rays lying in a face plane, rays starting on a face, edge or corner, and
    /// axis-parallel rays. A degenerate ray misses everything. A box with NaN bounds gives an
    /// unspecified answer but never panics.
    #[inline]
    pub fn intersect_aabb(&self, aabb: &Aabb) -> Option<f32> {
        let (near, far) = self.slab_interval(aabb.min, aabb.max);
        (near <= far).then_some(near)
    }

    /// True when the ray touches the box within its range (see [`Ray::intersect_aabb`]).
    #[inline]
    pub fn hits_aabb(&self, aabb: &Aabb) -> bool {
        let (near, far) = self.slab_interval(aabb.min, aabb.max);
        near <= far
    }

    /// The clamped, widened parameter interval `[near, far]` of the ray inside the box given by
    /// its corners; empty (`near > far`) on a miss.
    #[inline]
    pub fn slab_interval(&self, min: Vec3A, max: Vec3A) -> (f32, f32) {
        // Pick the entry and exit plane of each slab from the direction's sign (the sign of the
        // reciprocal, so -0.0 counts as negative), instead of sorting two distances with
        // min/max: that keeps NaN from ever meeting a min/max whose NaN rule varies by back end.
        let negative = self.inv_direction.cmplt(Vec3A::ZERO);
        let entry_plane = Vec3A::select(negative, max, min);
        let exit_plane = Vec3A::select(negative, min, max);
        let entry = (entry_plane - self.origin) * self.inv_direction;
        let exit = (exit_plane - self.origin) * self.inv_direction;
        // An axis-parallel ray starting on a slab plane computes 0 * inf = NaN there. It lies in
        // the closed slab for its whole length, so that axis must not constrain it: a NaN entry
        // becomes -inf and a NaN exit +inf. Flat (zero-thickness) boxes are hit this way too.
        let entry = Vec3A::select(entry.is_nan_mask(), Vec3A::NEG_INFINITY, entry);
        let exit = Vec3A::select(exit.is_nan_mask(), Vec3A::INFINITY, exit);
        let near = entry.max_element();
        let far = exit.min_element();
        // Widen by scaling, not by adding `|t| * w`: that would turn an infinite distance
        // (a parallel ray outside its slab) into inf - inf = NaN, and NaN would read as a hit.
        let near = near * (1.0 - SLAB_WIDENING.copysign(near));
        let far = far * (1.0 + SLAB_WIDENING.copysign(far));
        (near.max(self.t_min), far.min(self.t_max))
    }
}
