//! LBVH, the linear BVH (Lauterbach et al. 2009, "Fast BVH construction on GPUs"): the
//! primitives are sorted along the Morton curve, and the tree is the binary radix tree of
//! their codes (Karras 2012): each node splits its run of codes where the highest bit that
//! differs within the run changes. No box is read to choose a split, so the build is a sort
//! plus two linear passes; the price is the tree's quality, since a split follows the grid,
//! not the primitives' extents (a higher SAH cost than a binned SAH build on every benchmark
//! scene: BENCHMARKS.md, Static BVH builds).
//!
//! What it is for: rebuilding a tree of many entities often, where build time matters more
//! than the last percent of query speed (a level's static tree after an edit, a dynamic tree's
//! periodic rebuild).

use super::morton::sorted_keys;
use super::top_down::fitted_box;
use crate::Aabb;
use crate::bvh::{BuildConfig, BvhNode};

/// Builds the tree over the valid boxes of `bounds`: the same output as
/// [`super::top_down::build_nodes`] (node 0 the root, children after their parent as adjacent
/// pairs, leaves as contiguous ranges of the returned primitive order, invalid boxes left
/// out).
///
/// A run of at most `max_leaf_size` primitives, or one at `max_depth`, becomes a leaf. Runs
/// whose codes are all equal (primitives in one grid cell) are split at their middle, so
/// identical boxes make a balanced subtree rather than a deep one.
pub(super) fn build_nodes(bounds: &[Aabb], config: &BuildConfig) -> (Vec<BvhNode>, Vec<u32>) {
    let (layout, keys) = sorted_keys(bounds);
    if keys.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let nodes = radix_tree(&keys, layout.index_bits, config);
    let order: Vec<u32> = keys.iter().map(|&k| layout.id(k)).collect();
    let nodes = with_boxes(nodes, &order, bounds);
    (nodes, order)
}

/// The topology: node 0 over every key, each interior node's children a pair at `first`.
/// Boxes are left empty for [`with_boxes`].
fn radix_tree(keys: &[u64], index_bits: u32, config: &BuildConfig) -> Vec<BvhNode> {
    let max_leaf = config.max_leaf_size.max(1) as usize;
    let mut nodes = Vec::with_capacity(2 * keys.len().div_ceil(max_leaf));
    nodes.push(BvhNode::default());
    // (node, first key, end key, depth)
    let mut work = vec![(0usize, 0usize, keys.len(), 0u32)];
    while let Some((at, start, end, depth)) = work.pop() {
        let count = end - start;
        if count <= max_leaf || depth >= config.max_depth {
            nodes[at].first = start as u32;
            nodes[at].count = count as u32;
            continue;
        }
        let split = split_point(&keys[start..end], index_bits) + start;
        let left = nodes.len();
        nodes.push(BvhNode::default());
        nodes.push(BvhNode::default());
        nodes[at].first = left as u32;
        nodes[at].count = 0;
        work.push((left + 1, split, end, depth + 1));
        work.push((left, start, split, depth + 1));
    }
    nodes
}

/// Where a sorted run of keys (at least two) splits: the first key whose code has the highest
/// differing bit of the run set, or the middle when every code is the same. Both sides are
/// never empty.
fn split_point(keys: &[u64], index_bits: u32) -> usize {
    let code = |k: u64| k >> index_bits;
    let (first, last) = (code(keys[0]), code(keys[keys.len() - 1]));
    if first == last {
        return keys.len() / 2;
    }
    // The codes are sorted and share every bit above `bit`: those with `bit` clear come first.
    let bit = 63 - (first ^ last).leading_zeros();
    keys.partition_point(|&k| code(k) >> bit & 1 == 0)
}

/// Fills in the boxes bottom-up: children follow their parent, so one reverse sweep meets
/// both children of a node before the node.
fn with_boxes(mut nodes: Vec<BvhNode>, order: &[u32], bounds: &[Aabb]) -> Vec<BvhNode> {
    for i in (0..nodes.len()).rev() {
        let b = fitted_box(&nodes, i, |first, count| {
            order[first..first + count]
                .iter()
                .fold(Aabb::EMPTY, |acc, &p| acc.union(&bounds[p as usize]))
        });
        nodes[i].set_aabb(&b);
    }
    nodes
}

#[cfg(test)]
mod tests {
    use super::split_point;

    #[test]
    fn splits_where_the_highest_differing_bit_changes() {
        // Codes above 4 id bits.
        let keys: Vec<u64> = [0b0001u64, 0b0010, 0b0011, 0b0100, 0b0111]
            .iter()
            .enumerate()
            .map(|(i, c)| c << 4 | i as u64)
            .collect();
        assert_eq!(split_point(&keys, 4), 3);
        assert_eq!(split_point(&keys[..3], 4), 1);
        // Equal codes: the middle.
        let same = [5u64 << 4, 5 << 4 | 1, 5 << 4 | 2, 5 << 4 | 3];
        assert_eq!(split_point(&same, 4), 2);
    }
}
