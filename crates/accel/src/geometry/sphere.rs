//! Bounding spheres: a cheaper, rotation-invariant bound, offered as an alternative node volume.

use crate::Aabb;
use glam::{Affine3A, Vec3A};

/// A sphere given by its centre and radius.
///
/// A sphere is valid when nothing is NaN and the radius is not negative. Its bound is
/// rotation-invariant, which makes it cheap to keep up to date for spinning objects, but it
/// encloses a box loosely (up to 2.7x the volume of a cube's bound).
///
/// ```
/// use accel::{Aabb, Sphere};
/// use glam::Vec3A;
/// let s = Sphere::new(Vec3A::ZERO, 2.0);
/// assert_eq!(s.aabb(), Aabb::new(Vec3A::splat(-2.0), Vec3A::splat(2.0)));
/// assert!(Sphere::from_aabb(&s.aabb()).radius >= 2.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// The centre.
    pub center: Vec3A,
    /// The radius (never negative for a valid sphere).
    pub radius: f32,
}

impl Sphere {
    /// A sphere from centre and radius. No check is made: see [`Sphere::is_valid`].
    #[inline]
    pub fn new(center: impl Into<Vec3A>, radius: f32) -> Self {
        Self {
            center: center.into(),
            radius,
        }
    }

    /// True when the centre has no NaN and the radius is a non-negative number.
    #[inline]
    pub fn is_valid(&self) -> bool {
        !self.center.is_nan() && self.radius >= 0.0
    }

    /// The sphere circumscribing a box: centred on it, through its corners. An empty box gives
    /// an invalid sphere (negative radius).
    #[inline]
    pub fn from_aabb(aabb: &Aabb) -> Self {
        if aabb.is_empty() {
            return Self::new(Vec3A::ZERO, -1.0);
        }
        Self::new(aabb.center(), aabb.half_extents().length())
    }

    /// The tight box around the sphere.
    #[inline]
    pub fn aabb(&self) -> Aabb {
        Aabb::from_center_half_extents(self.center, Vec3A::splat(self.radius))
    }

    /// True when the point is inside or on the sphere.
    #[inline]
    pub fn contains_point(&self, p: impl Into<Vec3A>) -> bool {
        self.center.distance_squared(p.into()) <= self.radius * self.radius
    }

    /// True when the sphere and the box share a point (Arvo's closest-point test).
    #[inline]
    pub fn intersects_aabb(&self, aabb: &Aabb) -> bool {
        aabb.distance_squared_to_point(self.center) <= self.radius * self.radius
    }

    /// True when the two spheres share a point.
    #[inline]
    pub fn intersects_sphere(&self, other: &Self) -> bool {
        let r = self.radius + other.radius;
        self.center.distance_squared(other.center) <= r * r
    }

    /// The smallest sphere containing both spheres.
    pub fn merge(&self, other: &Self) -> Self {
        let d = other.center - self.center;
        let dist = d.length();
        if dist + other.radius <= self.radius {
            return *self;
        }
        if dist + self.radius <= other.radius {
            return *other;
        }
        let radius = 0.5 * (dist + self.radius + other.radius);
        // dist > 0 here: equal centres are handled by the containment cases above.
        let center = self.center + d * ((radius - self.radius) / dist);
        Self::new(center, radius)
    }

    /// A sphere containing the image of this one under an affine transform.
    ///
    /// The radius scales by an upper bound of the largest stretch (spectral norm) of the linear
    /// part: the largest column length when the columns are orthogonal (rotation and scale, the
    /// usual case, where it is exact), else the Frobenius norm, which is never smaller.
    pub fn transformed(&self, m: &Affine3A) -> Self {
        let [x, y, z] = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
        let (lx, ly, lz) = (x.length_squared(), y.length_squared(), z.length_squared());
        let tol = 1e-6 * (lx + ly + lz);
        let orthogonal = x.dot(y).abs() <= tol && y.dot(z).abs() <= tol && z.dot(x).abs() <= tol;
        let stretch_sq = if orthogonal {
            // The relative slack covers the rounding of the near-zero dot products.
            lx.max(ly).max(lz) * (1.0 + 4e-6)
        } else {
            lx + ly + lz
        };
        Self::new(
            m.transform_point3a(self.center),
            self.radius * stretch_sq.sqrt(),
        )
    }
}
