//! The tree PLOC builds, as merge records: the stopping rules that collapse it into leaves, and
//! its layout into the builder's node array.

use super::ploc::{Cluster, CurveBoxes, GATHER_AHEAD};
use super::top_down::{BuildPrim, build_subtree, first_node_reservation};
use crate::Aabb;
use crate::bvh::config::{BuildConfig, SplitStrategy};
use crate::bvh::node::BvhNode;
use glam::Vec3A;

/// One merge: the box of the new subtree and its two children (node ids: below `n` a sorted
/// primitive, from `n` on the merge `id - n`).
#[derive(Clone, Copy, Debug)]
pub(super) struct Merge {
    pub lo: [f32; 3],
    pub left: u32,
    pub hi: [f32; 3],
    /// The right child; the top bit marks a subtree collapsed into one leaf.
    pub right: u32,
}

impl Merge {
    /// Half the surface area of the merge's box.
    #[inline(always)]
    pub fn half_area(&self) -> f32 {
        Cluster {
            lo: self.lo,
            hi: self.hi,
            ..Cluster::default()
        }
        .half_area()
    }
}

/// The top bit of [`Merge::right`]: the merge's subtree is laid out as one leaf. Node ids stay
/// below it (PLOC builds top-down past a billion primitives).
pub(super) const COLLAPSED: u32 = 1 << 31;

/// The stopping rules, as the merges apply them.
#[derive(Clone, Copy, Debug)]
pub(super) struct Collapse {
    pub max_leaf: u32,
    pub by_sah: bool,
    pub traversal: f32,
    pub intersection: f32,
}

impl Collapse {
    /// Whether a subtree of `prims` primitives, box area `area` and children costing
    /// `cost_a` and `cost_b` is better as one leaf, and what it costs.
    ///
    /// The top-down builder's rule, `leaf_cost <= split_cost`, with the split's true cost:
    /// both children are finished (and collapsed where cheaper), so the decision is the optimal
    /// collapse of this subtree, not the top-down guess that children are leaves.
    #[inline(always)]
    pub fn decide(&self, prims: u32, area: f32, cost_a: f32, cost_b: f32) -> (bool, f32) {
        let keep = self.traversal * area + cost_a + cost_b;
        let leaf = self.intersection * prims as f32 * area;
        let collapse = prims <= self.max_leaf && (!self.by_sah || leaf <= keep);
        (collapse, if collapse { leaf } else { keep })
    }
}

/// The merge indices under `root`, children before parents.
fn post_order(n: usize, merges: &[Merge], root: u32) -> Vec<u32> {
    let mut out = Vec::with_capacity(merges.len());
    let mut work = vec![(root, false)];
    while let Some((id, children_done)) = work.pop() {
        let Some(m) = (id as usize).checked_sub(n) else {
            continue;
        };
        if children_done {
            out.push(m as u32);
        } else {
            let [l, r] = [merges[m].left, merges[m].right & !COLLAPSED];
            work.extend([(id, true), (l, false), (r, false)]);
        }
    }
    out
}

/// The height each merge's subtree will have once laid out (collapsed subtrees are leaves).
fn subtree_heights(n: usize, merges: &[Merge], post_order: &[u32]) -> Vec<u32> {
    let mut height = vec![0u32; merges.len()];
    for &m in post_order {
        let merge = &merges[m as usize];
        if merge.right & COLLAPSED == 0 {
            let of = |c: u32| (c as usize).checked_sub(n).map_or(0, |c| height[c]);
            height[m as usize] = 1 + of(merge.left).max(of(merge.right));
        }
    }
    height
}

/// The SAH cost of a merge's subtree (area-weighted, collapsed where a leaf is cheaper) and
/// how many primitives it holds: what deciding its parent's collapse needs.
pub(super) type SubtreeCost = (f32, u32);

/// Sets the collapse flags again where reinsertion changed the tree. Clustering decided every
/// merge's flag and recorded its `subtrees` cost; a merge whose subtree reinsertion left alone
/// (not `moved`) keeps both, so only the moved merges, the paths from each move to the root,
/// are visited, children before parents. Deciding them over the whole tree again would cost a
/// post-order and a pass over every merge (two million on a million triangles), a large part
/// of reinsertion's fixed cost, for the few paths a batch changes.
pub(super) fn collapse_moved(
    prims: CurveBoxes<'_>,
    merges: &mut [Merge],
    subtrees: &mut [SubtreeCost],
    moved: &[bool],
    root: u32,
    rule: &Collapse,
) {
    let n = prims.len();
    let mut work = vec![(root, false)];
    while let Some((id, children_done)) = work.pop() {
        let Some(m) = (id as usize).checked_sub(n).filter(|&m| moved[m]) else {
            continue;
        };
        let [l, r] = [merges[m].left, merges[m].right & !COLLAPSED];
        if !children_done {
            work.extend([(id, true), (l, false), (r, false)]);
            continue;
        }
        let of = |c: u32| match (c as usize).checked_sub(n) {
            None => (rule.intersection * prims.leaf(c).half_area(), 1),
            Some(c) => subtrees[c],
        };
        let ((cost_l, prims_l), (cost_r, prims_r)) = (of(l), of(r));
        let merge = &mut merges[m];
        let (flag, cost) = rule.decide(prims_l + prims_r, merge.half_area(), cost_l, cost_r);
        merge.right = r | if flag { COLLAPSED } else { 0 };
        subtrees[m] = (cost, prims_l + prims_r);
    }
}

/// [`layout_tree`], kept within `config.max_depth`. A bottom-up tree has no depth bound of its
/// own, yet it is rarely deeper than the limit (a million triangles after reinsertion stay well
/// within the default of 64 levels), so the tree is laid out as it is first, and only a layout that
/// went too deep is redone with the subtree heights that tell where to rebuild.
pub(super) fn layout_within_depth(
    prims: CurveBoxes<'_>,
    merges: &[Merge],
    root: u32,
    config: &BuildConfig,
) -> (Vec<BvhNode>, Vec<u32>) {
    let (nodes, order, deepest) = layout_tree(prims, merges, root, None, config);
    if deepest <= config.max_depth {
        return (nodes, order);
    }
    let n = prims.len();
    let heights = subtree_heights(n, merges, &post_order(n, merges, root));
    let (nodes, order, _) = layout_tree(prims, merges, root, Some(&heights), config);
    (nodes, order)
}

/// Lays the clustered tree out top-down in the builder's format: pairs of children allocated
/// together after their parent, depth-first with the left child first, so that leaves take
/// contiguous, increasing ranges of the primitive order. Collapsed subtrees become one leaf.
/// Returns the nodes, the primitive order and the depth of the deepest leaf (a subtree rebuilt
/// top-down counts as reaching `max_depth`).
///
/// `heights` (the laid-out height of each merge's subtree) is given when the tree may be
/// deeper than `config.max_depth`: a subtree that would cross it is rebuilt top-down, binned
/// SAH with the same stopping rules, from its depth (a bottom-up tree has no depth bound of
/// its own, and cutting it into leaves at the limit could leave one leaf with most of the
/// primitives).
fn layout_tree(
    leaves: CurveBoxes<'_>,
    merges: &[Merge],
    root: u32,
    heights: Option<&[u32]>,
    config: &BuildConfig,
) -> (Vec<BvhNode>, Vec<u32>, u32) {
    let n = leaves.len();
    let mut prims = Vec::with_capacity(n);
    if n == 0 {
        return (Vec::new(), prims, 0);
    }
    let mut deepest = 0;
    let mut nodes = Vec::with_capacity(first_node_reservation(n, config));
    nodes.push(BvhNode::default());
    let mut work = vec![(0usize, root, 0u32)];
    let mut gather = Vec::new();
    let mut subtree = Vec::new();
    while let Some((slot, id, depth)) = work.pop() {
        let Some(m) = (id as usize).checked_sub(n).map(|m| &merges[m]) else {
            // The walk meets the primitives in about curve order (exactly so without
            // reinsertion), and each box read is a cache miss at a random place: asking ahead
            // along the curve overlaps them. Trees of one primitive a leaf (the plugin's entity
            // tree) read a box for nearly every primitive here.
            leaves.prefetch(id + GATHER_AHEAD);
            let leaf = leaves.leaf(id);
            nodes[slot] = BvhNode {
                min: leaf.lo,
                first: prims.len() as u32,
                max: leaf.hi,
                count: 1,
            };
            prims.push(leaves.id(id));
            deepest = deepest.max(depth);
            continue;
        };
        let collapsed = m.right & COLLAPSED != 0;
        let too_deep = heights.is_some_and(|h| depth + h[id as usize - n] > config.max_depth);
        if collapsed || too_deep {
            gather.push(id);
            subtree.clear();
            while let Some(g) = gather.pop() {
                match (g as usize).checked_sub(n) {
                    None => subtree.push(g),
                    Some(m) => {
                        gather.push(merges[m].right & !COLLAPSED);
                        gather.push(merges[m].left);
                    }
                }
            }
        }
        if too_deep && !collapsed {
            let top_down = BuildConfig {
                split: SplitStrategy::BinnedSah { bins: 16 },
                ..*config
            };
            let mut build: Vec<BuildPrim> = subtree
                .iter()
                .map(|&s| {
                    let c = leaves.leaf(s);
                    let b = Aabb::new(Vec3A::from_array(c.lo), Vec3A::from_array(c.hi));
                    BuildPrim::new(b, leaves.id(s))
                })
                .collect();
            let sub = build_subtree(&mut build, &top_down, prims.len(), depth);
            prims.extend(build.iter().map(BuildPrim::index));
            // `sub` has its root at 0 and the rest after it; the root takes `slot`.
            let base = nodes.len() as u32;
            let place = |mut node: BvhNode| {
                if !node.is_leaf() {
                    node.first += base - 1;
                }
                node
            };
            nodes[slot] = place(sub[0]);
            nodes.extend(sub[1..].iter().map(|&node| place(node)));
            deepest = deepest.max(config.max_depth);
            continue;
        }
        let next_free = nodes.len();
        let node = &mut nodes[slot];
        node.min = m.lo;
        node.max = m.hi;
        if collapsed {
            node.first = prims.len() as u32;
            node.count = subtree.len() as u32;
            prims.extend(subtree.iter().map(|&s| leaves.id(s)));
            deepest = deepest.max(depth);
        } else {
            node.first = next_free as u32;
            node.count = 0;
            nodes.push(BvhNode::default());
            nodes.push(BvhNode::default());
            work.push((next_free + 1, m.right, depth + 1));
            work.push((next_free, m.left, depth + 1));
        }
    }
    (nodes, prims, deepest)
}
