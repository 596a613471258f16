//! The batched refit: only the paths above moved leaves, each node once, bottom-up.

use super::DynamicBvh;
use super::node::{FLAG_DIRTY, FLAG_JUMPED, FLAG_QUEUED, NULL};

impl DynamicBvh {
    /// Brings every ancestor of the leaves updated since the last call up to date, and
    /// returns how many internal nodes it recomputed (0, in O(1), when nothing moved).
    ///
    /// Per-leaf refits (Box2D's `b2MoveProxy`) walk to the root once per moved leaf, so the
    /// nodes near the root are recomputed once per leaf: O(k log n) for k leaves. Here each
    /// moved leaf marks its ancestors only until it meets one already marked, and the marked
    /// nodes are then recomputed once each in order of height (children before parents), so
    /// the cost is O(number of distinct ancestors), at most the size of the tree. With
    /// [`DynamicBvhConfig::rotations`](super::DynamicBvhConfig::rotations) every recomputed
    /// node is also offered a Kopta 2012 rotation: motion is exactly what makes a node's
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
        let mut queue = core::mem::take(&mut self.refit_queue);
        let mut sorted = core::mem::take(&mut self.refit_sorted);
        let mut counts = core::mem::take(&mut self.height_counts);
        queue.clear();
        let mut max_height = 0u32;
        {
            let nodes = &mut self.arena.nodes;
            for &leaf in &self.dirty {
                let n = &mut nodes[leaf as usize];
                // A leaf removed after its update (its slot free, or reused by a node that
                // was linked in with its ancestors already fixed) needs nothing.
                if n.flags & FLAG_DIRTY == 0 || !n.is_leaf() {
                    continue;
                }
                n.flags &= !FLAG_DIRTY;
                let mut p = n.parent;
                while p != NULL {
                    let pn = &mut nodes[p as usize];
                    if pn.flags & FLAG_QUEUED != 0 {
                        break;
                    }
                    pn.flags |= FLAG_QUEUED;
                    max_height = max_height.max(pn.height);
                    queue.push(p);
                    p = pn.parent;
                }
            }
        }
        self.dirty.clear();

        // Counting sort by height: linear, and heights are small (tens) in any sane tree.
        counts.clear();
        counts.resize(max_height as usize + 2, 0);
        for &i in &queue {
            counts[self.arena.nodes[i as usize].height as usize + 1] += 1;
        }
        for h in 1..counts.len() {
            counts[h] += counts[h - 1];
        }
        sorted.clear();
        sorted.resize(queue.len(), NULL);
        for &i in &queue {
            let h = self.arena.nodes[i as usize].height as usize;
            sorted[counts[h] as usize] = i;
            counts[h] += 1;
        }

        // Rotations read four grandchildren scattered through the arena per node. When most
        // of the tree moved at once they would cost more than the refit itself, and a mass
        // move is what the quality monitor's rebuild is for.
        let rotate = self.config.rotations && sorted.len() <= self.leaf_count / 4;
        for &i in &sorted {
            let n = self.arena.nodes[i as usize];
            let [a, b] = n.children;
            let (na, nb) = (&self.arena.nodes[a as usize], &self.arena.nodes[b as usize]);
            let new_box = na.aabb.union(&nb.aabb);
            let new_height = 1 + na.height.max(nb.height);
            let node = &mut self.arena.nodes[i as usize];
            node.flags &= !FLAG_QUEUED;
            node.height = new_height;
            // Only a node whose box changed can have started to overlap its sibling: an
            // unchanged one keeps the shape the last rotation chose, and skipping it saves a
            // visit to four grandchildren scattered through the arena.
            if new_box != n.aabb {
                self.set_aabb(i, new_box);
                if rotate {
                    self.rotate(i);
                }
            }
        }
        let touched = sorted.len();
        self.refit_queue = queue;
        self.refit_sorted = sorted;
        self.height_counts = counts;
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

    /// Internal nodes recomputed by the last refit (the optimiser's first candidates).
    pub(super) fn last_refit_nodes(&self) -> &[u32] {
        &self.refit_sorted
    }
}
