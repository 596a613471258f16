//! Refitting a wide tree in place after its primitives moved (skinned meshes, morphs).

use super::{WideBvh, WideLayout};
use crate::Aabb;

impl<const N: usize, L: WideLayout<N>> WideBvh<N, L> {
    /// Recomputes every slot box from new primitive boxes, keeping the topology.
    ///
    /// The collapse appends children after their parent, so one reverse sweep over the nodes
    /// sees every child before its parent: no recursion, no parent links, one pass, and a
    /// child's box is read back from its already refitted slots (no scratch array to allocate
    /// per refit). `primitive_bounds` is called exactly once per primitive, so it may also
    /// update the primitive. The tree's quality is that of the pose it was built in; rebuild
    /// when motion is large.
    pub fn refit(&mut self, mut primitive_bounds: impl FnMut(u32) -> Aabb) {
        for n in (0..self.nodes.len()).rev() {
            let node = &self.nodes[n];
            let mut boxes = [Aabb::EMPTY; N];
            for (slot, b) in boxes.iter_mut().enumerate() {
                if !node.is_used(slot) {
                    continue;
                }
                *b = if node.is_leaf(slot) {
                    let first = node.child(slot) as usize;
                    self.primitive_indices[first..first + node.count(slot) as usize]
                        .iter()
                        .fold(Aabb::EMPTY, |acc, &p| acc.union(&primitive_bounds(p)))
                } else {
                    // The child's stored slots: for a quantized layout, the rounded-out boxes
                    // its parent must enclose.
                    self.nodes[node.child(slot) as usize].bounds()
                };
            }
            self.nodes[n].set_child_boxes(&boxes);
        }
        self.bounds = self.nodes.first().map_or(Aabb::EMPTY, L::bounds);
    }
}
