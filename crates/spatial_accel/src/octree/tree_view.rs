//! The tree seen by the shared walks: octants as nodes, their tight bounds as volumes, and
//! the entries kept at each octant, interior ones included, as its primitives.

use super::cells::NONE;
use super::tree::LooseTree;
use crate::Aabb;
use crate::query::BoundingTree;

impl<const AXES: usize> BoundingTree for LooseTree<AXES> {
    type Volume = Aabb;
    type Children<'a> = core::iter::Copied<core::slice::Iter<'a, u32>>;
    /// Objects sit at the octant their size gives, interior ones included.
    const INTERIOR_PRIMITIVES: bool = true;

    #[inline]
    fn root(&self) -> Option<u32> {
        debug_assert!(
            self.dirty.is_empty(),
            "query on a loose tree with edits since the last maintain"
        );
        (self.root != NONE).then_some(self.root)
    }

    #[inline]
    fn node_bounds(&self, node: u32) -> Aabb {
        self.arena.get(node).tight
    }

    /// The children in ascending octant index. The shared ray walk orders them itself (the
    /// nearest it enters goes first), which also holds where loose cells overlap.
    #[inline]
    fn node_children(&self, node: u32) -> Option<Self::Children<'_>> {
        let children = self.arena.get(node).children();
        (!children.is_empty()).then(|| children.iter().copied())
    }

    /// The octants lie wherever the arena had room when they were made, so a walk misses the
    /// cache on most: it asks for the two lines it reads (bounds and children, then the ids)
    /// as soon as it knows it will.
    #[inline]
    fn prefetch_node(&self, node: u32) {
        if let Some(octant) = self.arena.octants.get(node as usize) {
            crate::prefetch::prefetch_node(&octant.tight);
            crate::prefetch::prefetch_node(&octant.ids);
        }
    }

    #[inline]
    fn node_primitives(&self, node: u32) -> &[u32] {
        &self.arena.get(node).ids
    }
}

crate::impl_spatial_query_for_tree!(impl[const AXES: usize] LooseTree<AXES>);
