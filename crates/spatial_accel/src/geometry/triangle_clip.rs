//! The box of the part of a triangle inside a box: what spatial splits and triangle
//! pre-splitting bound their pieces by.

use crate::Aabb;
use glam::Vec3A;

/// Most vertices a triangle clipped by a box's six planes can have (three, plus one per
/// plane).
const MAX_CLIPPED_VERTICES: usize = 9;

/// A box around the part of the triangle `corners` that lies inside `region`, never smaller
/// than that part (so no ray that hits the part misses the box), and [`Aabb::EMPTY`] when the
/// triangle stays clear of `region`.
///
/// The triangle is clipped against the region's six planes (Sutherland and Hodgman 1974) and
/// the clipped polygon bounded. Points computed on an edge are off by a few ulps, which could
/// shrink the box past a piece of the triangle, or lose a sliver that just touches the region;
/// so the polygon is clipped against the region grown by a margin far above that error, its
/// box is grown by the same margin, and the result is cut back to `region` (which holds the
/// exact part by definition) and to the triangle's own box.
///
/// ```
/// use spatial_accel::{Aabb, clipped_triangle_bounds};
/// use glam::Vec3A;
/// let corners = [Vec3A::ZERO, Vec3A::new(4.0, 0.0, 0.0), Vec3A::new(0.0, 4.0, 0.0)];
/// // The left half of the region holds a trapezoid of the triangle: x in 0..2, y in 0..4.
/// let left = Aabb::new(Vec3A::splat(-10.0), Vec3A::new(2.0, 10.0, 10.0));
/// let b = clipped_triangle_bounds(&corners, &left);
/// assert!(b.contains_aabb(&Aabb::new(Vec3A::ZERO, Vec3A::new(2.0, 4.0, 0.0))));
/// assert!(b.max.x <= 2.0 && b.max.y <= 4.0);
/// // Above y = 3 only a small triangle is left, x in 0..1.
/// let top = Aabb::new(Vec3A::new(-10.0, 3.0, -10.0), Vec3A::splat(10.0));
/// assert!(clipped_triangle_bounds(&corners, &top).max.x < 1.001);
/// ```
pub fn clipped_triangle_bounds(corners: &[Vec3A; 3], region: &Aabb) -> Aabb {
    let triangle = Aabb::from_points(*corners);
    let clip = triangle.intersection(region);
    if !clip.is_finite() || clip.is_empty() {
        return Aabb::EMPTY;
    }
    let margin = clip_margin(&triangle);
    let grown = clip.expanded(Vec3A::splat(margin));
    let Some(polygon) = Polygon::clipped_to(corners, &grown) else {
        return Aabb::EMPTY;
    };
    polygon
        .bounds()
        .expanded(Vec3A::splat(margin))
        .intersection(&clip)
}

/// Cuts `region` at the plane `point[axis] = plane`: for the side below and the side above,
/// that side's region and the box of the triangle's part in it ([`clipped_triangle_bounds`],
/// empty where the triangle does not reach the side). What pre-splitting and spatial splits
/// both do to a piece of a triangle.
pub(crate) fn cut_triangle_part(
    corners: &[Vec3A; 3],
    region: &Aabb,
    axis: usize,
    plane: f32,
) -> [(Aabb, Aabb); 2] {
    let (mut below, mut above) = (*region, *region);
    below.max[axis] = plane;
    above.min[axis] = plane;
    [below, above].map(|side| (side, clipped_triangle_bounds(corners, &side)))
}

/// The boxes of the parts of the triangle `corners` inside `region` between consecutive
/// planes, on each axis given planes: `cuts[axis]` lists planes across `region` on `axis`
/// (increasing), and `piece(axis, k, box)` gets the part below `planes[0]` (`k = 0`),
/// between `planes[k - 1]` and `planes[k]`, and above the last; parts the triangle does not
/// reach are skipped.
///
/// An estimate for pricing splits, not a bound: the triangle is clipped to the region once
/// (not at all when it lies inside) and then chopped plane by plane (Stich et al.'s
/// spatial-split binning), each cut computed from the last, with no margin for rounding. A
/// triangle across `k` slabs on three axes costs one clip and `3k` cuts instead of `3k`
/// clips ([`clipped_triangle_bounds`] bounds the pieces a tree keeps).
pub(crate) fn chopped_triangle_bounds(
    corners: &[Vec3A; 3],
    region: &Aabb,
    cuts: [Option<&[f32]>; 3],
    mut piece: impl FnMut(usize, usize, Aabb),
) {
    let polygon = if region.contains_aabb(&Aabb::from_points(*corners)) {
        Polygon::triangle(corners)
    } else {
        match Polygon::clipped_to(corners, region) {
            Some(polygon) => polygon,
            None => return,
        }
    };
    let (mut below, mut above) = (Polygon::EMPTY, Polygon::EMPTY);
    for (axis, planes) in cuts.iter().enumerate() {
        let Some(planes) = planes else {
            continue;
        };
        let mut rest = polygon;
        let mut reached_the_end = true;
        for (k, &plane) in planes.iter().enumerate() {
            rest.clip_into(axis, plane, -1.0, &mut below);
            if below.len > 0 {
                piece(axis, k, below.bounds());
            }
            rest.clip_into(axis, plane, 1.0, &mut above);
            if above.len == 0 {
                reached_the_end = false;
                break;
            }
            core::mem::swap(&mut rest, &mut above);
        }
        if reached_the_end {
            piece(axis, planes.len(), rest.bounds());
        }
    }
}

/// How far a clipped point may be from where it should be, with a wide allowance: 2^-16 of
/// the triangle's largest coordinate, some 128 ulps. Clipping by up to six planes compounds a
/// few roundings per cut, far less than that.
fn clip_margin(triangle: &Aabb) -> f32 {
    let largest = triangle.min.abs().max(triangle.max.abs()).max_element();
    (largest * (1.0 / 65_536.0)).max(f32::MIN_POSITIVE)
}

/// A convex polygon: a triangle as clipping cuts it down.
///
/// Clipping writes each cut into a second polygon instead of back into the first: copied
/// back, the 144-byte vertex array went through `memmove` on every cut, a seventh of a
/// spatial-split build.
#[derive(Clone, Copy)]
struct Polygon {
    points: [Vec3A; MAX_CLIPPED_VERTICES],
    len: usize,
}

impl Polygon {
    const EMPTY: Self = Self {
        points: [Vec3A::ZERO; MAX_CLIPPED_VERTICES],
        len: 0,
    };

    /// The triangle `corners`.
    fn triangle(corners: &[Vec3A; 3]) -> Self {
        let mut polygon = Self::EMPTY;
        polygon.points[..3].copy_from_slice(corners);
        polygon.len = 3;
        polygon
    }

    /// The triangle `corners` clipped to `region`'s six planes; `None` when nothing is left.
    fn clipped_to(corners: &[Vec3A; 3], region: &Aabb) -> Option<Self> {
        let mut polygon = Self::triangle(corners);
        let mut cut = Self::EMPTY;
        for axis in 0..3 {
            polygon.clip_into(axis, region.min[axis], 1.0, &mut cut);
            cut.clip_into(axis, region.max[axis], -1.0, &mut polygon);
            if polygon.len == 0 {
                return None;
            }
        }
        Some(polygon)
    }

    /// The box around the vertices.
    fn bounds(&self) -> Aabb {
        Aabb::from_points(self.points[..self.len].iter().copied())
    }

    /// Writes to `out` the part on the side of the plane `point[axis] = plane` that `side`
    /// points to (+1: above, -1: below).
    #[inline]
    fn clip_into(&self, axis: usize, plane: f32, side: f32, out: &mut Self) {
        let inside = |p: Vec3A| (p[axis] - plane) * side >= 0.0;
        out.len = 0;
        for i in 0..self.len {
            let (a, b) = (self.points[i], self.points[(i + 1) % self.len]);
            if inside(a) {
                out.points[out.len] = a;
                out.len += 1;
            }
            if inside(a) != inside(b) && out.len < MAX_CLIPPED_VERTICES {
                // The crossing, computed from the inside end so that an edge cut twice by the
                // same plane (once in each direction) gives the same point both times.
                let (from, to) = if inside(a) { (a, b) } else { (b, a) };
                let t = (plane - from[axis]) / (to[axis] - from[axis]);
                let mut p = from + (to - from) * t;
                p[axis] = plane;
                out.points[out.len] = p;
                out.len += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn point(extent: f32) -> impl Strategy<Value = Vec3A> {
        [-extent..extent, -extent..extent, -extent..extent].prop_map(Vec3A::from_array)
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 3000, rng_seed: proptest::test_runner::RngSeed::Fixed(31), ..ProptestConfig::default() })]

        /// Every point of the triangle inside the region lies in the clipped box, and the
        /// box stays inside both the region and the triangle's box; far from the origin too.
        #[test]
        fn clipped_box_holds_every_point_of_the_part_inside(
            corners in [point(10.0), point(10.0), point(10.0)],
            region in (point(12.0), point(12.0)).prop_map(|(a, b)| Aabb::new(a.min(b), a.max(b))),
            offset in prop_oneof![Just(0.0f32), Just(1.0e5f32), Just(-3.0e6f32)],
            samples in proptest::collection::vec((0.0f32..1.0, 0.0f32..1.0), 64),
        ) {
            let shift = Vec3A::splat(offset);
            let corners = corners.map(|c| c + shift);
            let region = Aabb::new(region.min + shift, region.max + shift);
            let clipped = clipped_triangle_bounds(&corners, &region);
            let triangle = Aabb::from_points(corners);
            if !clipped.is_empty() {
                prop_assert!(region.contains_aabb(&clipped));
                prop_assert!(triangle.contains_aabb(&clipped));
            }
            // Points on the triangle (the corners, edge points and inside points), and each
            // one's check against the region done exactly as the box test does it.
            let [a, b, c] = corners;
            let mut points: Vec<Vec3A> = vec![a, b, c];
            for (u, v) in samples {
                let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
                points.push(a + (b - a) * u + (c - a) * v);
                points.push(a + (b - a) * u);
            }
            // Rounding can put a computed point an ulp outside the triangle's box; those are
            // not on the triangle.
            for p in points {
                if region.contains_point(p) && triangle.contains_point(p) {
                    prop_assert!(clipped.contains_point(p), "{p} in the region, not in {clipped:?}");
                }
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 1000, rng_seed: proptest::test_runner::RngSeed::Fixed(37), ..ProptestConfig::default() })]

        /// The chopped estimate of each slab's piece is the clipped box of that slab, up to
        /// the clipping's margin, and slabs the triangle misses get no piece.
        #[test]
        fn chopped_pieces_match_clipping_each_slab(
            corners in [point(10.0), point(10.0), point(10.0)],
            region in (point(12.0), point(12.0)).prop_map(|(a, b)| Aabb::new(a.min(b), a.max(b))),
            axis in 0usize..3,
            slabs in 1usize..9,
        ) {
            let (lo, hi) = (region.min[axis], region.max[axis]);
            let planes: Vec<f32> =
                (1..slabs).map(|k| lo + (hi - lo) * k as f32 / slabs as f32).collect();
            let mut chopped = vec![Aabb::EMPTY; slabs];
            let mut cuts = [None; 3];
            cuts[axis] = Some(planes.as_slice());
            chopped_triangle_bounds(&corners, &region, cuts, |a, k, b| {
                assert_eq!(a, axis);
                chopped[k] = b;
            });
            for (k, piece) in chopped.iter().enumerate() {
                let mut slab = region;
                if k > 0 {
                    slab.min[axis] = planes[k - 1];
                }
                if k < planes.len() {
                    slab.max[axis] = planes[k];
                }
                // The slab clipped at once, without a margin: what chopping estimates.
                let mut direct = Aabb::EMPTY;
                let mut cuts = [None; 3];
                cuts[axis] = Some(&[][..]);
                chopped_triangle_bounds(&corners, &slab, cuts, |_, _, b| direct = b);
                let margin = Vec3A::splat(1e-3);
                if piece.is_empty() {
                    // A piece the chop lost can only be a sliver within the tolerance.
                    prop_assert!(direct.is_empty() || direct.extent().min_element() < 1e-3);
                } else {
                    prop_assert!(direct.expanded(margin).contains_aabb(piece), "{k}: {piece:?} vs {direct:?}");
                    prop_assert!(piece.expanded(margin).contains_aabb(&direct), "{k}: {piece:?} vs {direct:?}");
                    // And within the conservative box of the same slab.
                    let clipped = clipped_triangle_bounds(&corners, &slab);
                    prop_assert!(clipped.expanded(margin).contains_aabb(piece));
                }
            }
        }
    }

    /// A region the triangle only touches at a corner still gets that corner's box, and one it
    /// misses gets nothing.
    #[test]
    fn touching_and_missing_regions() {
        let corners = [Vec3A::ZERO, Vec3A::X, Vec3A::Y];
        let touching = Aabb::new(Vec3A::new(1.0, -1.0, -1.0), Vec3A::new(2.0, 1.0, 1.0));
        assert!(clipped_triangle_bounds(&corners, &touching).contains_point(Vec3A::X));
        // The boxes overlap (x and y in 0.6..1), the triangle (x + y <= 1) does not.
        let missing = Aabb::new(Vec3A::new(0.6, 0.6, -1.0), Vec3A::splat(2.0));
        assert!(clipped_triangle_bounds(&corners, &missing).is_empty());
    }
}
