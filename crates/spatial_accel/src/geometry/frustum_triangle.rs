//! Whether a triangle meets a frustum: the exact test behind selection by touching.

use crate::{Frustum, Plane};
use glam::{DVec3, Vec3A};

/// How far outside a frustum a triangle may lie and still count as touching it, relative to
/// the magnitudes in each plane's distance: `2^-22` (two `f32` ulps) of `|d| + |n|_1 *
/// max|corner|`. See [`Frustum::touches_triangle`].
///
/// Why two ulps: the planes of a frustum built from a matrix in `f64` and rounded once are
/// off the matrix's exact planes by at most half an ulp of those magnitudes (an `f32` one,
/// normalised in `f32`, by a few half ulps), so a band of two ulps holds every triangle that
/// the exact frustum touches, with room to spare; wider would only select more near misses.
pub const TOUCH_TOLERANCE: f32 = 1.0 / (1u32 << 22) as f32;

/// Most vertices the clipped polygon can have. A convex polygon gains at most one vertex
/// per plane, but rounding can leave it a hair from convex, and a pass over `n` vertices
/// gives at most `n + n / 2` (each run of cut-off vertices adds two crossings and drops at
/// least one): 3, 4, 6, 9, 13, 19, 28 over six planes. So the polygon never overflows.
const MAX_VERTICES: usize = 28;

impl Frustum {
    /// Whether the triangle `corners` meets the frustum: any point of it, inside or on the
    /// boundary. The test of [`SelectionMode::Touching`](crate::SelectionMode::Touching),
    /// exact where a box test is not: a triangle whose box reaches into the frustum while the
    /// triangle passes beside it is not touching.
    ///
    /// The triangle is clipped by each plane in turn (Sutherland and Hodgman 1974), in
    /// `f64` on the exact `f32` inputs, and touches when something is left. Degenerate
    /// triangles (a segment, a point) are tested as what they are.
    ///
    /// Tolerance policy: conservative by a few ulps. Each plane is moved outwards by
    /// [`TOUCH_TOLERANCE`] of the magnitudes in its distance (`|d| + |n|_1 * max|corner|`),
    /// far more than the `f64` rounding of the clipping, so a triangle that reaches the
    /// frustum, even at one point, or across a frustum of zero thickness (a rectangle of zero
    /// width), is never missed; a triangle is only called touching wrongly when it passes
    /// within that band outside. The band is in absolute terms: planes through an eye far
    /// from the origin are known only to an ulp of that distance, so near such an eye it
    /// is wide against what is seen, as every `f32` frustum's rounding is there.
    /// [`MeshBvh::any_triangle_in_frustum`](crate::mesh::MeshBvh::any_triangle_in_frustum)
    /// culls its nodes by a frustum widened past the band, and so answers exactly as this test
    /// over every triangle.
    ///
    /// A triangle with a non-finite corner touches nothing (as it is in no mesh tree).
    ///
    /// ```
    /// use spatial_accel::Frustum;
    /// use glam::{Mat4, Vec2, Vec3, Vec3A};
    /// let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1);
    /// let view = Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
    /// let centre = Frustum::from_clip_rect(&(proj * view), Vec2::splat(-0.1), Vec2::splat(0.1))
    ///     .unwrap();
    /// // A large triangle 10 ahead whose corners are all off the small rectangle, but which
    /// // covers its middle, and one whose box covers the middle while it passes beside it.
    /// let covering = [Vec3A::new(-9.0, -9.0, -10.0), Vec3A::new(9.0, -9.0, -10.0), Vec3A::new(0.0, 9.0, -10.0)];
    /// let beside = [Vec3A::new(-8.0, 10.0, -10.0), Vec3A::new(10.0, -8.0, -10.0), Vec3A::new(9.0, 9.0, -10.0)];
    /// assert!(centre.touches_triangle(&covering));
    /// assert!(!centre.touches_triangle(&beside));
    /// ```
    pub fn touches_triangle(&self, corners: &[Vec3A; 3]) -> bool {
        if !corners.iter().all(|c| c.is_finite()) {
            return false;
        }
        let scale = corner_scale(corners);
        let mut polygon = Polygon::triangle(corners);
        let mut cut = Polygon::EMPTY;
        for plane in &self.planes {
            if plane.normal == Vec3A::ZERO {
                if plane.d < 0.0 {
                    return false;
                }
                continue;
            }
            let (normal, d) = widened(plane, scale);
            polygon.clip_into(normal, d, &mut cut);
            if cut.len == 0 {
                return false;
            }
            core::mem::swap(&mut polygon, &mut cut);
        }
        true
    }
}

/// The largest corner coordinate's magnitude, which the touching band scales with.
fn corner_scale(corners: &[Vec3A; 3]) -> f64 {
    let largest = corners
        .iter()
        .fold(Vec3A::ZERO, |m, c| m.max(c.abs()))
        .max_element();
    f64::from(largest)
}

/// The touching band of a plane for points within `scale` of the origin on every axis:
/// [`TOUCH_TOLERANCE`] of the magnitudes in the plane's distance there, `|d| + |n|_1 *
/// scale`. Zero for a plane that holds all space or none.
pub(crate) fn touch_band(plane: &Plane, scale: f64) -> f64 {
    let magnitudes = f64::from(plane.d).abs() + plane.normal.as_dvec3().abs().element_sum() * scale;
    if plane.normal == Vec3A::ZERO {
        0.0
    } else {
        f64::from(TOUCH_TOLERANCE) * magnitudes
    }
}

/// The plane in `f64`, moved outwards by its touching band.
fn widened(plane: &Plane, scale: f64) -> (DVec3, f64) {
    (
        plane.normal.as_dvec3(),
        f64::from(plane.d) + touch_band(plane, scale),
    )
}

/// A convex polygon in `f64`: the triangle as the planes cut it down.
#[derive(Clone, Copy)]
struct Polygon {
    points: [DVec3; MAX_VERTICES],
    len: usize,
}

impl Polygon {
    const EMPTY: Self = Self {
        points: [DVec3::ZERO; MAX_VERTICES],
        len: 0,
    };

    fn triangle(corners: &[Vec3A; 3]) -> Self {
        let mut polygon = Self::EMPTY;
        for (point, corner) in polygon.points.iter_mut().zip(corners) {
            *point = corner.as_dvec3();
        }
        polygon.len = 3;
        polygon
    }

    /// Writes to `out` the part where `normal . p + d >= 0`.
    #[inline]
    fn clip_into(&self, normal: DVec3, d: f64, out: &mut Self) {
        let distance = |p: DVec3| normal.dot(p) + d;
        out.len = 0;
        let push = |out: &mut Self, p: DVec3| {
            // Never full (see `MAX_VERTICES`); the guard keeps a broken bound from panicking.
            if out.len < MAX_VERTICES {
                out.points[out.len] = p;
                out.len += 1;
            }
        };
        for i in 0..self.len {
            let (a, b) = (self.points[i], self.points[(i + 1) % self.len]);
            let (da, db) = (distance(a), distance(b));
            if da >= 0.0 {
                push(out, a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                // From the inside end, so an edge cut in both directions gives one point.
                let (from, to, df, dt) = if da >= 0.0 {
                    (a, b, da, db)
                } else {
                    (b, a, db, da)
                };
                let t = (df / (df - dt)).clamp(0.0, 1.0);
                push(out, from + (to - from) * t);
            }
        }
    }
}
