//! The painter's orders: every piece, back to front or front to back, from any eye point.

use super::tree::{BspTree, NONE};
use crate::query::TraversalStack;
use glam::Vec3A;

/// A step of the walk: a subtree to expand, or a node's own pieces to list.
#[derive(Clone, Copy)]
enum Step {
    Subtree(u32),
    Pieces(u32),
}

impl BspTree {
    /// Appends to `out` the index in [`BspTree::pieces`] of every piece, each once, in an
    /// order a painter can draw in from `eye` (each piece drawn after every piece it may
    /// hide from there), without a depth buffer.
    ///
    /// At each node the subtree on the far side of the plane from the eye comes first, then
    /// the node's own pieces (in the plane, so none hides another), then the near subtree:
    /// nothing on the far side can hide anything in the plane or on the eye's side (Fuchs,
    /// Kedem and Naylor 1980). An eye on a plane sees both sides edge on, so either order
    /// serves; a NaN eye gets some order, without panicking.
    pub fn back_to_front(&self, eye: Vec3A, out: &mut Vec<u32>) {
        self.walk(eye, false, out);
    }

    /// [`BspTree::back_to_front`] reversed, exactly: the eye's side first, the node's own
    /// pieces (in reverse), then the far side. Occluders come first, as a renderer that
    /// stops where the screen is covered wants them.
    pub fn front_to_back(&self, eye: Vec3A, out: &mut Vec<u32>) {
        self.walk(eye, true, out);
    }

    fn walk(&self, eye: Vec3A, eye_side_first: bool, out: &mut Vec<u32>) {
        if self.nodes.is_empty() {
            return;
        }
        out.reserve(self.pieces.len());
        let mut stack: TraversalStack<Step> = TraversalStack::new();
        stack.push(Step::Subtree(0));
        while let Some(step) = stack.pop() {
            match step {
                Step::Subtree(n) => {
                    let node = &self.nodes[n as usize];
                    let eye_in_front = node.plane.signed_distance(eye) >= 0.0;
                    let (near, far) = if eye_in_front {
                        (node.front, node.back)
                    } else {
                        (node.back, node.front)
                    };
                    let (first, last) = if eye_side_first {
                        (near, far)
                    } else {
                        (far, near)
                    };
                    // Pushed in reverse: the stack pops `first` first.
                    if last != NONE {
                        stack.push(Step::Subtree(last));
                    }
                    stack.push(Step::Pieces(n));
                    if first != NONE {
                        stack.push(Step::Subtree(first));
                    }
                }
                Step::Pieces(n) => {
                    let range = self.nodes[n as usize].range();
                    let range = range.start as u32..range.end as u32;
                    if eye_side_first {
                        out.extend(range.rev());
                    } else {
                        out.extend(range);
                    }
                }
            }
        }
    }
}
