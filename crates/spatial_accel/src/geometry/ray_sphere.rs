//! Ray/sphere intersection with a quadratic that stays accurate for far and small spheres.

use crate::{Ray, Sphere};

/// Up to this size (radius, coordinates) the f32 quadratic's products stay in range.
const SAFE: f32 = (1u64 << 30) as f32;
/// Direction components at least this large (the largest of them) keep `|d|^2` normal.
const SAFE_DIRECTION: f32 = 1.0 / SAFE;

/// The largest f32 not above `x`.
fn round_down(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) > x { y.next_down() } else { y }
}

/// The smallest f32 not below `x`.
fn round_up(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) < x { y.next_up() } else { y }
}

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
    /// use spatial_accel::{Ray, Sphere};
    /// use glam::Vec3A;
    /// let ray = Ray::new(Vec3A::new(0.0, 0.0, -10.0), Vec3A::Z);
    /// assert_eq!(ray.intersect_sphere(&Sphere::new(Vec3A::ZERO, 1.0)), Some(9.0));
    /// ```
    ///
    /// A sphere of infinite radius holds every ray from its start; one so large or so far
    /// that its roots lie beyond the float range is met where the range allows (an entry at
    /// `+inf` is no hit).
    pub fn intersect_sphere(&self, sphere: &Sphere) -> Option<f32> {
        let (t0, t1) = self.roots(sphere)?;
        if t1 < self.t_min || t0 > self.t_max {
            return None;
        }
        let entry = t0.max(self.t_min);
        (entry < f32::INFINITY).then_some(entry)
    }

    /// Both parameters (ascending) where the infinite line meets the sphere, ignoring the
    /// ray's range; `None` when the line misses or the input is degenerate.
    pub fn sphere_roots(&self, sphere: &Sphere) -> Option<(f32, f32)> {
        self.roots(sphere)
            .filter(|(t0, t1)| t0.is_finite() && t1.is_finite())
    }

    /// Both roots, ascending, which may be infinite: `(-inf, inf)` for a sphere of infinite
    /// radius, and a root beyond the float range rounds to infinity.
    #[expect(
        clippy::neg_cmp_op_on_partial_ord,
        reason = "a NaN discriminant (or direction) must read as a miss"
    )]
    fn roots(&self, sphere: &Sphere) -> Option<(f32, f32)> {
        if self.is_degenerate() || !sphere.is_valid() || !self.origin.is_finite() {
            return None;
        }
        let d = self.direction.abs().max_element();
        if !(d > 0.0 && self.direction.is_finite()) {
            return None;
        }
        if sphere.radius == f32::INFINITY {
            return Some((f32::NEG_INFINITY, f32::INFINITY));
        }
        // Where the products of the quadratic below overflow or underflow in f32 (a radius or
        // a distance past 1e9, a direction far from unit length: the stress suite's huge node
        // spheres of a tree over 1e30 boxes), the same steps run in f64, where they cannot.
        let reach = sphere
            .radius
            .max(self.origin.abs().max_element())
            .max(sphere.center.abs().max_element());
        if reach > SAFE || !(SAFE_DIRECTION..=SAFE).contains(&d) {
            return self.roots_f64(sphere);
        }
        let f = self.origin - sphere.center;
        let a = self.direction.length_squared();
        let b = -f.dot(self.direction);
        let c = f.length_squared() - sphere.radius * sphere.radius;
        // Closest point of the line to the centre, relative to the centre.
        let l = f + self.direction * (b / a);
        // One correction step. `b` is a dot product of numbers of size |f|, so its rounding
        // leaves `l` off along the direction by a few ulps of |f|: at 1e5 that is more than the
        // radius of a 1 cm sphere, and rays dead on its centre would miss. The residual `l . d` is
        // small and computed accurately, so removing it leaves only the rounding of the products.
        let l = l - self.direction * (l.dot(self.direction) / a);
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

    /// [`Ray::roots`] in f64: the squares of f32 values never overflow there.
    #[expect(
        clippy::neg_cmp_op_on_partial_ord,
        reason = "a NaN discriminant must read as a miss"
    )]
    fn roots_f64(&self, sphere: &Sphere) -> Option<(f32, f32)> {
        let (o, dir, c) = (
            self.origin.as_dvec3(),
            self.direction.as_dvec3(),
            sphere.center.as_dvec3(),
        );
        let radius = f64::from(sphere.radius);
        let f = o - c;
        let a = dir.length_squared();
        let b = -f.dot(dir);
        let l = f + dir * (b / a);
        let l = l - dir * (l.dot(dir) / a);
        let discriminant = a * (radius * radius - l.length_squared());
        if !(discriminant >= 0.0) {
            return None;
        }
        let q = b + discriminant.sqrt().copysign(b);
        let (t0, t1) = if q == 0.0 {
            (0.0, 0.0)
        } else {
            let c = f.length_squared() - radius * radius;
            let (r0, r1) = (c / q, q / a);
            (r0.min(r1), r0.max(r1))
        };
        // The roots round to f32 outwards, so that the interval still holds the sphere: a node
        // bound entered an ulp late would lose a child at its edge.
        let (t0, t1) = (round_down(t0), round_up(t1));
        (!t0.is_nan() && !t1.is_nan()).then_some((t0, t1))
    }

    /// True when the ray touches the solid sphere within its range.
    #[inline]
    pub fn hits_sphere(&self, sphere: &Sphere) -> bool {
        self.intersect_sphere(sphere).is_some()
    }
}
