//! The dynamic tree copied into the static tree's flat layout, so that it can be collapsed
//! into wide nodes for rays while it holds still (see
//! [`StaticDynamicPair::snapshot_dynamic_for_rays`](super::StaticDynamicPair::snapshot_dynamic_for_rays)).

use super::DynamicBvh;
use super::node::{NULL, Node};
use crate::Bvh;
use crate::bvh::BvhNode;
use crate::prefetch::prefetch_node;

/// How many queue entries ahead the copy asks for nodes (as the refit schedule's compilation
/// does, whose steps are as short).
const PREFETCH_DISTANCE: usize = 48;

impl DynamicBvh {
    /// The tree as a flat binary [`Bvh`] of the same shape: the same boxes (fat ones at the
    /// leaves), one primitive per leaf, whose index is the leaf's id. Call it on a refit tree
    /// (no [`needs_refit`](Self::needs_refit)), or inner boxes may not bound their leaves.
    pub(crate) fn to_flat_bvh(&self) -> Bvh {
        flatten(&self.arena.nodes, self.root, self.len())
    }
}

/// [`DynamicBvh::to_flat_bvh`] over an arena's nodes (or a copy of them) and its root, with
/// room reserved for `leaves` leaves.
pub(super) fn flatten(arena: &[Node], root: u32, leaves: usize) -> Bvh {
    let mut nodes: Vec<BvhNode> = Vec::with_capacity(2 * leaves);
    let mut primitive_indices = Vec::with_capacity(leaves);
    if root != NULL {
        nodes.push(BvhNode::default());
        // Breadth-first, as a queue of (arena node, flat node): the arena's order is
        // random after edits, and a queue names each node long before it is read, so it
        // is prefetched a fixed distance ahead and the misses overlap (a depth-first
        // copy waited one memory latency per node: 11-12 ms of a 100k-leaf tree's
        // 33-38 ms snapshot). Children get adjacent flat slots, as the layout needs.
        let mut queue = vec![(root, 0usize)];
        let mut k = 0;
        while k < queue.len() {
            if let Some(&(ahead, _)) = queue.get(k + PREFETCH_DISTANCE) {
                prefetch_node(&arena[ahead as usize]);
            }
            let (node, flat) = queue[k];
            k += 1;
            let n = &arena[node as usize];
            nodes[flat].set_aabb(&n.aabb);
            if n.is_leaf() {
                nodes[flat].first = primitive_indices.len() as u32;
                nodes[flat].count = 1;
                primitive_indices.push(n.id);
            } else {
                let left = nodes.len();
                nodes[flat].first = left as u32;
                nodes[flat].count = 0;
                nodes.push(BvhNode::default());
                nodes.push(BvhNode::default());
                queue.push((n.children[0], left));
                queue.push((n.children[1], left + 1));
            }
        }
    }
    Bvh {
        nodes,
        primitive_indices,
    }
}
