//! The static BVH: a flat array of 32-byte binary nodes, built top-down or bottom-up.
//!
//! - [`config`]: split strategies (midpoint, median, binned and sweep SAH, LBVH, PLOC) and
//!   stopping rules.
//! - `build/`: the builders, one file per strategy: the top-down driver and its splits, the
//!   linear BVH (Morton-sorted radix tree, the fastest build), and the bottom-up PLOC builder
//!   (with optional reinsertion), all sharing one output format and the same stopping rules.
//! - [`stats`]: SAH cost, depth and leaf statistics of a built tree.
//! - [`validate`]: the invariant checker every test runs.
//! - [`SphereBvh`]: the same topology bounded by spheres instead of boxes.
//! - [`wide`]: the tree collapsed to 4-, 8- or 16-wide nodes for SIMD traversal, with exact or
//!   quantised child boxes, refit along the paths of moved primitives.
//!
//! Queries come from [`crate::SpatialQuery`], through the traversals shared with the dynamic
//! tree ([`crate::query::walks`]).

pub(crate) mod build;
pub mod config;
mod node;
mod sphere_tree;
pub mod stats;
pub mod validate;
pub mod wide;

pub use build::{MAX_BINS, MAX_SEARCH_RADIUS};
pub use config::{BuildConfig, SahCosts, SplitStrategy};
pub use node::BvhNode;
pub use sphere_tree::SphereBvh;

use crate::Aabb;
use crate::query::BoundingTree;

/// A bounding volume hierarchy over primitive boxes, built once, refittable.
///
/// Primitives are named by their index in the slice given to [`Bvh::build`]; leaves store these
/// ids in [`Bvh::primitive_indices`]. Invalid boxes (NaN or empty) are left out of the tree.
///
/// ```
/// use spatial_accel::{Aabb, Bvh, BuildConfig, SplitStrategy};
/// use glam::Vec3A;
/// let boxes: Vec<Aabb> = (0..1000)
///     .map(|i| {
///         let p = Vec3A::new((i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32);
///         Aabb::new(p, p + 0.5)
///     })
///     .collect();
/// let bvh = Bvh::build(&boxes, &BuildConfig::with_split(SplitStrategy::BinnedSah { bins: 16 }));
/// bvh.validate(&boxes).unwrap();
/// assert_eq!(bvh.primitive_count(), 1000);
/// ```
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub(crate) nodes: Vec<BvhNode>,
    pub(crate) primitive_indices: Vec<u32>,
}

impl Bvh {
    /// Builds a tree over the boxes with the given configuration (single-threaded).
    pub fn build(bounds: &[Aabb], config: &BuildConfig) -> Self {
        let (nodes, primitive_indices) = build::build_nodes(bounds, config);
        Self {
            nodes,
            primitive_indices,
        }
    }

    /// Builds like [`Bvh::build`] on rayon's thread pool: the same splits and leaves, with
    /// subtrees built in parallel (cargo feature `rayon`).
    #[cfg(feature = "rayon")]
    pub fn build_parallel(bounds: &[Aabb], config: &BuildConfig) -> Self {
        let (nodes, primitive_indices) = build::build_nodes_parallel(bounds, config);
        Self {
            nodes,
            primitive_indices,
        }
    }

    /// The node array; node 0 is the root.
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// Primitive ids in leaf order: leaf `n` holds `primitive_indices[n.first..n.first + n.count]`.
    pub fn primitive_indices(&self) -> &[u32] {
        &self.primitive_indices
    }

    /// Number of primitives in the tree.
    pub fn primitive_count(&self) -> usize {
        self.primitive_indices.len()
    }

    /// True for a tree with no primitives.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The bounds of everything in the tree (empty for an empty tree).
    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, BvhNode::aabb)
    }

    /// Recomputes every node box from new primitive boxes, keeping the topology.
    ///
    /// Children always follow their parent in the array, so one reverse sweep refits
    /// bottom-up with no recursion. Quality decays as primitives move away from where the tree
    /// was built; rebuild when [`stats::TreeStats::sah_cost`] grows too far.
    pub fn refit(&mut self, bounds: &[Aabb]) {
        for i in (0..self.nodes.len()).rev() {
            let node = self.nodes[i];
            let b = if node.is_leaf() {
                let first = node.first as usize;
                self.primitive_indices[first..first + node.count as usize]
                    .iter()
                    .fold(Aabb::EMPTY, |acc, &p| acc.union(&bounds[p as usize]))
            } else {
                let l = node.first as usize;
                self.nodes[l].aabb().union(&self.nodes[l + 1].aabb())
            };
            self.nodes[i].set_aabb(&b);
        }
    }

    /// Each node's span of [`Bvh::primitive_indices`]: node `i` holds the primitives
    /// `primitive_indices[r[0]..r[1]]` where `r = subtree_ranges()[i]`.
    ///
    /// Why a table: [`BoundingTree::subtree_primitives`] finds a span by walking down both
    /// edges of the subtree, a chain of dependent node loads; a frustum walk emits every
    /// subtree it proves inside, and in a tree too large for the cache each of those loads
    /// is a miss. A holder of a tree that is queried often (the static half of a
    /// [`StaticDynamicPair`](crate::dynamic::StaticDynamicPair)) builds this once, 8 bytes
    /// per node, and answers each span with one read.
    ///
    /// ```
    /// use spatial_accel::{Aabb, Bvh, BuildConfig};
    /// use glam::Vec3A;
    /// let boxes: Vec<Aabb> = (0..100).map(|i| Aabb::from_point(Vec3A::splat(i as f32))).collect();
    /// let bvh = Bvh::build(&boxes, &BuildConfig::default());
    /// let ranges = bvh.subtree_ranges();
    /// assert_eq!(ranges[0], [0, 100]);
    /// ```
    pub fn subtree_ranges(&self) -> Vec<[u32; 2]> {
        let mut ranges = vec![[0u32; 2]; self.nodes.len()];
        // Children always follow their parent in the array, so a reverse sweep meets both
        // children of a node before the node.
        for i in (0..self.nodes.len()).rev() {
            let node = &self.nodes[i];
            ranges[i] = if node.is_leaf() {
                [node.first, node.first + node.count]
            } else {
                let l = node.first as usize;
                [ranges[l][0], ranges[l + 1][1]]
            };
        }
        ranges
    }

    /// Memory held by the tree, in bytes (nodes plus the primitive order).
    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * core::mem::size_of::<BvhNode>() + self.primitive_indices.len() * 4
    }
}

impl BoundingTree for Bvh {
    type Volume = Aabb;
    type Children<'a>
        = [u32; 2]
    where
        Self: 'a;

    #[inline]
    fn root(&self) -> Option<u32> {
        (!self.nodes.is_empty()).then_some(0)
    }

    #[inline]
    fn node_bounds(&self, node: u32) -> Aabb {
        self.nodes[node as usize].aabb()
    }

    #[inline]
    fn node_children(&self, node: u32) -> Option<[u32; 2]> {
        let n = &self.nodes[node as usize];
        (!n.is_leaf()).then_some([n.first, n.first + 1])
    }

    #[inline]
    fn prefetch_node(&self, node: u32) {
        if let Some(n) = self.nodes.get(node as usize) {
            crate::prefetch::prefetch_node(n);
        }
    }

    #[inline]
    fn node_primitives(&self, node: u32) -> &[u32] {
        let n = &self.nodes[node as usize];
        if n.is_leaf() {
            &self.primitive_indices[n.first as usize..(n.first + n.count) as usize]
        } else {
            &[]
        }
    }

    /// The builder partitions in place, left child before right, so a subtree's primitives
    /// run from its leftmost leaf to its rightmost: two walks down its edges find them.
    fn subtree_primitives(&self, node: u32) -> Option<&[u32]> {
        let (mut left, mut right) = (&self.nodes[node as usize], &self.nodes[node as usize]);
        while !left.is_leaf() {
            left = &self.nodes[left.first as usize];
        }
        while !right.is_leaf() {
            right = &self.nodes[right.first as usize + 1];
        }
        self.primitive_indices
            .get(left.first as usize..(right.first + right.count) as usize)
    }
}

crate::impl_spatial_query_for_tree!(Bvh);
