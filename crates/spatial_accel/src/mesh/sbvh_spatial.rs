//! The spatial splits of an SBVH (Stich et al. 2009, section 4): pricing planes that cut
//! straddling references in two, and cutting them.

use super::sbvh::{Reference, sweep_bins};
use crate::Aabb;
use crate::geometry::{chopped_triangle_bounds, cut_triangle_part};
use glam::Vec3A;

/// The most bins a spatial-split build may ask for (the bin arrays live on the stack).
pub(super) const MAX_BINS: usize = 64;

/// The cheapest spatial split of a node, as the bins estimate it.
pub(super) struct SpatialSplit {
    pub axis: usize,
    pub plane: f32,
    /// `area(L) n(L) + area(R) n(R)`, with straddlers counted on both sides.
    pub cost: f32,
    pub left: Aabb,
    pub right: Aabb,
    pub left_count: usize,
    pub right_count: usize,
}

/// Bins the node's space into `bins` slabs on each axis at least `min_extent` wide, puts in
/// each slab the box of the part of every reference inside it (clipping the triangle), and
/// sweeps for the cheapest plane between slabs. A reference counts on the left of a plane
/// when it starts left of it and on the right when it ends right of it (Stich et al.'s entry
/// and exit counts), so a straddler counts on both sides.
pub(super) fn best_spatial_split(
    refs: &[Reference],
    node: &Aabb,
    corners: &impl Fn(u32) -> [Vec3A; 3],
    bins: usize,
    min_extent: Vec3A,
) -> Option<SpatialSplit> {
    let (lo, hi) = (node.min, node.max);
    let extent = hi - lo;
    let splittable: [bool; 3] =
        core::array::from_fn(|a| extent[a] > min_extent[a] && extent[a].is_finite());
    let width = extent / bins as f32;
    let plane_at = |axis: usize, j: usize| {
        if j == bins {
            hi[axis]
        } else {
            lo[axis] + j as f32 * width[axis]
        }
    };
    // Float-to-integer casts saturate: a coordinate rounded below `lo` lands in bin 0.
    let bin_of = |axis: usize, x: f32| (((x - lo[axis]) / width[axis]) as usize).min(bins - 1);
    let mut boxes = [[Aabb::EMPTY; MAX_BINS]; 3];
    let mut enter = [[0u32; MAX_BINS]; 3];
    let mut leave = [[0u32; MAX_BINS]; 3];
    let mut planes = [[0.0f32; MAX_BINS]; 3];
    // One pass for the three axes: a straddler's triangle is clipped to its box once, then
    // chopped along each axis it straddles.
    for r in refs {
        let mut spans = [(0usize, 0usize); 3];
        let mut straddles = false;
        for axis in (0..3).filter(|&a| splittable[a]) {
            let (first, last) = (
                bin_of(axis, r.bounds.min[axis]),
                bin_of(axis, r.bounds.max[axis]),
            );
            enter[axis][first] += 1;
            leave[axis][last] += 1;
            spans[axis] = (first, last);
            if first == last {
                boxes[axis][first] = boxes[axis][first].union(&r.bounds);
            } else {
                straddles = true;
                for (k, plane) in planes[axis][..last - first].iter_mut().enumerate() {
                    *plane = plane_at(axis, first + 1 + k);
                }
            }
        }
        if !straddles {
            continue;
        }
        // Only the cost is estimated here; the pieces the tree keeps are bounded
        // conservatively when the split is made (`partition_spatially`).
        let cuts: [Option<&[f32]>; 3] = core::array::from_fn(|a| {
            let (first, last) = spans[a];
            (last > first).then(|| &planes[a][..last - first])
        });
        chopped_triangle_bounds(&corners(r.triangle), &r.bounds, cuts, |axis, k, b| {
            let bin = &mut boxes[axis][spans[axis].0 + k];
            *bin = bin.union(&b);
        });
    }
    let mut best: Option<SpatialSplit> = None;
    for axis in (0..3).filter(|&a| splittable[a]) {
        let (enter, leave) = (&enter[axis][..bins], &leave[axis][..bins]);
        let Some((plane, cost, left, right)) = sweep_bins(&boxes[axis][..bins], enter, leave)
        else {
            continue;
        };
        if best.as_ref().is_none_or(|b| cost < b.cost) {
            best = Some(SpatialSplit {
                axis,
                plane: plane_at(axis, plane + 1),
                cost,
                left,
                right,
                left_count: enter[..=plane].iter().sum::<u32>() as usize,
                right_count: leave[plane + 1..].iter().sum::<u32>() as usize,
            });
        }
    }
    best
}

/// Sorts the references to the two sides of the split's plane, into `scratch`: those wholly
/// on one side go there; a straddler goes wholly to one side where that costs less than
/// cutting it (Stich et al.'s reference unsplitting, section 4.4), and otherwise is cut into
/// the pieces on either side, each bounded by clipping its triangle. Returns the sides, or
/// `None` when one came out empty (the bins' estimate and the exact sides can differ).
pub(super) fn partition_spatially<'s>(
    refs: &[Reference],
    split: &SpatialSplit,
    corners: &impl Fn(u32) -> [Vec3A; 3],
    scratch: &'s mut (Vec<Reference>, Vec<Reference>),
) -> Option<(&'s [Reference], &'s [Reference])> {
    let (left, right) = scratch;
    left.clear();
    right.clear();
    let (axis, plane) = (split.axis, split.plane);
    let (mut left_box, mut right_box) = (split.left, split.right);
    let (mut nl, mut nr) = (split.left_count as f32, split.right_count as f32);
    for r in refs {
        if r.bounds.max[axis] <= plane {
            left.push(*r);
            continue;
        }
        if r.bounds.min[axis] >= plane {
            right.push(*r);
            continue;
        }
        let cut = left_box.half_area() * nl + right_box.half_area() * nr;
        let whole_left = left_box.union(&r.bounds);
        let whole_right = right_box.union(&r.bounds);
        let cost_left = whole_left.half_area() * nl + right_box.half_area() * (nr - 1.0);
        let cost_right = left_box.half_area() * (nl - 1.0) + whole_right.half_area() * nr;
        if nr > 1.0 && cost_left <= cut && cost_left <= cost_right {
            left.push(*r);
            left_box = whole_left;
            nr -= 1.0;
            continue;
        }
        if nl > 1.0 && cost_right <= cut {
            right.push(*r);
            right_box = whole_right;
            nl -= 1.0;
            continue;
        }
        let pieces =
            cut_triangle_part(&corners(r.triangle), &r.bounds, axis, plane).map(|(_, p)| p);
        let piece = |bounds: Aabb| Reference {
            bounds,
            triangle: r.triangle,
        };
        match pieces.map(|p| !p.is_empty()) {
            [true, true] => {
                left.push(piece(pieces[0]));
                right.push(piece(pieces[1]));
            }
            [true, false] => left.push(piece(pieces[0])),
            [false, true] => right.push(piece(pieces[1])),
            // The triangle's part in the box lies on neither side only if rounding says so:
            // kept whole rather than lost.
            [false, false] => left.push(*r),
        }
    }
    (!left.is_empty() && !right.is_empty()).then_some((left.as_slice(), right.as_slice()))
}
