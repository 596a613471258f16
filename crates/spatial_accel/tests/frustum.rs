//! Frustum classification against f64 ground truth on the same (f32) view-projection matrices,
//! and the transformed bounds of boxes and spheres against f64 corner and sample loops.

mod support;

use accel_testkit::Rng;
use glam::{Affine3A, DMat3, DVec3, DVec4, Mat3, Mat4, Quat, Vec3, Vec3A};
use spatial_accel::{Aabb, Containment, Frustum, Sphere};
use support::d;

/// Planes of the f32 matrix, extracted in f64 (Gribb-Hartmann, the same rows the crate uses), as
/// unnormalised `(n, w)`; a zero normal means "everything" (w >= 0) or "nothing".
fn planes_f64(m: &Mat4) -> [DVec4; 6] {
    let t = m.as_dmat4().transpose();
    let (r0, r1, r2, r3) = (t.x_axis, t.y_axis, t.z_axis, t.w_axis);
    [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r3 - r2, r2]
}

/// Signed distance in f64 (positive inside), +-inf for the zero-normal plane.
fn signed_dist(p: &DVec4, x: DVec3) -> f64 {
    let n = p.truncate();
    let len = n.length();
    if len == 0.0 {
        if p.w >= 0.0 {
            f64::INFINITY
        } else {
            f64::NEG_INFINITY
        }
    } else {
        (n.dot(x) + p.w) / len
    }
}

/// The rounding allowance at a point: f32 planes and distances are good to a few ulps of the
/// magnitudes involved (the point, the plane offset, the volume's size).
fn tol(p: &DVec4, x: DVec3, size: f64) -> f64 {
    let len = p.truncate().length();
    let offset = if len == 0.0 { 0.0 } else { (p.w / len).abs() };
    1e-5 * (x.length() + offset + size + 1e-3)
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Perspective,
    InfiniteReverse,
    Orthographic,
}

/// A random camera: eye up to 1e3 from the origin, random orientation, random projection.
fn camera(rng: &mut Rng, kind: Kind) -> (Mat4, Vec3, f32) {
    let eye = Vec3::from(rng.vec3a(-1e3, 1e3));
    let fwd = Vec3::from(rng.unit_vector_f64());
    let up = Vec3::from(rng.unit_vector_f64());
    let view = Mat4::look_to_rh(eye, fwd, up);
    let near = rng.log_range(0.01, 1.0);
    let far = near * rng.log_range(10.0, 1e4);
    let (fov, aspect) = (rng.range(0.3, 2.5), rng.range(0.5, 2.5));
    let (proj, reach) = match kind {
        Kind::Perspective => (Mat4::perspective_rh(fov, aspect, near, far), far),
        Kind::InfiniteReverse => (
            Mat4::perspective_infinite_reverse_rh(fov, aspect, near),
            1e4,
        ),
        Kind::Orthographic => {
            let (w, h) = (rng.log_range(0.1, 100.0), rng.log_range(0.1, 100.0));
            let off = rng.range(-0.5, 0.5);
            (
                Mat4::orthographic_rh(-w + off * w, w + off * w, -h, h, near, far),
                far,
            )
        }
    };
    (proj * view, eye, reach)
}

#[derive(Default, Debug)]
struct Counts {
    outside: u64,
    intersecting: u64,
    inside: u64,
}

impl Counts {
    fn add(&mut self, c: Containment) {
        match c {
            Containment::Outside => self.outside += 1,
            Containment::Intersecting => self.intersecting += 1,
            Containment::Inside => self.inside += 1,
        }
    }

    fn assert_mixed(&self, what: &str) {
        let total = self.outside + self.intersecting + self.inside;
        println!("{what}: {self:?}");
        for n in [self.outside, self.intersecting, self.inside] {
            assert!(n * 20 > total, "{what}: generator lost its mix: {self:?}");
        }
    }
}

/// A log-uniform distance from the eye, from well inside the near plane to past the far one.
fn view_distance(rng: &mut Rng, reach: f32) -> f32 {
    rng.log_range(1e-2, reach * 1.5)
}

#[test]
fn aabb_classification_is_sound() {
    for kind in [Kind::Perspective, Kind::InfiniteReverse, Kind::Orthographic] {
        let mut rng = Rng::new(kind as u64 + 1);
        let mut counts = Counts::default();
        for _ in 0..200 {
            let (m, eye, reach) = camera(&mut rng, kind);
            let f = Frustum::from_clip_from_world(&m);
            let planes = planes_f64(&m);
            // Centres along the view direction (from the inverse matrix) or anywhere around.
            let fwd = m.inverse().project_point3(Vec3::new(0.0, 0.0, 0.5)) - eye;
            for _ in 0..1000 {
                let dist = view_distance(&mut rng, reach);
                let spread = if rng.below(3) == 0 {
                    rng.unit_vector_f64()
                } else {
                    Vec3A::from(fwd.normalize_or_zero())
                        + rng.unit_vector_f64() * rng.range(0.0, 0.8)
                };
                let c = Vec3A::from(eye) + spread * dist;
                let half =
                    Vec3A::from_array(core::array::from_fn(|_| rng.log_range(1e-3, 0.5) * dist));
                let b = Aabb::from_center_half_extents(c, half);
                let got = f.classify_aabb(&b);
                counts.add(got);
                let corners = b.corners().map(d);
                let size = d(half).length();
                match got {
                    Containment::Outside => {
                        // Some plane must have all eight corners behind it.
                        let separated = planes
                            .iter()
                            .any(|p| corners.iter().all(|&x| signed_dist(p, x) < tol(p, x, size)));
                        assert!(
                            separated,
                            "{kind:?}: {b:?} called Outside, but no plane separates it"
                        );
                        // And so no corner nor sample inside the box is inside the frustum.
                        let samples: Vec<DVec3> = (0..8)
                            .map(|_| {
                                d(b.min)
                                    + d(b.extent()) * d(Vec3A::new(rng.f32(), rng.f32(), rng.f32()))
                            })
                            .collect();
                        for &x in corners.iter().chain(&samples) {
                            let inside = planes.iter().all(|p| signed_dist(p, x) > tol(p, x, size));
                            assert!(!inside, "{kind:?}: {b:?} called Outside, but {x} is inside");
                        }
                    }
                    Containment::Inside => {
                        for p in &planes {
                            for &x in &corners {
                                assert!(
                                    signed_dist(p, x) >= -tol(p, x, size),
                                    "{kind:?}: {b:?} called Inside, corner {x} is behind {p}"
                                );
                            }
                        }
                    }
                    Containment::Intersecting => {}
                }
            }
        }
        counts.assert_mixed(&format!("{kind:?} boxes"));
    }
}

#[test]
fn sphere_classification_is_sound() {
    for kind in [Kind::Perspective, Kind::InfiniteReverse, Kind::Orthographic] {
        let mut rng = Rng::new(kind as u64 + 10);
        let mut counts = Counts::default();
        for _ in 0..200 {
            let (m, eye, reach) = camera(&mut rng, kind);
            let f = Frustum::from_clip_from_world(&m);
            let planes = planes_f64(&m);
            let fwd = m.inverse().project_point3(Vec3::new(0.0, 0.0, 0.5)) - eye;
            for _ in 0..1000 {
                let dist = view_distance(&mut rng, reach);
                let spread = Vec3A::from(fwd.normalize_or_zero())
                    + rng.unit_vector_f64() * rng.range(0.0, 0.8);
                let s = Sphere::new(
                    Vec3A::from(eye) + spread * dist,
                    rng.log_range(1e-3, 0.5) * dist,
                );
                let got = f.classify_sphere(&s);
                counts.add(got);
                let (c, r) = (d(s.center), f64::from(s.radius));
                match got {
                    Containment::Outside => {
                        let separated = planes.iter().any(|p| signed_dist(p, c) + r < tol(p, c, r));
                        assert!(
                            separated,
                            "{kind:?}: {s:?} called Outside, but no plane separates it"
                        );
                        for _ in 0..8 {
                            let x = c + d(rng.unit_vector_f64()) * r * rng.f64();
                            assert!(
                                !planes.iter().all(|p| signed_dist(p, x) > tol(p, x, r)),
                                "{kind:?}: {s:?} Outside, {x} inside"
                            );
                        }
                    }
                    Containment::Inside => {
                        for p in &planes {
                            assert!(
                                signed_dist(p, c) - r >= -tol(p, c, r),
                                "{kind:?}: {s:?} called Inside, crosses {p}"
                            );
                        }
                    }
                    Containment::Intersecting => {}
                }
            }
        }
        counts.assert_mixed(&format!("{kind:?} spheres"));
    }
}

/// A random affine map: rotation with non-uniform, possibly negative scale, or a general matrix
/// (shear), with a translation up to 1e4.
fn random_affine(rng: &mut Rng) -> Affine3A {
    let t = Vec3::from(rng.vec3a(-1e4, 1e4));
    if rng.bool() {
        let s = Vec3::new(
            rng.signed_log(1e-2, 1e2),
            rng.signed_log(1e-2, 1e2),
            rng.signed_log(1e-2, 1e2),
        );
        let q = Quat::from_axis_angle(Vec3::from(rng.unit_vector_f64()), rng.range(0.0, 6.3));
        Affine3A::from_scale_rotation_translation(s, q, t)
    } else {
        let m = Mat3::from_cols(
            rng.vec3a(-10.0, 10.0).into(),
            rng.vec3a(-10.0, 10.0).into(),
            rng.vec3a(-10.0, 10.0).into(),
        );
        Affine3A::from_mat3_translation(m, t)
    }
}

fn apply(m: &Affine3A, p: DVec3) -> DVec3 {
    DMat3::from_cols(
        d(m.matrix3.x_axis),
        d(m.matrix3.y_axis),
        d(m.matrix3.z_axis),
    ) * p
        + d(m.translation)
}

#[test]
fn aabb_transformed_matches_corner_loop() {
    let mut rng = Rng::new(20);
    for _ in 0..200_000 {
        let m = random_affine(&mut rng);
        let c = rng.vec3a(-1e3, 1e3);
        let b = Aabb::from_center_half_extents(
            c,
            Vec3A::from_array(core::array::from_fn(|_| rng.log_range(1e-3, 1e2))),
        );
        let got = b.transformed(&m);
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for x in b.corners() {
            let y = apply(&m, d(x));
            lo = lo.min(y);
            hi = hi.max(y);
        }
        // Per axis: the magnitudes the f32 sums are formed at.
        let lin = DMat3::from_cols(
            d(m.matrix3.x_axis.abs()),
            d(m.matrix3.y_axis.abs()),
            d(m.matrix3.z_axis.abs()),
        );
        let scale = lin * d(b.min.abs().max(b.max.abs())) + d(m.translation.abs());
        let allowed = scale * 1e-6;
        let err = (d(got.min) - lo).abs().max((d(got.max) - hi).abs());
        assert!(
            err.cmple(allowed).all(),
            "transformed {got:?} vs corners [{lo}, {hi}] (err {err}, allowed {allowed}) for {b:?} under {m:?}"
        );
    }
    assert_eq!(
        Aabb::EMPTY.transformed(&Affine3A::from_scale(Vec3::splat(-2.0))),
        Aabb::EMPTY
    );
}

/// The direction of greatest stretch of `m` (power iteration on m^T m): where a sphere's bound
/// is tight, so the sample that would expose an underestimated radius.
fn stretch_direction(m: &DMat3) -> DVec3 {
    let mtm = m.transpose() * *m;
    let mut v = DVec3::new(0.6, 0.7, 0.4);
    for _ in 0..200 {
        v = (mtm * v).normalize_or(DVec3::X);
    }
    v
}

#[test]
fn sphere_transformed_contains_images() {
    let mut rng = Rng::new(21);
    let mut worst_gap = f64::NEG_INFINITY;
    for _ in 0..100_000 {
        let m = random_affine(&mut rng);
        let s = Sphere::new(rng.vec3a(-1e3, 1e3), rng.log_range(1e-3, 1e2));
        let got = s.transformed(&m);
        let lin = DMat3::from_cols(
            d(m.matrix3.x_axis),
            d(m.matrix3.y_axis),
            d(m.matrix3.z_axis),
        );
        let (c, r) = (d(s.center), f64::from(s.radius));
        let (gc, gr) = (d(got.center), f64::from(got.radius));
        let allowed = 1e-6 * (gr + gc.length());
        let v = stretch_direction(&lin);
        let samples = [v, -v]
            .into_iter()
            .chain((0..14).map(|_| d(rng.unit_vector_f64())));
        for u in samples {
            let y = apply(&m, c + u * r);
            let gap = (y - gc).length() - gr;
            worst_gap = worst_gap.max(gap / (gr + gc.length()));
            assert!(
                gap <= allowed,
                "image {y} of a surface point is {gap} outside {got:?} ({s:?} under {m:?})"
            );
        }
    }
    // Positive values are images outside the bound by rounding (the f32 centre itself is only
    // good to half an ulp of its magnitude); they must stay within the 1e-6 allowance.
    println!("worst sample gap, relative to radius + |centre|: {worst_gap:e}");
}
