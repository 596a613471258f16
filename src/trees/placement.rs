//! Where an entity is: its world box, from its Bevy `Aabb` and `GlobalTransform`, and its own
//! space ([`LocalFrame`]), kept beside the box for exact ray tests.

use bevy::camera::primitives::Aabb as BevyAabb;
use bevy::math::Affine3A;
use bevy::prelude::*;
use spatial_accel::Aabb;

/// An entity's own space as the trees last saw it: what an exact ray test needs once a ray
/// has reached the entity's world box.
///
/// Kept by slot, next to the world boxes, because a ray's candidates are scattered through the
/// ECS tables: reading the `GlobalTransform` and `Aabb` rows and inverting the transform for
/// each candidate would cost three cache misses and an inversion. Written by the sync system whenever it places
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

/// Where an entity is: its world box, and what its own space is taken from.
pub(crate) struct Placement {
    /// The entity's `Aabb` in world space.
    pub(crate) world: Aabb,
    affine: Affine3A,
    local: Aabb,
}

impl Placement {
    /// The entity's own space. Taken on demand: a busy mover's sync needs only the box.
    pub(crate) fn frame(&self) -> LocalFrame {
        // Inverted as Bevy's `MeshRayCast` does for each ray, so local rays match its own.
        LocalFrame {
            local_from_world: self.affine.inverse(),
            local_bounds: self.local,
        }
    }
}

/// The world box and own space of an entity, or why it has none. Non-finite or singular
/// transforms would put NaN or infinities into the tree (a NaN box hides its whole subtree
/// from every query), so they are refused here and the entity stays out until its transform
/// is valid again.
pub(crate) fn placement(
    aabb: &BevyAabb,
    transform: &GlobalTransform,
) -> Result<Placement, &'static str> {
    let affine = transform.affine();
    let det = affine.matrix3.determinant();
    if !det.is_finite() || !affine.translation.is_finite() {
        return Err("its GlobalTransform is not finite");
    }
    if det == 0.0 {
        return Err("its GlobalTransform has a zero scale");
    }
    let local = Aabb::from_center_half_extents(aabb.center, aabb.half_extents);
    if !local.is_finite() {
        return Err("its Aabb is not finite");
    }
    let world = local.transformed(&affine);
    if !world.is_finite() {
        return Err("its world bounds overflow");
    }
    Ok(Placement {
        world,
        affine,
        local,
    })
}
