//! Ray/sphere intersection with a quadratic that stays accurate for far and small spheres.

use crate::{Ray, Sphere};

impl Ray {
    /// The first parameter in range at which the ray meets the sphere's surface, or the ray's
    /// `t_min` when it starts inside (a solid sphere, as a bound is); `None` on a miss.
    ///
    /// The textbook `b^2 - 4ac` loses every digit when the sphere is small against its distance
    /// from the origin. This follows Haines et al., "Precision Improvements for Ray/Sphere
    /// Intersection" (Ray Tracing Gems, ch. 7): the discriminant is taken from the squared
    /// distance between the centre and the ray's closest point, and the smaller root comes from
    /// `c / q` rather than a difference of nearly equal numbers.
    ///
    /// ```
    /// use accel::{Ray, Sphere};
    /// use glam::Vec3A;
    /// let ray = Ray::new(Vec3A::new(0.0, 0.0, -10.0), Vec3A::Z);
    /// assert_eq!(ray.intersect_sphere(&Sphere::new(Vec3A::ZERO, 1.0)), Some(9.0));
    /// ```
    pub fn intersect_sphere(&self, sphere: &Sphere) -> Option<f32> {
        let (t0, t1) = self.sphere_roots(sphere)?;
        if t1 < self.t_min || t0 > self.t_max {
            return None;
        }
        Some(t0.max(self.t_min))
    }

    /// Both parameters (ascending) where the infinite line meets the sphere, ignoring the
    /// ray's range; `None` when the line misses or the input is degenerate.
    // `!(d >= 0)` also rejects a NaN discriminant, which `d < 0` would let through.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn sphere_roots(&self, sphere: &Sphere) -> Option<(f32, f32)> {
        if self.is_degenerate() || !sphere.is_valid() {
            return None;
        }
        let f = self.origin - sphere.center;
        let a = self.direction.length_squared();
        let b = -f.dot(self.direction);
        let c = f.length_squared() - sphere.radius * sphere.radius;
        // Closest point of the line to the centre, relative to the centre.
        let l = f + self.direction * (b / a);
        let discriminant = a * (sphere.radius * sphere.radius - l.length_squared());
        if !(discriminant >= 0.0) {
            return None;
        }
        let q = b + discriminant.sqrt().copysign(b);
        let (t0, t1) = if q == 0.0 {
            // Origin at the centre of a zero-radius sphere, or b = 0 with a tangent line.
            (0.0, 0.0)
        } else {
            let (r0, r1) = (c / q, q / a);
            (r0.min(r1), r0.max(r1))
        };
        (t0.is_finite() && t1.is_finite()).then_some((t0, t1))
    }

    /// True when the ray touches the solid sphere within its range.
    #[inline]
    pub fn hits_sphere(&self, sphere: &Sphere) -> bool {
        self.intersect_sphere(sphere).is_some()
    }
}
