//! The top-down builder: one driver, four ways to split (and the dispatch to the bottom-up
//! PLOC builder, which shares its output format).

use super::config::{BuildConfig, SplitStrategy};
use super::node::BvhNode;
use super::{ploc, split_binned, split_object, split_sweep};
use crate::Aabb;
use glam::{Vec3A, Vec4};

/// A primitive during the build: its box and its id, moved as one so partitions stay local in
/// memory (an index array into the boxes would cost a cache miss per access on large builds).
///
/// 32 bytes, the id in the fourth lane of the box's lower corner (stored as
/// [`ID_LANE_FLIP`]` ^ id`, see there). Why: the top levels of a
/// large build stream every primitive through memory once per pass (binning, partition), and
/// at a million triangles they are bound by memory bandwidth; the 64-byte record this replaced
/// (box, stored centroid, id) moved twice the bytes. The centroid is recomputed where it is
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
/// denormal, which makes every multiply on it take a microcode assist: the first version of
/// this record built 6x slower. With bit 30 flipped the lane's exponent is nonzero for every
/// id below 2^30.
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
    /// SAH: the node boxes from its bins, the centroid bounds from its partition), so the
    /// children need no pass of their own to find them.
    SplitWithBounds(usize, [NodeBounds; 2]),
    /// No split by position exists (all centroids on one plane for this strategy).
    NoPositionalSplit,
}

/// Builds the flat node array and the primitive order for `bounds`.
///
/// Primitives with invalid bounds (NaN, or empty) are left out: they could never be hit, and a
/// NaN in a node box would hide its whole subtree from every query.
pub(super) fn build_nodes(bounds: &[Aabb], config: &BuildConfig) -> (Vec<BvhNode>, Vec<u32>) {
    if let SplitStrategy::Ploc {
        search_radius,
        reinsert_per_mille,
    } = config.split
    {
        return ploc::build_nodes(bounds, config, search_radius, reinsert_per_mille);
    }
    let mut prims = collect_prims(bounds);
    let nodes = build_subtree(&mut prims, config, 0, 0);
    (nodes, prims.iter().map(BuildPrim::index).collect())
}

pub(super) fn collect_prims(bounds: &[Aabb]) -> Vec<BuildPrim> {
    assert!(
        bounds.len() < u32::MAX as usize,
        "a BVH holds at most u32::MAX - 1 primitives"
    );
    bounds
        .iter()
        .enumerate()
        .filter(|(_, b)| b.is_valid())
        .map(|(i, b)| BuildPrim::new(*b, i as u32))
        .collect()
}

/// A node's box and the bounds of its primitives' centroids: what deciding its split starts
/// from.
#[derive(Clone, Copy, Debug)]
pub(super) struct NodeBounds {
    pub node: Aabb,
    pub centroids: Aabb,
}

impl NodeBounds {
    /// The bounds of `prims`, by a pass over them.
    pub(super) fn of(prims: &[BuildPrim]) -> Self {
        let mut node = Aabb::EMPTY;
        let mut centroids = Aabb::EMPTY;
        for p in prims {
            let b = p.bounds();
            node = node.union(&b);
            centroids = centroids.grow(centroid(&b));
        }
        Self { node, centroids }
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

/// [`build_subtree`] over non-empty `prims` whose bounds the caller already has.
pub(super) fn build_subtree_within(
    prims: &mut [BuildPrim],
    bounds: NodeBounds,
    config: &BuildConfig,
    prim_offset: usize,
    depth: u32,
) -> Vec<BvhNode> {
    let n = prims.len();
    let mut nodes = Vec::with_capacity(2 * n - 1);
    nodes.push(BvhNode::default());
    // An explicit stack, not recursion: a depth limit of 64 is the default, but a user may ask
    // for more, and the thread's stack must not be what decides.
    let mut work = vec![(0usize, 0usize, n, depth, bounds)];
    while let Some((node, start, end, depth, bounds)) = work.pop() {
        nodes[node].set_aabb(&bounds.node);
        match split_node(&mut prims[start..end], &bounds, depth, config) {
            Some((mid, [left_bounds, right_bounds])) => {
                debug_assert!(mid > 0 && mid < end - start);
                let left = nodes.len();
                nodes.push(BvhNode::default());
                nodes.push(BvhNode::default());
                nodes[node].first = left as u32;
                nodes[node].count = 0;
                work.push((left + 1, start + mid, end, depth + 1, right_bounds));
                work.push((left, start, start + mid, depth + 1, left_bounds));
            }
            None => {
                nodes[node].first = (prim_offset + start) as u32;
                nodes[node].count = (end - start) as u32;
            }
        }
    }
    nodes
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
        SplitStrategy::Midpoint => split_object::midpoint(prims, centroid_bounds),
        SplitStrategy::Median => split_object::median(prims, centroid_bounds),
        SplitStrategy::BinnedSah { .. } | SplitStrategy::SweepSah
            if fits_in_leaf && !config.sah_termination =>
        {
            SplitOutcome::Leaf
        }
        SplitStrategy::BinnedSah { bins } => split_binned::split(
            prims,
            node_bounds,
            centroid_bounds,
            bins as usize,
            config,
            fits_in_leaf,
        ),
        SplitStrategy::SweepSah => split_sweep::split(prims, node_bounds, config, fits_in_leaf),
        // PLOC builds bottom-up and never reaches the top-down driver (`build_nodes` and the
        // parallel build hand it to `ploc`); should it, an object-median split keeps the tree
        // valid.
        SplitStrategy::Ploc { .. } if fits_in_leaf => SplitOutcome::Leaf,
        SplitStrategy::Ploc { .. } => split_object::median(prims, centroid_bounds),
    }
}

/// Partitions in place so that the primitives for which `left` holds come first; returns how
/// many did.
///
/// Hoare's scheme: both ends scan inwards and only misplaced pairs are swapped, each
/// primitive tested once (the first version swapped every right-side primitive met from the
/// left end, whether or not the one it swapped with belonged on the right too). On this
/// machine the difference in build time is inside the run-to-run noise (about 20%).
pub(super) fn partition(
    prims: &mut [BuildPrim],
    mut left: impl FnMut(&BuildPrim) -> bool,
) -> usize {
    let mut i = 0;
    let mut j = prims.len();
    loop {
        while i < j && left(&prims[i]) {
            i += 1;
        }
        while i < j && !left(&prims[j - 1]) {
            j -= 1;
        }
        if i + 1 >= j {
            // `i == j`: done. `i + 1 == j`: the one primitive between the scans failed the
            // first test and passed the second; predicates are pure, so this cannot happen,
            // but the bound keeps a misbehaving one from swapping out of range.
            return i;
        }
        prims.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

/// Elements classified at a time by each end of [`partition_by_centroid`] (offsets fit a
/// byte).
const PARTITION_BLOCK: usize = 64;

/// [`partition`] by a test on a point of each primitive (`point`: its centroid, or a
/// multiple), returning with the split the bounds of the points on each side: a partition
/// reads every primitive anyway, so the children's centroid bounds cost no pass of their own.
///
/// Block partitioning (Edelkamp & Weiss 2016, "BlockQuicksort"): each end classifies a block
/// of elements without branching, recording the offsets of the misplaced ones, then the two
/// lists are swapped pairwise. Why: Hoare's loop branches on every element's side, and deep in
/// a build, where boxes are scattered, that branch is a coin toss.
pub(super) fn partition_by_centroid(
    prims: &mut [BuildPrim],
    point: impl Fn(&BuildPrim) -> Vec3A,
    left: impl Fn(Vec3A) -> bool,
) -> (usize, [Aabb; 2]) {
    let mut sides = SideBounds::default();
    let (mut l, mut r) = (0usize, prims.len());
    let mut misplaced_l = [0u8; PARTITION_BLOCK];
    let mut misplaced_r = [0u8; PARTITION_BLOCK];
    let (mut start_l, mut count_l, mut start_r, mut count_r) = (0, 0, 0, 0);
    // Every element left of `l` goes left, every one from `r` on goes right.
    while r - l >= 2 * PARTITION_BLOCK {
        if count_l == 0 {
            start_l = 0;
            for (i, p) in prims[l..l + PARTITION_BLOCK].iter().enumerate() {
                let c = point(p);
                let goes_left = left(c);
                sides.add(c, goes_left);
                misplaced_l[count_l] = i as u8;
                count_l += usize::from(!goes_left);
            }
        }
        if count_r == 0 {
            start_r = 0;
            for (i, p) in prims[r - PARTITION_BLOCK..r].iter().rev().enumerate() {
                let c = point(p);
                let goes_left = left(c);
                sides.add(c, goes_left);
                misplaced_r[count_r] = i as u8;
                count_r += usize::from(goes_left);
            }
        }
        let swaps = count_l.min(count_r);
        for k in 0..swaps {
            let i = l + misplaced_l[start_l + k] as usize;
            let j = r - 1 - misplaced_r[start_r + k] as usize;
            prims.swap(i, j);
        }
        (count_l, count_r) = (count_l - swaps, count_r - swaps);
        (start_l, start_r) = (start_l + swaps, start_r + swaps);
        if count_l == 0 {
            l += PARTITION_BLOCK;
        }
        if count_r == 0 {
            r -= PARTITION_BLOCK;
        }
    }
    // The rest, including a block whose misplaced elements are still waiting, by Hoare's
    // loop. It classifies some elements a second time; adding a point to its side's bounds
    // twice changes nothing.
    let (mid, rest) = partition_scalar(&mut prims[l..r], &point, &left);
    let [left_bounds, right_bounds] = sides.bounds();
    (
        l + mid,
        [left_bounds.union(&rest[0]), right_bounds.union(&rest[1])],
    )
}

/// The bounds of the points sent to each side, kept without branching on the side.
struct SideBounds {
    left_min: Vec3A,
    left_max: Vec3A,
    right_min: Vec3A,
    right_max: Vec3A,
}

impl Default for SideBounds {
    fn default() -> Self {
        Self {
            left_min: Vec3A::INFINITY,
            left_max: Vec3A::NEG_INFINITY,
            right_min: Vec3A::INFINITY,
            right_max: Vec3A::NEG_INFINITY,
        }
    }
}

impl SideBounds {
    #[inline(always)]
    fn add(&mut self, c: Vec3A, goes_left: bool) {
        let to_left = glam::BVec3A::splat(goes_left);
        let inf = Vec3A::INFINITY;
        self.left_min = self.left_min.min(Vec3A::select(to_left, c, inf));
        self.left_max = self.left_max.max(Vec3A::select(to_left, c, -inf));
        self.right_min = self.right_min.min(Vec3A::select(to_left, inf, c));
        self.right_max = self.right_max.max(Vec3A::select(to_left, -inf, c));
    }

    fn bounds(&self) -> [Aabb; 2] {
        [
            Aabb {
                min: self.left_min,
                max: self.left_max,
            },
            Aabb {
                min: self.right_min,
                max: self.right_max,
            },
        ]
    }
}

/// Hoare's partition with the bounds of each side's points: the tail of
/// [`partition_by_centroid`].
fn partition_scalar(
    prims: &mut [BuildPrim],
    point: impl Fn(&BuildPrim) -> Vec3A,
    left: impl Fn(Vec3A) -> bool,
) -> (usize, [Aabb; 2]) {
    let mut bounds = [Aabb::EMPTY; 2];
    let mut i = 0;
    let mut j = prims.len();
    loop {
        while i < j {
            let c = point(&prims[i]);
            if !left(c) {
                break;
            }
            bounds[0] = bounds[0].grow(c);
            i += 1;
        }
        while i < j {
            let c = point(&prims[j - 1]);
            if left(c) {
                break;
            }
            bounds[1] = bounds[1].grow(c);
            j -= 1;
        }
        if i + 1 >= j {
            return (i, bounds);
        }
        // `prims[i]` belongs right and `prims[j - 1]` left: swapped, each joins its side.
        bounds[0] = bounds[0].grow(point(&prims[j - 1]));
        bounds[1] = bounds[1].grow(point(&prims[i]));
        prims.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    /// The block partition against a plain filter: every primitive on its side, none lost or
    /// repeated, and each side's centroid bounds those of its primitives, at sizes around the
    /// block length (where the block loop hands over to the scalar tail) and with skewed
    /// sides.
    #[test]
    fn block_partition_matches_a_filter() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let b = PARTITION_BLOCK;
        for n in [
            0,
            1,
            2,
            3,
            b - 1,
            b,
            b + 1,
            2 * b - 1,
            2 * b,
            2 * b + 1,
            5 * b + 7,
            3000,
        ] {
            for threshold in [0.0, 0.05, 0.5, 0.95, 1.0] {
                let mut prims: Vec<BuildPrim> = (0..n)
                    .map(|i| {
                        let c = Vec3A::new(next(), next(), next());
                        BuildPrim::new(Aabb::new(c, c + 0.01), i as u32)
                    })
                    .collect();
                let goes_left = |c: Vec3A| c.x < threshold;
                let expected_left = prims.iter().filter(|p| goes_left(p.centroid())).count();
                let (mid, bounds) =
                    partition_by_centroid(&mut prims, BuildPrim::centroid, goes_left);
                assert_eq!(mid, expected_left, "n {n}, threshold {threshold}");
                let mut ids: Vec<u32> = prims.iter().map(BuildPrim::index).collect();
                ids.sort_unstable();
                assert!(
                    ids.iter().copied().eq(0..n as u32),
                    "n {n}: ids lost or repeated"
                );
                for (side, range) in [(0, 0..mid), (1, mid..n)] {
                    let mut want = Aabb::EMPTY;
                    for p in &prims[range] {
                        assert_eq!(goes_left(p.centroid()), side == 0, "n {n}");
                        want = want.grow(p.centroid());
                    }
                    assert_eq!(bounds[side].min, want.min, "n {n}, side {side}");
                    assert_eq!(bounds[side].max, want.max, "n {n}, side {side}");
                }
            }
        }
    }
}
