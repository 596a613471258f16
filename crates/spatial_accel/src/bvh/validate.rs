//! The invariant checker: what every test asks of every tree after every change.

use crate::Aabb;
use crate::query::BoundingTree;
use std::fmt;

/// A broken tree invariant.
#[derive(Clone, Debug, PartialEq)]
pub enum ValidationError {
    /// A node's box does not contain a child's box.
    ChildOutsideParent {
        /// The parent node.
        parent: u32,
        /// The child node.
        child: u32,
    },
    /// A leaf's box does not contain one of its primitives' boxes.
    PrimitiveOutsideLeaf {
        /// The leaf node.
        leaf: u32,
        /// The primitive id.
        primitive: u32,
    },
    /// A primitive id is reachable more than once.
    DuplicatePrimitive(u32),
    /// A primitive id outside the input, or with no bounds given.
    UnknownPrimitive(u32),
    /// A valid input primitive is not reachable from the root.
    MissingPrimitive(u32),
    /// A node is reachable twice (the "tree" has a cycle or shared subtree).
    NodeReachedTwice(u32),
    /// A primitive built as pieces (a pre-split triangle's) has a piece's box that its own
    /// box does not contain.
    PieceOutsidePrimitive(u32),
    /// A node has a NaN box.
    InvalidBounds(u32),
    /// An empty leaf.
    EmptyLeaf(u32),
    /// An interior node holds primitives in a tree whose walks read them at leaves only
    /// ([`BoundingTree::INTERIOR_PRIMITIVES`] is false): queries would never see them.
    PrimitivesAtInteriorNode(u32),
    /// A wide node's inlined primitive id (see
    /// [`WideBvh::inline_single_leaves`](super::wide::WideBvh::inline_single_leaves)) is not
    /// the id at its slot's position in the primitive array.
    InlinePrimitiveMismatch {
        /// The node.
        node: u32,
        /// The inlined id.
        primitive: u32,
    },
}

impl fmt::Display for ValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "BVH invariant broken: {self:?}")
    }
}

impl std::error::Error for ValidationError {}

/// Checks that every node bounds its children, every leaf bounds its primitives, and every valid
/// primitive of `bounds` is reachable exactly once (invalid ones not at all). `bounds(id)`
/// gives a primitive's box, or `None` for ids that should not be in the tree.
pub fn validate_tree<T, B>(
    tree: &T,
    node_count: usize,
    primitive_count: usize,
    bounds: B,
) -> Result<(), ValidationError>
where
    T: BoundingTree<Volume = Aabb> + ?Sized,
    B: Fn(u32) -> Option<Aabb>,
{
    let mut seen_prim = vec![false; primitive_count];
    let mut seen_node = vec![false; node_count];
    if let Some(root) = tree.root() {
        let mut stack = vec![root];
        while let Some(node) = stack.pop() {
            let slot = seen_node
                .get_mut(node as usize)
                .ok_or(ValidationError::NodeReachedTwice(node))?;
            if std::mem::replace(slot, true) {
                return Err(ValidationError::NodeReachedTwice(node));
            }
            let nb = tree.node_bounds(node);
            if nb.min.is_nan() || nb.max.is_nan() {
                return Err(ValidationError::InvalidBounds(node));
            }
            let children = tree.node_children(node);
            let prims = tree.node_primitives(node);
            if children.is_none() && prims.is_empty() {
                return Err(ValidationError::EmptyLeaf(node));
            }
            if children.is_some() && !prims.is_empty() && !T::INTERIOR_PRIMITIVES {
                return Err(ValidationError::PrimitivesAtInteriorNode(node));
            }
            for c in children.into_iter().flatten() {
                if !nb.contains_aabb(&tree.node_bounds(c)) {
                    return Err(ValidationError::ChildOutsideParent {
                        parent: node,
                        child: c,
                    });
                }
                stack.push(c);
            }
            for &p in prims {
                let b = bounds(p).ok_or(ValidationError::UnknownPrimitive(p))?;
                let seen = seen_prim
                    .get_mut(p as usize)
                    .ok_or(ValidationError::UnknownPrimitive(p))?;
                if std::mem::replace(seen, true) {
                    return Err(ValidationError::DuplicatePrimitive(p));
                }
                if !nb.contains_aabb(&b) {
                    return Err(ValidationError::PrimitiveOutsideLeaf {
                        leaf: node,
                        primitive: p,
                    });
                }
            }
        }
    }
    for (p, seen) in seen_prim.iter().enumerate() {
        if !seen && bounds(p as u32).is_some() {
            return Err(ValidationError::MissingPrimitive(p as u32));
        }
    }
    Ok(())
}

impl super::Bvh {
    /// Validates the tree against the boxes it was built (or refit) from: see [`validate_tree`].
    pub fn validate(&self, bounds: &[Aabb]) -> Result<(), ValidationError> {
        validate_tree(self, self.nodes.len(), bounds.len(), |p| {
            bounds.get(p as usize).copied().filter(Aabb::is_valid)
        })
    }

    /// SAH cost and shape statistics.
    pub fn stats(&self, costs: &super::SahCosts) -> super::stats::TreeStats {
        super::stats::tree_stats(self, costs)
    }
}
