//! Local tree rotations (Kopta et al. 2012, "Fast, effective BVH updates for animated
//! scenes"; the variant of Box2D v3 `b2RotateNodes`).
//!
//! Insertion and refit make a node's boxes grow where the geometry went; a rotation swaps a
//! child of a node with a grandchild on the other side when that shrinks the changed child's
//! box. It touches three nodes, costs a handful of box unions, and is what keeps a tree that
//! is only edited incrementally from degrading into long thin overlapping boxes.

use super::DynamicBvh;

impl DynamicBvh {
    /// Applies the best of the four rotations at internal node `a`, if one lowers the surface
    /// area of the node it rebuilds. The box of `a` does not change when the boxes below it
    /// are current (it still bounds the same four grandchildren); heights of `a` and of the
    /// rebuilt child are updated.
    pub(super) fn rotate(&mut self, a: u32) {
        let nodes = &self.arena.nodes;
        let na = &nodes[a as usize];
        if na.height < 2 {
            return;
        }
        let [b, c] = na.children;
        let (nb, nc) = (&nodes[b as usize], &nodes[c as usize]);
        // (gain, child of `a` moving down, side of `a` it is on, slot of the grandchild moving
        //  up in the other child).
        let mut best: Option<(f32, usize, usize)> = None;
        let mut consider = |gain: f32, down_side: usize, up_slot: usize| {
            if gain > 0.0 && best.is_none_or(|(g, _, _)| gain > g) {
                best = Some((gain, down_side, up_slot));
            }
        };
        if nc.height > 0 {
            // Move b down into c, in place of one of c's children; c then holds b and the other.
            let area_c = nc.aabb.half_area();
            let [f, g] = nc.children;
            let (bf, bg) = (&nodes[f as usize].aabb, &nodes[g as usize].aabb);
            consider(area_c - nb.aabb.union(bg).half_area(), 0, 0);
            consider(area_c - nb.aabb.union(bf).half_area(), 0, 1);
        }
        if nb.height > 0 {
            let area_b = nb.aabb.half_area();
            let [d, e] = nb.children;
            let (bd, be) = (&nodes[d as usize].aabb, &nodes[e as usize].aabb);
            consider(area_b - nc.aabb.union(be).half_area(), 1, 0);
            consider(area_b - nc.aabb.union(bd).half_area(), 1, 1);
        }
        let Some((_, down_side, up_slot)) = best else {
            return;
        };
        let down = [b, c][down_side];
        let other = [b, c][1 - down_side];
        let up = self.arena.nodes[other as usize].children[up_slot];
        let keep = self.arena.nodes[other as usize].children[1 - up_slot];
        self.schedule.invalidate();

        self.arena.nodes[a as usize].children[down_side] = up;
        self.arena.nodes[other as usize].children[up_slot] = down;
        self.arena.nodes[down as usize].parent = other;
        self.arena.nodes[up as usize].parent = a;

        let (nd, nk) = (
            &self.arena.nodes[down as usize],
            &self.arena.nodes[keep as usize],
        );
        let other_box = nd.aabb.union(&nk.aabb);
        let other_height = 1 + nd.height.max(nk.height);
        self.arena.nodes[other as usize].height = other_height;
        self.set_aabb(other, other_box);
        let (up_height, up_box) = {
            let nu = &self.arena.nodes[up as usize];
            (nu.height, nu.aabb)
        };
        self.arena.nodes[a as usize].height = 1 + other_height.max(up_height);
        // With leaf updates pending (an insertion between `update` and `refit`), `a`'s box
        // may not yet cover a moved grandchild that `other` now covers: widen it, so every
        // internal node keeps containing its internal children and the refit may stop at the
        // first box that did not change.
        let a_box = self.arena.nodes[a as usize].aabb;
        let covering = up_box.union(&other_box);
        if !a_box.contains_aabb(&covering) {
            self.set_aabb(a, a_box.union(&covering));
        }
    }
}
