//! Reinsertion: the tree optimisation of Bittner, Hapala & Havran 2013 ("Fast Insertion-Based
//! Optimization of Bounding Volume Hierarchies"), in the form of Meister & Bittner 2018
//! ("Parallel Reinsertion for Bounding Volume Hierarchy Optimization"), run on one thread.
//!
//! A node is taken out of the tree (its parent disappears, its sibling takes the parent's
//! place) and put back as the sibling of whichever node makes the sum of interior node areas,
//! the SAH's traversal term, smallest. A branch-and-bound search finds that place. The nodes
//! with the largest boxes are the ones worth moving: a big primitive that the Morton order put
//! among small ones inflates every box on its way to the root, and reinsertion lifts it to where
//! its size belongs.
//!
//! It works on PLOC's merge records, before the tree is collapsed into leaves and laid out.

use super::ploc::{Cluster, CurveBoxes, GATHER_AHEAD, fmax, fmin};
use super::ploc_tree::{COLLAPSED, Merge};

/// No node (the root's parent).
const NONE: u32 = u32::MAX;

/// A box, as the merge records and clusters store it.
#[derive(Clone, Copy, Debug)]
struct Bounds {
    lo: [f32; 3],
    hi: [f32; 3],
}

impl Bounds {
    #[inline(always)]
    fn union(&self, o: &Self) -> Self {
        Self {
            lo: [0, 1, 2].map(|i| fmin(self.lo[i], o.lo[i])),
            hi: [0, 1, 2].map(|i| fmax(self.hi[i], o.hi[i])),
        }
    }

    #[inline(always)]
    fn half_area(&self) -> f32 {
        let (lo, hi) = (self.lo, self.hi);
        let (dx, dy, dz) = (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
        dx * dy + dy * dz + dz * dx
    }
}

/// The tree PLOC built, in place: node ids below `leaves.len()` are primitives (in curve
/// order), the others merges. Parents are kept for the search's walk to the root.
pub(super) struct Tree<'a> {
    leaves: CurveBoxes<'a>,
    merges: &'a mut [Merge],
    parent: Vec<u32>,
    /// Half the surface area of every node's box, kept up to date by the refits: choosing
    /// candidates reads all of them every round.
    area: Vec<f32>,
    /// The merges a refit went through: every subtree that changed, for
    /// [`super::ploc_tree::collapse_moved`].
    moved: Vec<bool>,
    root: u32,
    stack: Vec<(f32, u32)>,
}

impl<'a> Tree<'a> {
    /// The tree of `merges` over `leaves` (at least two leaves; the last merge is the root).
    pub fn new(leaves: CurveBoxes<'a>, merges: &'a mut [Merge]) -> Self {
        let n = leaves.len();
        let mut parent = vec![NONE; n + merges.len()];
        for (m, merge) in merges.iter().enumerate() {
            parent[merge.left as usize] = (n + m) as u32;
            parent[(merge.right & !COLLAPSED) as usize] = (n + m) as u32;
        }
        let area = (0..n as u32)
            .map(|slot| {
                leaves.prefetch(slot + GATHER_AHEAD);
                leaves.leaf(slot).half_area()
            })
            .chain(
                merges
                    .iter()
                    .map(|m| Bounds { lo: m.lo, hi: m.hi }.half_area()),
            )
            .collect();
        Self {
            leaves,
            root: (n + merges.len() - 1) as u32,
            merges,
            parent,
            area,
            moved: vec![false; n - 1],
            stack: Vec::new(),
        }
    }

    #[inline(always)]
    fn leaf_bounds(c: &Cluster) -> Bounds {
        Bounds { lo: c.lo, hi: c.hi }
    }

    #[inline(always)]
    fn bounds(&self, id: u32) -> Bounds {
        match (id as usize).checked_sub(self.leaves.len()) {
            None => Self::leaf_bounds(&self.leaves.leaf(id)),
            Some(m) => {
                let m = &self.merges[m];
                Bounds { lo: m.lo, hi: m.hi }
            }
        }
    }

    #[inline(always)]
    fn children(&self, id: u32) -> Option<[u32; 2]> {
        let m = self
            .merges
            .get((id as usize).checked_sub(self.leaves.len())?)?;
        Some([m.left, m.right & !COLLAPSED])
    }

    #[inline(always)]
    fn sibling(&self, id: u32) -> u32 {
        let [l, r] = self.children(self.parent[id as usize]).unwrap_or([id, id]);
        if l == id { r } else { l }
    }

    /// Runs `rounds` rounds; round `i` offers the `batch / (2 i + 1)` nodes with the largest
    /// boxes for reinsertion (the schedule of the paper's implementation in `madmann91/bvh`,
    /// which spends most of its effort near the top of the tree).
    ///
    /// A round moves its nodes in increasing id: the primitives in curve order, then the merges
    /// in the order clustering made them, from the bottom up. On the million-triangle benchmark
    /// scene this finds a cheaper tree than moving the largest first, and each search starts
    /// near the previous one, so they share the cache.
    pub fn optimize(&mut self, batch: usize, rounds: u32) {
        let mut ids = Vec::new();
        for round in 0..rounds as usize {
            let want = (batch / (2 * round + 1)).max(1);
            self.largest(want, &mut ids);
            for &node in &ids {
                if let Some((to, _)) = self.find(node) {
                    self.reinsert(node, to);
                }
            }
        }
    }

    /// The `want` nodes (the root aside) with the largest boxes, in increasing id. A
    /// histogram of the areas' top bits finds the area bucket where the cut falls in one
    /// pass; the second pass collects the nodes at or above it, and only the ones in that
    /// bucket are ordered, to drop the smallest.
    fn largest(&self, want: usize, ids: &mut Vec<u32>) {
        // Positive floats order like their bits; NaN areas (0 times infinity) are never moved.
        let key = |a: f32| -> Option<u32> { (a >= 0.0).then_some(a.to_bits()) };
        let mut hist = vec![0u32; 1 << 12];
        for &a in &self.area {
            if let Some(k) = key(a) {
                hist[(k >> 20) as usize] += 1;
            }
        }
        let mut threshold = 0;
        let mut above = 0usize;
        for (bucket, &count) in hist.iter().enumerate().rev() {
            above += count as usize;
            if above >= want {
                threshold = bucket as u32;
                break;
            }
        }
        ids.clear();
        // The cut bucket's nodes as `area bits << 32 | id`: a total order, so ties are cut
        // the same way whatever order they come in.
        let mut edge = Vec::new();
        for (id, &a) in self.area.iter().enumerate() {
            let Some(k) = key(a).filter(|k| k >> 20 >= threshold && id as u32 != self.root) else {
                continue;
            };
            ids.push(id as u32);
            if k >> 20 == threshold {
                edge.push((u64::from(k) << 32) | id as u64);
            }
        }
        let extra = ids.len().saturating_sub(want);
        if extra > 0 {
            // Fewer than `want` nodes lie above the cut bucket, so `extra < edge.len()`.
            let (_, &mut cut, _) = edge.select_nth_unstable(extra - 1);
            ids.retain(|&id| {
                let k = self.area[id as usize].to_bits();
                k >> 20 != threshold || (u64::from(k) << 32) | u64::from(id) > cut
            });
        }
    }

    /// The best new sibling for `node` and the area it saves, if any saves area: a
    /// branch-and-bound search outward from the node's old place (Meister & Bittner 2018,
    /// section 4).
    fn find(&mut self, node: u32) -> Option<(u32, f32)> {
        let parent = self.parent[node as usize];
        if parent == NONE {
            return None;
        }
        let nb = self.bounds(node);
        let node_area = self.area[node as usize];
        let mut best = (NONE, 0.0f32);
        // Taking the node out removes its parent; every ancestor above shrinks to the union of
        // the siblings on the way up. `gain` is what the removal saves above the subtree being
        // searched.
        let mut gain = self.area[parent as usize];
        let mut sibling = self.sibling(node);
        let mut pivot = parent;
        let mut pivot_bounds = self.bounds(sibling);
        let mut stack = std::mem::take(&mut self.stack);
        loop {
            stack.push((gain, sibling));
            while let Some((g, x)) = stack.pop() {
                // The new parent costs at least the node's own area.
                if g - node_area <= best.1 {
                    continue;
                }
                let xb = self.bounds(x);
                let here = g - xb.union(&nb).half_area();
                if here > best.1 {
                    best = (x, here);
                }
                if let Some([l, r]) = self.children(x) {
                    // Below `x`, `x` itself grows to hold the node.
                    let below = here + self.area[x as usize];
                    stack.push((below, l));
                    stack.push((below, r));
                }
            }
            if pivot != parent {
                pivot_bounds = pivot_bounds.union(&self.bounds(sibling));
                gain += self.area[pivot as usize] - pivot_bounds.half_area();
            }
            if pivot == self.root {
                break;
            }
            sibling = self.sibling(pivot);
            pivot = self.parent[pivot as usize];
        }
        self.stack = stack;
        (best.0 != NONE && best.0 != self.sibling(node)).then_some(best)
    }

    /// Replaces child `old` of `parent` (or the root) by `new`.
    fn replace_child(&mut self, parent: u32, old: u32, new: u32) {
        if parent == NONE {
            self.root = new;
        } else {
            let m = &mut self.merges[parent as usize - self.leaves.len()];
            if m.left == old {
                m.left = new;
            } else {
                m.right = new | (m.right & COLLAPSED);
            }
        }
        self.parent[new as usize] = parent;
    }

    /// Moves `node` to be the sibling of `to`, reusing its old parent as their new parent.
    fn reinsert(&mut self, node: u32, to: u32) {
        let p = self.parent[node as usize];
        let sibling = self.sibling(node);
        let grand = self.parent[p as usize];
        self.replace_child(grand, p, sibling);
        let to_parent = self.parent[to as usize];
        self.replace_child(to_parent, to, p);
        let m = &mut self.merges[p as usize - self.leaves.len()];
        m.left = node;
        m.right = to | (m.right & COLLAPSED);
        self.parent[to as usize] = p;
        // The old place first: where the two paths to the root meet, the second refit sees
        // both sides already right.
        self.refit(grand);
        self.refit(p);
    }

    /// Recomputes the boxes from `id` to the root.
    fn refit(&mut self, mut id: u32) {
        while id != NONE {
            let [l, r] = self.children(id).expect("only merges are refit");
            let b = self.bounds(l).union(&self.bounds(r));
            let m = id as usize - self.leaves.len();
            self.moved[m] = true;
            let m = &mut self.merges[m];
            (m.lo, m.hi) = (b.lo, b.hi);
            self.area[id as usize] = b.half_area();
            id = self.parent[id as usize];
        }
    }

    /// The root's node id (it changes when a reinsertion moves a node next to the old root)
    /// and which merges' subtrees changed (indexed by merge).
    pub fn finish(self) -> (u32, Vec<bool>) {
        (self.root, self.moved)
    }
}

#[cfg(test)]
mod tests {
    use super::super::ploc::tests::{clusters_of, coarse_boxes};
    use super::*;

    /// A balanced tree over `leaves`: neighbours paired level by level.
    fn paired_tree(leaves: &[Cluster]) -> Vec<Merge> {
        let n = leaves.len();
        let mut level: Vec<(u32, Bounds)> = (0..n)
            .map(|i| (i as u32, Tree::leaf_bounds(&leaves[i])))
            .collect();
        let mut merges = Vec::new();
        while level.len() > 1 {
            let mut next = Vec::new();
            for pair in level.chunks(2) {
                match *pair {
                    [(a, ab), (b, bb)] => {
                        let u = ab.union(&bb);
                        merges.push(Merge {
                            lo: u.lo,
                            left: a,
                            hi: u.hi,
                            right: b,
                        });
                        next.push(((n + merges.len() - 1) as u32, u));
                    }
                    [single] => next.push(single),
                    _ => unreachable!(),
                }
            }
            level = next;
        }
        merges
    }

    /// The candidates are the `want` largest boxes under the total order (area, then id), the
    /// root left out, whatever the ties; and they come in increasing id.
    #[test]
    fn largest_takes_the_largest_boxes_in_id_order() {
        let boxes = coarse_boxes(1_000, 3);
        let leaves = clusters_of(&boxes).cl;
        let mut merges = paired_tree(&leaves);
        let order: Vec<u32> = (0..boxes.len() as u32).collect();
        let tree = Tree::new(CurveBoxes::new(&boxes, &order), &mut merges);
        let mut all: Vec<(u32, u32)> = (0..tree.area.len() as u32)
            .filter(|&id| id != tree.root)
            .map(|id| (tree.area[id as usize].to_bits(), id))
            .collect();
        all.sort_unstable_by(|a, b| b.cmp(a));
        let mut ids = Vec::new();
        for want in [1, 2, 17, 300, 1_000, all.len()] {
            tree.largest(want, &mut ids);
            let mut expect: Vec<u32> = all[..want].iter().map(|&(_, id)| id).collect();
            expect.sort_unstable();
            assert_eq!(ids, expect, "want {want}");
        }
    }
}
