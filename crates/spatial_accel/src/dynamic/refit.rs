//! The batched refit: only the paths above moved leaves, each node once, bottom-up.

use super::DynamicBvh;
use super::node::{FLAG_QUEUED, MARK_JUMPED, NULL, prefetch_index};

impl DynamicBvh {
    /// Brings every ancestor of the leaves updated since the last call up to date, and
    /// returns how many internal nodes it recomputed (0, in O(1), when nothing moved).
    ///
    /// Per-leaf refits (Box2D's `b2MoveProxy`) walk to the root once per moved leaf, so the
    /// nodes near the root are recomputed once per leaf: O(k log n) for k leaves. Here nodes
    /// are recomputed in order of height (children before parents), each at most once, and a
    /// node is visited only if a child's box or height actually changed: a fat leaf box that
    /// moved inside its parent's box stops there. Most moves change a few levels, so the
    /// cost follows the boxes that changed, not the number of distinct ancestors (marking every
    /// ancestor up to the root and recomputing them all would pay cache misses at each of
    /// them). With
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
        let jumped = core::mem::take(&mut self.jumped_pending);
        if jumped > 0 && jumped <= (self.leaf_count / 64).max(64) {
            self.reinsert_jumped_leaves();
        }
        if self.leaf_count >= 256 && self.dirty.len() > self.leaf_count / WHOLE_TREE_REFIT_SHARE {
            return self.refit_whole_tree();
        }
        let mut buckets = core::mem::take(&mut self.refit_buckets);
        let mut processed = core::mem::take(&mut self.refit_sorted);
        processed.clear();
        let dirty_leaves = self.dirty.len();
        let listed = self.refit_epoch << 1;
        for k in 0..self.dirty.len() {
            // Software pipelining over scattered nodes: the leaf needed 16 steps from now, and
            // the parent of the one needed 8 steps from now (its leaf asked for 8 steps ago),
            // are fetched while this one is processed.
            if let Some(&ahead) = self.dirty.get(k + 16) {
                prefetch_index(&self.arena.nodes, ahead);
            }
            if let Some(&ahead) = self.dirty.get(k + 8) {
                prefetch_index(&self.arena.nodes, self.arena.nodes[ahead as usize].parent);
            }
            let leaf = self.dirty[k];
            let n = &mut self.arena.nodes[leaf as usize];
            // A leaf removed after its update (its slot free, or reused by a node that was
            // linked in with its ancestors already fixed) needs nothing. Jumped leaves get
            // here only when they were too many to reinsert.
            if n.dirty_mark & !MARK_JUMPED != listed || !n.is_leaf() {
                continue;
            }
            // Unmarked one by one (unlike the whole-tree refit): a slot freed and listed again
            // within the batch is in the list twice, and is processed once.
            n.dirty_mark = 0;
            let p = n.parent;
            queue_node(&mut self.arena.nodes, &mut buckets, p, 1);
        }
        self.end_refit_epoch();

        // Rotations read four grandchildren scattered through the arena per node. When most
        // of the tree moved at once they would cost more than the refit itself, and a mass
        // move is what the quality monitor's rebuild is for.
        let rotate = self.config.rotations && dirty_leaves <= self.leaf_count / 8;
        let mut h = 0;
        while h < buckets.len() {
            let mut bucket = core::mem::take(&mut buckets[h]);
            for j in 0..bucket.len() {
                // As above: the node 16 steps ahead, the children of the one 8 steps ahead.
                if let Some(&ahead) = bucket.get(j + 16) {
                    prefetch_index(&self.arena.nodes, ahead);
                }
                if let Some(&ahead) = bucket.get(j + 8) {
                    let n = &self.arena.nodes[ahead as usize];
                    for c in n.children {
                        prefetch_index(&self.arena.nodes, c);
                    }
                    // Its parent is queued (flags and height read) as soon as it changes.
                    prefetch_index(&self.arena.nodes, n.parent);
                }
                // A rotation also reads the four grandchildren: ask for them once the
                // children asked for four steps ago are (most likely) in.
                if rotate && let Some(&ahead) = bucket.get(j + 4) {
                    for c in self.arena.nodes[ahead as usize].children {
                        if let Some(child) = self.arena.nodes.get(c as usize) {
                            for g in child.children {
                                prefetch_index(&self.arena.nodes, g);
                            }
                        }
                    }
                }
                let i = bucket[j];
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
        self.quality.note_edit();
        touched
    }

    /// The refit for mass motion: every internal node recomputed once, by replaying the
    /// tree's compiled shape (see [`super::refit_schedule`]), with no per-node queueing.
    ///
    /// When most leaves moved, the bucketed refit would queue nearly every internal node and
    /// pay for the flags, the buckets and one parent lookup per node on top of the
    /// recomputation; a depth-first pass would wait on one cache miss per node (the arena's
    /// order is random after insertions). The leaves leave the dirty list by a new refit
    /// epoch, so neither the list is read nor the leaves written. No rotations here, for the
    /// reason given in [`Self::refit`]; the internal-area sum is recomputed from scratch in the
    /// same pass.
    fn refit_whole_tree(&mut self) -> usize {
        self.end_refit_epoch();
        let mut order = core::mem::take(&mut self.refit_sorted);
        order.clear();
        if self.root != NULL && !self.arena.nodes[self.root as usize].is_leaf() {
            self.internal_area = self.schedule.replay(
                &mut self.arena.nodes,
                self.root,
                &mut order,
                self.config.parallel_refit,
            );
            // A recount from scratch: no rounding error left to guard against.
            self.area_peaks.0 = self.internal_area;
        }
        let touched = order.len();
        self.refit_sorted = order;
        self.optimizer.note_refit();
        self.quality.note_edit();
        touched
    }

    fn reinsert_jumped_leaves(&mut self) {
        let listed_jumped = self.refit_epoch << 1 | MARK_JUMPED;
        for k in 0..self.dirty.len() {
            // The dirty list is in update order, scattered over the arena.
            if let Some(&ahead) = self.dirty.get(k + 16) {
                prefetch_index(&self.arena.nodes, ahead);
            }
            let leaf = self.dirty[k];
            let n = &mut self.arena.nodes[leaf as usize];
            if n.dirty_mark != listed_jumped || !n.is_leaf() {
                continue;
            }
            // Reinsertion fixes the boxes on both paths: nothing left to refit for it.
            n.dirty_mark = 0;
            self.detach(leaf);
            self.attach(leaf);
        }
    }

    /// Internal nodes recomputed by the last refit, children before parents (the optimiser's
    /// first candidates).
    pub(super) fn last_refit_nodes(&self) -> &[u32] {
        &self.refit_sorted
    }
}

/// Above `leaf_count / WHOLE_TREE_REFIT_SHARE` dirty leaves, [`DynamicBvh::refit`] sweeps the
/// whole tree instead of queueing the dirty paths: the sweep costs about what the bucketed
/// refit costs for that share of the leaves (BENCHMARKS.md, Dynamic BVH).
const WHOLE_TREE_REFIT_SHARE: usize = 4;

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
