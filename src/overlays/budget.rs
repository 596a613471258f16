//! The overlays' shared line budget, and what they drew.

use super::{AccelGizmos, AccelOverlaySettings};
use bevy::prelude::*;

/// Lines a box costs.
const BOX_LINES: usize = 12;

/// What the overlays drew in the last frame.
#[derive(Resource, Clone, Debug, Default, PartialEq, Eq)]
pub struct AccelOverlayStats {
    /// Lines drawn, over all overlays.
    pub lines: usize,
    /// Tree nodes drawn (static and dynamic).
    pub nodes: usize,
    /// Entity boxes drawn.
    pub entity_boxes: usize,
    /// Entity boxes drawn that the culling view sees.
    pub visible_boxes: usize,
    /// Picking rays drawn.
    pub rays: usize,
    /// True when the line budget left something out.
    pub truncated: bool,
}

/// This frame's remaining lines, and the counts so far.
#[derive(Resource, Default)]
pub(crate) struct LineBudget {
    left: usize,
    pub(crate) stats: AccelOverlayStats,
}

impl LineBudget {
    /// Takes `lines` from the budget if it has them; marks the frame truncated if not.
    pub(crate) fn take(&mut self, lines: usize) -> bool {
        if lines > self.left {
            self.stats.truncated = true;
            return false;
        }
        self.left -= lines;
        self.stats.lines += lines;
        true
    }

    /// Lines left this frame.
    pub(crate) fn remaining(&self) -> usize {
        self.left
    }

    /// Draws a box's twelve edges, if the budget allows. True if drawn.
    pub(crate) fn draw_box(
        &mut self,
        gizmos: &mut Gizmos<AccelGizmos>,
        bounds: &spatial_accel::Aabb,
        color: Color,
    ) -> bool {
        if !bounds.is_valid() || !self.take(BOX_LINES) {
            return false;
        }
        let center = Vec3::from(bounds.center());
        // A flat box (a quadtree cell, a plane's bounds) still shows as a rectangle.
        let size = Vec3::from(bounds.max - bounds.min).max(Vec3::splat(1e-4));
        gizmos.cube(Transform::from_translation(center).with_scale(size), color);
        true
    }
}

pub(crate) fn start_frame(settings: Res<AccelOverlaySettings>, mut budget: ResMut<LineBudget>) {
    *budget = LineBudget {
        left: settings.line_budget,
        stats: AccelOverlayStats::default(),
    };
}

pub(crate) fn publish_stats(budget: Res<LineBudget>, mut stats: ResMut<AccelOverlayStats>) {
    stats.set_if_neq(budget.stats.clone());
}

pub(crate) fn clear_stats(mut stats: ResMut<AccelOverlayStats>) {
    stats.set_if_neq(AccelOverlayStats::default());
}
