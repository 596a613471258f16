//! A structure the crate does not have: a ternary tree that keeps large boxes at interior
//! nodes, as an octree does. It writes no walk: every query comes from the shared walks
//! through its [`BoundingTree`] view, which is what the conformance suite checks.

use core::ops::Range;
use spatial_accel::Aabb;
use spatial_accel::query::BoundingTree;

/// Each node: its box, its children (a run of node ids) and the primitives kept at it.
pub struct ToyTree {
    bounds: Vec<Aabb>,
    children: Vec<Range<u32>>,
    primitives: Vec<Range<u32>>,
    ids: Vec<u32>,
}

/// Leaves hold up to this many primitives.
const LEAF_SIZE: usize = 3;

impl ToyTree {
    /// A tree over `(id, box)` entries.
    pub fn build(entries: &[(u32, Aabb)]) -> Self {
        let mut tree = Self {
            bounds: Vec::new(),
            children: Vec::new(),
            primitives: Vec::new(),
            ids: Vec::new(),
        };
        if !entries.is_empty() {
            tree.push_node();
            tree.fill(0, entries.to_vec());
        }
        tree
    }

    pub fn node_count(&self) -> usize {
        self.bounds.len()
    }

    fn push_node(&mut self) -> u32 {
        self.bounds.push(Aabb::EMPTY);
        self.children.push(0..0);
        self.primitives.push(0..0);
        (self.bounds.len() - 1) as u32
    }

    fn fill(&mut self, node: u32, mut entries: Vec<(u32, Aabb)>) {
        let n = node as usize;
        self.bounds[n] = entries.iter().fold(Aabb::EMPTY, |acc, (_, b)| acc.union(b));
        let extent = self.bounds[n].extent().max_element();
        // Boxes larger than a quarter of the node stay here, as an octree keeps an object
        // at the depth its size gives.
        let (kept, rest): (Vec<_>, Vec<_>) = if entries.len() <= LEAF_SIZE {
            (core::mem::take(&mut entries), Vec::new())
        } else {
            entries
                .into_iter()
                .partition(|(_, b)| b.extent().max_element() > 0.25 * extent)
        };
        let first = self.ids.len() as u32;
        self.ids.extend(kept.iter().map(|&(id, _)| id));
        self.primitives[n] = first..self.ids.len() as u32;
        if rest.is_empty() {
            return;
        }
        let mut rest = rest;
        let axis = self.bounds[n].longest_axis();
        rest.sort_by(|a, b| a.1.center()[axis].total_cmp(&b.1.center()[axis]));
        let parts: Vec<Vec<(u32, Aabb)>> = rest
            .chunks(rest.len().div_ceil(3))
            .map(<[_]>::to_vec)
            .collect();
        let start = self.bounds.len() as u32;
        for _ in &parts {
            self.push_node();
        }
        self.children[n] = start..start + parts.len() as u32;
        for (i, part) in parts.into_iter().enumerate() {
            self.fill(start + i as u32, part);
        }
    }
}

impl BoundingTree for ToyTree {
    type Volume = Aabb;
    const INTERIOR_PRIMITIVES: bool = true;
    type Children<'a> = Range<u32>;

    fn root(&self) -> Option<u32> {
        (!self.bounds.is_empty()).then_some(0)
    }

    fn node_bounds(&self, node: u32) -> Aabb {
        self.bounds[node as usize]
    }

    fn node_children(&self, node: u32) -> Option<Range<u32>> {
        let children = self.children[node as usize].clone();
        (!children.is_empty()).then_some(children)
    }

    fn node_primitives(&self, node: u32) -> &[u32] {
        let r = self.primitives[node as usize].clone();
        &self.ids[r.start as usize..r.end as usize]
    }
}

spatial_accel::impl_spatial_query_for_tree!(ToyTree);
