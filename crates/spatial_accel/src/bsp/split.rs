//! Cutting a triangle by a plane into the triangles on either side.

use super::plane::Side;
use glam::Vec3A;

/// Up to two triangles on one side of a cut (a triangle cut in three leaves one on one side
/// and two on the other).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Pieces {
    triangles: [[Vec3A; 3]; 2],
    len: usize,
}

impl Pieces {
    fn push(&mut self, corners: [Vec3A; 3]) {
        self.triangles[self.len] = corners;
        self.len += 1;
    }

    /// The triangles, in the order they were cut.
    pub(super) fn as_slice(&self) -> &[[Vec3A; 3]] {
        &self.triangles[..self.len]
    }
}

/// The two sides of a cut triangle.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Halves {
    /// The triangles in front of the plane.
    pub(super) front: Pieces,
    /// The triangles behind it.
    pub(super) back: Pieces,
}

/// Cuts the triangle `corners` whose corners lie on `sides` at signed `distances` from the
/// plane, which must straddle it (a corner in front and one behind). Every triangle keeps
/// the source's winding, so its front face stays the source's.
///
/// A corner on the plane makes two triangles through it; otherwise the corner alone on its
/// side makes one, and the other two a quadrilateral, cut along its shorter diagonal into
/// two (the better shaped pair).
pub(super) fn split_triangle(
    corners: &[Vec3A; 3],
    distances: [f64; 3],
    sides: [Side; 3],
) -> Halves {
    let mut halves = Halves::default();
    let mut put = |side: Side, corners: [Vec3A; 3]| match side {
        Side::Front => halves.front.push(corners),
        _ => halves.back.push(corners),
    };
    // Rotations keep the winding: `r(k)` is corner `(i + k) % 3` of the rotation starting
    // at `i`.
    if let Some(i) = (0..3).find(|&i| sides[i] == Side::On) {
        let (a, b, c) = (i, (i + 1) % 3, (i + 2) % 3);
        let m = crossing(corners[b], corners[c], distances[b], distances[c]);
        put(sides[b], [corners[a], corners[b], m]);
        put(sides[c], [corners[a], m, corners[c]]);
    } else {
        // The corner whose side neither other corner shares.
        let i = (0..3)
            .find(|&i| sides[(i + 1) % 3] == sides[(i + 2) % 3])
            .unwrap_or(0);
        let (a, b, c) = (i, (i + 1) % 3, (i + 2) % 3);
        let ab = crossing(corners[a], corners[b], distances[a], distances[b]);
        let ca = crossing(corners[c], corners[a], distances[c], distances[a]);
        put(sides[a], [corners[a], ab, ca]);
        // The quadrilateral ab, b, c, ca.
        let (b, c, side) = (corners[b], corners[c], sides[b]);
        if ab.distance_squared(c) <= b.distance_squared(ca) {
            put(side, [ab, b, c]);
            put(side, [ab, c, ca]);
        } else {
            put(side, [ab, b, ca]);
            put(side, [b, c, ca]);
        }
    }
    halves
}

/// Where the edge `p q` crosses the plane, given the corners' signed distances (of opposite
/// signs).
///
/// Computed from the edge's end points in one canonical order (the smaller point first,
/// by coordinates), in `f64` and rounded once: the neighbour across the edge walks it the
/// other way, and this way both get the same point, to the bit, so the cut leaves no crack
/// or T-junction gap between their pieces.
pub(super) fn crossing(p: Vec3A, q: Vec3A, dp: f64, dq: f64) -> Vec3A {
    let before = |u: Vec3A, v: Vec3A| {
        let (u, v) = (u.to_array(), v.to_array());
        (0..3)
            .map(|k| u[k].total_cmp(&v[k]))
            .find(|o| o.is_ne())
            .is_some_and(|o| o.is_lt())
    };
    let ((lo, d_lo), (hi, d_hi)) = if before(q, p) {
        ((q, dq), (p, dp))
    } else {
        ((p, dp), (q, dq))
    };
    // The distances have opposite signs beyond the tolerance, so the parameter lies well
    // inside (0, 1); the clamp only keeps a rounding from stepping past an end.
    let t = (d_lo / (d_lo - d_hi)).clamp(0.0, 1.0);
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    (lo + (hi - lo) * t).as_vec3a()
}

#[cfg(test)]
mod tests {
    use super::super::plane::{BspPlane, double_area};
    use super::*;

    fn cut(corners: [Vec3A; 3], plane: &BspPlane) -> Halves {
        let d = corners.map(|c| plane.signed_distance(c));
        split_triangle(&corners, d, d.map(|d| BspPlane::side_of(d, 1e-6)))
    }

    fn total_area(halves: &Halves) -> f64 {
        let (f, b) = (halves.front.as_slice(), halves.back.as_slice());
        f.iter().chain(b).map(double_area).sum::<f64>() / 2.0
    }

    #[test]
    fn a_cut_through_two_edges_makes_three_triangles_of_the_same_area_and_winding() {
        let corners = [
            Vec3A::ZERO,
            Vec3A::new(4.0, 0.0, 0.0),
            Vec3A::new(0.0, 4.0, 0.0),
        ];
        // x = 1: the corner at (4, 0, 0) alone in front.
        let plane = BspPlane {
            normal: glam::DVec3::X,
            offset: 1.0,
        };
        let halves = cut(corners, &plane);
        assert_eq!(
            (halves.back.as_slice().len(), halves.front.as_slice().len()),
            (2, 1)
        );
        assert!((total_area(&halves) - 8.0).abs() < 1e-9);
        let source = BspPlane::from_triangle(&corners).unwrap();
        for t in halves.front.as_slice().iter().chain(halves.back.as_slice()) {
            assert_eq!(BspPlane::from_triangle(t).unwrap().normal, source.normal);
        }
        assert!(halves.front.as_slice()[0].iter().all(|c| c.x >= 1.0));
        for t in halves.back.as_slice() {
            assert!(t.iter().all(|c| c.x <= 1.0));
        }
    }

    #[test]
    fn a_cut_through_a_corner_makes_two_triangles() {
        let corners = [
            Vec3A::ZERO,
            Vec3A::new(2.0, 0.0, 0.0),
            Vec3A::new(0.0, 2.0, 0.0),
        ];
        // x = y through the origin corner.
        let plane = BspPlane {
            normal: glam::DVec3::new(1.0, -1.0, 0.0).normalize(),
            offset: 0.0,
        };
        let halves = cut(corners, &plane);
        assert_eq!(
            (halves.back.as_slice().len(), halves.front.as_slice().len()),
            (1, 1)
        );
        assert!((total_area(&halves) - 2.0).abs() < 1e-9);
        assert_eq!(halves.front.as_slice()[0][2], Vec3A::new(1.0, 1.0, 0.0));
    }

    #[test]
    fn both_walks_of_an_edge_cross_at_the_same_point() {
        let mut next = crate::test_floats(5);
        for _ in 0..10_000 {
            let mut point = || Vec3A::new(next(), next(), next()) * 20.0 - 10.0;
            let (p, q) = (point(), point());
            let plane = BspPlane {
                normal: point().as_dvec3().normalize(),
                offset: f64::from(next()),
            };
            let (dp, dq) = (plane.signed_distance(p), plane.signed_distance(q));
            if dp * dq >= 0.0 {
                continue;
            }
            let m = crossing(p, q, dp, dq);
            assert_eq!(
                m.to_array().map(f32::to_bits),
                crossing(q, p, dq, dp).to_array().map(f32::to_bits)
            );
            assert!(plane.signed_distance(m).abs() < 1e-5, "{m} off the plane");
        }
    }
}
