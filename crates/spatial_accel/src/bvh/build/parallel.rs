//! The parallel build: the same splits as the serial builder, subtrees built on rayon's pool.

use super::top_down::{BuildPrim, NodeBounds, build_subtree_within, collect_prims, split_node};
use crate::Aabb;
use crate::bvh::config::{BuildConfig, SplitStrategy};
use crate::bvh::node::BvhNode;

/// Below this many primitives a subtree is built serially: a task costs more than it saves.
const SERIAL_BELOW: usize = 4096;

/// Builds like [`super::top_down::build_nodes`], splitting the top of the tree serially and
/// handing the two halves of every large node to `rayon::join`. The result is the tree the
/// serial build makes (same splits, same leaves), laid out in another node order.
///
/// PLOC and LBVH are built serially: PLOC's iterations are sequential scans, and this crate's
/// version is the single-threaded one; LBVH is a sort and two linear passes.
pub(in crate::bvh) fn build_nodes_parallel(
    bounds: &[Aabb],
    config: &BuildConfig,
) -> (Vec<BvhNode>, Vec<u32>) {
    if let SplitStrategy::Ploc { .. } | SplitStrategy::Lbvh = config.split {
        return super::top_down::build_nodes(bounds, config);
    }
    let (mut prims, bounds) = collect_prims(bounds);
    if prims.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let nodes = build_parallel(&mut prims, bounds, config, 0, 0);
    (nodes, prims.iter().map(BuildPrim::index).collect())
}

/// Builds over non-empty `prims`, whose bounds are `bounds`.
fn build_parallel(
    prims: &mut [BuildPrim],
    bounds: NodeBounds,
    config: &BuildConfig,
    prim_offset: usize,
    depth: u32,
) -> Vec<BvhNode> {
    if prims.len() < SERIAL_BELOW {
        return build_subtree_within(prims, bounds, config, prim_offset, depth);
    }
    let mut root = BvhNode::default();
    root.set_aabb(&bounds.node);
    let Some((mid, [left_bounds, right_bounds])) = split_node(prims, &bounds, depth, config) else {
        root.first = prim_offset as u32;
        root.count = prims.len() as u32;
        if !bounds.tight {
            root.set_aabb(&NodeBounds::of(prims).node);
        }
        return vec![root];
    };
    let (left, right) = prims.split_at_mut(mid);
    let (l, r) = rayon::join(
        || build_parallel(left, left_bounds, config, prim_offset, depth + 1),
        || build_parallel(right, right_bounds, config, prim_offset + mid, depth + 1),
    );
    // Layout: root, left root, right root, then the rest of each subtree. Keeping the two
    // children adjacent is what lets one index name both.
    let remap_left = |i: u32| if i == 0 { 1 } else { i + 2 };
    let right_base = l.len() as u32 + 1;
    let remap_right = |i: u32| if i == 0 { 2 } else { right_base + i };
    let fix = |mut n: BvhNode, remap: &dyn Fn(u32) -> u32| {
        if !n.is_leaf() {
            n.first = remap(n.first);
        }
        n
    };
    root.first = 1;
    root.count = 0;
    if !bounds.tight {
        root.set_aabb(&l[0].aabb().union(&r[0].aabb()));
    }
    let mut nodes = Vec::with_capacity(1 + l.len() + r.len());
    nodes.push(root);
    nodes.push(fix(l[0], &remap_left));
    nodes.push(fix(r[0], &remap_right));
    nodes.extend(l[1..].iter().map(|&n| fix(n, &remap_left)));
    nodes.extend(r[1..].iter().map(|&n| fix(n, &remap_right)));
    nodes
}
