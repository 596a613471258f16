//! The top-down builder: one driver, four ways to split (and the dispatch to the bottom-up
//! PLOC builder, which shares its output format).

use super::{binned, lbvh, object, ploc, sweep};
use crate::Aabb;
use crate::bvh::config::{BuildConfig, SplitStrategy};
use crate::bvh::node::BvhNode;
use glam::{Vec3A, Vec4};

/// A primitive during the build: its box and its id, moved as one so partitions stay local in
/// memory (an index array into the boxes would cost a cache miss per access on large builds).
///
/// 32 bytes, the id in the fourth lane of the box's lower corner (stored as
/// [`ID_LANE_FLIP`]` ^ id`, see there). Why: the top levels of a
/// large build stream every primitive through memory once per pass (binning, partition), and
/// at a million triangles they are bound by memory bandwidth; a 64-byte record (box, stored
/// centroid, id) would move twice the bytes. The centroid is recomputed where it is
/// needed: four vector operations against a cache line.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(super) struct BuildPrim {
    /// Lower corner in x, y, z; the primitive id's bits in w.
    lo: Vec4,
    /// Upper corner in x, y, z (w unused, 1).
    hi: Vec4,
}

/// Flipped into an id before its bits go into a float lane. Why: the lane rides along through
/// the vector arithmetic of centroids and unions, and an id below 2^23 read as a float is a
/// denormal, which makes every multiply on it take a microcode assist, enough to dominate a
/// build's time. With bit 30 flipped the lane's exponent is nonzero for every id below 2^30.
const ID_LANE_FLIP: u32 = 1 << 30;

impl BuildPrim {
    pub(super) fn new(bounds: Aabb, index: u32) -> Self {
        Self {
            lo: Vec4::from((bounds.min, f32::from_bits(index ^ ID_LANE_FLIP))),
            hi: Vec4::from((bounds.max, 1.0)),
        }
    }

    /// The primitive's box.
    #[inline(always)]
    pub(super) fn bounds(&self) -> Aabb {
        Aabb {
            min: Vec3A::from_vec4(self.lo),
            max: Vec3A::from_vec4(self.hi),
        }
    }

    /// The centre of the primitive's box (see [`centroid`]).
    #[inline(always)]
    pub(super) fn centroid(&self) -> Vec3A {
        centroid(&self.bounds())
    }

    /// `lo + hi` on one axis: lane `axis` of `bounds().min + bounds().max`, the same float
    /// without the other two lanes.
    #[inline(always)]
    pub(super) fn corner_sum(&self, axis: usize) -> f32 {
        // Read through references into the record: `to_array()[axis]` copied the lower
        // corner to the stack at every call to index it (a store and a reload per primitive
        // in the partition's classification loop). The mask spares the bounds checks (the
        // axis is below 3).
        let (lo, hi): (&[f32; 4], &[f32; 4]) = (self.lo.as_ref(), self.hi.as_ref());
        lo[axis & 3] + hi[axis & 3]
    }

    /// The primitive's id.
    #[inline(always)]
    pub(super) fn index(&self) -> u32 {
        self.lo.w.to_bits() ^ ID_LANE_FLIP
    }
}

/// The centre of a valid box, always finite. Infinite boxes are valid but have no finite
/// centre; clamping the corners to the largest finite float first keeps every centroid finite,
/// so binning and Morton codes never see NaN.
#[inline]
pub(super) fn centroid(bounds: &Aabb) -> Vec3A {
    let lo = bounds
        .min
        .clamp(Vec3A::splat(-f32::MAX), Vec3A::splat(f32::MAX));
    let hi = bounds
        .max
        .clamp(Vec3A::splat(-f32::MAX), Vec3A::splat(f32::MAX));
    lo * 0.5 + hi * 0.5
}

/// What a split strategy decided for one node.
pub(super) enum SplitOutcome {
    /// Make the node a leaf (the SAH found no split worth its cost).
    Leaf,
    /// The slice was partitioned: `[..mid]` goes left, `[mid..]` right; both are non-empty.
    Split(usize),
    /// As `Split`, with the children's bounds, which the strategy found on the way (binned
    /// SAH: the node boxes from its bins, or the node's own box, flagged loose, when it binned
    /// a sample; centroid bounds from the boxes and the plane), so the children need no pass
    /// of their own to find them.
    SplitWithBounds(usize, [NodeBounds; 2]),
    /// No split by position exists (all centroids on one plane for this strategy).
    NoPositionalSplit,
}

/// Builds the flat node array and the primitive order for `bounds`.
///
/// Primitives with invalid bounds (NaN, or empty) are left out: they could never be hit, and a
/// NaN in a node box would hide its whole subtree from every query.
pub(in crate::bvh) fn build_nodes(
    bounds: &[Aabb],
    config: &BuildConfig,
) -> (Vec<BvhNode>, Vec<u32>) {
    if let SplitStrategy::Ploc {
        search_radius,
        reinsert_per_mille,
    } = config.split
    {
        return ploc::build_nodes(bounds, config, search_radius, reinsert_per_mille);
    }
    if config.split == SplitStrategy::Lbvh {
        return lbvh::build_nodes(bounds, config);
    }
    let (mut prims, root) = collect_prims(bounds);
    if prims.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let nodes = build_subtree_within(&mut prims, root, config, 0, 0);
    (nodes, prims.iter().map(BuildPrim::index).collect())
}

/// The build records of the valid boxes of `bounds`, and their bounds.
///
/// Why the bounds here: as a pass of their own, the root's box and centroid bounds read every
/// record once more; folded into the pass that writes the records, they cost next to nothing.
pub(super) fn collect_prims(bounds: &[Aabb]) -> (Vec<BuildPrim>, NodeBounds) {
    assert!(
        bounds.len() < u32::MAX as usize,
        "a BVH holds at most u32::MAX - 1 primitives"
    );
    let mut root = NodeBounds::EMPTY;
    let prims = bounds
        .iter()
        .enumerate()
        .filter(|(_, b)| b.is_valid())
        .map(|(i, b)| {
            root.include(b);
            BuildPrim::new(*b, i as u32)
        })
        .collect();
    (prims, root)
}

/// A node's box and the bounds of its primitives' centroids: what deciding its split starts
/// from.
#[derive(Clone, Copy, Debug)]
pub(super) struct NodeBounds {
    pub node: Aabb,
    pub centroids: Aabb,
    /// Whether `node` is the node's tight box. A split that binned only a sample of its
    /// primitives knows its children's boxes only as its own (see `binned`): the driver
    /// tightens those boxes from the children once the subtree is built.
    pub tight: bool,
}

impl NodeBounds {
    /// The bounds of no primitive, tight.
    const EMPTY: Self = Self {
        node: Aabb::EMPTY,
        centroids: Aabb::EMPTY,
        tight: true,
    };

    /// The bounds of `prims`, by a pass over them.
    pub(super) fn of(prims: &[BuildPrim]) -> Self {
        let mut bounds = Self::EMPTY;
        for p in prims {
            bounds.include(&p.bounds());
        }
        bounds
    }

    /// Grows the bounds by a primitive's box and its centroid.
    #[inline(always)]
    fn include(&mut self, b: &Aabb) {
        self.node = self.node.union(b);
        self.centroids = self.centroids.grow(centroid(b));
    }
}

/// One node's decision, given its bounds: where its primitives split and the two children's
/// bounds (`None` for a leaf).
pub(super) fn split_node(
    prims: &mut [BuildPrim],
    bounds: &NodeBounds,
    depth: u32,
    config: &BuildConfig,
) -> Option<(usize, [NodeBounds; 2])> {
    let count = prims.len();
    let outcome = if count == 1 || depth >= config.max_depth {
        SplitOutcome::Leaf
    } else {
        choose_split(prims, &bounds.node, &bounds.centroids, config)
    };
    let mid = match outcome {
        SplitOutcome::SplitWithBounds(mid, children) => return Some((mid, children)),
        SplitOutcome::Split(mid) => mid,
        // Coincident centroids: positions cannot separate them, so split by count if the
        // leaf would be too big. Halving terminates in log2(n) levels, even for a million
        // identical boxes.
        SplitOutcome::NoPositionalSplit if count > config.max_leaf_size as usize => count / 2,
        SplitOutcome::NoPositionalSplit | SplitOutcome::Leaf => return None,
    };
    let (left, right) = prims.split_at(mid);
    Some((mid, [NodeBounds::of(left), NodeBounds::of(right)]))
}

/// Builds the tree over `prims` with its root at index 0 of the returned array. Leaves refer to
/// primitive slots `prim_offset + i`; the root sits at `depth`. Children always follow their
/// parent in the array (refits rely on it).
pub(super) fn build_subtree(
    prims: &mut [BuildPrim],
    config: &BuildConfig,
    prim_offset: usize,
    depth: u32,
) -> Vec<BvhNode> {
    if prims.is_empty() {
        return Vec::new();
    }
    let bounds = NodeBounds::of(prims);
    build_subtree_within(prims, bounds, config, prim_offset, depth)
}

/// How many nodes a builder first reserves for `n` primitives under `config`. Where leaves
/// come out small (at most one primitive, or a primitive test costed above a node visit, as in
/// the plugin's entity tree), the tree has close to `2n - 1` nodes and that bound is reserved;
/// otherwise `n`, which holds leaves of two primitives on average, and the rare tree of smaller
/// leaves grows it.
///
/// Why not always the bound: `2n - 1` nodes is twice the size of every other buffer of a
/// build, and glibc serves a block that large by mapping fresh pages, while blocks no larger
/// than the build's other buffers come from its heap once those are freed. In a loop of
/// builds, each dropped before the next (as criterion, or a game that rebuilds, does),
/// reserving `n` spares most of a build's page faults, which are dear on a VM. It also matters
/// across builders: one builder reserving `2n - 1` slows the builds of the others later in the
/// same process. Why not always `n`: a tree that needs about `2n` grows it by a copy into a
/// block mapped afresh, which slows the build of the plugin's entity tree (one or two entities
/// a leaf) (BENCHMARKS.md, Static BVH builds). A first build in a fresh process gains nothing
/// either way.
pub(super) fn first_node_reservation(n: usize, config: &BuildConfig) -> usize {
    let small_leaves = config.max_leaf_size <= 1 || config.sah.intersection > config.sah.traversal;
    if small_leaves {
        (2 * n).saturating_sub(1)
    } else {
        n
    }
}

/// [`build_subtree`] over non-empty `prims` whose bounds the caller already has.
pub(super) fn build_subtree_within(
    prims: &mut [BuildPrim],
    bounds: NodeBounds,
    config: &BuildConfig,
    prim_offset: usize,
    depth: u32,
) -> Vec<BvhNode> {
    let n = prims.len();
    let mut nodes = Vec::with_capacity(first_node_reservation(n, config));
    nodes.push(BvhNode::default());
    // An explicit stack, not recursion: a depth limit of 64 is the default, but a user may ask
    // for more, and the thread's stack must not be what decides.
    let mut work: Vec<Pending> = Vec::new();
    let mut loose = Vec::new();
    // The left child is split next, straight from `current`; only the right one waits on the
    // stack. Why: popping the entry just pushed would read it back from memory through stores
    // of other sizes and offsets, which the CPU cannot forward to the loads; those stalls would
    // take a large share of the driver's time.
    let mut current = Pending {
        bounds,
        node: 0,
        start: 0,
        end: n,
        depth,
    };
    loop {
        let Pending {
            bounds,
            node,
            start,
            end,
            depth,
        } = current;
        nodes[node].set_aabb(&bounds.node);
        if !bounds.tight {
            loose.push(node);
        }
        match split_node(&mut prims[start..end], &bounds, depth, config) {
            Some((mid, [left_bounds, right_bounds])) => {
                debug_assert!(mid > 0 && mid < end - start);
                let left = nodes.len();
                nodes.push(BvhNode::default());
                nodes.push(BvhNode::default());
                nodes[node].first = left as u32;
                nodes[node].count = 0;
                work.push(Pending {
                    bounds: right_bounds,
                    node: left + 1,
                    start: start + mid,
                    end,
                    depth: depth + 1,
                });
                current = Pending {
                    bounds: left_bounds,
                    node: left,
                    start,
                    end: start + mid,
                    depth: depth + 1,
                };
            }
            None => {
                nodes[node].first = (prim_offset + start) as u32;
                nodes[node].count = (end - start) as u32;
                match work.pop() {
                    Some(next) => current = next,
                    None => break,
                }
            }
        }
    }
    tighten(&mut nodes, &loose, prims, prim_offset);
    nodes
}

/// A node of the top-down build waiting for its split: its bounds, its slot in the node
/// array, its primitives' range and its depth.
#[derive(Clone, Copy)]
struct Pending {
    bounds: NodeBounds,
    node: usize,
    start: usize,
    end: usize,
    depth: u32,
}

/// SAH termination: whether a leaf of `count` primitives costs no more than the split whose
/// `area(L) n(L) + area(R) n(R)` is `split_area_cost`, in a node with box `node`.
pub(super) fn leaf_is_cheaper(
    config: &BuildConfig,
    count: usize,
    split_area_cost: f32,
    node: &Aabb,
) -> bool {
    let split_cost = config.sah.traversal
        + config.sah.intersection * split_area_cost / node.half_area().max(f32::MIN_POSITIVE);
    config.sah.intersection * count as f32 <= split_cost
}

/// The box of node `i` from what it holds: its two children's boxes, or for a leaf
/// `leaf_box(first, count)`.
pub(super) fn fitted_box(
    nodes: &[BvhNode],
    i: usize,
    leaf_box: impl FnOnce(usize, usize) -> Aabb,
) -> Aabb {
    let node = nodes[i];
    let first = node.first as usize;
    if node.is_leaf() {
        leaf_box(first, node.count as usize)
    } else {
        nodes[first].aabb().union(&nodes[first + 1].aabb())
    }
}

/// Gives the nodes in `loose` (in the order they were created) their tight boxes, children
/// first: the reverse of creation order meets every child before its parent.
fn tighten(nodes: &mut [BvhNode], loose: &[usize], prims: &[BuildPrim], prim_offset: usize) {
    for &i in loose.iter().rev() {
        let b = fitted_box(nodes, i, |first, count| {
            let first = first - prim_offset;
            prims[first..first + count]
                .iter()
                .fold(Aabb::EMPTY, |acc, p| acc.union(&p.bounds()))
        });
        nodes[i].set_aabb(&b);
    }
}

fn choose_split(
    prims: &mut [BuildPrim],
    node_bounds: &Aabb,
    centroid_bounds: &Aabb,
    config: &BuildConfig,
) -> SplitOutcome {
    let count = prims.len();
    let fits_in_leaf = count <= config.max_leaf_size as usize;
    if centroid_bounds.extent().max_element() <= 0.0 {
        return SplitOutcome::NoPositionalSplit;
    }
    match config.split {
        SplitStrategy::Midpoint | SplitStrategy::Median if fits_in_leaf => SplitOutcome::Leaf,
        SplitStrategy::Midpoint => object::midpoint(prims, centroid_bounds),
        SplitStrategy::Median => object::median(prims, centroid_bounds),
        SplitStrategy::BinnedSah { .. } | SplitStrategy::SweepSah
            if fits_in_leaf && !config.sah_termination =>
        {
            SplitOutcome::Leaf
        }
        SplitStrategy::BinnedSah { bins } => binned::split(
            prims,
            node_bounds,
            centroid_bounds,
            bins as usize,
            config,
            fits_in_leaf,
        ),
        SplitStrategy::SweepSah => sweep::split(prims, node_bounds, config, fits_in_leaf),
        // PLOC and LBVH never reach the top-down driver (`build_nodes` and the parallel build
        // hand them to their own builders); should they, an object-median split keeps the
        // tree valid.
        SplitStrategy::Ploc { .. } | SplitStrategy::Lbvh if fits_in_leaf => SplitOutcome::Leaf,
        SplitStrategy::Ploc { .. } | SplitStrategy::Lbvh => object::median(prims, centroid_bounds),
    }
}

/// Build records for `boxes`, primitive `i` for box `i` (for tests).
#[cfg(test)]
pub(super) fn records_of(boxes: &[Aabb]) -> Vec<BuildPrim> {
    boxes
        .iter()
        .enumerate()
        .map(|(i, b)| BuildPrim::new(*b, i as u32))
        .collect()
}

/// The SAH's leaf verdict written out for the tests, apart from [`leaf_is_cheaper`] (which
/// the splits under test call): a leaf of `count` primitives wins when its cost is no more
/// than a traversal step plus the children's intersections, weighted by their areas
/// (`split_area_cost`) over the node's.
#[cfg(test)]
pub(super) fn leaf_wins_by_sah(
    config: &BuildConfig,
    count: usize,
    split_area_cost: f32,
    node: &Aabb,
) -> bool {
    config.sah.intersection * count as f32
        <= config.sah.traversal
            + config.sah.intersection * split_area_cost / node.half_area().max(f32::MIN_POSITIVE)
}

/// Checks shared by the small-node splits' tests: the leaf decision against `leaf_wins` (the
/// SAH's verdict for the cheapest split), and that every primitive `0..n` is still there once.
/// Returns the split's `mid`, or `None` for a (correct) leaf.
#[cfg(test)]
pub(super) fn check_small_split(
    trial: usize,
    outcome: &SplitOutcome,
    prims: &[BuildPrim],
    may_stop: bool,
    leaf_wins: bool,
) -> Option<usize> {
    let mid = match outcome {
        SplitOutcome::Split(mid) | SplitOutcome::SplitWithBounds(mid, _) => *mid,
        SplitOutcome::Leaf => {
            assert!(
                may_stop && leaf_wins,
                "trial {trial}: a leaf where a split pays"
            );
            return None;
        }
        SplitOutcome::NoPositionalSplit => panic!("trial {trial}: no split of finite boxes"),
    };
    assert!(
        !(may_stop && leaf_wins),
        "trial {trial}: a split where a leaf pays"
    );
    assert!(mid > 0 && mid < prims.len(), "trial {trial}: an empty side");
    let mut ids: Vec<u32> = prims.iter().map(BuildPrim::index).collect();
    ids.sort_unstable();
    assert!(
        ids.iter().copied().eq(0..prims.len() as u32),
        "trial {trial}: ids lost"
    );
    Some(mid)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every node's box is exactly the union of what it holds.
    fn assert_tight(nodes: &[BvhNode], order: &[u32], boxes: &[Aabb], scene: &str) {
        for (i, node) in nodes.iter().enumerate() {
            let expected = if node.is_leaf() {
                let first = node.first as usize;
                order[first..first + node.count as usize]
                    .iter()
                    .fold(Aabb::EMPTY, |acc, &p| acc.union(&boxes[p as usize]))
            } else {
                let l = node.first as usize;
                nodes[l].aabb().union(&nodes[l + 1].aabb())
            };
            assert_eq!(node.aabb(), expected, "{scene}: node {i} is not tight");
        }
    }

    /// Binned SAH splits that bin a sample hand their children the node's box; the driver
    /// tightens it afterwards. Every box of a large build, serial and parallel, is tight:
    /// uniform and clustered scenes, and a grid given row by row (a periodic order).
    #[test]
    fn node_boxes_are_tight_after_sampled_splits() {
        let mut next = crate::test_floats(0x2545_f491_4f6c_dd1d);
        let uniform: Vec<Aabb> = (0..40_000)
            .map(|_| {
                let c = Vec3A::new(next(), next(), next()) * 100.0;
                Aabb::new(c, c + Vec3A::new(next(), next(), next()))
            })
            .collect();
        let clustered: Vec<Aabb> = (0..40_000)
            .map(|i| {
                let centre = Vec3A::splat((i % 7) as f32 * 50.0);
                let c = centre + Vec3A::new(next(), next(), next());
                Aabb::new(c, c + 0.01)
            })
            .collect();
        let grid: Vec<Aabb> = (0..40_000)
            .map(|i| {
                let c = Vec3A::new((i % 64) as f32, (i / 64) as f32, 0.0);
                Aabb::new(c, c + 0.5)
            })
            .collect();
        let config = BuildConfig::default();
        for (name, boxes) in [
            ("uniform", uniform),
            ("clustered", clustered),
            ("grid", grid),
        ] {
            let (nodes, order) = build_nodes(&boxes, &config);
            assert_tight(&nodes, &order, &boxes, name);
            #[cfg(feature = "rayon")]
            {
                let (nodes, order) = super::super::parallel::build_nodes_parallel(&boxes, &config);
                assert_tight(&nodes, &order, &boxes, name);
            }
        }
    }

    /// The id survives its trip through the float lane for every bit pattern class: small ids
    /// (denormal as floats before the flip), the flip's own bit, and the largest.
    #[test]
    fn build_prim_keeps_its_id_and_box() {
        let b = Aabb::new(Vec3A::new(-1.0, 2.0, -3.0), Vec3A::new(4.0, 5.0, 6.0));
        for id in [
            0,
            1,
            7,
            (1 << 23) - 1,
            1 << 23,
            1 << 30,
            (1 << 30) + 5,
            u32::MAX - 1,
        ] {
            let p = BuildPrim::new(b, id);
            assert_eq!(p.index(), id);
            assert_eq!(p.bounds(), b);
            assert_eq!(p.centroid(), centroid(&b));
        }
    }
}
