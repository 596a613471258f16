//! The view of a binary bounding-volume tree that the shared traversals walk.

use crate::Aabb;

/// A binary tree of boxes whose leaves hold primitive ids.
///
/// The static [`crate::Bvh`] and the dynamic tree both implement it, so every query is written
/// once (in [`crate::query`]) and behaves the same on both. Node ids are the implementer's own;
/// primitive ids are what the caller gave when the primitive entered the tree.
pub trait BoundingTree {
    /// The root node, or `None` for an empty tree.
    fn root(&self) -> Option<u32>;

    /// The bounds of a node: a box containing everything below it.
    fn node_bounds(&self, node: u32) -> Aabb;

    /// The two children of an interior node, or `None` for a leaf.
    fn node_children(&self, node: u32) -> Option<[u32; 2]>;

    /// The primitive ids stored in a leaf (empty for interior nodes).
    fn leaf_primitives(&self, node: u32) -> &[u32];

    /// All primitive ids below a node as one slice, when the tree stores them contiguously
    /// (a top-down build does). Queries that accept a whole subtree (a frustum containing it)
    /// then copy a slice instead of walking every node below. `None` when not contiguous.
    fn subtree_primitives(&self, _node: u32) -> Option<&[u32]> {
        None
    }

    /// Hints that `node` will be read soon: a cache prefetch, for trees whose nodes lie at
    /// scattered places in memory (the dynamic tree's arena). The default does nothing.
    #[inline]
    fn prefetch_node(&self, _node: u32) {}
}
