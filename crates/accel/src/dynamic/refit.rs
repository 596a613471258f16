//! The batched refit: only the paths above moved leaves, each node once, bottom-up.

use super::DynamicBvh;
use super::node::{FLAG_DIRTY, FLAG_JUMPED, FLAG_QUEUED, NULL};

impl DynamicBvh {
    /// Brings every ancestor of the leaves updated since the last call up to date, and
    /// returns how many internal nodes it recomputed (0, in O(1), when nothing moved).
    ///
    /// Per-leaf refits (Box2D's `b2MoveProxy`) walk to the root once per moved leaf, so the
    /// nodes near the root are recomputed once per leaf: O(k log n) for k leaves. Here nodes
    /// are recomputed in order of height (children before parents), each at most once, and a
    /// node is visited only if a child's box or height actually changed: a fat leaf box that
    /// moved inside its parent's box stops there. Most moves change a few levels, so the
    /// cost follows the boxes that changed, not the number of distinct ancestors (the first
    /// version marked every ancestor up to the root and recomputed them all: ~3 cache misses
    /// each at 100k leaves). With
    /// [`DynamicBvhConfig::rotations`](super::DynamicBvhConfig::rotations) every node whose
    /// box changed is also offered a Kopta 2012 rotation: motion is exactly what makes a node's
    /// children overlap, and fixing it where it happens is cheaper than finding it later.
    ///
    /// Leaves that jumped clear of their old fat box are reinserted first, where the SAH wants
    /// them now (Box2D's `b2MoveProxy`): refitting would stretch every ancestor across both
    /// places and rot the tree for every later query. That holds while such jumps are rare;
    /// when more than 1/64 of the leaves jumped in one batch (a whole crowd moving fast), one
    /// SAH insertion each would cost far more than refitting them all and letting the quality
    /// monitor decide on a rebuild, so they are refit like the rest.
    pub fn refit(&mut self) -> usize {
        if self.dirty.is_empty() {
            return 0;
        }
        self.reinsert_jumped_leaves();
        let mut buckets = core::mem::take(&mut self.refit_buckets);
        let mut processed = core::mem::take(&mut self.refit_sorted);
        processed.clear();
        let dirty_leaves = self.dirty.len();
        for &leaf in &self.dirty {
            let n = &mut self.arena.nodes[leaf as usize];
            // A leaf removed after its update (its slot free, or reused by a node that was
            // linked in with its ancestors already fixed) needs nothing.
            if n.flags & FLAG_DIRTY == 0 || !n.is_leaf() {
                continue;
            }
            n.flags &= !FLAG_DIRTY;
            let p = n.parent;
            queue_node(&mut self.arena.nodes, &mut buckets, p, 1);
        }
        self.dirty.clear();

        // Rotations read four grandchildren scattered through the arena per node. When most
        // of the tree moved at once they would cost more than the refit itself, and a mass
        // move is what the quality monitor's rebuild is for.
        let rotate = self.config.rotations && dirty_leaves <= self.leaf_count / 8;
        let mut h = 0;
        while h < buckets.len() {
            let mut bucket = core::mem::take(&mut buckets[h]);
            for &i in &bucket {
                let n = self.arena.nodes[i as usize];
                let [a, b] = n.children;
                let (na, nb) = (&self.arena.nodes[a as usize], &self.arena.nodes[b as usize]);
                let new_box = na.aabb.union(&nb.aabb);
                let new_height = 1 + na.height.max(nb.height);
                let node = &mut self.arena.nodes[i as usize];
                node.flags &= !FLAG_QUEUED;
                node.height = new_height;
                processed.push(i);
                if new_box == n.aabb && new_height == n.height {
                    continue;
                }
                self.set_aabb(i, new_box);
                if rotate {
                    self.rotate(i);
                }
                let parent = self.arena.nodes[i as usize].parent;
                queue_node(&mut self.arena.nodes, &mut buckets, parent, h + 1);
            }
            bucket.clear();
            buckets[h] = bucket;
            h += 1;
        }
        let touched = processed.len();
        self.refit_buckets = buckets;
        self.refit_sorted = processed;
        self.optimizer.note_refit();
        touched
    }

    fn reinsert_jumped_leaves(&mut self) {
        let nodes = &self.arena.nodes;
        let jumped = self
            .dirty
            .iter()
            .filter(|&&l| nodes[l as usize].flags & FLAG_JUMPED != 0)
            .count();
        let reinsert = jumped > 0 && jumped <= (self.leaf_count / 64).max(64);
        for k in 0..self.dirty.len() {
            let leaf = self.dirty[k];
            let n = &mut self.arena.nodes[leaf as usize];
            if n.flags & FLAG_JUMPED == 0 {
                continue;
            }
            n.flags &= !FLAG_JUMPED;
            if reinsert && n.is_leaf() && n.flags & FLAG_DIRTY != 0 {
                // Reinsertion fixes the boxes on both paths: nothing left to refit for it.
                n.flags &= !FLAG_DIRTY;
                self.detach(leaf);
                self.attach(leaf);
            }
        }
    }

    /// Internal nodes recomputed by the last refit, children before parents (the optimiser's
    /// first candidates).
    pub(super) fn last_refit_nodes(&self) -> &[u32] {
        &self.refit_sorted
    }
}

/// Queues internal node `node` (unless null or already queued) in the bucket of its height,
/// but never below `at_least`: the bucket being processed must not receive nodes, and a
/// rotation may have left a stored height stale until the node is recomputed.
fn queue_node(
    nodes: &mut [super::node::Node],
    buckets: &mut Vec<Vec<u32>>,
    node: u32,
    at_least: usize,
) {
    if node == NULL {
        return;
    }
    let n = &mut nodes[node as usize];
    if n.flags & FLAG_QUEUED != 0 {
        return;
    }
    n.flags |= FLAG_QUEUED;
    let h = (n.height as usize).max(at_least);
    if buckets.len() <= h {
        buckets.resize_with(h + 1, Vec::new);
    }
    buckets[h].push(node);
}
