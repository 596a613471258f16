//! The dynamic tree copied into the static tree's flat layout, so that it can be collapsed
//! into wide nodes for rays while it holds still (see
//! [`StaticDynamicPair::snapshot_dynamic_for_rays`](super::StaticDynamicPair::snapshot_dynamic_for_rays)).

use super::DynamicBvh;
use super::node::{NULL, Node};
use crate::bvh::BvhNode;
use crate::prefetch::{prefetch_node, prefetch_value};
use crate::{Aabb, Bvh};

/// How many queue entries ahead the copy asks for nodes (as the refit schedule's compilation
/// does, whose steps are as short).
const PREFETCH_DISTANCE: usize = 48;

impl DynamicBvh {
    /// The tree as a flat binary [`Bvh`] of the same shape over the leaves' *tight* boxes
    /// (inner boxes refit from them), one primitive per leaf, whose index is the leaf's id.
    pub(crate) fn to_flat_bvh(&self) -> Bvh {
        flatten(&self.arena.nodes, &self.tight, self.root, self.len())
    }
}

/// [`DynamicBvh::to_flat_bvh`] over an arena's nodes and tight leaf boxes (or copies of
/// them) and its root, with room reserved for `leaves` leaves.
///
/// Why tight boxes: the fat ones leave room for motion, and the copy never sees motion (the
/// tree's next change drops it). Their margins only let rays into more nodes and candidates:
/// on the picking bench, rays through a copy over the tight boxes ran 8-10% faster.
pub(super) fn flatten(arena: &[Node], tight: &[Aabb], root: u32, leaves: usize) -> Bvh {
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
                // Its tight box, read if it is a leaf (inner nodes' entries are unused, and
                // asking for them costs less than a branch on a node not yet loaded).
                if let Some(b) = tight.get(ahead as usize) {
                    prefetch_value(b);
                }
            }
            let (node, flat) = queue[k];
            k += 1;
            let n = &arena[node as usize];
            if n.is_leaf() {
                nodes[flat].set_aabb(&tight[node as usize]);
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
        // Inner boxes from the tight leaves: children come after their parent in the queue's
        // order, so a backward pass sees both children of a node before the node.
        for i in (0..nodes.len()).rev() {
            if nodes[i].count == 0 {
                let first = nodes[i].first as usize;
                let union = nodes[first].aabb().union(&nodes[first + 1].aabb());
                nodes[i].set_aabb(&union);
            }
        }
    }
    Bvh {
        nodes,
        primitive_indices,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    /// The copy is the tree's shape over the tight boxes: valid against them, every leaf's box
    /// its tight box, and the root their union (a copy over the fat boxes fails the last two),
    /// also after leaves moved within and out of their fat boxes.
    #[test]
    fn flat_copy_is_refit_to_the_tight_boxes() {
        let mut next = crate::test_floats(0x51f1_5eed_0bad_cafe);
        let mut tree = DynamicBvh::new();
        let mut boxes = Vec::new();
        let mut handles = Vec::new();
        let random_box = |next: &mut dyn FnMut() -> f32| {
            let c = Vec3A::new(next(), next(), next()) * 100.0;
            Aabb::new(c, c + Vec3A::new(next(), next(), next()) + 0.5)
        };
        for id in 0..600u32 {
            let b = random_box(&mut next);
            handles.push(tree.insert(id, b).unwrap());
            boxes.push(b);
        }
        for round in 0..3 {
            tree.maintain();
            let flat = tree.to_flat_bvh();
            flat.validate(&boxes).unwrap();
            let union = boxes.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
            assert_eq!(flat.nodes[0].aabb(), union, "round {round}");
            for node in flat.nodes.iter().filter(|n| n.count > 0) {
                let id = flat.primitive_indices[node.first as usize];
                assert_eq!(node.aabb(), boxes[id as usize], "round {round}, leaf {id}");
            }
            // Move a third: small steps stay inside the fat boxes, every tenth jumps away.
            for (i, h) in handles.iter().enumerate().filter(|(i, _)| i % 3 == round) {
                let b = if i % 10 == 0 {
                    random_box(&mut next)
                } else {
                    let step = Vec3A::splat(0.01);
                    Aabb::new(boxes[i].min + step, boxes[i].max + step)
                };
                tree.update(*h, b).unwrap();
                boxes[i] = b;
            }
        }
    }
}
