//! Binned SAH (Wald 2007): the best of `bins - 1` candidate planes per axis, in two passes.

#[cfg(target_arch = "x86_64")]
use super::binned_avx2;
use super::exhaustive;
use super::partition::partition;
#[cfg(target_arch = "x86_64")]
use super::sorted;
use super::top_down::{BuildPrim, NodeBounds, SplitOutcome, centroid, leaf_is_cheaper};
use crate::Aabb;
use crate::bvh::config::BuildConfig;
use glam::{BVec3A, Vec3A};

/// The most bins a build may ask for (the bin arrays live on the stack).
pub const MAX_BINS: usize = 64;

// The bin arrays are sized to powers of two, which lets the binning mask its indices.
const _: () = assert!(MAX_BINS.is_power_of_two());

/// Bins the centroids on all three axes, sweeps for the cheapest plane, and partitions.
pub(super) fn split(
    prims: &mut [BuildPrim],
    node_bounds: &Aabb,
    centroid_bounds: &Aabb,
    bins: usize,
    config: &BuildConfig,
    may_stop: bool,
) -> SplitOutcome {
    // A split costs at least the traversal step, so a node whose leaf costs no more is a leaf
    // whatever the bins would say: with the default costs, pairs, a sixth of the nodes binned
    // in a million-triangle build.
    if may_stop && config.sah.intersection * prims.len() as f32 <= config.sah.traversal {
        return SplitOutcome::Leaf;
    }
    // Tiny nodes: every partition costs less to try than the bins (see `exhaustive`).
    if prims.len() <= exhaustive::MAX_PRIMS {
        return exhaustive::split(prims, node_bounds, config, may_stop);
    }
    // Corners of at most half the largest float add without overflow, which lets the binning
    // work on `lo + hi` (see `BinMap`); beyond that, the clamped centroid of `centroid`.
    let half_max = Vec3A::splat(f32::MAX / 2.0);
    let sums_finite =
        node_bounds.min.abs().cmple(half_max).all() && node_bounds.max.abs().cmple(half_max).all();
    // Small nodes: every plane, in the lanes of one register (see `sorted`).
    #[cfg(target_arch = "x86_64")]
    if sums_finite && prims.len() <= sorted::MAX_PRIMS && sorted::available() {
        return sorted::split(prims, node_bounds, config, may_stop);
    }
    // Only as many bins as there are primitives can be non-empty. Most nodes of a tree are
    // small, and clearing 3 x 64 bin boxes for each would cost more than binning its
    // primitives: the bin arrays are sized to the node.
    let bins = bins.clamp(2, MAX_BINS).min(prims.len().max(2));
    let args = (prims, node_bounds, centroid_bounds, bins, config, may_stop);
    split_sized(args, sums_finite)
}

/// The split with bin arrays sized to the node's bin count.
#[inline(always)]
fn split_sized(args: SplitArgs<'_>, sums_finite: bool) -> SplitOutcome {
    let bins = args.3;
    match (bins, sums_finite) {
        (0..=4, true) => split_with::<4, true>(args, true),
        (5..=8, true) => split_with::<8, true>(args, true),
        (9..=16, true) => split_with::<16, true>(args, true),
        (17..=32, true) => split_with::<32, true>(args, true),
        (_, true) => split_with::<MAX_BINS, true>(args, true),
        (_, false) => split_with::<MAX_BINS, false>(args, true),
    }
}

type SplitArgs<'a> = (
    &'a mut [BuildPrim],
    &'a Aabb,
    &'a Aabb,
    usize,
    &'a BuildConfig,
    bool,
);

/// Where a primitive falls among the bins: `(c - origin) * scale` for its centroid `c`.
///
/// With `SUMS` (every corner of the node at most half the largest float), this is computed as
/// `(lo + hi - 2 origin) * (scale / 2)`: three vector operations where the clamped centroid
/// takes nine, in the build's hottest loop. The two agree bit for bit, since scaling by two is
/// exact: `(lo + hi) / 2` rounds once, as `lo / 2 + hi / 2` does.
struct BinMap<const SUMS: bool> {
    origin: Vec3A,
    scale: Vec3A,
    last: Vec3A,
}

impl<const SUMS: bool> BinMap<SUMS> {
    /// The map of `bins` bins over the centroid bounds `centroids`.
    fn new(centroids: &Aabb, bins: usize) -> Self {
        let extent = centroids.extent();
        // Scale so that the largest centroid lands just inside the last bin; axes with no extent
        // get scale 0 and put everything in bin 0, where no plane can split them.
        let scale = Vec3A::select(
            extent.cmpgt(Vec3A::ZERO),
            Vec3A::splat(bins as f32 * (1.0 - 1e-6)) / extent,
            Vec3A::ZERO,
        );
        Self {
            origin: if SUMS {
                centroids.min * 2.0
            } else {
                centroids.min
            },
            scale: if SUMS { scale * 0.5 } else { scale },
            last: Vec3A::splat((bins - 1) as f32),
        }
    }

    /// The point binned for `p`: its centroid, doubled when `SUMS`.
    #[inline(always)]
    fn point(p: &BuildPrim) -> Vec3A {
        let b = p.bounds();
        if SUMS { b.min + b.max } else { centroid(&b) }
    }

    /// Lane `axis` of [`Self::point`], computed on that lane alone.
    #[inline(always)]
    fn point_on(p: &BuildPrim, axis: usize) -> f32 {
        if SUMS {
            p.corner_sum(axis)
        } else {
            p.centroid().to_array()[axis]
        }
    }

    /// The bin coordinates of a point from [`Self::point`], clamped to the bins.
    #[inline(always)]
    fn coordinates(&self, point: Vec3A) -> Vec3A {
        ((point - self.origin) * self.scale)
            .min(self.last)
            .max(Vec3A::ZERO)
    }
}

/// Nodes of at least this many primitives bin a sample of them ([`SAMPLES`]).
///
/// Why: the top levels of a large build stream every primitive through the binning once per
/// level, only to choose one of `3 (bins - 1)` planes. Binning already evaluates the cost on
/// a coarse set of planes; the counts and boxes of a thousand stratified samples estimate it
/// nearly as well on a large node: builds of triangles and of entity boxes alike get faster,
/// for an SAH cost barely higher (BENCHMARKS.md, Static BVH builds).
const SAMPLE_FROM: usize = 8192;

/// Primitives binned in a sampled node.
const SAMPLES: usize = 1024;

/// A 32-bit hash (a multiplicative one, Knuth's constant, with a final mix): the jitter of the
/// sampling.
#[inline(always)]
fn jitter_hash(k: u32) -> u32 {
    let h = k.wrapping_mul(0x9e37_79b9);
    h ^ (h >> 15)
}

/// The split, with the bins `B` wide; `sample` lets a large node bin a sample of its
/// primitives.
#[inline(always)]
fn split_with<const B: usize, const SUMS: bool>(
    (prims, node_bounds, centroid_bounds, bins, config, may_stop): SplitArgs<'_>,
    sample: bool,
) -> SplitOutcome {
    let map = BinMap::<SUMS>::new(centroid_bounds, bins);
    let n = prims.len();
    let stride = if sample && n >= SAMPLE_FROM {
        n / SAMPLES
    } else {
        1
    };
    // Where the CPU has AVX2, both passes in wide registers (see `binned_avx2`): the same
    // decision, a faster build (BENCHMARKS.md, Static BVH builds).
    #[cfg(target_arch = "x86_64")]
    let found = if SUMS && stride == 1 && (B == 8 || B == 16) && binned_avx2::available() {
        wide_plane::<B, SUMS>(prims, &map)
    } else {
        portable_plane::<B, SUMS>(prims, &map, bins, stride)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let found = portable_plane::<B, SUMS>(prims, &map, bins, stride);
    if !found.cost.is_finite() {
        // A sample can miss every primitive that a plane would separate (all its centroids
        // coincide): only the whole node can say no plane exists.
        if stride > 1 {
            let args = (prims, node_bounds, centroid_bounds, bins, config, may_stop);
            return split_with::<B, SUMS>(args, false);
        }
        return SplitOutcome::NoPositionalSplit;
    }
    let args = (prims, node_bounds, centroid_bounds, bins, config, may_stop);
    split_at_plane::<SUMS>(args, &map, &found, n / stride)
}

/// The cheapest plane the bins found: `area(L) n(L) + area(R) n(R)` over the binned
/// primitives (infinite for none), its axis and its bin (the last one on the left), and the
/// two sides' boxes: the unions of the bins on each side, exactly what a pass over each
/// child would find (a union does not depend on order).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct BinnedPlane {
    pub cost: f32,
    pub axis: usize,
    pub plane: usize,
    pub sides: [Aabb; 2],
}

/// [`binned_avx2::split_plane`] for `B` bins (8 or 16); only where it is available.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn wide_plane<const B: usize, const SUMS: bool>(
    prims: &[BuildPrim],
    map: &BinMap<SUMS>,
) -> BinnedPlane {
    let (origin, scale, last) = (map.origin, map.scale, map.last);
    if B == 8 {
        binned_avx2::split_plane::<8>(prims, origin, scale, last)
    } else {
        binned_avx2::split_plane::<16>(prims, origin, scale, last)
    }
}

/// Bins the primitives of `prims` (every `stride`-th, jittered, for a sample) into `bins`
/// bins per axis and sweeps them for the cheapest plane, one box at a time.
#[inline(always)]
fn portable_plane<const B: usize, const SUMS: bool>(
    prims: &[BuildPrim],
    map: &BinMap<SUMS>,
    bins: usize,
    stride: usize,
) -> BinnedPlane {
    let mut bin_bounds = [[Aabb::EMPTY; B]; 3];
    let mut bin_count = [[0u32; B]; 3];
    let mut bin = |p: &BuildPrim| {
        // Truncate all three coordinates at once and index plain arrays: indexing `Vec3A` by
        // a run-time axis is a `match`, which dominated this loop. The mask (`B` is a power of
        // two, the index already below `bins`) only spares the bounds checks.
        let b = bin_indices(map.coordinates(BinMap::<SUMS>::point(p)));
        let bounds = p.bounds();
        for axis in 0..3 {
            let i = b[axis] as usize & (B - 1);
            bin_bounds[axis][i] = bin_bounds[axis][i].union(&bounds);
            bin_count[axis][i] += 1;
        }
    };
    if stride == 1 {
        prims.iter().for_each(&mut bin);
    } else {
        // One primitive from each run of `stride`, at a pseudo-random place in the run
        // (jittered sampling): a fixed place would alias with periodic input orders, such as
        // a grid of objects row by row, and could sample a single column.
        for k in 0..prims.len() / stride {
            let jitter = (u64::from(jitter_hash(k as u32)) * stride as u64) >> 32;
            bin(&prims[k * stride + jitter as usize]);
        }
    }

    // For each axis, sweep right to left accumulating the right side, then left to right
    // evaluating `area(L) * n(L) + area(R) * n(R)` at each plane.
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        if map.scale[axis] == 0.0 {
            continue;
        }
        let mut right_cost = [0.0f32; B];
        let mut acc = Aabb::EMPTY;
        let mut n = 0u32;
        for i in (1..bins).rev() {
            acc = acc.union(&bin_bounds[axis][i]);
            n += bin_count[axis][i];
            right_cost[i] = if n > 0 {
                acc.half_area() * n as f32
            } else {
                f32::INFINITY
            };
        }
        let mut acc = Aabb::EMPTY;
        let mut n = 0u32;
        for i in 0..bins - 1 {
            acc = acc.union(&bin_bounds[axis][i]);
            n += bin_count[axis][i];
            // Selects, not branches: in the small nodes that most of a build's nodes are,
            // whether a plane is the best so far is a coin toss.
            let cost = match n {
                0 => f32::INFINITY,
                _ => acc.half_area() * n as f32 + right_cost[i + 1],
            };
            let better = cost < best.0;
            best.0 = if better { cost } else { best.0 };
            best.1 = if better { axis } else { best.1 };
            best.2 = if better { i } else { best.2 };
        }
    }
    let (cost, axis, plane) = best;
    let side = |bins: &[Aabb]| bins.iter().fold(Aabb::EMPTY, |acc, b| acc.union(b));
    let (left, right) = bin_bounds[axis][..bins].split_at(plane + 1);
    BinnedPlane {
        cost,
        axis,
        plane,
        sides: [side(left), side(right)],
    }
}

/// The rest of a binned split once its plane `found` is chosen (its cost finite, over the
/// `binned` primitives, fewer than the node's for a sample): the leaf verdict, the partition,
/// and the children's bounds.
#[inline(always)]
fn split_at_plane<const SUMS: bool>(
    (prims, node_bounds, centroid_bounds, _, config, may_stop): SplitArgs<'_>,
    map: &BinMap<SUMS>,
    found: &BinnedPlane,
    binned: usize,
) -> SplitOutcome {
    let (axis, plane) = (found.axis, found.plane);
    let n = prims.len();
    // A sample's counts, scaled to the node's.
    let cost = found.cost * (n as f32 / binned as f32);
    if may_stop && leaf_is_cheaper(config, n, cost, node_bounds) {
        return SplitOutcome::Leaf;
    }
    // The binning put a primitive in bin `floor(clamp(v, 0, bins - 1))` with `v` its bin
    // coordinate; it is in a bin at or left of `plane` (at most `bins - 2`) exactly when
    // `v < plane + 1`. Comparing floats skips a saturating float-to-integer conversion per
    // primitive, a few branches each.
    let (o, sc, limit) = (map.origin[axis], map.scale[axis], (plane + 1) as f32);
    let mid = partition(prims, |p| {
        (BinMap::<SUMS>::point_on(p, axis) - o) * sc < limit
    });
    debug_assert!(mid > 0 && mid < prims.len());
    // A sample's bins hold only the sampled boxes: the children get the node's box, and the
    // driver tightens it once they are built (`NodeBounds::tight`).
    let sampled = binned < n;
    let boxes = if sampled {
        [*node_bounds; 2]
    } else {
        found.sides
    };
    // The points' coordinate on `axis` at the plane, widened by a few ulps of the terms that
    // computed it so that no point classified to a side lies beyond its side's bound (one
    // that did would only be clamped into an end bin of the next level).
    let at_plane = o + limit / sc;
    let margin = (at_plane.abs() + o.abs()) * (4.0 * f32::EPSILON);
    let to_centroid = if SUMS { 0.5 } else { 1.0 };
    // `f32::min` and `max` return the other operand for NaN: a plane that overflowed bounds
    // nothing.
    let planes = [
        ((at_plane + margin) * to_centroid).min(f32::INFINITY),
        ((at_plane - margin) * to_centroid).max(f32::NEG_INFINITY),
    ];
    SplitOutcome::SplitWithBounds(
        mid,
        [0, 1].map(|s| NodeBounds {
            node: boxes[s],
            tight: !sampled,
            centroids: child_centroid_bounds(centroid_bounds, &boxes[s], axis, s == 0, planes[s]),
        }),
    )
}

/// Bounds on a child's centroids, found without a pass over them: its centroids lie in its
/// box, in the parent's centroid bounds, and on its side of the split plane (`plane`, already
/// widened outwards, infinite for no bound).
///
/// Why not the exact bounds: the partition tracked them, four vector selects and four min/max
/// per primitive and level. These bounds are never tighter, so the next level's bins are a
/// little wider: about the same SAH cost on the benchmark scenes, for a faster build
/// (BENCHMARKS.md, Static BVH builds).
/// They are conservative, so coincident centroids still find no plane that separates them
/// (their bins cannot), and the split by count still applies.
#[inline(always)]
fn child_centroid_bounds(
    parent: &Aabb,
    child_box: &Aabb,
    axis: usize,
    left: bool,
    plane: f32,
) -> Aabb {
    let on_axis = BVec3A::new(axis == 0, axis == 1, axis == 2);
    let plane = Vec3A::splat(plane);
    let side = if left {
        Aabb::new(
            Vec3A::NEG_INFINITY,
            Vec3A::select(on_axis, plane, Vec3A::INFINITY),
        )
    } else {
        Aabb::new(
            Vec3A::select(on_axis, plane, Vec3A::NEG_INFINITY),
            Vec3A::INFINITY,
        )
    };
    parent.intersection(child_box).intersection(&side)
}

/// The bins of a centroid on the three axes, from its bin coordinates (already clamped to
/// `0..=bins - 1`): truncated toward zero, as the sweep's planes assume.
///
/// One SIMD conversion for the three axes: glam's `as_uvec3` converts lane by lane with
/// Rust's saturating casts, a few instructions and branches each, in the build's hottest
/// loop.
#[inline(always)]
fn bin_indices(coordinates: Vec3A) -> [u32; 3] {
    #[cfg(target_arch = "x86_64")]
    {
        use core::arch::x86_64::{__m128, __m128i, _mm_cvttps_epi32};
        // SAFETY: SSE2 is part of the x86-64 baseline; the lanes are in `0..=bins - 1`, so the
        // conversion is exact truncation (the fourth lane is never read).
        let lanes: [i32; 4] = unsafe {
            core::mem::transmute::<__m128i, [i32; 4]>(_mm_cvttps_epi32(__m128::from(coordinates)))
        };
        [lanes[0] as u32, lanes[1] as u32, lanes[2] as u32]
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        coordinates.as_uvec3().to_array()
    }
}

#[cfg(test)]
mod tests {
    use super::super::top_down;
    use super::*;

    /// Boxes for the wide binning's checks: `n` of them, random, sometimes flat, with copies
    /// (equal centroids), on one plane of x, far from the origin, or huge (corners near a
    /// quarter of the largest float, where areas overflow to infinity).
    fn varied_node(next: &mut impl FnMut() -> f32, trial: usize, n: usize) -> Vec<Aabb> {
        let offset = if trial.is_multiple_of(7) { 1.0e6 } else { 0.0 };
        let scale = if trial.is_multiple_of(13) && offset == 0.0 {
            8.0e36
        } else {
            1.0
        };
        let flat = if trial.is_multiple_of(3) { 0.0 } else { 1.0 };
        let mut boxes: Vec<Aabb> = (0..n)
            .map(|_| {
                let c = (Vec3A::new(next(), next(), next()) * 10.0 + offset) * scale;
                let h = Vec3A::new(next(), next() * flat, next()) * scale;
                Aabb::new(c - h, c + h)
            })
            .collect();
        if trial.is_multiple_of(5) {
            for i in (1..n).step_by(2) {
                boxes[i] = boxes[i - 1];
            }
        }
        if trial.is_multiple_of(11) {
            for b in &mut boxes {
                b.min.x = -1.0;
                b.max.x = 1.0;
            }
        }
        boxes
    }

    /// The AVX2 passes choose what the portable ones choose, to the bit: the same cost, axis
    /// and plane, and the same boxes on each side, on nodes from 9 to 300 primitives with 8
    /// and 16 bins (and fewer bins than lanes, as small nodes use).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn wide_split_matches_the_portable_passes() {
        if !binned_avx2::available() {
            return;
        }
        let mut next = crate::test_floats(0x51f1_5e2d_0c4b_8a97);
        for trial in 0..3000 {
            let n = 9 + (trial * 37) % 292;
            let prims = top_down::records_of(&varied_node(&mut next, trial, n));
            let bounds = NodeBounds::of(&prims);
            for bins in [3usize, 8, 11, 16] {
                let map = BinMap::<true>::new(&bounds.centroids, bins);
                let (wide, portable) = if bins <= 8 {
                    (
                        wide_plane::<8, true>(&prims, &map),
                        portable_plane::<8, true>(&prims, &map, bins, 1),
                    )
                } else {
                    (
                        wide_plane::<16, true>(&prims, &map),
                        portable_plane::<16, true>(&prims, &map, bins, 1),
                    )
                };
                assert_eq!(
                    wide.cost.to_bits(),
                    portable.cost.to_bits(),
                    "trial {trial}, {n} prims, {bins} bins"
                );
                if portable.cost.is_finite() {
                    assert_eq!(wide, portable, "trial {trial}, {n} prims, {bins} bins");
                }
            }
        }
    }

    /// A node that may become a leaf (large leaves allowed) becomes one exactly when the SAH
    /// says so for the cheapest plane of the bins: the split's cost is over the node's
    /// primitives, whichever passes found it. (Scaling the wide passes' cost as if a sample of
    /// `bins` primitives had been binned would break this.)
    #[test]
    fn binned_leaf_verdict_follows_the_sah() {
        let mut next = crate::test_floats(0x0d6e_8fd1_4c3a_2b97);
        let config = BuildConfig {
            max_leaf_size: 64,
            ..BuildConfig::default()
        };
        let (mut leaves, mut splits) = (0, 0);
        for trial in 0..2000 {
            let n = 9 + trial % 56;
            let mut boxes = varied_node(&mut next, trial, n);
            if trial.is_multiple_of(2) {
                // Large boxes over nearby centres: no plane separates much, and the leaf wins.
                for b in &mut boxes {
                    let c = b.center();
                    *b = Aabb::new(c - 30.0, c + 30.0);
                }
            }
            let mut prims = top_down::records_of(&boxes);
            let bounds = NodeBounds::of(&prims);
            let map = BinMap::<true>::new(&bounds.centroids, 16);
            let plane = portable_plane::<16, true>(&prims, &map, 16, 1);
            let outcome = split(
                &mut prims,
                &bounds.node,
                &bounds.centroids,
                16,
                &config,
                true,
            );
            let leaf_wins = top_down::leaf_wins_by_sah(&config, n, plane.cost, &bounds.node);
            match outcome {
                SplitOutcome::Leaf => {
                    assert!(leaf_wins, "trial {trial}: a leaf where a split pays");
                    leaves += 1;
                }
                SplitOutcome::SplitWithBounds(..) | SplitOutcome::Split(_) => {
                    assert!(!leaf_wins, "trial {trial}: a split where a leaf pays");
                    splits += 1;
                }
                SplitOutcome::NoPositionalSplit => assert!(!plane.cost.is_finite()),
            }
        }
        assert!(
            leaves > 100 && splits > 100,
            "{leaves} leaves, {splits} splits"
        );
    }

    /// The children's centroid bounds, found without a pass, contain every child centroid:
    /// at every node of builds over uniform, clustered, far-from-origin and huge-coordinate
    /// boxes (the last past half the largest float, where the binning uses clamped centroids),
    /// large enough that the top splits bin a sample. It fails when a side is clipped by the
    /// other side's plane.
    #[test]
    fn child_centroid_bounds_contain_the_centroids() {
        let mut next = crate::test_floats(0x2545_f491_4f6c_dd1d);
        let config = BuildConfig::default();
        let scenes: [(f32, f32, f32); 4] = [
            (0.0, 100.0, 1.0),
            (0.0, 1.0, 0.001),
            (1.0e7, 10.0, 0.5),
            (0.0, 3.0e38, 1.0e37),
        ];
        for (offset, spread, size) in scenes {
            for n in [2usize, 3, 9, 17, 200, 3000, 20_000] {
                let mut prims: Vec<BuildPrim> = (0..n)
                    .map(|i| {
                        // Half the points in a tight cluster, so some nodes are narrow.
                        let s = if i % 2 == 0 { spread } else { spread * 1e-3 };
                        let c = Vec3A::new(next(), next(), next()) * s - s * 0.5 + offset;
                        let h = Vec3A::new(next(), next(), next()) * size;
                        BuildPrim::new(Aabb::new(c - h, c + h), i as u32)
                    })
                    .collect();
                let mut work = vec![(0, n, NodeBounds::of(&prims))];
                while let Some((start, end, bounds)) = work.pop() {
                    let node = &mut prims[start..end];
                    let outcome = split(node, &bounds.node, &bounds.centroids, 16, &config, true);
                    let SplitOutcome::SplitWithBounds(mid, children) = outcome else {
                        continue;
                    };
                    for (range, child) in [
                        (start..start + mid, &children[0]),
                        (start + mid..end, &children[1]),
                    ] {
                        for p in &prims[range.clone()] {
                            let c = p.centroid();
                            assert!(
                                c.cmpge(child.centroids.min).all()
                                    && c.cmple(child.centroids.max).all(),
                                "offset {offset}, n {n}: centroid {c} outside {:?}",
                                child.centroids
                            );
                        }
                        work.push((range.start, range.end, *child));
                    }
                }
            }
        }
    }
}
