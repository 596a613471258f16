//! The once-per-frame refit: the node bounds of the octants edits touched, recomputed
//! bottom-up, each once.

use super::cells::NONE;
use super::tree::LooseTree;

/// How far an octant's node bounds reach past its entries' union, as a fraction of its
/// cell's half size: a box that moves inside that margin (and inside its loose cell) costs
/// one box write and no refit. Why: with exact bounds every move of every entry would queue
/// its octant and, through the changed bounds, its ancestors, so a world of small movers
/// would pay a refit per mover per frame (BENCHMARKS.md, Loose octree). This is the dynamic BVH's fat leaf, sized by the cell rather than the box.
pub(super) const OWN_MARGIN: f32 = 0.5;

/// How many queued octants ahead the refit asks for the next one: a few octants' unions
/// cover a memory latency.
const REFIT_LOOKAHEAD: usize = 8;

impl<const AXES: usize> LooseTree<AXES> {
    /// Makes the tree consistent for queries after edits: each octant an edit touched gets
    /// the union of its entries' boxes (kept by the edits) and its children's bounds as node
    /// bounds, deepest first, and passes the change up only when its bounds changed. Returns
    /// the octants refit.
    ///
    /// Edits only queue octants, so a frame in which thousands of entries move costs one
    /// union per touched octant here, not one walk to the root per move. The bounds shrink
    /// as content leaves, which a loose cell never does, so queries prune on what is really
    /// in an octant rather than on where it could be.
    pub fn maintain(&mut self) -> usize {
        if self.root == NONE {
            self.dirty.clear();
            return 0;
        }
        let root_level = self.arena.get(self.root).level;
        let levels = (i16::from(self.config.max_depth) - root_level + 1) as usize;
        let mut buckets = core::mem::take(&mut self.refit_buckets);
        if buckets.len() < levels {
            buckets.resize_with(levels, Vec::new);
        }
        for (o, level) in self.dirty.drain(..) {
            // A released octant stays listed (the refit skips it by its cleared flag); one
            // above the root now belongs to a root since collapsed.
            if (root_level..=i16::from(self.config.max_depth)).contains(&level) {
                buckets[(level - root_level) as usize].push(o);
            }
        }
        let mut refit = 0;
        for depth in (0..levels).rev() {
            let level = root_level + depth as i16;
            let mut bucket = core::mem::take(&mut buckets[depth]);
            for (i, &o) in bucket.iter().enumerate() {
                // The queue is in edit order, so its octants lie scattered through the arena:
                // each is asked for a few octants ahead, as the dynamic BVH's refit does.
                if let Some(&ahead) = bucket.get(i + REFIT_LOOKAHEAD)
                    && let Some(octant) = self.arena.octants.get(ahead as usize)
                {
                    crate::prefetch::prefetch_all(octant);
                }
                let octant = self.arena.get(o);
                // Listed twice (released and made again, or moved to another level in
                // place): refit once, at its level.
                if !octant.dirty || octant.level != level {
                    continue;
                }
                let mut bounds = octant
                    .own
                    .expanded(glam::Vec3A::splat(octant.half * OWN_MARGIN));
                for &child in octant.children() {
                    bounds = bounds.union(&self.arena.get(child).tight);
                }
                let parent = octant.parent;
                let octant = self.arena.get_mut(o);
                octant.dirty = false;
                refit += 1;
                if octant.tight != bounds {
                    octant.tight = bounds;
                    if parent != NONE && !self.arena.get(parent).dirty {
                        // A parent may be several levels up (the octree is compressed).
                        let p = self.arena.get_mut(parent);
                        p.dirty = true;
                        buckets[(p.level - root_level) as usize].push(parent);
                    }
                }
            }
            bucket.clear();
            buckets[depth] = bucket;
        }
        self.refit_buckets = buckets;
        refit
    }
}
