//! Each slot's record: an entity's exact world box and own space, as the sync last wrote
//! them.

#[cfg(doc)]
use super::AccelTrees;
use super::LocalFrame;
use bevy::prelude::*;
use spatial_accel::Aabb;

/// What the sync writes for a slot each time its entity moves, and what a ray's candidate
/// reads once its exact box is hit: the box, then the entity's own space.
///
/// One record of exactly two cache lines, aligned to them. Why: the sync writes both parts
/// for every moved entity, and as two arrays (a 48-byte box-and-entity entry, a 96-byte
/// frame) they spanned four lines on average, each a miss at a scattered slot; a ray's
/// candidate reads the box on the first line and the frame mostly on the second.
///
/// The box is stored as plain coordinates so the entity fits on the first line too: a ray's
/// candidate then finds its entity on the line its box test loaded, where reading it from the
/// packed [`AccelTrees::slot_entities`] array costs one more miss per candidate
/// (BENCHMARKS.md, Picking). The packed array stays for
/// culling, which walks slots in order and reads 8 bytes per entity instead of a line.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct SlotEntry {
    pub(super) min: [f32; 3],
    pub(super) max: [f32; 3],
    pub(super) entity: Option<Entity>,
    pub(super) frame: LocalFrame,
}

const _: () = assert!(core::mem::size_of::<SlotEntry>() == 128);

impl SlotEntry {
    pub(super) const FREE: Self = Self {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
        entity: None,
        frame: LocalFrame::NONE,
    };

    /// The record of a busy mover's slot: its box lives in the busy movers' list, and its
    /// own space is not kept (the sync would have to write it for every move, which is what
    /// the list exists to avoid). The NaN box marks it, and hides it from any test that
    /// reads it by mistake.
    pub(super) const fn busy(entity: Entity) -> Self {
        Self {
            min: [f32::NAN; 3],
            max: [f32::NAN; 3],
            entity: Some(entity),
            frame: LocalFrame::NONE,
        }
    }

    #[inline]
    pub(super) fn is_busy(&self) -> bool {
        self.min[0].is_nan()
    }

    pub(super) fn new(entity: Entity, bounds: Aabb, frame: LocalFrame) -> Self {
        Self {
            min: bounds.min.to_array(),
            max: bounds.max.to_array(),
            entity: Some(entity),
            frame,
        }
    }

    #[inline]
    pub(super) fn bounds(&self) -> Aabb {
        Aabb::new(Vec3A::from_array(self.min), Vec3A::from_array(self.max))
    }
}
