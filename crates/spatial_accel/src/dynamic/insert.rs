//! Insertion: where a new leaf (or a detached subtree) goes, and the repair above it.

use super::DynamicBvh;
use super::node::{NULL, prefetch_index};
use crate::Aabb;

impl DynamicBvh {
    /// The node next to which a box of bounds `d` adds the least total surface area.
    ///
    /// Bittner et al. 2013 ("Fast insertion-based optimization of bounding volume
    /// hierarchies") showed the best sibling can be found by branch and bound: making `d` the
    /// sibling of node `x` costs `area(x ∪ d)` for the new parent plus, for every ancestor,
    /// the growth `area(a ∪ d) - area(a)` ("inherited" cost). Descending only ever adds
    /// inherited cost, so a subtree whose lower bound exceeds the best cost found is skipped.
    /// This is the greedy single-path form of Box2D v3's `b2FindBestSibling`: it follows the
    /// child with the lower bound and stops when neither child can beat the best, which keeps
    /// insertion O(depth) instead of the priority queue's worst case O(n).
    pub(super) fn find_best_sibling(&self, d: &Aabb) -> u32 {
        let nodes = &self.arena.nodes;
        let area_d = d.half_area();
        let center_d = d.center();
        let root_box = nodes[self.root as usize].aabb;

        let mut area_base = root_box.half_area();
        let mut direct_cost = root_box.union(d).half_area();
        let mut inherited_cost = 0.0f32;
        let mut best_sibling = self.root;
        let mut best_cost = direct_cost;
        let mut index = self.root;

        while nodes[index as usize].height > 0 {
            let [c1, c2] = nodes[index as usize].children;
            // Cost of making `index` the sibling.
            let cost = direct_cost + inherited_cost;
            if cost < best_cost {
                best_sibling = index;
                best_cost = cost;
            }
            // Every node below `index` now also pays for growing `index`.
            inherited_cost += direct_cost - area_base;

            let n1 = &nodes[c1 as usize];
            let n2 = &nodes[c2 as usize];
            let leaf1 = n1.height == 0;
            let leaf2 = n2.height == 0;
            // The next step reads the children of `c1` or `c2`: ask for all four lines now, so
            // the descent waits on one memory latency per level instead of two (nodes sit at
            // random places in the arena).
            for (n, leaf) in [(n1, leaf1), (n2, leaf2)] {
                if !leaf {
                    for c in n.children {
                        prefetch_index(nodes, c);
                    }
                }
            }

            let direct1 = n1.aabb.union(d).half_area();
            let mut lower1 = f32::MAX;
            let mut area1 = 0.0;
            if leaf1 {
                let cost1 = direct1 + inherited_cost;
                if cost1 < best_cost {
                    best_sibling = c1;
                    best_cost = cost1;
                }
            } else {
                area1 = n1.aabb.half_area();
                // Below c1 the sibling costs at least area(d) plus what c1 itself grows.
                lower1 = inherited_cost + direct1 + (area_d - area1).min(0.0);
            }

            let direct2 = n2.aabb.union(d).half_area();
            let mut lower2 = f32::MAX;
            let mut area2 = 0.0;
            if leaf2 {
                let cost2 = direct2 + inherited_cost;
                if cost2 < best_cost {
                    best_sibling = c2;
                    best_cost = cost2;
                }
            } else {
                area2 = n2.aabb.half_area();
                lower2 = inherited_cost + direct2 + (area_d - area2).min(0.0);
            }

            if leaf1 && leaf2 {
                break;
            }
            if best_cost <= lower1 && best_cost <= lower2 {
                break;
            }
            // Equal bounds happen when `d` lies inside both children (zero growth): go to
            // the nearer one, or a cluster of small boxes piles up on one side.
            let go_first = if lower1 == lower2 && !leaf1 {
                let dist1 = (n1.aabb.center() - center_d).length_squared();
                let dist2 = (n2.aabb.center() - center_d).length_squared();
                dist1 < dist2
            } else {
                lower1 < lower2 && !leaf1
            };
            if go_first {
                index = c1;
                area_base = area1;
                direct_cost = direct1;
            } else {
                if leaf2 {
                    break;
                }
                index = c2;
                area_base = area2;
                direct_cost = direct2;
            }
        }
        best_sibling
    }

    /// Links `node` (a leaf, or the root of a detached subtree, with its box and height set
    /// and no parent) into the tree under a new internal node, then refits and rotates the
    /// ancestors.
    pub(super) fn attach(&mut self, node: u32) {
        self.schedule.invalidate();
        if self.root == NULL {
            self.root = node;
            self.arena.nodes[node as usize].parent = NULL;
            return;
        }
        let node_box = self.arena.nodes[node as usize].aabb;
        let sibling = self.find_best_sibling(&node_box);
        let old_parent = self.arena.nodes[sibling as usize].parent;
        let new_parent = self.alloc_internal();
        {
            let s = &self.arena.nodes[sibling as usize];
            let (s_box, s_height) = (s.aabb, s.height);
            let n_height = self.arena.nodes[node as usize].height;
            let p = &mut self.arena.nodes[new_parent as usize];
            p.parent = old_parent;
            p.children = [sibling, node];
            p.height = 1 + s_height.max(n_height);
            self.set_aabb(new_parent, s_box.union(&node_box));
        }
        if old_parent == NULL {
            self.root = new_parent;
        } else {
            let op = &mut self.arena.nodes[old_parent as usize];
            let slot = usize::from(op.children[1] == sibling);
            op.children[slot] = new_parent;
        }
        self.arena.nodes[sibling as usize].parent = new_parent;
        self.arena.nodes[node as usize].parent = new_parent;
        self.fix_upwards(old_parent, self.config.rotations);
    }

    /// Recomputes box and height of `index` and its ancestors, rotating each when asked
    /// (Box2D v3 does the same after insertion). The walk stops at the first ancestor whose
    /// box and height did not change: Box2D walks to the root every time, which in a large
    /// tree costs most of an insertion's time for no change in the tree.
    pub(super) fn fix_upwards(&mut self, mut index: u32, rotate: bool) {
        while index != NULL {
            let n = self.arena.nodes[index as usize];
            let [a, b] = n.children;
            let (na, nb) = (&self.arena.nodes[a as usize], &self.arena.nodes[b as usize]);
            let new_box = na.aabb.union(&nb.aabb);
            let new_height = 1 + na.height.max(nb.height);
            // Nothing below changed what this node sees, so nothing above can change either
            // (a rotation here would face the same boxes it faced last time).
            if new_box == n.aabb && new_height == n.height {
                return;
            }
            self.arena.nodes[index as usize].height = new_height;
            self.set_aabb(index, new_box);
            if rotate {
                self.rotate(index);
            }
            index = self.arena.nodes[index as usize].parent;
        }
    }
}
