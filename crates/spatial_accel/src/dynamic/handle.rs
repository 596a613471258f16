//! Handles to a dynamic tree's leaves, and the errors its edits report.

/// A stable reference to one leaf of a [`DynamicBvh`](super::DynamicBvh): valid from `insert`
/// until `remove`.
///
/// Its [`index`](crate::query::Handle::index) is the leaf's arena index (leaves never move),
/// a [`BoundingTree`](crate::query::BoundingTree) node id; its generation is the leaf node's,
/// so a handle kept past `remove` is reported stale instead of naming whatever later reused
/// the node.
pub type LeafHandle = crate::query::Handle<super::DynamicBvh>;

/// Why a dynamic-tree edit was refused: the [`IndexError`](crate::query::IndexError) of
/// every [`DynamicIndex`](crate::query::DynamicIndex). The tree is unchanged when one is
/// returned; it holds at most 2^31 - 1 nodes.
pub type DynamicBvhError = crate::query::IndexError;
