//! The dynamic tree copied into the static tree's flat layout, so that it can be collapsed
//! into wide nodes for rays while it holds still (see
//! [`StaticDynamicPair::snapshot_dynamic_for_rays`](super::StaticDynamicPair::snapshot_dynamic_for_rays)).

use super::DynamicBvh;
use super::node::NULL;
use crate::Bvh;
use crate::bvh::BvhNode;

impl DynamicBvh {
    /// The tree as a flat binary [`Bvh`] of the same shape: the same boxes (fat ones at the
    /// leaves), one primitive per leaf, whose index is the leaf's id. Call it on a refit tree
    /// (no [`needs_refit`](Self::needs_refit)), or inner boxes may not bound their leaves.
    pub(crate) fn to_flat_bvh(&self) -> Bvh {
        let mut nodes: Vec<BvhNode> = Vec::with_capacity(2 * self.len());
        let mut primitive_indices = Vec::with_capacity(self.len());
        if self.root != NULL {
            nodes.push(BvhNode::default());
            // (arena node, flat node); children are placed next to each other, as the flat
            // layout names both by the left one.
            let mut stack = vec![(self.root, 0usize)];
            while let Some((node, flat)) = stack.pop() {
                let n = &self.arena.nodes[node as usize];
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
                    stack.push((n.children[1], left + 1));
                    stack.push((n.children[0], left));
                }
            }
        }
        Bvh {
            nodes,
            primitive_indices,
        }
    }
}
