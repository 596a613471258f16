//! From binary to wide: pull grandchildren up until each node has `N` children.

use super::{WideBvh, WideNode};
use crate::Aabb;
use crate::bvh::validate::ValidationError;
use crate::bvh::{Bvh, BvhNode};

/// Collapses top-down. At each wide node the binary children are opened greedily, always the
/// interior one with the largest surface area: that is the child a random ray is most likely
/// to enter, so opening it saves the most expected traversal steps (the SAH-greedy collapse
/// of Wald et al. 2008 and of Embree's BVH4/8 builders).
pub(super) fn collapse<const N: usize>(bvh: &Bvh) -> WideBvh<N> {
    assert!(N >= 2, "a wide node needs at least two children");
    let mut out = WideBvh::<N> {
        nodes: Vec::new(),
        primitive_indices: bvh.primitive_indices.clone(),
        bounds: bvh.bounds(),
    };
    if bvh.nodes.is_empty() {
        return out;
    }
    out.nodes.push(WideNode::default());
    // (wide node to fill, binary node whose children it takes)
    let mut work = vec![(0usize, 0usize)];
    while let Some((wide, binary)) = work.pop() {
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
            out.nodes[wide].set_child_aabb(i, &n.aabb());
            if n.is_leaf() {
                out.nodes[wide].child[i] = n.first;
                out.nodes[wide].count[i] = n.count;
            } else {
                let child = out.nodes.len();
                out.nodes.push(WideNode::default());
                out.nodes[wide].child[i] = child as u32;
                out.nodes[wide].count[i] = 0;
                work.push((child, s));
            }
        }
    }
    out
}

pub(super) fn validate<const N: usize>(
    tree: &WideBvh<N>,
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
                        child: n.child[i],
                    });
                }
                if !n.is_leaf(i) {
                    stack.push((n.child[i], b));
                    continue;
                }
                let first = n.child[i] as usize;
                for &p in &tree.primitive_indices[first..first + n.count[i] as usize] {
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
