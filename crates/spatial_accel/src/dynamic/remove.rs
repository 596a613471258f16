//! Removal: unlinking a leaf or a whole subtree.

use super::DynamicBvh;
use super::node::NULL;

impl DynamicBvh {
    /// Unlinks `node` and everything below it from the tree. Its parent is freed and its
    /// sibling takes the parent's place (Box2D `b2RemoveLeaf`); the ancestors are refit up
    /// to the first one that does not change. `node` keeps its box and height, with no parent.
    pub(super) fn detach(&mut self, node: u32) {
        self.schedule.invalidate();
        if node == self.root {
            self.root = NULL;
            return;
        }
        let parent = self.arena.nodes[node as usize].parent;
        let p = self.arena.nodes[parent as usize];
        let sibling = if p.children[0] == node {
            p.children[1]
        } else {
            p.children[0]
        };
        let grand = p.parent;
        self.arena.nodes[node as usize].parent = NULL;
        self.arena.nodes[sibling as usize].parent = grand;
        self.free_node(parent);
        if grand == NULL {
            self.root = sibling;
        } else {
            let g = &mut self.arena.nodes[grand as usize];
            let slot = usize::from(g.children[1] == parent);
            g.children[slot] = sibling;
            self.fix_upwards(grand, false);
        }
    }
}
