//! Bounding spheres: a cheaper, rotation-invariant bound, offered as an alternative node volume.

use crate::Aabb;
use glam::{Affine3A, Vec3A};

/// A sphere given by its centre and radius.
///
/// A sphere is valid when its centre is finite and its radius is a non-negative number; an
/// infinite radius is allowed (the sphere holds all of space, as [`Aabb::EVERYTHING`] does).
/// An invalid sphere (a NaN or infinite centre, a NaN or negative radius) holds nothing: every
/// test here says no, and every structure's sphere query reports nothing for it. Its bound is
/// rotation-invariant, which makes it cheap to keep up to date for spinning objects, but it
/// encloses a box loosely (up to 2.7 times the volume of a cube's bound).
///
/// ```
/// use spatial_accel::{Aabb, Sphere};
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

    /// True when the centre is finite and the radius is a non-negative number (`+inf`
    /// included).
    ///
    /// Why an infinite centre is invalid: it is no place, and the tests' arithmetic turns it
    /// into `inf - inf`; the structures and the brute-force oracle all ask this first, so that
    /// they agree that such a sphere overlaps nothing.
    #[inline]
    pub fn is_valid(&self) -> bool {
        self.center.is_finite() && self.radius >= 0.0
    }

    /// The sphere circumscribing a box: centred on it, through its corners. An empty (or NaN)
    /// box gives an invalid sphere (negative radius); a box with an infinite bound, or one
    /// whose circumscribed radius overflows, gives a sphere of infinite radius, which holds it.
    #[inline]
    pub fn from_aabb(aabb: &Aabb) -> Self {
        if aabb.is_empty() {
            return Self::new(Vec3A::ZERO, -1.0);
        }
        // Halves first: `min + max` and `max - min` overflow for finite boxes near the end of
        // the float range, and an infinite centre would make the sphere invalid.
        let (lo, hi) = (aabb.min * 0.5, aabb.max * 0.5);
        let (center, radius) = (lo + hi, (hi - lo).length());
        if center.is_finite() && radius.is_finite() {
            Self::new(center, radius)
        } else {
            Self::new(Vec3A::ZERO, f32::INFINITY)
        }
    }

    /// The tight box around the sphere.
    #[inline]
    pub fn aabb(&self) -> Aabb {
        Aabb::from_center_half_extents(self.center, Vec3A::splat(self.radius))
    }

    /// True when the point is inside or on the sphere (false for an invalid sphere).
    #[inline]
    pub fn contains_point(&self, p: impl Into<Vec3A>) -> bool {
        self.intersects_aabb(&Aabb::from_point(p))
    }

    /// True when the sphere and the box share a point (Arvo's closest-point test); false for
    /// an invalid sphere.
    ///
    /// The box must also meet the sphere's own box [`Sphere::aabb`], computed as the grids
    /// compute the cells a sphere query visits: far from the origin `c - max` absorbs the
    /// box's coordinate (`3e38 + 50` rounds to `3e38`) and the distance test alone passed
    /// boxes that lie outside those cells, so the grid and the oracle disagreed.
    #[inline]
    pub fn intersects_aabb(&self, aabb: &Aabb) -> bool {
        if !self.is_valid() || !self.aabb().intersects_aabb(aabb) {
            return false;
        }
        let d = (aabb.min - self.center)
            .max(self.center - aabb.max)
            .max(Vec3A::ZERO);
        within(d, self.radius)
    }

    /// True when the two spheres share a point (false when either is invalid).
    #[inline]
    pub fn intersects_sphere(&self, other: &Self) -> bool {
        if !self.is_valid() || !other.is_valid() {
            return false;
        }
        // In halves, so that neither the centres' difference nor the radii's sum overflows.
        let d = (self.center * 0.5 - other.center * 0.5).abs();
        within(d, self.radius * 0.5 + other.radius * 0.5)
    }

    /// The smallest sphere containing both spheres; an invalid one is ignored (two invalid
    /// spheres give the first).
    pub fn merge(&self, other: &Self) -> Self {
        if !other.is_valid() {
            return *self;
        }
        if !self.is_valid() {
            return *other;
        }
        let d = other.center - self.center;
        let dist = d.length();
        if dist + other.radius <= self.radius {
            return *self;
        }
        if dist + self.radius <= other.radius {
            return *other;
        }
        let radius = 0.5 * (dist + self.radius + other.radius);
        if !radius.is_finite() {
            // The centres' distance or the radii overflowed: no finite sphere is known to
            // hold both, and `inf / inf` would make the centre NaN. All of space holds both.
            return Self::new(self.center, f32::INFINITY);
        }
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

/// True when the vector `d` (non-negative components) is no longer than `r`.
///
/// Why the scaling: squaring overflows above about `1.8e19` (and underflows below `1e-19`),
/// after which every distance compares equal to an infinite `r * r`. Each component is at
/// most `r` once the first test passes, so scaling by a power of two chosen from `r` alone
/// keeps the squares in range; a power of two scales exactly, and ordinary radii are not
/// scaled at all.
#[inline]
fn within(d: Vec3A, r: f32) -> bool {
    // NaN components fail here.
    if !d.cmple(Vec3A::splat(r)).all() {
        return false;
    }
    const BIG: f32 = (1u64 << 60) as f32;
    const SMALL: f32 = 1.0 / BIG;
    let scale = if r > BIG {
        // 2^-70.
        SMALL * (1.0 / 1024.0)
    } else if r < SMALL {
        // 2^70.
        BIG * 1024.0
    } else {
        1.0
    };
    let (d, r) = (d * scale, r * scale);
    d.length_squared() <= r * r
}
