//! The trees' nodes by depth.

use super::budget::LineBudget;
use super::{AccelGizmos, AccelOverlaySettings, level_color};
use crate::AccelTrees;
use bevy::prelude::*;
use core::ops::ControlFlow;
use spatial_accel::query::{NodeView, visit_tree_nodes};

/// Draws the nodes of the static tree and of the dynamic index in the chosen depth range,
/// each tree shallowest levels first (the walks are breadth first), sharing what is left of
/// the line budget evenly when both are on, so that a large static tree cannot crowd out the
/// dynamic one.
pub(crate) fn draw_tree_nodes(
    settings: Res<AccelOverlaySettings>,
    trees: Res<AccelTrees>,
    mut budget: ResMut<LineBudget>,
    mut gizmos: Gizmos<AccelGizmos>,
) {
    let depths = settings.min_depth..=settings.max_depth;
    let index = trees.query();
    let both = settings.static_nodes && settings.dynamic_nodes;
    if settings.dynamic_nodes {
        let share = budget.remaining() / if both { 2 } else { 1 };
        let mut visit = node_drawer(&mut budget, &mut gizmos, false, share);
        let _ = index.visit_dynamic_nodes(depths.clone(), &mut visit);
    }
    if settings.static_nodes {
        let share = budget.remaining();
        let visit = node_drawer(&mut budget, &mut gizmos, true, share);
        let _ = visit_tree_nodes(trees.static_tree(), depths, visit);
    }
}

/// A node visitor drawing each node's box until `share` lines are drawn or the budget ends.
fn node_drawer<'a>(
    budget: &'a mut LineBudget,
    gizmos: &'a mut Gizmos<'_, '_, AccelGizmos>,
    is_static: bool,
    share: usize,
) -> impl FnMut(NodeView) -> ControlFlow<()> + 'a {
    let mut lines = 0;
    move |node: NodeView| {
        if !node.bounds.is_valid() {
            return ControlFlow::Continue(());
        }
        let color = level_color(node.depth, is_static);
        if lines + 12 > share || !budget.draw_box(gizmos, &node.bounds, color) {
            budget.stats.truncated = true;
            return ControlFlow::Break(());
        }
        lines += 12;
        budget.stats.nodes += 1;
        ControlFlow::Continue(())
    }
}
