//! Double-precision reference versions of the geometric tests, shared by the acceptance
//! tests (the generator and the test meshes are `accel_testkit`'s).
//!
//! Every test binary includes this module with `mod support;` and uses a different subset of it.
#![allow(dead_code)]

use glam::{DVec3, Vec3A};

/// `f32` vectors widened to `f64` exactly.
pub fn d(v: Vec3A) -> DVec3 {
    v.as_dvec3()
}

/// Reference slab test in f64 on the exact (widened) inputs: the parameter interval of the ray
/// inside the closed box, clamped to `[t_min, t_max]`, or `None`. A zero direction component
/// (either sign) constrains nothing when the origin lies in that slab and rejects otherwise.
pub fn slab_f64(
    origin: DVec3,
    dir: DVec3,
    min: DVec3,
    max: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(f64, f64)> {
    let (mut near, mut far) = (t_min, t_max);
    for k in 0..3 {
        if dir[k] == 0.0 {
            if origin[k] < min[k] || origin[k] > max[k] {
                return None;
            }
        } else {
            let t1 = (min[k] - origin[k]) / dir[k];
            let t2 = (max[k] - origin[k]) / dir[k];
            near = near.max(t1.min(t2));
            far = far.min(t1.max(t2));
        }
    }
    (near <= far).then_some((near, far))
}

/// What the f64 reference knows about a ray and a sphere.
#[derive(Clone, Copy, Debug)]
pub struct SphereRef {
    /// Distance from the centre to the ray's line, over the radius: < 1 crosses, > 1 misses,
    /// near 1 is the tangency band where f32 is allowed to disagree.
    pub closeness: f64,
    /// Both roots of the line, ascending, when it crosses.
    pub roots: Option<(f64, f64)>,
}

/// Reference ray/sphere in f64, with the same stable formulation (closest point of the line,
/// `c / q` for the near root) so that f64 itself is not the weak link.
pub fn sphere_f64(origin: DVec3, dir: DVec3, center: DVec3, radius: f64) -> SphereRef {
    let f = origin - center;
    let a = dir.length_squared();
    let b = -f.dot(dir);
    let l = f + dir * (b / a);
    let closeness = l.length() / radius;
    let disc = a * (radius * radius - l.length_squared());
    let roots = (disc >= 0.0).then(|| {
        let q = b + disc.sqrt().copysign(b);
        let c = f.length_squared() - radius * radius;
        if q == 0.0 {
            (0.0, 0.0)
        } else {
            let (r0, r1) = (c / q, q / a);
            (r0.min(r1), r0.max(r1))
        }
    });
    SphereRef { closeness, roots }
}

/// Relative difference, safe at zero: `|a - b| / max(|a|, |b|, floor)`.
pub fn rel_diff(a: f64, b: f64, floor: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(floor)
}
