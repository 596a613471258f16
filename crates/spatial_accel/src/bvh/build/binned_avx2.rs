//! The binned SAH split's two passes with AVX2: binning with one 256-bit `min` per bin, and
//! the sweep over the bins with every plane of an axis costed at once.
//!
//! Why: nodes of 9 to 64 primitives are most of a binned build's splits, and in them the
//! fixed costs rule: the portable sweep walks `2 (bins - 1)` planes per axis one box at a time
//! (a union, an area and a select each), more work than binning the primitives. Here a bin is
//! one 256-bit row (its lower corner, then its upper corner negated, so that one `min` grows
//! both); an axis's prefix and suffix boxes are built a row at a time and transposed into
//! planes of eight bins, whose areas and costs are then computed eight planes at a time.
//!
//! The decisions are those of the portable passes in `binned`, bit for bit: the same
//! bins (a union does not depend on order), the same areas and costs by the same operations
//! in the same order, the first least cost in the same order of axes and planes (checked by
//! `wide_split_matches_the_portable_passes` there).

use super::binned::BinnedPlane;
use super::top_down::BuildPrim;
use crate::Aabb;
use core::arch::x86_64::{
    __m256, __m256i, _CMP_EQ_OQ, _CMP_GT_OQ, _mm_add_ps, _mm_cvtsi128_si32, _mm_cvttps_epi32,
    _mm_extract_epi32, _mm_max_ps, _mm_min_ps, _mm_mul_ps, _mm_setzero_ps, _mm_sub_ps,
    _mm256_add_epi32, _mm256_add_ps, _mm256_and_ps, _mm256_blend_epi32, _mm256_blend_ps,
    _mm256_blendv_ps, _mm256_castps256_ps128, _mm256_cmp_ps, _mm256_cvtepi32_ps, _mm256_cvtss_f32,
    _mm256_extractf128_ps, _mm256_loadu_ps, _mm256_loadu_si256, _mm256_max_ps, _mm256_min_ps,
    _mm256_movemask_ps, _mm256_mul_ps, _mm256_permute2f128_ps, _mm256_permutevar8x32_epi32,
    _mm256_permutevar8x32_ps, _mm256_set1_ps, _mm256_setr_epi32, _mm256_setr_ps, _mm256_setzero_ps,
    _mm256_setzero_si256, _mm256_shuffle_ps, _mm256_storeu_ps, _mm256_sub_ps, _mm256_unpackhi_ps,
    _mm256_unpacklo_ps, _mm256_xor_ps,
};
use glam::Vec3A;

/// Whether [`split_plane`] may be called: the CPU has AVX2.
#[inline]
pub(super) fn available() -> bool {
    std::is_x86_feature_detected!("avx2")
}

/// Bins every primitive of `prims` into `B` bins per axis (8 or 16) by its corner sum
/// `lo + hi`, at bin coordinate `((lo + hi) - origin) * scale` clamped to `0..=last`, and
/// sweeps the bins for the cheapest plane (the `BinMap` with corner sums and the sweep of
/// `binned`). Only where [`available`].
pub(super) fn split_plane<const B: usize>(
    prims: &[BuildPrim],
    origin: Vec3A,
    scale: Vec3A,
    last: Vec3A,
) -> BinnedPlane {
    const { assert!(B == 8 || B == 16, "eight or sixteen bins") };
    assert!(available(), "binned_avx2 needs AVX2");
    // SAFETY: the CPU has AVX2.
    unsafe { bin_and_sweep::<B>(prims, origin, scale, last) }
}

/// Both passes in one function, so that the bins stay in its frame (returned from a function
/// of their own, they would be copied).
#[target_feature(enable = "avx2")]
fn bin_and_sweep<const B: usize>(
    prims: &[BuildPrim],
    origin: Vec3A,
    scale: Vec3A,
    last: Vec3A,
) -> BinnedPlane {
    let (rows, counts) = bin::<B>(prims, origin, scale, last);
    sweep::<B>(&rows, &counts, prims.len())
}

/// An empty bin row: `+inf` in every lane, the lower corner's and the negated upper's.
const EMPTY_ROW: f32 = f32::INFINITY;

/// The bins' rows and counts.
#[inline]
#[target_feature(enable = "avx2")]
fn bin<const B: usize>(
    prims: &[BuildPrim],
    origin: Vec3A,
    scale: Vec3A,
    last: Vec3A,
) -> ([[__m256; B]; 3], [[u32; B]; 3]) {
    let mut rows = [[_mm256_set1_ps(EMPTY_ROW); B]; 3];
    let mut counts = [[0u32; B]; 3];
    let negate_upper = _mm256_setr_ps(0.0, 0.0, 0.0, 0.0, -0.0, -0.0, -0.0, -0.0);
    let (origin, scale, last) = (origin.into(), scale.into(), last.into());
    let zero = _mm_setzero_ps();
    for p in prims {
        // SAFETY: a `BuildPrim` is eight floats, its lower corner then its upper.
        let record = unsafe { _mm256_loadu_ps((p as *const BuildPrim).cast::<f32>()) };
        let sum = _mm_add_ps(
            _mm256_castps256_ps128(record),
            _mm256_extractf128_ps::<1>(record),
        );
        let coordinates = _mm_max_ps(
            _mm_min_ps(_mm_mul_ps(_mm_sub_ps(sum, origin), scale), last),
            zero,
        );
        let bins = _mm_cvttps_epi32(coordinates);
        // The mask (`B` is a power of two, the index already below the bin count) spares the
        // bounds checks.
        let index = [
            _mm_cvtsi128_si32(bins) as usize & (B - 1),
            _mm_extract_epi32::<1>(bins) as usize & (B - 1),
            _mm_extract_epi32::<2>(bins) as usize & (B - 1),
        ];
        let row = _mm256_xor_ps(record, negate_upper);
        for axis in 0..3 {
            let i = index[axis];
            rows[axis][i] = _mm256_min_ps(rows[axis][i], row);
            counts[axis][i] += 1;
        }
    }
    (rows, counts)
}

/// Eight records of eight floats transposed, component `k` of every record in `out[k]`, for
/// the six components that hold corners: 0-2 and 4-6 (a box's lower corner then its upper, as
/// a `BuildPrim` holds them; here, a bin's lower corner then its negated upper one).
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn transpose(r: &[__m256]) -> [__m256; 6] {
    let t: [__m256; 8] = core::array::from_fn(|k| {
        let (a, b) = (r[k / 2 * 2], r[k / 2 * 2 + 1]);
        if k % 2 == 0 {
            _mm256_unpacklo_ps(a, b)
        } else {
            _mm256_unpackhi_ps(a, b)
        }
    });
    let x = [0, 4].map(|q| _mm256_shuffle_ps::<0x44>(t[q], t[q + 2]));
    let y = [0, 4].map(|q| _mm256_shuffle_ps::<0xEE>(t[q], t[q + 2]));
    let z = [1, 5].map(|q| _mm256_shuffle_ps::<0x44>(t[q], t[q + 2]));
    let lower = |v: [__m256; 2]| _mm256_permute2f128_ps::<0x20>(v[0], v[1]);
    let upper = |v: [__m256; 2]| _mm256_permute2f128_ps::<0x31>(v[0], v[1]);
    [lower(x), lower(y), lower(z), upper(x), upper(y), upper(z)]
}

/// Inclusive prefix sums of eight counts, from lane 0 up.
#[inline]
#[target_feature(enable = "avx2")]
fn prefix_sums(v: __m256i) -> __m256i {
    let zero = _mm256_setzero_si256();
    let v = _mm256_add_epi32(
        v,
        _mm256_blend_epi32::<0x01>(
            _mm256_permutevar8x32_epi32(v, _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6)),
            zero,
        ),
    );
    let v = _mm256_add_epi32(
        v,
        _mm256_blend_epi32::<0x03>(
            _mm256_permutevar8x32_epi32(v, _mm256_setr_epi32(0, 0, 0, 1, 2, 3, 4, 5)),
            zero,
        ),
    );
    _mm256_add_epi32(
        v,
        _mm256_blend_epi32::<0x0F>(
            _mm256_permutevar8x32_epi32(v, _mm256_setr_epi32(0, 0, 0, 0, 0, 1, 2, 3)),
            zero,
        ),
    )
}

/// Half the area of each lane's box from its lower corner and its negated upper corner:
/// `Aabb::half_area`'s operations in its order (the upper corner is negated back exactly).
#[inline]
#[target_feature(enable = "avx2")]
fn half_areas(b: &[__m256; 6]) -> __m256 {
    let zero = _mm256_setzero_ps();
    let sign = _mm256_set1_ps(-0.0);
    let extent = |k: usize| _mm256_max_ps(_mm256_sub_ps(_mm256_xor_ps(b[k + 3], sign), b[k]), zero);
    let (ex, ey, ez) = (extent(0), extent(1), extent(2));
    _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(ex, ey), _mm256_mul_ps(ey, ez)),
        _mm256_mul_ps(ez, ex),
    )
}

/// Every plane's cost on the bins, and the cheapest, first by axis then by plane.
#[inline]
#[target_feature(enable = "avx2")]
fn sweep<const B: usize>(rows: &[[__m256; B]; 3], counts: &[[u32; B]; 3], n: usize) -> BinnedPlane {
    let fill = _mm256_set1_ps(EMPTY_ROW);
    let inf = _mm256_set1_ps(f32::INFINITY);
    let zero = _mm256_setzero_ps();
    let total = _mm256_set1_ps(n as f32);
    let mut best = (f32::INFINITY, 0usize, 0usize);
    // The best plane's two sides, as rows: its prefix row and the next bin's suffix row.
    let mut best_sides = [fill; 2];
    for axis in 0..3 {
        // The prefix and suffix boxes, a row (both corners) at a time: one `min` per bin and
        // direction, where scans of the transposed components took six registers through
        // three shift-and-`min` steps each.
        let row = &rows[axis];
        let mut prefix_rows = [fill; B];
        let mut suffix_rows = [fill; B];
        let mut acc = fill;
        for (i, r) in row.iter().enumerate() {
            acc = _mm256_min_ps(acc, *r);
            prefix_rows[i] = acc;
        }
        acc = fill;
        for (i, r) in row.iter().enumerate().rev() {
            acc = _mm256_min_ps(acc, *r);
            suffix_rows[i] = acc;
        }
        // `B / 8` registers of eight bins.
        let mut prefix = [[zero; 6]; 2];
        let mut suffix = [[zero; 6]; 2];
        let mut left_count = [zero; 2];
        for g in 0..B / 8 {
            prefix[g] = transpose(&prefix_rows[g * 8..g * 8 + 8]);
            suffix[g] = transpose(&suffix_rows[g * 8..g * 8 + 8]);
            // SAFETY: eight counts from `g * 8` on.
            let c = unsafe { _mm256_loadu_si256(counts[axis][g * 8..].as_ptr().cast()) };
            left_count[g] = _mm256_cvtepi32_ps(prefix_sums(c));
        }
        if B == 16 {
            // The high eight bins' counts on the left include the low eight's.
            let last = _mm256_setr_epi32(7, 7, 7, 7, 7, 7, 7, 7);
            left_count[1] =
                _mm256_add_ps(left_count[1], _mm256_permutevar8x32_ps(left_count[0], last));
        }
        // Plane `i` (after bin `i`) has the suffix from bin `i + 1` on its right.
        let next = _mm256_setr_epi32(1, 2, 3, 4, 5, 6, 7, 7);
        let suffix_area = [0, 1].map(|g| {
            if g < B / 8 {
                half_areas(&suffix[g])
            } else {
                zero
            }
        });
        let mut costs = [inf; 2];
        for g in 0..B / 8 {
            let left_area = half_areas(&prefix[g]);
            let carried_in = if g + 1 < B / 8 {
                _mm256_permutevar8x32_ps(suffix_area[g + 1], _mm256_setzero_si256())
            } else {
                zero
            };
            let right_area =
                _mm256_blend_ps::<0x80>(_mm256_permutevar8x32_ps(suffix_area[g], next), carried_in);
            let right_count = _mm256_sub_ps(total, left_count[g]);
            let cost = _mm256_add_ps(
                _mm256_mul_ps(left_area, left_count[g]),
                _mm256_mul_ps(right_area, right_count),
            );
            // A plane with primitives on both sides (which also rules out every plane past
            // the last bin in use).
            let valid = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(left_count[g], zero),
                _mm256_cmp_ps::<_CMP_GT_OQ>(right_count, zero),
            );
            costs[g] = _mm256_blendv_ps(inf, cost, valid);
        }
        let m = broadcast_min(if B == 16 {
            _mm256_min_ps(costs[0], costs[1])
        } else {
            costs[0]
        });
        let least = _mm256_cvtss_f32(m);
        if least < best.0 {
            let at = |g: usize| _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(costs[g], m)) as u32;
            let mask = if B == 16 { at(0) | (at(1) << 8) } else { at(0) };
            let plane = mask.trailing_zeros() as usize;
            best = (least, axis, plane);
            // A finite cost has primitives right of the plane, so bin `plane + 1` exists.
            best_sides = [prefix_rows[plane], suffix_rows[plane + 1]];
        }
    }
    let (cost, axis, plane) = best;
    let side = |row: __m256| {
        let mut lanes = [0.0f32; 8];
        // SAFETY: eight floats into eight floats.
        unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), row) };
        Aabb {
            min: Vec3A::new(lanes[0], lanes[1], lanes[2]),
            max: -Vec3A::new(lanes[4], lanes[5], lanes[6]),
        }
    };
    BinnedPlane {
        cost,
        axis,
        plane,
        sides: best_sides.map(side),
    }
}

/// The least of eight lanes, in every lane.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) fn broadcast_min(v: __m256) -> __m256 {
    let v = _mm256_min_ps(
        v,
        _mm256_permutevar8x32_ps(v, _mm256_setr_epi32(4, 5, 6, 7, 0, 1, 2, 3)),
    );
    let v = _mm256_min_ps(
        v,
        _mm256_permutevar8x32_ps(v, _mm256_setr_epi32(2, 3, 0, 1, 6, 7, 4, 5)),
    );
    _mm256_min_ps(
        v,
        _mm256_permutevar8x32_ps(v, _mm256_setr_epi32(1, 0, 3, 2, 5, 4, 7, 6)),
    )
}
