//! Splitting planes: the plane of a triangle, and which side of it a point lies on.

use glam::{DVec3, Vec3A};

/// The classification tolerance, relative to the mesh's scale: a point within
/// `RELATIVE_TOLERANCE * scale` of a plane is on it.
///
/// The scale is the largest absolute coordinate of the mesh's finite vertices (see
/// [`tolerance_for_scale`]), because rounding grows with a coordinate's magnitude, not with
/// the mesh's size: a split point rounded to `f32` is off the exact cut by up to half an ulp
/// per coordinate, which is at most `2^-24` of the scale. `2^-19` is 32 times that, so a piece cut from a triangle stays on its source's plane and a split point
/// classifies as on the plane that made it; and it is far below any feature a mesh in
/// `f32` can resolve.
pub const RELATIVE_TOLERANCE: f64 = 1.0 / (1u32 << 19) as f64;

/// The absolute tolerance for a mesh whose largest absolute coordinate is `scale`; never
/// zero, so a mesh at the origin still has one.
pub fn tolerance_for_scale(scale: f64) -> f64 {
    let scale = if scale.is_finite() { scale } else { 0.0 };
    (scale * RELATIVE_TOLERANCE).max(f64::from(f32::MIN_POSITIVE))
}

/// Where a point lies with respect to a plane, with the tolerance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Side {
    /// More than the tolerance behind the plane (against its normal).
    Back,
    /// Within the tolerance of the plane.
    On,
    /// More than the tolerance in front of the plane (along its normal).
    Front,
}

/// A plane `normal . p = offset` in `f64`, the normal of unit length.
///
/// Double precision because the distances it gives decide the sides: a point is classified
/// from its own `f32` coordinates alone, so every triangle sharing a vertex sees that vertex
/// on the same side, and the `f64` arithmetic keeps the distance's own error far below the
/// tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BspPlane {
    /// Unit normal; the front side is where it points.
    pub normal: DVec3,
    /// The signed distance of the plane from the origin along the normal.
    pub offset: f64,
}

impl BspPlane {
    /// The stand-in for a triangle without a plane: every point is on it, so a node cut by it
    /// would keep all its triangles and end there.
    pub const EVERYWHERE: Self = Self {
        normal: DVec3::ZERO,
        offset: 0.0,
    };

    /// The plane of a triangle, its normal on the front (counter-clockwise) side; `None` when
    /// a corner is not finite or the corners are collinear.
    pub fn from_triangle(corners: &[Vec3A; 3]) -> Option<Self> {
        let [a, b, c] = corners.map(|v| v.as_dvec3());
        // The differences of f32 coordinates are exact in f64, so only the cross product
        // rounds.
        let n = (b - a).cross(c - a);
        let length = n.length();
        if !(length > 0.0 && length.is_finite()) {
            return None;
        }
        let normal = n / length;
        // The mean of the three corners' offsets: each is on the plane, and averaging spreads
        // the rounding of the normal evenly over them.
        let offset = (normal.dot(a) + normal.dot(b) + normal.dot(c)) / 3.0;
        Some(Self { normal, offset })
    }

    /// The signed distance of a point (positive in front); NaN for a NaN point.
    #[inline]
    pub fn signed_distance(&self, p: Vec3A) -> f64 {
        self.normal.dot(p.as_dvec3()) - self.offset
    }

    /// The side of a signed distance, given the tolerance. NaN reads as on the plane, so a
    /// caller that lets one through never splits on it.
    #[inline]
    pub fn side_of(distance: f64, tolerance: f64) -> Side {
        if distance > tolerance {
            Side::Front
        } else if distance < -tolerance {
            Side::Back
        } else {
            Side::On
        }
    }

    /// The side a point is on, given the tolerance.
    #[inline]
    pub fn classify(&self, p: Vec3A, tolerance: f64) -> Side {
        Self::side_of(self.signed_distance(p), tolerance)
    }
}

/// Twice the area of a triangle, in `f64`.
pub(super) fn double_area(corners: &[Vec3A; 3]) -> f64 {
    let [a, b, c] = corners.map(|v| v.as_dvec3());
    (b - a).cross(c - a).length()
}

/// True when the triangle is thinner than the tolerance: its height over its longest edge
/// (twice its area over that edge) is at most `tolerance`, or it has no area at all. Such a
/// triangle has no plane worth splitting by, and its own corners could classify on both
/// sides of the plane its rounded normal gives.
pub(super) fn is_degenerate(corners: &[Vec3A; 3], tolerance: f64) -> bool {
    let [a, b, c] = corners.map(|v| v.as_dvec3());
    let longest = (b - a).length().max((c - b).length()).max((a - c).length());
    let double_area = double_area(corners);
    !(longest > 0.0 && double_area > tolerance * longest)
        || BspPlane::from_triangle(corners).is_none()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_plane_faces_its_front_and_holds_its_corners() {
        let corners = [Vec3A::ZERO, Vec3A::X, Vec3A::Y];
        let plane = BspPlane::from_triangle(&corners).unwrap();
        assert_eq!(plane.normal, DVec3::Z);
        assert!(corners.iter().all(|&c| plane.classify(c, 1e-9) == Side::On));
        assert_eq!(plane.classify(Vec3A::Z, 1e-9), Side::Front);
        assert_eq!(plane.classify(-Vec3A::Z, 1e-9), Side::Back);
        assert_eq!(plane.classify(Vec3A::NAN, 1e-9), Side::On);
    }

    #[test]
    fn collinear_and_non_finite_corners_have_no_plane() {
        let line = [Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0];
        assert!(BspPlane::from_triangle(&line).is_none());
        assert!(is_degenerate(&line, 1e-9));
        let nan = [Vec3A::ZERO, Vec3A::X, Vec3A::NAN];
        assert!(BspPlane::from_triangle(&nan).is_none());
        assert!(is_degenerate(&nan, 1e-9));
        // A sliver one thousandth of the tolerance high is degenerate; a fat one is not.
        let sliver = [Vec3A::ZERO, Vec3A::X, Vec3A::new(0.5, 1e-9, 0.0)];
        assert!(is_degenerate(&sliver, 1e-6));
        assert!(!is_degenerate(&[Vec3A::ZERO, Vec3A::X, Vec3A::Y], 1e-6));
    }

    #[test]
    fn the_tolerance_follows_the_magnitude_and_is_never_zero() {
        assert_eq!(tolerance_for_scale(2.0), 2.0 * RELATIVE_TOLERANCE);
        assert!(tolerance_for_scale(0.0) > 0.0);
        assert!(tolerance_for_scale(f64::NAN) > 0.0);
        // Sixteen ulps of a coordinate of the scale's magnitude.
        assert_eq!(tolerance_for_scale(1.0), 16.0 * f64::from(f32::EPSILON));
    }
}
