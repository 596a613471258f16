//! The nodes of a structure, level by level, for debug overlays: what each node covers, how
//! deep it sits and how many entries it keeps.

use super::{BoundingTree, NodeVolume};
use crate::Aabb;
use core::ops::{ControlFlow, RangeInclusive};

/// One node of a spatial structure as a debug overlay sees it, handed out by
/// [`DynamicIndex::visit_nodes`](super::DynamicIndex::visit_nodes) and [`visit_tree_nodes`].
///
/// What a node and its depth are differs by structure (each implementation documents its
/// own):
/// - a tree through [`visit_tree_nodes`] (the static [`Bvh`](crate::Bvh), the wide trees,
///   the dynamic BVH): every node with its stored bounds, `depth` the edges from the root
///   (the root is 0);
/// - the loose octree and quadtree: every octant in use with its loose cell, `depth` the
///   levels below the root (the cell's size: a link may skip levels);
/// - the uniform grid: every non-empty cell at depth 0, every oversize entry at depth 1;
/// - the brute-force list: the list itself as one leaf at depth 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeView {
    /// The region the node stands for: a box around its bounding volume, or a loose cell.
    pub bounds: Aabb,
    /// How deep the node sits; 0 for a root.
    pub depth: u32,
    /// True when the node has no children.
    pub leaf: bool,
    /// The entries kept at this node itself, not below it (0 at a BVH's interior nodes).
    pub entries: u32,
}

/// Calls `visit` for each node of `tree` whose depth (edges from the root, the root 0) lies
/// in `depths`, breadth first: every node of one depth before any deeper one, and within a
/// depth in the order a depth-first walk takes them. The walk stops as soon as `visit`
/// breaks, and returns [`ControlFlow::Break`] then.
///
/// Nodes below `depths.end()` are never read, so the cost is that of the nodes down to that
/// depth: an overlay with a line budget keeps the top of the tree by breaking once it is
/// spent. Nodes above `depths.start()` are walked through but not visited. A node's bounds
/// are [`NodeVolume::bounding_box`] of its volume (a sphere tree's spheres come as boxes),
/// `leaf` is true where it has no children and `entries` counts
/// [`node_primitives`](BoundingTree::node_primitives).
///
/// On a loose tree this is its query view, node bounds (what the octants hold) and links
/// counted as depths; its [`DynamicIndex::visit_nodes`](super::DynamicIndex::visit_nodes)
/// shows the loose cells by level instead. The tree must be ready for queries (the dynamic
/// trees assert it in debug builds); `visit_nodes` shows a dynamic index between edits too.
///
/// ```
/// use spatial_accel::query::{NodeView, visit_tree_nodes};
/// use spatial_accel::{Aabb, BuildConfig, Bvh};
/// use core::ops::ControlFlow;
/// use glam::Vec3A;
///
/// let boxes: Vec<Aabb> = (0..64)
///     .map(|i| Aabb::new(Vec3A::splat(i as f32), Vec3A::splat(i as f32 + 0.5)))
///     .collect();
/// let bvh = Bvh::build(&boxes, &BuildConfig::default());
/// // The root and its two children.
/// let mut top: Vec<NodeView> = Vec::new();
/// visit_tree_nodes(&bvh, 0..=1, |node| {
///     top.push(node);
///     ControlFlow::Continue(())
/// });
/// assert_eq!(top.iter().map(|n| n.depth).collect::<Vec<_>>(), [0, 1, 1]);
/// assert!(top[0].bounds.contains_aabb(&top[1].bounds));
/// // Every node, with each primitive counted at its leaf.
/// let mut count = 0;
/// let mut primitives = 0;
/// visit_tree_nodes(&bvh, 0..=u32::MAX, |node| {
///     count += 1;
///     primitives += node.entries;
///     ControlFlow::Continue(())
/// });
/// assert_eq!((count, primitives), (bvh.nodes().len(), 64));
/// ```
pub fn visit_tree_nodes<T, F>(tree: &T, depths: RangeInclusive<u32>, visit: F) -> ControlFlow<()>
where
    T: BoundingTree + ?Sized,
    F: FnMut(NodeView) -> ControlFlow<()>,
{
    visit_levels(tree, tree.root(), &depths, visit)
}

/// [`visit_tree_nodes`] from a root given by the caller: a structure whose
/// [`BoundingTree::root`] asserts it is ready for queries (the dynamic BVH) shows its nodes
/// as they are without that check.
pub(crate) fn visit_levels<T, F>(
    tree: &T,
    root: Option<u32>,
    depths: &RangeInclusive<u32>,
    mut visit: F,
) -> ControlFlow<()>
where
    T: BoundingTree + ?Sized,
    F: FnMut(NodeView) -> ControlFlow<()>,
{
    let Some(root) = root else {
        return ControlFlow::Continue(());
    };
    if depths.is_empty() {
        return ControlFlow::Continue(());
    }
    let last = *depths.end();
    let mut level = vec![root];
    let mut next = Vec::new();
    let mut depth = 0u32;
    loop {
        let shown = depths.contains(&depth);
        for &node in &level {
            let children = tree.node_children(node);
            let leaf = children.is_none();
            if depth < last
                && let Some(children) = children
            {
                next.extend(children);
            }
            if shown {
                visit(NodeView {
                    bounds: tree.node_bounds(node).bounding_box(),
                    depth,
                    leaf,
                    entries: count(tree.node_primitives(node).len()),
                })?;
            }
        }
        if next.is_empty() {
            return ControlFlow::Continue(());
        }
        core::mem::swap(&mut level, &mut next);
        next.clear();
        depth += 1;
    }
}

/// An entry count as a [`NodeView::entries`] (saturating; no structure holds 2^32).
#[inline]
pub(crate) fn count(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}
