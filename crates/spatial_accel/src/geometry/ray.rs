//! Rays: origin, direction and a parameter range, with what every slab test needs precomputed.

use glam::{Affine3A, Vec3, Vec3A};

/// A ray `origin + t * direction` for `t` in `[t_min, t_max]`.
///
/// Rays are kept as origin, direction and range rather than two end points: far from the origin
/// an end point loses the precision the direction keeps (Godot fixed false hits past ~1000 km
/// this way). The direction need not be normalised; `t` is measured in units of its length.
///
/// The reciprocal direction is precomputed for the slab test. A zero component gives an
/// infinite reciprocal, with the sign of the zero; [`Ray::intersect_aabb`] handles the `0 * inf`
/// that this produces for origins on a slab plane.
///
/// A ray with a NaN or infinite origin or direction, a zero direction, a direction component
/// larger than [`Ray::MAX_DIRECTION`] or a NaN range is made *degenerate*: its range is
/// emptied so that it misses everything, rather than poisoning a traversal with NaN.
///
/// ```
/// use spatial_accel::{Aabb, Ray};
/// use glam::Vec3A;
/// let ray = Ray::new(Vec3A::new(-5.0, 0.5, 0.5), Vec3A::X);
/// let t = ray.intersect_aabb(&Aabb::new(Vec3A::ZERO, Vec3A::ONE)).unwrap();
/// // The entry is widened towards the origin by a few ulps (see `SLAB_WIDENING`), never past 5.
/// assert!(t <= 5.0 && t > 4.9999);
/// assert!(Ray::new(Vec3A::NAN, Vec3A::X).is_degenerate());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts (t = 0).
    pub origin: Vec3A,
    /// Where it goes; not necessarily unit length.
    pub direction: Vec3A,
    /// `1 / direction`, component-wise; +-inf for zero components.
    pub inv_direction: Vec3A,
    /// The nearest parameter that counts as a hit.
    pub t_min: f32,
    /// The farthest parameter that counts as a hit; traversals shrink it to the closest hit.
    pub t_max: f32,
}

impl Ray {
    /// The largest direction component a traceable ray may have: `2^126`.
    ///
    /// Why a limit: above it the reciprocal is subnormal and carries fewer significant bits
    /// than the slab test's widening ([`crate::SLAB_WIDENING`]) allows for, so box tests could
    /// cull a box the ray touches (the stress suite found an instance whose world box a ray
    /// of direction `f32::MAX` missed while its mesh was hit in local space). Such a ray
    /// covers the whole float range within `t` of about `1e-38`; it hits nothing.
    pub const MAX_DIRECTION: f32 = (1u128 << 126) as f32;

    /// A ray over `[0, +inf)`.
    #[inline]
    pub fn new(origin: impl Into<Vec3A>, direction: impl Into<Vec3A>) -> Self {
        Self::with_range(origin, direction, 0.0, f32::INFINITY)
    }

    /// A ray over `[t_min, t_max]`. Invalid input gives a degenerate ray (see the type docs).
    #[inline]
    pub fn with_range(
        origin: impl Into<Vec3A>,
        direction: impl Into<Vec3A>,
        t_min: f32,
        t_max: f32,
    ) -> Self {
        let (origin, direction) = (origin.into(), direction.into());
        let valid = origin.is_finite()
            && direction.is_finite()
            && direction != Vec3A::ZERO
            && direction.abs().max_element() <= Self::MAX_DIRECTION
            && t_min <= t_max;
        let (t_min, t_max) = if valid {
            (t_min, t_max)
        } else {
            (f32::INFINITY, f32::NEG_INFINITY)
        };
        Self {
            origin,
            direction,
            inv_direction: direction.recip(),
            t_min,
            t_max,
        }
    }

    /// The segment from `start` to `end`: `t` runs over `[0, 1]`.
    #[inline]
    pub fn segment(start: impl Into<Vec3A>, end: impl Into<Vec3A>) -> Self {
        let start = start.into();
        Self::with_range(start, end.into() - start, 0.0, 1.0)
    }

    /// True when the ray's range is empty, so it can hit nothing (invalid input makes this so).
    #[inline]
    #[expect(
        clippy::neg_cmp_op_on_partial_ord,
        reason = "a NaN range must read as degenerate"
    )]
    pub fn is_degenerate(&self) -> bool {
        !(self.t_min <= self.t_max)
    }

    /// True when the ray can hit something: a finite origin, a finite non-zero direction no
    /// component of which exceeds [`Ray::MAX_DIRECTION`], whose reciprocal is not NaN, and a
    /// non-empty range.
    ///
    /// [`Ray::new`] makes every invalid ray degenerate, but the fields are public, so a ray
    /// written field by field (or one whose direction was overwritten) may carry a NaN
    /// direction with a valid range. The slab tests treat a NaN slab distance as "this axis
    /// does not constrain the ray" (the `0 * inf` rule), so such a ray would pass every box,
    /// empty node slots included; every ray walk asks this first instead.
    #[inline]
    pub fn is_traceable(&self) -> bool {
        !self.is_degenerate()
            && self.origin.is_finite()
            && self.direction.is_finite()
            && self.direction != Vec3A::ZERO
            && self.direction.abs().max_element() <= Self::MAX_DIRECTION
            && !self.inv_direction.is_nan()
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3A {
        self.origin + self.direction * t
    }

    /// The same ray limited to `t <= t_max` (for shrinking the search after a hit).
    #[inline]
    pub fn with_t_max(mut self, t_max: f32) -> Self {
        self.t_max = self.t_max.min(t_max);
        self
    }

    /// The ray in another space, e.g. an instance's local space given its world-from-local
    /// inverse. The parameter `t` is preserved (the direction is not renormalised), so hit
    /// distances compare across instances without conversion.
    #[inline]
    pub fn transformed(&self, m: &Affine3A) -> Self {
        let mut r = Self::with_range(
            m.transform_point3a(self.origin),
            m.transform_vector3a(self.direction),
            self.t_min,
            self.t_max,
        );
        if self.is_degenerate() {
            r.t_min = f32::INFINITY;
            r.t_max = f32::NEG_INFINITY;
        }
        r
    }

    /// The origin as a plain `Vec3`.
    #[inline]
    pub fn origin_vec3(&self) -> Vec3 {
        self.origin.into()
    }
}
