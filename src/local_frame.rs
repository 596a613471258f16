//! An entity's own space, kept beside its world box for exact ray tests.

use bevy::math::Affine3A;
use spatial_accel::Aabb;

/// An entity's own space as the trees last saw it: what an exact ray test needs once a ray
/// has reached the entity's world box.
///
/// Kept by slot, next to the world boxes, because a ray's candidates are scattered through the
/// ECS tables: reading the `GlobalTransform` and `Aabb` rows and inverting the transform for
/// each candidate cost three cache misses and an inversion (perf on the picking bench put the
/// transform read alone at a tenth of a ray). Written by the sync system whenever it places
/// the entity, so it is as current as the trees: a `GlobalTransform` edited after the sync
/// (by hand, in `PostUpdate`) is seen from the next frame, as the trees' boxes are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    /// World to the entity's space: the inverse of its `GlobalTransform`.
    pub local_from_world: Affine3A,
    /// The entity's `Aabb`, in its own space.
    pub local_bounds: Aabb,
}

impl LocalFrame {
    pub(crate) const NONE: Self = Self {
        local_from_world: Affine3A::IDENTITY,
        local_bounds: Aabb::EMPTY,
    };

    /// The entity's space to world: the entity's `GlobalTransform` as the sync saw it, taken
    /// back from its inverse (to within rounding).
    ///
    /// Computed on demand, not stored: a ray needs it only for the hits it reports, and a
    /// second affine in the slot record would make it three cache lines, for the sync to write
    /// and every candidate to read. Reading the `GlobalTransform` row instead costs a cache
    /// miss per candidate.
    pub fn world_from_local(&self) -> Affine3A {
        self.local_from_world.inverse()
    }
}
