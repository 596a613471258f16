//! The trees' word on a flat pass's frustum tests: which entities a walk of the view proved
//! inside, and which it never reached.

use super::view_walk::ViewWalk;
use crate::trees::{AccelTrees, TreeSlot};
use bevy::prelude::*;

/// The trees' answers for a flat pass: a walk of the view's frustum kept as sets
/// ([`super::view_walk::WalkForm::Bits`]), and which entities the trees hold.
///
/// Why: Bevy's frustum test (a bounding sphere, then the oriented box, from the entity's
/// transform) is most of what its loop spends per entity (BENCHMARKS.md, Culling). The walk
/// settles it for every entity it proves inside or never reaches, by the same rules the tree path decides by, so the results are Bevy's; the
/// entities it cannot settle (leaves crossing a plane, entities outside the trees) get
/// Bevy's test.
#[derive(Clone, Copy)]
pub(crate) struct TreeVerdicts<'a> {
    pub(crate) walk: &'a ViewWalk,
    pub(crate) trees: &'a AccelTrees,
}

impl TreeVerdicts<'_> {
    /// Whether `entity` passes the view's frustum test, if the trees know: yes inside a
    /// subtree fully in view, no if tracked and in no leaf the walk reached.
    #[inline]
    pub(super) fn frustum_test(&self, entity: Entity) -> Option<bool> {
        let (slot, tree) = self.trees.tracked_location(entity)?;
        if tree == TreeSlot::Busy {
            // A walk kept from an earlier frame knows only where a busy mover was.
            None
        } else if self.walk.inside_bits.contains(slot) {
            Some(true)
        } else if self.walk.crossing_bits.contains(slot) {
            None
        } else {
            Some(false)
        }
    }
}
