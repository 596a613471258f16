//! The invariant checker: what the tests ask of every built tree.

use super::plane::{BspPlane, Side};
use super::tree::{BspTree, NONE};
use crate::Aabb;
use std::fmt;

/// A broken tree invariant.
#[derive(Clone, Debug, PartialEq)]
pub enum BspValidationError {
    /// A node is reached twice, or not at all, from the root, or a child index is out of
    /// range.
    Structure,
    /// A piece belongs to no node's list, to two, or a node's list runs past the pieces.
    PieceCoverage,
    /// A piece in a node's own list does not lie in the node's plane (and the depth limit
    /// did not stop the node).
    NotInPlane {
        /// The node.
        node: u32,
        /// The piece.
        piece: u32,
    },
    /// A piece has a corner on the wrong side of an ancestor's plane.
    WrongSide {
        /// The ancestor node.
        ancestor: u32,
        /// The piece.
        piece: u32,
    },
    /// A piece is off its source triangle's plane, or its source is left out of the tree.
    OffSource {
        /// The piece.
        piece: u32,
    },
    /// A node's box does not hold its pieces or its children's boxes.
    Bounds {
        /// The node.
        node: u32,
    },
    /// A count in the stats disagrees with a recount.
    Count(&'static str),
}

impl fmt::Display for BspValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Structure => write!(f, "nodes not a tree from the root"),
            Self::PieceCoverage => write!(f, "pieces not in exactly one node each"),
            Self::NotInPlane { node, piece } => {
                write!(f, "piece {piece} of node {node} is not in its plane")
            }
            Self::WrongSide { ancestor, piece } => {
                write!(f, "piece {piece} on the wrong side of node {ancestor}")
            }
            Self::OffSource { piece } => write!(f, "piece {piece} is off its source's plane"),
            Self::Bounds { node } => write!(f, "node {node}'s box misses part of its subtree"),
            Self::Count(what) => write!(f, "the {what} count disagrees with a recount"),
        }
    }
}

impl std::error::Error for BspValidationError {}

/// A step down the tree: the parent and the side of its plane taken.
type Step = (u32, Side);

impl BspTree {
    /// Checks every invariant: the nodes form a tree from the root and each piece is in one
    /// node's list; a node's pieces lie in its plane and every piece of a subtree is on that
    /// subtree's side of each ancestor's plane (all within the tolerance); each piece lies
    /// in its source's plane; node boxes hold their subtrees; the stats match a recount.
    pub fn validate(&self) -> Result<(), BspValidationError> {
        self.check_sources()?;
        let tolerance = self.tolerance;
        let mut seen_node = vec![false; self.nodes.len()];
        let mut seen_piece = vec![false; self.pieces.len()];
        // (node, its depth below the root, its parent and the side of the parent's plane it
        // is on), and the path to the node: each ancestor and the side taken there. A depth
        // first walk leaves the path above a node's parent as it was when the parent came.
        let mut stack: Vec<(u32, usize, Option<Step>)> = Vec::new();
        let mut path: Vec<Step> = Vec::new();
        if !self.nodes.is_empty() {
            stack.push((0, 0, None));
        }
        let mut depth = 0;
        while let Some((n, level, parent)) = stack.pop() {
            let node = self
                .nodes
                .get(n as usize)
                .ok_or(BspValidationError::Structure)?;
            if std::mem::replace(&mut seen_node[n as usize], true) {
                return Err(BspValidationError::Structure);
            }
            path.truncate(level.saturating_sub(1));
            path.extend(parent);
            depth = depth.max(level + 1);
            let range = node.range();
            if range.end > self.pieces.len() {
                return Err(BspValidationError::PieceCoverage);
            }
            for p in range {
                if std::mem::replace(&mut seen_piece[p], true) {
                    return Err(BspValidationError::PieceCoverage);
                }
                let piece = &self.pieces[p];
                let side = |plane: &BspPlane| piece.vertices.map(|v| plane.classify(v, tolerance));
                let in_plane = side(&node.plane).iter().all(|&s| s == Side::On);
                if !(in_plane || node.depth_limited || piece.source == node.source) {
                    return Err(BspValidationError::NotInPlane {
                        node: n,
                        piece: p as u32,
                    });
                }
                for &(ancestor, taken) in &path {
                    let wrong = match taken {
                        Side::Front => Side::Back,
                        _ => Side::Front,
                    };
                    if side(&self.nodes[ancestor as usize].plane).contains(&wrong) {
                        return Err(BspValidationError::WrongSide {
                            ancestor,
                            piece: p as u32,
                        });
                    }
                }
                if !node
                    .bounds
                    .contains_aabb(&Aabb::from_points(piece.vertices))
                {
                    return Err(BspValidationError::Bounds { node: n });
                }
            }
            for (child, taken) in [(node.front, Side::Front), (node.back, Side::Back)] {
                if child == NONE {
                    continue;
                }
                let inner = self
                    .nodes
                    .get(child as usize)
                    .ok_or(BspValidationError::Structure)?;
                if !node.bounds.contains_aabb(&inner.bounds) {
                    return Err(BspValidationError::Bounds { node: n });
                }
                stack.push((child, level + 1, Some((n, taken))));
            }
        }
        if seen_node.contains(&false) {
            return Err(BspValidationError::Structure);
        }
        if seen_piece.contains(&false) {
            return Err(BspValidationError::PieceCoverage);
        }
        self.check_counts(depth)
    }

    /// Each piece lies in its source's plane, and its source is in the tree.
    fn check_sources(&self) -> Result<(), BspValidationError> {
        for (p, piece) in self.pieces.iter().enumerate() {
            let off = BspValidationError::OffSource { piece: p as u32 };
            let source = self.source_triangle(piece.source).ok_or(off.clone())?;
            if self.loose.contains(&piece.source) {
                return Err(off);
            }
            let plane = BspPlane::from_triangle(&source.vertices).ok_or(off.clone())?;
            if piece
                .vertices
                .iter()
                .any(|&v| plane.classify(v, self.tolerance) != Side::On)
            {
                return Err(off);
            }
        }
        Ok(())
    }

    fn check_counts(&self, depth: usize) -> Result<(), BspValidationError> {
        let s = &self.stats;
        let count = |what, ok: bool| ok.then_some(()).ok_or(BspValidationError::Count(what));
        count("node", s.nodes == self.nodes.len())?;
        count("piece", s.pieces == self.pieces.len())?;
        count("depth", s.depth == depth)?;
        count("degenerate", s.degenerate == self.loose.len())?;
        let non_finite = self.sources.iter().filter(|t| t.is_none()).count();
        count("non-finite", s.non_finite == non_finite)?;
        let mut per_source = vec![0usize; self.sources.len()];
        for p in &self.pieces {
            per_source[p.source as usize] += 1;
        }
        let in_tree = per_source.iter().filter(|&&n| n > 0).count();
        count("source", s.sources == in_tree)?;
        count(
            "source",
            s.sources + s.degenerate + s.non_finite == self.sources.len(),
        )?;
        count(
            "pieces per source",
            s.max_pieces_per_source == per_source.iter().copied().max().unwrap_or(0),
        )?;
        // Each cut turns one piece into two or three.
        count(
            "split",
            s.pieces >= s.sources + s.splits && s.pieces <= s.sources + 2 * s.splits,
        )?;
        let limited: usize = self
            .nodes
            .iter()
            .filter(|n| n.depth_limited)
            .map(|n| n.count as usize)
            .sum();
        count("depth-limited", s.depth_limited == limited)
    }
}
