//! Binned SAH (Wald 2007): the best of `bins - 1` candidate planes per axis, in two passes.

use super::build::{BuildPrim, SplitOutcome, partition};
use super::config::BuildConfig;
use crate::Aabb;
use glam::Vec3A;

/// The most bins a build may ask for (the bin arrays live on the stack).
pub const MAX_BINS: usize = 64;

/// Bins the centroids on all three axes, sweeps for the cheapest plane, and partitions.
pub(super) fn split(
    prims: &mut [BuildPrim],
    node_bounds: &Aabb,
    centroid_bounds: &Aabb,
    bins: usize,
    config: &BuildConfig,
    may_stop: bool,
) -> SplitOutcome {
    // Only as many bins as there are primitives can be non-empty. Most nodes of a tree are
    // small, and clearing 3 x 64 bin boxes for each would cost more than binning its
    // primitives: the bin arrays are sized to the node.
    let bins = bins.clamp(2, MAX_BINS).min(prims.len().max(2));
    let args = (prims, node_bounds, centroid_bounds, bins, config, may_stop);
    match bins {
        0..=4 => split_with::<4>(args),
        5..=8 => split_with::<8>(args),
        9..=16 => split_with::<16>(args),
        17..=32 => split_with::<32>(args),
        _ => split_with::<MAX_BINS>(args),
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

fn split_with<const B: usize>(
    (prims, node_bounds, centroid_bounds, bins, config, may_stop): SplitArgs<'_>,
) -> SplitOutcome {
    let extent = centroid_bounds.extent();
    let origin = centroid_bounds.min;
    let last = Vec3A::splat((bins - 1) as f32);
    // Scale so that the largest centroid lands just inside the last bin; axes with no extent
    // get scale 0 and put everything in bin 0, where no plane can split them.
    let scale = Vec3A::select(
        extent.cmpgt(Vec3A::ZERO),
        Vec3A::splat(bins as f32 * (1.0 - 1e-6)) / extent,
        Vec3A::ZERO,
    );
    let bin_of = |c: Vec3A| ((c - origin) * scale).min(last).max(Vec3A::ZERO);
    let mut bin_bounds = [[Aabb::EMPTY; B]; 3];
    let mut bin_count = [[0u32; B]; 3];
    for p in prims.iter() {
        // Truncate all three coordinates at once and index plain arrays: indexing `Vec3A` by
        // a run-time axis is a `match`, which dominated this loop.
        let b = bin_indices(bin_of(p.centroid));
        for axis in 0..3 {
            let i = b[axis] as usize;
            bin_bounds[axis][i] = bin_bounds[axis][i].union(&p.bounds);
            bin_count[axis][i] += 1;
        }
    }

    // For each axis, sweep right to left accumulating the right side, then left to right
    // evaluating `area(L) * n(L) + area(R) * n(R)` at each plane.
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        if scale[axis] == 0.0 {
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
            if n == 0 {
                continue;
            }
            let cost = acc.half_area() * n as f32 + right_cost[i + 1];
            if cost < best.0 {
                best = (cost, axis, i);
            }
        }
    }
    let (cost, axis, plane) = best;
    if !cost.is_finite() {
        return SplitOutcome::NoPositionalSplit;
    }
    if may_stop {
        let split_cost = config.sah.traversal
            + config.sah.intersection * cost / node_bounds.half_area().max(f32::MIN_POSITIVE);
        let leaf_cost = config.sah.intersection * prims.len() as f32;
        if leaf_cost <= split_cost {
            return SplitOutcome::Leaf;
        }
    }
    // The binning put a primitive in bin `floor(clamp(v, 0, bins - 1))` with
    // `v = (c - o) * sc`; it is in a bin at or left of `plane` (at most `bins - 2`) exactly when
    // `v < plane + 1`. Comparing floats skips a saturating float-to-integer conversion per
    // primitive, a few branches each.
    let (o, sc, limit) = (origin[axis], scale[axis], (plane + 1) as f32);
    let mid = partition(prims, |p| (p.centroid.to_array()[axis] - o) * sc < limit);
    debug_assert!(mid > 0 && mid < prims.len());
    SplitOutcome::Split(mid)
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
