//! From binary to wide: pull grandchildren up until each node has `N` children.

use super::{WideBvh, WideLayout, WideNode};
use crate::Aabb;
use crate::bvh::validate::ValidationError;
use crate::bvh::{Bvh, BvhNode};
use std::borrow::Cow;

/// Collapses top-down. At each wide node the binary children are opened greedily, always the
/// interior one with the largest surface area: that is the child a random ray is most likely
/// to enter, so opening it saves the most expected traversal steps (the SAH-greedy collapse
/// of Wald et al. 2008 and of Embree's BVH4/8 builders).
pub(super) fn collapse<const N: usize, L: WideLayout<N>>(bvh: &Bvh) -> WideBvh<N, L> {
    assert!(N >= 2, "a wide node needs at least two children");
    let bvh = split_oversized_leaves(bvh, L::MAX_LEAF_PRIMITIVES);
    let mut nodes: Vec<WideNode<N>> = Vec::new();
    if !bvh.nodes.is_empty() {
        nodes.push(WideNode::default());
    }
    // (wide node to fill, binary node whose children it takes)
    let mut work = vec![(0usize, 0usize)];
    while let Some((wide, binary)) = work.pop().filter(|_| !bvh.nodes.is_empty()) {
        let mut slots: Vec<usize> = Vec::with_capacity(N);
        let root = &bvh.nodes[binary];
        if root.is_leaf() {
            // Only a one-leaf tree has a leaf root: it becomes a node with one leaf slot.
            slots.push(binary);
        } else {
            slots.push(root.first as usize);
            slots.push(root.first as usize + 1);
            while slots.len() < N {
                let Some(open) = slots
                    .iter()
                    .enumerate()
                    .filter(|(_, s)| !bvh.nodes[**s].is_leaf())
                    .max_by(|a, b| {
                        let area = |s: usize| bvh.nodes[s].aabb().half_area();
                        area(*a.1).total_cmp(&area(*b.1))
                    })
                    .map(|(i, _)| i)
                else {
                    break;
                };
                let n = bvh.nodes[slots[open]];
                slots[open] = n.first as usize;
                slots.push(n.first as usize + 1);
            }
        }
        for (i, &s) in slots.iter().enumerate() {
            let n: &BvhNode = &bvh.nodes[s];
            nodes[wide].set_child_aabb(i, &n.aabb());
            if n.is_leaf() {
                nodes[wide].child[i] = n.first;
                nodes[wide].count[i] = n.count;
            } else {
                let child = nodes.len();
                nodes.push(WideNode::default());
                nodes[wide].child[i] = child as u32;
                nodes[wide].count[i] = 0;
                work.push((child, s));
            }
        }
    }
    // Converted bottom-up (children follow parents, so in reverse): a parent's slot box is
    // the union of the child's boxes as the layout stores them, which for a quantized layout
    // are rounded outward; converting from the binary boxes would let a child stick out of
    // its parent's slot.
    let mut out = vec![L::default(); nodes.len()];
    let mut stored_bounds = vec![Aabb::EMPTY; nodes.len()];
    for n in (0..nodes.len()).rev() {
        let mut node = nodes[n];
        for slot in 0..N {
            if node.is_used(slot) && !node.is_leaf(slot) {
                node.set_child_aabb(slot, &stored_bounds[node.child[slot] as usize]);
            }
        }
        out[n] = L::from_float(&node);
        stored_bounds[n] = (0..N)
            .filter(|&s| out[n].is_used(s))
            .fold(Aabb::EMPTY, |acc, s| acc.union(&out[n].child_aabb(s)));
    }
    WideBvh {
        bounds: stored_bounds.first().copied().unwrap_or(Aabb::EMPTY),
        nodes: out,
        primitive_indices: bvh.primitive_indices.clone(),
    }
}

/// A binary tree whose leaves hold at most `max` primitives: larger leaves (which only a
/// depth limit makes) become balanced subtrees of leaves that share the big leaf's box, a
/// valid if loose bound. Layouts with narrow per-slot counts need this; the common case
/// borrows the tree unchanged.
fn split_oversized_leaves(bvh: &Bvh, max: u32) -> Cow<'_, Bvh> {
    if bvh.nodes.iter().all(|n| n.count <= max) {
        return Cow::Borrowed(bvh);
    }
    enum Source {
        Node(usize),
        Run { aabb: Aabb, first: u32, count: u32 },
    }
    let mut nodes = vec![BvhNode::default()];
    let mut work = vec![(0usize, Source::Node(0))];
    while let Some((at, source)) = work.pop() {
        let (aabb, halves) = match source {
            Source::Node(i) if !bvh.nodes[i].is_leaf() => {
                let n = bvh.nodes[i];
                let halves = [
                    Source::Node(n.first as usize),
                    Source::Node(n.first as usize + 1),
                ];
                (n.aabb(), Some(halves))
            }
            Source::Node(i) => {
                let n = bvh.nodes[i];
                work.push((
                    at,
                    Source::Run {
                        aabb: n.aabb(),
                        first: n.first,
                        count: n.count,
                    },
                ));
                continue;
            }
            Source::Run { aabb, first, count } if count > max => {
                let half = count / 2;
                let halves = [
                    Source::Run {
                        aabb,
                        first,
                        count: half,
                    },
                    Source::Run {
                        aabb,
                        first: first + half,
                        count: count - half,
                    },
                ];
                (aabb, Some(halves))
            }
            Source::Run { aabb, first, count } => {
                nodes[at].set_aabb(&aabb);
                nodes[at].first = first;
                nodes[at].count = count;
                continue;
            }
        };
        nodes[at].set_aabb(&aabb);
        if let Some([left, right]) = halves {
            let l = nodes.len();
            nodes.push(BvhNode::default());
            nodes.push(BvhNode::default());
            nodes[at].first = l as u32;
            nodes[at].count = 0;
            work.push((l + 1, right));
            work.push((l, left));
        }
    }
    Cow::Owned(Bvh {
        nodes,
        primitive_indices: bvh.primitive_indices.clone(),
    })
}

pub(super) fn validate<const N: usize, L: WideLayout<N>>(
    tree: &WideBvh<N, L>,
    bounds: &[Aabb],
) -> Result<(), ValidationError> {
    let mut seen_prim = vec![false; bounds.len()];
    let mut seen_node = vec![false; tree.nodes.len()];
    if !tree.nodes.is_empty() {
        let mut stack = vec![(0u32, tree.bounds)];
        while let Some((node, parent_box)) = stack.pop() {
            let slot = seen_node
                .get_mut(node as usize)
                .ok_or(ValidationError::NodeReachedTwice(node))?;
            if std::mem::replace(slot, true) {
                return Err(ValidationError::NodeReachedTwice(node));
            }
            let n = &tree.nodes[node as usize];
            for i in (0..N).filter(|&i| n.is_used(i)) {
                let b = n.child_aabb(i);
                if !parent_box.contains_aabb(&b) {
                    return Err(ValidationError::ChildOutsideParent {
                        parent: node,
                        child: n.child(i),
                    });
                }
                if !n.is_leaf(i) {
                    stack.push((n.child(i), b));
                    continue;
                }
                let first = n.child(i) as usize;
                for &p in &tree.primitive_indices[first..first + n.count(i) as usize] {
                    let pb = bounds
                        .get(p as usize)
                        .copied()
                        .filter(Aabb::is_valid)
                        .ok_or(ValidationError::UnknownPrimitive(p))?;
                    if std::mem::replace(&mut seen_prim[p as usize], true) {
                        return Err(ValidationError::DuplicatePrimitive(p));
                    }
                    if !b.contains_aabb(&pb) {
                        return Err(ValidationError::PrimitiveOutsideLeaf {
                            leaf: node,
                            primitive: p,
                        });
                    }
                }
            }
        }
    }
    for (p, seen) in seen_prim.iter().enumerate() {
        if !seen && bounds[p].is_valid() {
            return Err(ValidationError::MissingPrimitive(p as u32));
        }
    }
    Ok(())
}
