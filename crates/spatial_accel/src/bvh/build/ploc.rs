//! PLOC, Parallel Locally-Ordered Clustering (Meister & Bittner 2018, "Parallel Locally-Ordered
//! Clustering for Bounding Volume Hierarchy Construction"), run on one thread.
//!
//! Bottom-up: primitives are sorted along a Morton curve ([`super::morton`]) and become the
//! first clusters. Each iteration, every cluster picks the neighbour within `radius` places on
//! the curve whose union with it has the smallest surface area; pairs that pick each other
//! merge into one cluster, which takes the left one's place. The list shrinks until one
//! cluster, the root, is left.
//!
//! Costs are known as the tree grows, so each merge also decides whether its subtree would be
//! cheaper as one leaf (the stopping rules of [`BuildConfig`]); a final top-down pass
//! ([`super::ploc_tree`]) lays the tree out in the builder's format (children after their
//! parent, leaves as contiguous ranges of the primitive order).

use super::morton::sorted_keys;
use super::ploc_search::Search;
use super::ploc_tree::{
    COLLAPSED, Collapse, Merge, SubtreeCost, collapse_moved, layout_within_depth,
};
use super::reinsert::Tree;
use crate::Aabb;
use crate::bvh::config::{BuildConfig, SplitStrategy};
use crate::bvh::node::BvhNode;

/// The largest search radius; larger requests are clamped.
pub const MAX_SEARCH_RADIUS: u32 = 64;

/// An iteration that merges fewer than one cluster in this many is stalled. Ties and NaN
/// areas can leave PLOC merging a single pair per iteration (boxes nested like onions, sorted
/// by size, chain up one at a time): quadratic time, and a tree as deep as the input is long.
/// A stalled iteration is followed by one at radius 1 and, if that stalls too, by one that
/// pairs neighbours blindly, which keeps every run at O(log n) iterations and so bounds the
/// depth. Normal input never stalls: larger radii merge fewer pairs per iteration, down to
/// about one cluster in sixteen at radius 14.
const STALL_FRACTION: usize = 32;

/// The last this many clusters search at least [`TOP_RADIUS`]. At the top of the tree a
/// handful of large clusters is left, and neighbours on the curve need not be near in space
/// (the curve jumps between distant regions): at radius 1, scenes of a few dense clusters far
/// apart pair distant clusters early, for a tree far costlier than the binned SAH one, which
/// the wider search keeps close to it. Elsewhere it changes nothing measurable.
const TOP_CLUSTERS: usize = 32;

/// See [`TOP_CLUSTERS`].
const TOP_RADIUS: u32 = 4;

/// How many boxes ahead of the one it reads the gather into curve order asks for a box.
pub(super) const GATHER_AHEAD: u32 = 32;

/// Reinsertion rounds (see [`Tree::optimize`]). On the million-triangle benchmark scene the
/// second round moves a small fraction of the nodes the first moves, and further rounds lower
/// the SAH cost by next to nothing.
const REINSERT_ROUNDS: u32 = 2;

/// A live cluster: its box, its tree node and how many primitives it holds. 32 bytes, so a
/// move is two vector copies.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
pub(super) struct Cluster {
    pub lo: [f32; 3],
    /// The cluster's tree node (see [`Merge`]).
    pub node: u32,
    pub hi: [f32; 3],
    pub prims: u32,
}

#[inline(always)]
pub(super) fn fmin(a: f32, b: f32) -> f32 {
    // The plain compare, not `f32::min`: this is one `minss`, and boxes here are never NaN.
    if a < b { a } else { b }
}

#[inline(always)]
pub(super) fn fmax(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

impl Cluster {
    pub fn leaf(b: &Aabb, slot: u32) -> Self {
        Self {
            lo: b.min.to_array(),
            node: slot,
            hi: b.max.to_array(),
            prims: 1,
        }
    }

    #[inline(always)]
    pub fn half_area(&self) -> f32 {
        let (lo, hi) = (self.lo, self.hi);
        let (dx, dy, dz) = (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
        dx * dy + dy * dz + dz * dx
    }

    /// The smallest cluster box holding both (node and count left to the caller).
    #[inline(always)]
    fn union(&self, o: &Self) -> Self {
        let (a, b) = (self, o);
        Self {
            lo: [
                fmin(a.lo[0], b.lo[0]),
                fmin(a.lo[1], b.lo[1]),
                fmin(a.lo[2], b.lo[2]),
            ],
            node: 0,
            hi: [
                fmax(a.hi[0], b.hi[0]),
                fmax(a.hi[1], b.hi[1]),
                fmax(a.hi[2], b.hi[2]),
            ],
            prims: 0,
        }
    }

    /// Half the surface area of the union of two clusters.
    #[inline(always)]
    pub fn union_area(&self, o: &Self) -> f32 {
        self.union(o).half_area()
    }
}

/// Records merges: what every pass hands its pairs to.
pub(super) struct Merger<'a> {
    merges: &'a mut Vec<Merge>,
    first_merge_id: u32,
    rule: Collapse,
    /// Each merge's subtree cost, kept when reinsertion follows (see [`collapse_moved`]).
    subtrees: Option<&'a mut Vec<SubtreeCost>>,
}

impl Merger<'_> {
    /// Merges two clusters with subtree costs `cost_a` and `cost_b`: records the merge and
    /// whether its subtree is better as one leaf; returns the new cluster and its cost.
    #[inline(always)]
    pub fn merge(&mut self, a: &Cluster, cost_a: f32, b: &Cluster, cost_b: f32) -> (Cluster, f32) {
        let prims = a.prims + b.prims;
        let m = Cluster {
            node: self.first_merge_id + self.merges.len() as u32,
            prims,
            ..a.union(b)
        };
        let (collapse, cost) = self.rule.decide(prims, m.half_area(), cost_a, cost_b);
        self.merges.push(Merge {
            lo: m.lo,
            left: a.node,
            hi: m.hi,
            right: b.node | if collapse { COLLAPSED } else { 0 },
        });
        if let Some(subtrees) = self.subtrees.as_deref_mut() {
            subtrees.push((cost, prims));
        }
        (m, cost)
    }
}

/// Builds the tree over the valid boxes of `bounds` with PLOC: the same output as
/// [`super::top_down::build_nodes`] (node 0 the root, children after their parent, leaves as
/// contiguous ranges of the returned primitive order, invalid boxes left out).
pub(super) fn build_nodes(
    bounds: &[Aabb],
    config: &BuildConfig,
    radius: u32,
    reinsert_per_mille: u32,
) -> (Vec<BvhNode>, Vec<u32>) {
    let (layout, keys) = sorted_keys(bounds);
    let n = keys.len();
    if n >= COLLAPSED as usize / 2 {
        // Node ids would reach the collapse flag: build top-down instead.
        let top_down = BuildConfig {
            split: SplitStrategy::BinnedSah { bins: 16 },
            ..*config
        };
        return super::top_down::build_nodes(bounds, &top_down);
    }
    let order: Vec<u32> = keys.iter().map(|&k| layout.id(k)).collect();
    drop(keys);
    let prims = CurveBoxes::new(bounds, &order);

    let rule = Collapse {
        max_leaf: config.max_leaf_size,
        by_sah: config.sah_termination,
        traversal: config.sah.traversal,
        intersection: config.sah.intersection,
    };
    let radius = radius.clamp(1, MAX_SEARCH_RADIUS);
    let root = (2 * n).saturating_sub(2) as u32;
    if reinsert_per_mille == 0 || n < 3 {
        let merges = cluster(prims, radius, &rule, None);
        return layout_within_depth(prims, &merges, root, config);
    }
    // Reinsertion moves nodes of the binary tree, so the collapse flags clustering decides
    // are decided again on every path a move changed.
    let mut subtrees = Vec::with_capacity(n - 1);
    let mut merges = cluster(prims, radius, &rule, Some(&mut subtrees));
    let mut tree = Tree::new(prims, &mut merges);
    let batch = (2 * n - 1) * reinsert_per_mille.min(1000) as usize / 1000;
    tree.optimize(batch, REINSERT_ROUNDS);
    let (root, moved) = tree.finish();
    collapse_moved(prims, &mut merges, &mut subtrees, &moved, root, &rule);
    layout_within_depth(prims, &merges, root, config)
}

/// Clusters and the SAH costs of their subtrees (area-weighted, not divided by the root's
/// area; collapsed where a leaf is cheaper).
#[derive(Debug, Default)]
pub(super) struct Clusters {
    pub cl: Vec<Cluster>,
    pub cost: Vec<f32>,
}

/// An iteration reads the clusters and writes the next ones in place: writes never overtake
/// reads (merged clusters take the left member's place, and slots after the one being read
/// are still unread), so one buffer serves every iteration.
impl Clusters {
    /// Copies cluster `i` to slot `to`.
    #[inline(always)]
    pub fn keep(&mut self, i: usize, to: usize) {
        self.cl[to] = self.cl[i];
        self.cost[to] = self.cost[i];
    }

    /// Merges clusters `a` and `b` into slot `to`.
    #[inline(always)]
    pub fn merge(&mut self, a: usize, b: usize, to: usize, merger: &mut Merger<'_>) {
        let (ca, cb) = (self.cl[a], self.cl[b]);
        let (c, cost) = merger.merge(&ca, self.cost[a], &cb, self.cost[b]);
        self.cl[to] = c;
        self.cost[to] = cost;
    }
}

/// The primitives' boxes in curve order, read from the caller's boxes through the sort order.
/// Clustering works in place on one gathered copy, which merges overwrite; what needs a
/// primitive's box afterwards (the layout's single-primitive leaves, the collapse and
/// reinsertion) reads it here. A second, kept copy would be 32 bytes a primitive of fresh
/// memory every build, and fresh memory is dear: each 4 KB page is a fault (BENCHMARKS.md,
/// Static BVH builds).
#[derive(Clone, Copy, Debug)]
pub(super) struct CurveBoxes<'a> {
    bounds: &'a [Aabb],
    order: &'a [u32],
}

impl<'a> CurveBoxes<'a> {
    /// The boxes `bounds[order[0]]`, `bounds[order[1]]`, ...
    pub fn new(bounds: &'a [Aabb], order: &'a [u32]) -> Self {
        Self { bounds, order }
    }

    /// How many primitives.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// The caller's index of the primitive at curve position `slot`.
    #[inline(always)]
    pub fn id(&self, slot: u32) -> u32 {
        self.order[slot as usize]
    }

    /// The primitive at curve position `slot`, as a one-primitive cluster.
    #[inline(always)]
    pub fn leaf(&self, slot: u32) -> Cluster {
        Cluster::leaf(&self.bounds[self.id(slot) as usize], slot)
    }

    /// Asks for the box of the primitive at `slot` ahead of its read.
    #[inline(always)]
    pub fn prefetch(&self, slot: u32) {
        if let Some(&id) = self.order.get(slot as usize) {
            crate::prefetch::prefetch_all(&self.bounds[id as usize]);
        }
    }
}

/// Runs the clustering over the primitives in curve order; returns the merges (the last one
/// the root; none for fewer than two primitives). Each merge's subtree cost goes to
/// `subtrees` when given.
fn cluster(
    prims: CurveBoxes<'_>,
    radius: u32,
    rule: &Collapse,
    subtrees: Option<&mut Vec<SubtreeCost>>,
) -> Vec<Merge> {
    let n = prims.len();
    let mut merges = Vec::with_capacity(n.saturating_sub(1));
    if n < 2 {
        return merges;
    }
    // The boxes are read in curve order, each at a random place: asking for the one
    // `GATHER_AHEAD` places on overlaps the cache misses, which otherwise bound the gather
    // (BENCHMARKS.md, Static BVH builds).
    let cl: Vec<Cluster> = (0..n as u32)
        .map(|slot| {
            prims.prefetch(slot + GATHER_AHEAD);
            prims.leaf(slot)
        })
        .collect();
    let cost = cl
        .iter()
        .map(|c| rule.intersection * c.half_area())
        .collect();
    let mut cur = Clusters { cl, cost };
    let mut merger = Merger {
        merges: &mut merges,
        first_merge_id: n as u32,
        rule: *rule,
        subtrees,
    };
    let mut driver = Driver {
        radius,
        search: Search::new(if radius > 1 { n } else { TOP_CLUSTERS }),
        fallback: 0,
    };
    while cur.cl.len() > 1 {
        let next = driver.step(&mut cur, &mut merger);
        cur.cl.truncate(next);
        cur.cost.truncate(next);
    }
    merges
}

/// Chooses each iteration's pass.
struct Driver {
    radius: u32,
    search: Search,
    /// 0: the configured radius; 1: radius 1 after a stalled iteration; 2: blind pairing
    /// after a stalled radius-1 iteration.
    fallback: u8,
}

impl Driver {
    /// Runs one iteration; returns the number of clusters left.
    fn step(&mut self, cur: &mut Clusters, merger: &mut Merger<'_>) -> usize {
        let count = cur.cl.len();
        let radius = match count {
            ..=TOP_CLUSTERS => self.radius.max(TOP_RADIUS),
            _ => self.radius,
        };
        let next = match (self.fallback, radius) {
            (2.., _) => pair_blindly(cur, merger),
            (1, _) | (_, 1) => pass_radius_one(cur, merger),
            _ => {
                self.search.find(&cur.cl, radius as usize);
                self.search.merge_mutual(cur, merger)
            }
        };
        let stalled = (count - next) * STALL_FRACTION < count;
        self.fallback = match (stalled, self.fallback) {
            (false, _) => 0,
            (true, 0) if radius > 1 => 1,
            (true, _) => 2,
        };
        next
    }
}

/// The radius-1 iteration: cluster `i` picks `i + 1` when the union to the right is smaller
/// than the one to the left, so a pair merges when its union is a local minimum of the
/// sequence of adjacent unions, which one scan finds. Returns the number of clusters left.
fn pass_radius_one(cur: &mut Clusters, merger: &mut Merger<'_>) -> usize {
    let count = cur.cl.len();
    let area = |cur: &Clusters, i: usize| match cur.cl.get(i..i + 2) {
        Some([a, b]) => a.union_area(b),
        _ => f32::INFINITY,
    };
    // Ties go to the pair whose left member has an even slot (the tie rule of `Search`, at
    // distance 1): a run of equal unions (a grid of identical boxes) then merges as
    // (0, 1), (2, 3), ... instead of one pair per iteration.
    let mut i = 0;
    let mut to = 0;
    let mut left = f32::INFINITY;
    let mut here = area(cur, 0);
    while i + 1 < count {
        // Read before the write below: `to <= i`, and slot `i + 2` is still unread.
        let right = area(cur, i + 1);
        let even = i % 2 == 0;
        let i_picks_right = here < left || (here == left && even);
        let next_picks_left = here < right || (here == right && even);
        if i_picks_right && next_picks_left {
            cur.merge(i, i + 1, to, merger);
            left = right;
            i += 2;
            here = area(cur, i);
        } else {
            cur.keep(i, to);
            left = here;
            here = right;
            i += 1;
        }
        to += 1;
    }
    if i < count {
        cur.keep(i, to);
        to += 1;
    }
    to
}

/// The stall guard's last resort: merges slots (0, 1), (2, 3), ... whatever their areas.
fn pair_blindly(cur: &mut Clusters, merger: &mut Merger<'_>) -> usize {
    let count = cur.cl.len();
    for to in 0..count / 2 {
        cur.merge(2 * to, 2 * to + 1, to, merger);
    }
    if count % 2 == 1 {
        cur.keep(count - 1, count / 2);
    }
    count.div_ceil(2)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use glam::Vec3A;

    pub(in crate::bvh::build) fn clusters_of(boxes: &[Aabb]) -> Clusters {
        let cl: Vec<Cluster> = (0..boxes.len())
            .map(|i| Cluster::leaf(&boxes[i], i as u32))
            .collect();
        let cost = cl.iter().map(Cluster::half_area).collect();
        Clusters { cl, cost }
    }

    const RULE: Collapse = Collapse {
        max_leaf: 1,
        by_sah: false,
        traversal: 1.0,
        intersection: 1.0,
    };

    /// Boxes on a coarse grid of sizes, so that equal union areas are frequent.
    pub(in crate::bvh::build) fn coarse_boxes(n: usize, seed: u32) -> Vec<Aabb> {
        let mut state = seed;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 28) as f32
        };
        (0..n)
            .map(|_| {
                let p = Vec3A::new(next(), next(), next());
                Aabb::new(p, p + Vec3A::new(next(), 1.0, 2.0))
            })
            .collect()
    }

    /// The general search at radius 1 and the one-scan radius-1 pass merge the same pairs,
    /// ties included.
    #[test]
    fn radius_one_scan_agrees_with_the_search() {
        for n in [2, 3, 4, 5, 50, 1_000] {
            let mut a = clusters_of(&coarse_boxes(n, 7));
            let mut b = clusters_of(&coarse_boxes(n, 7));
            let (mut ma, mut mb) = (Vec::new(), Vec::new());
            let mut merger = Merger {
                merges: &mut ma,
                first_merge_id: n as u32,
                rule: RULE,
                subtrees: None,
            };
            let left_a = pass_radius_one(&mut a, &mut merger);
            let mut search = Search::new(n);
            search.find(&b.cl, 1);
            let mut merger = Merger {
                merges: &mut mb,
                first_merge_id: n as u32,
                rule: RULE,
                subtrees: None,
            };
            let left_b = search.merge_mutual(&mut b, &mut merger);
            let nodes =
                |c: &Clusters, k: usize| c.cl[..k].iter().map(|c| c.node).collect::<Vec<_>>();
            assert_eq!(nodes(&a, left_a), nodes(&b, left_b), "n {n}");
            assert!(left_a < n, "n {n}: no merge");
        }
    }

    /// After reinsertion, deciding the collapse only on the moved paths sets every merge's
    /// flag as deciding it over the whole tree does.
    #[test]
    fn collapse_of_moved_paths_equals_a_full_pass() {
        // Small boxes along a line (so the identity order is a good curve order) and every
        // fiftieth one large: what reinsertion lifts.
        let mut next = crate::test_floats(5);
        let boxes: Vec<Aabb> = (0..3_000)
            .map(|i| {
                let c = Vec3A::new(i as f32 * 0.1, next(), next());
                let half = if i % 50 == 0 { 20.0 } else { 0.2 } * (next() + 0.1);
                Aabb::from_center_half_extents(c, Vec3A::splat(half))
            })
            .collect();
        let order: Vec<u32> = (0..boxes.len() as u32).collect();
        let rule = Collapse {
            max_leaf: 8,
            by_sah: true,
            traversal: 2.0,
            intersection: 1.0,
        };
        let mut subtrees = Vec::new();
        let prims = CurveBoxes::new(&boxes, &order);
        let mut merges = cluster(prims, 1, &rule, Some(&mut subtrees));
        let mut tree = Tree::new(prims, &mut merges);
        tree.optimize(300, REINSERT_ROUNDS);
        let (root, moved) = tree.finish();
        assert!(moved.iter().any(|&m| m) && !moved.iter().all(|&m| m));
        collapse_moved(prims, &mut merges, &mut subtrees, &moved, root, &rule);
        let n = prims.len();
        // The full pass: every merge decided again, children first.
        fn decide(
            id: u32,
            n: usize,
            leaves: CurveBoxes<'_>,
            merges: &[Merge],
            rule: &Collapse,
            out: &mut Vec<bool>,
        ) -> (f32, u32) {
            let Some(m) = (id as usize).checked_sub(n) else {
                return (rule.intersection * leaves.leaf(id).half_area(), 1);
            };
            let merge = merges[m];
            let (cl, pl) = decide(merge.left, n, leaves, merges, rule, out);
            let (cr, pr) = decide(merge.right & !COLLAPSED, n, leaves, merges, rule, out);
            let (flag, cost) = rule.decide(pl + pr, merge.half_area(), cl, cr);
            out[m] = flag;
            (cost, pl + pr)
        }
        let mut want = vec![false; merges.len()];
        decide(root, n, prims, &merges, &rule, &mut want);
        let got: Vec<bool> = merges.iter().map(|m| m.right & COLLAPSED != 0).collect();
        assert_eq!(got, want);
    }

    #[test]
    fn identical_boxes_halve_every_iteration() {
        let boxes = vec![Aabb::from_point(Vec3A::ONE); 1024];
        for radius in [1, 2, 5] {
            let order: Vec<u32> = (0..1024).collect();
            let prims = CurveBoxes::new(&boxes, &order);
            let merges = cluster(prims, radius, &RULE, None);
            assert_eq!(merges.len(), 1023);
            let config = BuildConfig::default();
            let (nodes, primitive_indices) = layout_within_depth(prims, &merges, 2046, &config);
            let bvh = crate::Bvh {
                nodes,
                primitive_indices,
            };
            let s = crate::bvh::stats::tree_stats(&bvh, &Default::default());
            assert_eq!(s.max_depth, 10, "radius {radius}");
        }
    }
}
