//! The top-down builder: one driver, four ways to split (and the dispatch to the bottom-up
//! PLOC builder, which shares its output format).

use super::config::{BuildConfig, SplitStrategy};
use super::node::BvhNode;
use super::{ploc, split_binned, split_object, split_sweep};
use crate::Aabb;
use glam::Vec3A;

/// A primitive during the build: its box and its id, moved as one so partitions stay local in
/// memory (an index array into the boxes would cost a cache miss per access on large builds).
#[derive(Clone, Copy, Debug)]
pub(super) struct BuildPrim {
    pub bounds: Aabb,
    pub centroid: Vec3A,
    pub index: u32,
}

impl BuildPrim {
    pub(super) fn new(bounds: Aabb, index: u32) -> Self {
        Self {
            bounds,
            centroid: centroid(&bounds),
            index,
        }
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
    (nodes, prims.iter().map(|p| p.index).collect())
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

/// One node's decision: its box, and where its primitives split (`None` for a leaf).
pub(super) fn split_node(
    prims: &mut [BuildPrim],
    depth: u32,
    config: &BuildConfig,
) -> (Aabb, Option<usize>) {
    let (node_bounds, centroid_bounds) = bounds_of(prims);
    let count = prims.len();
    let outcome = if count == 1 || depth >= config.max_depth {
        SplitOutcome::Leaf
    } else {
        choose_split(prims, &node_bounds, &centroid_bounds, config)
    };
    let mid = match outcome {
        SplitOutcome::Split(mid) => Some(mid),
        // Coincident centroids: positions cannot separate them, so split by count if the
        // leaf would be too big. Halving terminates in log2(n) levels, even for a million
        // identical boxes.
        SplitOutcome::NoPositionalSplit if count > config.max_leaf_size as usize => Some(count / 2),
        SplitOutcome::NoPositionalSplit | SplitOutcome::Leaf => None,
    };
    (node_bounds, mid)
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
    let n = prims.len();
    if n == 0 {
        return Vec::new();
    }
    let mut nodes = Vec::with_capacity(2 * n - 1);
    nodes.push(BvhNode::default());
    // An explicit stack, not recursion: a depth limit of 64 is the default, but a user may ask
    // for more, and the thread's stack must not be what decides.
    let mut work = vec![(0usize, 0usize, n, depth)];
    while let Some((node, start, end, depth)) = work.pop() {
        let (node_bounds, mid) = split_node(&mut prims[start..end], depth, config);
        nodes[node].set_aabb(&node_bounds);
        match mid {
            Some(mid) => {
                debug_assert!(mid > 0 && mid < end - start);
                let left = nodes.len();
                nodes.push(BvhNode::default());
                nodes.push(BvhNode::default());
                nodes[node].first = left as u32;
                nodes[node].count = 0;
                work.push((left + 1, start + mid, end, depth + 1));
                work.push((left, start, start + mid, depth + 1));
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

/// The union of the primitives' boxes and the bounds of their centroids.
pub(super) fn bounds_of(prims: &[BuildPrim]) -> (Aabb, Aabb) {
    let mut b = Aabb::EMPTY;
    let mut c = Aabb::EMPTY;
    for p in prims {
        b = b.union(&p.bounds);
        c = c.grow(p.centroid);
    }
    (b, c)
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
