//! The batched refit: only the paths above moved leaves, each node once, bottom-up.

use super::DynamicBvh;
use super::node::{FLAG_DIRTY, FLAG_QUEUED, NULL};

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
    pub fn refit(&mut self) -> usize {
        if self.dirty.is_empty() {
            return 0;
        }
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

        let rotate = self.config.rotations;
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

    /// Internal nodes recomputed by the last refit (the optimiser's first candidates).
    pub(super) fn last_refit_nodes(&self) -> &[u32] {
        &self.refit_sorted
    }
}
