//! From binary to wide: pull grandchildren up until each node has `N` children.

use super::plan::plan_slots;
use super::{WideBvh, WideLayout, WideNode, ids_are_positions};
use crate::Aabb;
use crate::bvh::validate::ValidationError;
use crate::bvh::{Bvh, BvhNode};
use crate::prefetch::prefetch_node;
use std::borrow::Cow;

/// Collapses along the least-cost plan of [`plan_slots`]: which binary nodes become wide
/// nodes, chosen so that the wide nodes' total surface area (the nodes a random ray is
/// expected to visit) is least. The greedy top-down collapse (open the interior child of
/// largest area until the node is full: Wald et al. 2008, Embree's BVH4/8 builders) leaves the
/// bottom level, which holds most nodes, half empty; see `plan.rs`.
///
/// The plan records only which binary node each slot takes (a few bytes a slot);
/// the wide nodes are written once, by the bottom-up pass. Why: building every node twice, as
/// a float node and then in the layout, in arrays grown by doubling, spends much of a large
/// collapse on page faults and copies of those arrays (BENCHMARKS.md, Static BVH builds).
pub(super) fn collapse<const N: usize, L: WideLayout<N>>(bvh: &Bvh) -> WideBvh<N, L> {
    assert!(N >= 2, "a wide node needs at least two children");
    let bvh = split_oversized_leaves(bvh, L::MAX_LEAF_PRIMITIVES);
    if bvh.nodes.is_empty() {
        return WideBvh {
            bounds: Aabb::EMPTY,
            nodes: Vec::new(),
            primitive_indices: bvh.primitive_indices.clone(),
            ids_are_positions: ids_are_positions(&bvh.primitive_indices),
        };
    }
    let plan = plan_slots::<N>(&bvh.nodes);
    // Converted bottom-up (children follow parents, so in reverse): a parent's slot box is
    // the union of the child's boxes as the layout stores them, which for a quantized layout
    // are rounded outward; converting from the binary boxes would let a child stick out of
    // its parent's slot.
    let mut out = vec![L::default(); plan.len()];
    let mut stored_bounds = vec![Aabb::EMPTY; plan.len()];
    for n in (0..plan.len()).rev() {
        // The binary nodes a wide node takes lie at scattered places in a large tree: ask
        // for those of the node converted a few steps from now.
        if let Some(ahead) = n.checked_sub(PREFETCH_AHEAD) {
            for slot in plan[ahead].iter().map_while(|s| *s) {
                prefetch_node(&bvh.nodes[slot.binary as usize]);
            }
        }
        let mut node = WideNode::<N>::default();
        for (i, slot) in plan[n].iter().enumerate() {
            let Some(slot) = slot else { break };
            let b = &bvh.nodes[slot.binary as usize];
            if b.is_leaf() {
                node.set_child_aabb(i, &b.aabb());
                node.child[i] = b.first;
                node.count[i] = b.count;
            } else {
                node.set_child_aabb(i, &stored_bounds[slot.wide as usize]);
                node.child[i] = slot.wide;
                node.count[i] = 0;
            }
        }
        out[n] = L::from_float(&node);
        stored_bounds[n] = (0..N)
            .filter(|&s| out[n].is_used(s))
            .fold(Aabb::EMPTY, |acc, s| acc.union(&out[n].child_aabb(s)));
    }
    WideBvh {
        bounds: stored_bounds[0],
        nodes: out,
        primitive_indices: bvh.primitive_indices.clone(),
        ids_are_positions: ids_are_positions(&bvh.primitive_indices),
    }
}

/// How many wide nodes ahead the bottom-up pass of [`collapse`] asks for binary nodes.
const PREFETCH_AHEAD: usize = 4;

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
    primitive_count: usize,
    bounds: impl Fn(u32) -> Option<Aabb>,
) -> Result<(), ValidationError> {
    let mut seen_prim = vec![false; primitive_count];
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
                let prims = &tree.primitive_indices[first..first + n.count(i) as usize];
                // An inlined id must be the one its slot's position in the array names.
                if let Some(p) = n.inline_primitive(i)
                    && prims != [p]
                {
                    return Err(ValidationError::InlinePrimitiveMismatch { node, primitive: p });
                }
                for &p in prims {
                    let pb = bounds(p).ok_or(ValidationError::UnknownPrimitive(p))?;
                    let seen = seen_prim
                        .get_mut(p as usize)
                        .ok_or(ValidationError::UnknownPrimitive(p))?;
                    if std::mem::replace(seen, true) {
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
        if !seen && bounds(p as u32).is_some_and(|b| b.is_valid()) {
            return Err(ValidationError::MissingPrimitive(p as u32));
        }
    }
    Ok(())
}
