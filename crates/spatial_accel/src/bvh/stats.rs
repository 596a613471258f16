//! What a built tree looks like: SAH cost, depth, leaf sizes, memory.

use super::config::SahCosts;
use crate::Aabb;
use crate::query::BoundingTree;

/// Shape and cost statistics of a binary tree.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TreeStats {
    /// Expected cost of a random ray that hits the root, under the SAH:
    /// `sum over interior nodes (area / root area) * traversal
    ///  + sum over leaves (area / root area) * count * intersection`.
    pub sah_cost: f32,
    /// Interior nodes.
    pub interior_nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Primitives, counted through the leaves.
    pub primitives: usize,
    /// Longest root-to-leaf path, in edges (a lone leaf has depth 0).
    pub max_depth: usize,
    /// Largest leaf.
    pub max_leaf_size: usize,
}

/// Walks the tree once and gathers [`TreeStats`].
pub fn tree_stats<T>(tree: &T, costs: &SahCosts) -> TreeStats
where
    T: BoundingTree<Volume = Aabb> + ?Sized,
{
    let mut s = TreeStats::default();
    let Some(root) = tree.root() else { return s };
    let root_area = tree.node_bounds(root).half_area();
    // A point-like or flat root has zero area; weight every node equally then rather than
    // divide by zero (the cost is still comparable between trees over the same input).
    let weight = |area: f32| {
        if root_area > 0.0 {
            area / root_area
        } else {
            1.0
        }
    };
    let mut stack = vec![(root, 0usize)];
    let mut cost = 0.0f64;
    while let Some((node, depth)) = stack.pop() {
        let w = weight(tree.node_bounds(node).half_area()) as f64;
        s.max_depth = s.max_depth.max(depth);
        match tree.node_children(node) {
            Some(children) => {
                s.interior_nodes += 1;
                cost += w * costs.traversal as f64;
                if T::INTERIOR_PRIMITIVES {
                    let n = tree.node_primitives(node).len();
                    s.primitives += n;
                    cost += w * n as f64 * costs.intersection as f64;
                }
                for c in children {
                    stack.push((c, depth + 1));
                }
            }
            None => {
                let n = tree.node_primitives(node).len();
                s.leaves += 1;
                s.primitives += n;
                s.max_leaf_size = s.max_leaf_size.max(n);
                cost += w * n as f64 * costs.intersection as f64;
            }
        }
    }
    s.sah_cost = cost as f32;
    s
}
