//! Refitting a wide tree in place after its primitives moved (skinned meshes, morphs).

use super::WideBvh;
use crate::Aabb;

impl<const N: usize> WideBvh<N> {
    /// Recomputes every slot box from new primitive boxes, keeping the topology.
    ///
    /// The collapse appends children after their parent, so one reverse sweep over the nodes
    /// sees every child before its parent: no recursion, no parent links, one pass. The tree's
    /// quality is that of the pose it was built in; rebuild when motion is large.
    pub fn refit(&mut self, mut primitive_bounds: impl FnMut(u32) -> Aabb) {
        let mut node_boxes = vec![Aabb::EMPTY; self.nodes.len()];
        for n in (0..self.nodes.len()).rev() {
            let mut node_box = Aabb::EMPTY;
            for slot in 0..N {
                let node = &self.nodes[n];
                if !node.is_used(slot) {
                    continue;
                }
                let b = if node.is_leaf(slot) {
                    let first = node.child[slot] as usize;
                    self.primitive_indices[first..first + node.count[slot] as usize]
                        .iter()
                        .fold(Aabb::EMPTY, |acc, &p| acc.union(&primitive_bounds(p)))
                } else {
                    node_boxes[node.child[slot] as usize]
                };
                self.nodes[n].set_child_aabb(slot, &b);
                node_box = node_box.union(&b);
            }
            node_boxes[n] = node_box;
        }
        self.bounds = node_boxes.first().copied().unwrap_or(Aabb::EMPTY);
    }
}
