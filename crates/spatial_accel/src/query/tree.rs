//! The view of a hierarchy that the shared traversals walk, whatever its branching factor.

use super::NodeVolume;

/// A hierarchy of bounding volumes over primitive ids: a binary BVH, a wide BVH, a sphere
/// tree, the dynamic BVH, a loose octree or quadtree.
///
/// Every query of [`SpatialQuery`](super::SpatialQuery) is written once over this view (in
/// [`crate::query::walks`] and [`crate::query::views`]) and behaves the same on every tree
/// shape; a structure keeps a walk of its own only where one measures faster (the wide
/// trees' SIMD ray walk: BENCHMARKS.md, Shared walks).
///
/// What an implementation promises:
/// - a node's volume contains the volumes of its children and the bounds of the primitives
///   stored at it ([`node_primitives`](Self::node_primitives));
/// - every primitive is stored at exactly one node, so a walk reports it at most once (a
///   structure that stores one primitive in several cells, a grid, cannot be this view: it
///   answers queries itself and keeps the duplicates contract of
///   [`SpatialQuery`](super::SpatialQuery));
/// - node ids are the implementer's own; primitive ids are what the caller gave.
///
/// Primitives may sit at interior nodes as well as leaves: a loose octree keeps an object at
/// the depth its size gives. Walks visit a node's own primitives when they enter the node.
pub trait BoundingTree {
    /// The bounding volume of a node.
    type Volume: NodeVolume;

    /// The children of an interior node, in the order a depth-first walk takes them.
    type Children<'a>: IntoIterator<Item = u32, IntoIter: DoubleEndedIterator>
    where
        Self: 'a;

    /// Whether interior nodes may hold primitives too (an octree's); when false, walks read
    /// [`node_primitives`](Self::node_primitives) at leaves only.
    const INTERIOR_PRIMITIVES: bool = false;

    /// The root node, or `None` for an empty tree.
    fn root(&self) -> Option<u32>;

    /// The bounds of a node: a volume containing everything below it.
    fn node_bounds(&self, node: u32) -> Self::Volume;

    /// The children of an interior node, or `None` for a leaf.
    fn node_children(&self, node: u32) -> Option<Self::Children<'_>>;

    /// The primitive ids stored at a node: a BVH's leaf primitives (none at its interior
    /// nodes); the objects an octree keeps at that cell.
    fn node_primitives(&self, node: u32) -> &[u32];

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

    /// Hints that the children of `node` will be read soon. The ray walk asks this of every
    /// child a ray enters: in a scattered tree the misses of one level then overlap instead
    /// of queueing one node at a time. The default prefetches each child through
    /// [`prefetch_node`](Self::prefetch_node).
    #[inline]
    fn prefetch_children(&self, node: u32) {
        if let Some(children) = self.node_children(node) {
            for child in children {
                self.prefetch_node(child);
            }
        }
    }
}

/// A subtree of a [`BoundingTree`], itself a tree rooted at one of its nodes.
pub struct Subtree<'a, T: ?Sized> {
    tree: &'a T,
    root: u32,
}

impl<'a, T: BoundingTree + ?Sized> Subtree<'a, T> {
    /// The subtree of `tree` below `node`.
    pub fn new(tree: &'a T, node: u32) -> Self {
        Self { tree, root: node }
    }
}

impl<T: BoundingTree + ?Sized> BoundingTree for Subtree<'_, T> {
    type Volume = T::Volume;
    const INTERIOR_PRIMITIVES: bool = T::INTERIOR_PRIMITIVES;
    type Children<'b>
        = T::Children<'b>
    where
        Self: 'b;

    #[inline]
    fn root(&self) -> Option<u32> {
        Some(self.root)
    }
    #[inline]
    fn node_bounds(&self, node: u32) -> T::Volume {
        self.tree.node_bounds(node)
    }
    #[inline]
    fn node_children(&self, node: u32) -> Option<Self::Children<'_>> {
        self.tree.node_children(node)
    }
    #[inline]
    fn node_primitives(&self, node: u32) -> &[u32] {
        self.tree.node_primitives(node)
    }
    #[inline]
    fn subtree_primitives(&self, node: u32) -> Option<&[u32]> {
        self.tree.subtree_primitives(node)
    }
    #[inline]
    fn prefetch_node(&self, node: u32) {
        self.tree.prefetch_node(node)
    }
    #[inline]
    fn prefetch_children(&self, node: u32) {
        self.tree.prefetch_children(node)
    }
}
