//! A rectangle on the screen → a frustum → the trees' candidates → the mode's verdict. The
//! geometry is the core's ([`Frustum::from_clip_rect`], [`SelectionMode`],
//! [`MeshBvh::any_triangle_in_frustum`](spatial_accel::mesh::MeshBvh::any_triangle_in_frustum));
//! this file only connects it to the trees and the ECS.

use crate::trees::{AccelTrees, LocalFrame, placement};
use bevy::camera::primitives::Aabb as BevyAabb;
use bevy::prelude::*;
use spatial_accel::sort::sort_keys;
use spatial_accel::{Aabb, Containment, Frustum, SelectionMode, SpatialQuery, Sphere};
use std::borrow::Cow;

/// The part of the rectangle `a`–`b` (NDC, corners in any order) that lies in the viewport
/// (`[-1, 1]` on both axes), or `None` when none does: what the camera does not draw is not
/// selected, as picking casts no ray outside the viewport.
pub(crate) fn clamp_to_viewport(a: Vec2, b: Vec2) -> Option<(Vec2, Vec2)> {
    let lo = a.min(b).max(Vec2::NEG_ONE);
    let hi = a.max(b).min(Vec2::ONE);
    // NaN fails the comparison too.
    (lo.cmple(hi).all()).then_some((lo, hi))
}

/// The frustum of the rectangle `a`–`b` (NDC) seen through a camera: its projection and its
/// `GlobalTransform`. `None` for a rectangle wholly outside the viewport, or input that is
/// not finite.
pub(crate) fn rect_frustum(
    clip_from_view: Mat4,
    camera: &GlobalTransform,
    a: Vec2,
    b: Vec2,
) -> Option<Frustum> {
    let (lo, hi) = clamp_to_viewport(a, b)?;
    let clip_from_world = clip_from_view * camera.to_matrix().inverse();
    Frustum::from_clip_rect(&clip_from_world, lo, hi)
}

/// Calls `select(slot, entity)` for each tracked entity whose world box the `mode` does not
/// rule out in `frustum`, with `Some(verdict)` where the box decides and `None` where the
/// mesh must (see [`SelectionMode::select_by_aabb`]), in the order of the slots. `walked` is
/// scratch.
///
/// The walk only gathers slots; they are sorted before anything else is read. A tree's leaves
/// come in no order of memory, so reading each slot's record (and, in `select`, its entity's
/// components) as the walk reaches it is a cache miss per candidate. In slot order the records
/// are read in sequence, and slots follow the order entities were spawned in, which is how
/// Bevy's tables hold their rows.
pub(crate) fn candidates_in_frustum(
    trees: &AccelTrees,
    frustum: &Frustum,
    mode: SelectionMode,
    walked: &mut Vec<u64>,
    mut select: impl FnMut(u32, Entity, Option<bool>),
) {
    walked.clear();
    trees
        .query()
        .for_each_in_frustum(frustum, |slot, containment| {
            // The slot, and in bit 0 whether its tree box is wholly inside.
            walked.push(u64::from(slot) << 1 | u64::from(containment == Containment::Inside));
        });
    sort_keys(walked);
    // The packed entity column: a slot wholly inside needs its entity only, and the record
    // holding it beside the box is sixteen times as wide.
    let entities = trees.slot_entities();
    for &key in walked.iter() {
        let slot = (key >> 1) as u32;
        let Some(&Some(entity)) = entities.get(slot as usize) else {
            continue;
        };
        // A tree box wholly inside holds the exact box, and the mesh inside it (Bevy's `Aabb`
        // bounds its mesh): every mode selects it without a test.
        let verdict = if key & 1 == 1 {
            Some(true)
        } else {
            mode.select_by_aabb(frustum, &trees.world_bounds(slot))
        };
        if verdict != Some(false) {
            select(slot, entity, verdict);
        }
    }
}

/// Calls `select(slot, entity)` for each tracked entity the `mode` selects in `sphere`, judged
/// on its world box: its centre within the sphere (centre), its farthest corner (enclosed),
/// any point (touching).
pub(crate) fn candidates_in_sphere(
    trees: &AccelTrees,
    sphere: &Sphere,
    mode: SelectionMode,
    mut select: impl FnMut(u32, Entity),
) {
    let r2 = sphere.radius * sphere.radius;
    trees.query().for_each_overlapping_sphere(sphere, |slot| {
        let b = trees.world_bounds(slot);
        let verdict = b.is_valid()
            && match mode {
                SelectionMode::Center => b.center().distance_squared(sphere.center) <= r2,
                SelectionMode::Enclosed => {
                    let far = (b.min - sphere.center)
                        .abs()
                        .max((b.max - sphere.center).abs());
                    far.length_squared() <= r2
                }
                SelectionMode::Touching => b.distance_squared_to_point(sphere.center) <= r2,
            };
        if verdict && let Some(entity) = trees.entity(slot) {
            select(slot, entity);
        }
        core::ops::ControlFlow::Continue(())
    });
}

/// A slot's own space: kept by the trees, or for a busy mover taken from its rows as the sync
/// placed it.
pub(crate) fn frame_of<'a>(
    trees: &'a AccelTrees,
    slot: u32,
    rows: Option<(&BevyAabb, &GlobalTransform)>,
) -> Option<Cow<'a, LocalFrame>> {
    match trees.local_frame(slot) {
        Some(frame) => Some(Cow::Borrowed(frame)),
        None => {
            let (aabb, gt) = rows?;
            placement(aabb, gt).ok().map(|at| Cow::Owned(at.frame()))
        }
    }
}

/// Whether any of the twelve triangles of a box's faces meets the frustum (both in the same
/// space): the touching test of an entity without a readable mesh (a sprite's flat box is its
/// quad).
pub(crate) fn box_faces_touch(frustum: &Frustum, bounds: &Aabb) -> bool {
    if !bounds.is_valid() || !frustum.intersects_aabb(bounds) {
        return false;
    }
    let corner = |i: usize| {
        Vec3A::new(
            if i & 1 == 0 {
                bounds.min.x
            } else {
                bounds.max.x
            },
            if i & 2 == 0 {
                bounds.min.y
            } else {
                bounds.max.y
            },
            if i & 4 == 0 {
                bounds.min.z
            } else {
                bounds.max.z
            },
        )
    };
    // Each face as two triangles of its corners' indices (bit 0: x, 1: y, 2: z).
    const FACES: [[usize; 4]; 6] = [
        [0, 2, 6, 4],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 5, 7, 6],
    ];
    FACES.iter().any(|&[a, b, c, d]| {
        frustum.touches_triangle(&[corner(a), corner(b), corner(c)])
            || frustum.touches_triangle(&[corner(a), corner(c), corner(d)])
    })
}
