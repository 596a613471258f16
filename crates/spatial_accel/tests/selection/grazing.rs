//! Triangles built to graze one plane of a rectangle's frustum, at a corner, along an edge or
//! lying in the plane, from a few bands outside to a few inside: touching must take the
//! conservative side, and its band must stay a band.

use super::oracle::{Camera, Kind, d, f};
use accel_testkit::Rng;
use glam::{DVec2, DVec3, Vec2, Vec3A};
use spatial_accel::{Frustum, TOUCH_TOLERANCE};

#[derive(Clone, Copy, Debug)]
enum Shape {
    /// One corner on the plane, the others outside.
    Corner,
    /// An edge along the plane, the third corner outside.
    Edge,
    /// All three corners in the plane.
    Face,
}

#[derive(Default, Debug)]
struct Counts {
    /// Touching by the exact distances, within a band of the plane: rounding decides.
    grazing_in: u64,
    /// Outside by less than half a band: must still be called touching.
    band: u64,
    /// Outside by more than two bands: must not be.
    clear: u64,
    /// Between: either answer.
    between: u64,
    /// Left out: the plane alone does not decide.
    unclear: u64,
}

#[test]
fn grazing_triangles_take_the_conservative_side() {
    for (seed, kind) in [(11, Kind::Perspective), (12, Kind::Orthographic)] {
        let mut rng = Rng::new(seed);
        let mut counts = Counts::default();
        for _ in 0..300 {
            let camera = Camera::random(&mut rng, kind, 1e3, None);
            let lo = DVec2::new(rng.range_f64(-0.9, 0.3), rng.range_f64(-0.9, 0.3));
            let hi = lo + DVec2::new(rng.range_f64(0.1, 0.6), rng.range_f64(0.1, 0.6));
            let (a, b) = (lo.as_vec2(), hi.as_vec2());
            let frustum = Frustum::from_clip_rect(&camera.clip_from_world, a, b).unwrap();
            let (lo, hi) = (a.as_dvec2(), b.as_dvec2());
            for _ in 0..40 {
                let plane = rng.below(5);
                let shape = [Shape::Corner, Shape::Edge, Shape::Face][rng.below(3)];
                let Some((corners, reach, band)) =
                    grazing_triangle(&mut rng, &camera, &frustum, plane, shape, lo, hi)
                else {
                    counts.unclear += 1;
                    continue;
                };
                let got = frustum.touches_triangle(&corners);
                let case = || {
                    format!(
                        "{kind:?} plane {plane} {shape:?} reach {reach:e} band {band:e}: {corners:?} in {frustum:?}"
                    )
                };
                if reach >= 0.0 {
                    assert!(got, "touching, missed: {}", case());
                    if reach < band {
                        counts.grazing_in += 1;
                    }
                } else if reach >= -0.5 * band {
                    assert!(got, "within half a band, missed: {}", case());
                    counts.band += 1;
                } else if reach < -2.0 * band {
                    assert!(!got, "two bands outside, called touching: {}", case());
                    counts.clear += 1;
                } else {
                    counts.between += 1;
                }
            }
        }
        println!("{kind:?}: {counts:?}");
        assert!(
            counts.grazing_in > 500 && counts.band > 500 && counts.clear > 500,
            "{kind:?}: {counts:?}"
        );
    }
}

/// A triangle grazing `plane` of `frustum` (the rectangle `[lo, hi]` of `camera`), placed
/// a random number of bands off it; with its reach (the exact `f64` distance of its most
/// inward corner to the `f32` plane, positive inside) and the band the test widens that
/// plane by for it. `None` where its corners near the plane are not clear inside the
/// others.
fn grazing_triangle(
    rng: &mut Rng,
    camera: &Camera,
    frustum: &Frustum,
    plane: usize,
    shape: Shape,
    lo: DVec2,
    hi: DVec2,
) -> Option<([Vec3A; 3], f64, f64)> {
    // A point on that face of the frustum, inside the others by a fifth of the rectangle.
    let mut ndc = lo + (hi - lo) * DVec2::new(rng.range_f64(0.2, 0.8), rng.range_f64(0.2, 0.8));
    let mut depth = camera.depth_in_view(rng);
    match plane {
        0 => ndc.x = lo.x,
        1 => ndc.x = hi.x,
        2 => ndc.y = lo.y,
        3 => ndc.y = hi.y,
        _ => depth = camera.near,
    }
    let p = frustum.planes[plane];
    let (n, dist) = (p.normal.as_dvec3(), f64::from(p.d));
    let onto = |x: DVec3| x - n * (n.dot(x) + dist);
    let q0 = onto(camera.world(camera.view_point(ndc, depth)));
    // Small against the margin to the other planes.
    let size = camera.size_at(depth) * (hi - lo).min_element() * 0.03;
    let band_at =
        |scale: f64| f64::from(TOUCH_TOLERANCE) * (dist.abs() + n.abs().element_sum() * scale);
    let estimate = band_at(q0.abs().max_element() + 2.0 * size);
    let sigma = [-3.0, -1.0, -0.5, -0.25, 0.0, 0.0, 0.0, 0.25, 0.5, 3.0][rng.below(10)];
    let off = n * (sigma * estimate * rng.range_f64(0.9, 1.1));
    let t1 = n.any_orthonormal_vector();
    let t2 = n.cross(t1);
    let out = -n * size;
    let q = q0 + off;
    let corners = match shape {
        Shape::Corner => [q, q + out + t1 * size, q + out - t1 * size + t2 * size],
        Shape::Edge => [q, onto(q0 + t1 * size) + off, q + out + t2 * size],
        Shape::Face => [q, onto(q0 + t1 * size) + off, onto(q0 + t2 * size) + off],
    }
    .map(f);
    let reach = corners
        .iter()
        .map(|&c| n.dot(d(c)) + dist)
        .fold(f64::NEG_INFINITY, f64::max);
    let scale = f64::from(
        corners
            .iter()
            .fold(0.0f32, |m, c| m.max(c.abs().max_element())),
    );
    // The corners near the plane must lie clear inside the others, or the plane alone does
    // not decide (a near plane a hundredth from an eye a thousand from the origin is not
    // resolved by `f32` planes: such cases are left out).
    let clear = corners
        .iter()
        .filter(|&&c| n.dot(d(c)) + dist >= -4.0 * estimate)
        .all(|&c| {
            frustum.planes.iter().enumerate().all(|(j, other)| {
                let (m, e) = (other.normal.as_dvec3(), f64::from(other.d));
                let band = f64::from(TOUCH_TOLERANCE) * (e.abs() + m.abs().element_sum() * scale);
                j == plane || m.dot(d(c)) + e >= 8.0 * band
            })
        });
    clear.then_some((corners, reach, band_at(scale)))
}

/// Planes moved into a mesh's space keep grazing triangles on the conservative side too:
/// a triangle with a corner at a corner of the frustum (where three planes meet, solved in
/// `f64` and rounded once, in local space), mapped by a mirrored, non-uniformly scaled
/// transform, is touching in local space.
#[test]
fn grazing_survives_the_move_to_local_space() {
    use glam::{DMat3, Mat4, Quat, Vec3};
    let mut rng = Rng::new(13);
    for _ in 0..2000 {
        let kind = [Kind::Perspective, Kind::Orthographic][rng.below(2)];
        let camera = Camera::random(&mut rng, kind, 100.0, None);
        let (a, b) = (
            Vec2::new(rng.range(-1.0, 0.0), rng.range(-1.0, 0.0)),
            Vec2::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0)),
        );
        let rect = Frustum::from_clip_rect(&camera.clip_from_world, a, b).unwrap();
        let [x, y] = [rng.below(2), 2 + rng.below(2)];
        let planes = [x, y, Frustum::NEAR].map(|i| rect.planes[i]);
        let normals =
            DMat3::from_cols_array_2d(&planes.map(|p| p.normal.as_dvec3().to_array())).transpose();
        let apex = normals.inverse() * -DVec3::from_array(planes.map(|p| f64::from(p.d)));
        // Fanning out from the apex, away from the frustum.
        let outward = -(planes[0].normal + planes[1].normal + planes[2].normal).as_dvec3();
        let side = outward.any_orthonormal_vector() * 0.5;
        let world = [apex, apex + outward + side, apex + outward - side];
        let scale = Vec3::new(
            rng.signed_log(0.2, 5.0),
            rng.signed_log(0.2, 5.0),
            rng.signed_log(0.2, 5.0),
        );
        let rotation =
            Quat::from_axis_angle(Vec3::from(rng.unit_vector_f64()), rng.range(0.0, 6.0));
        let world_from_local = Mat4::from_scale_rotation_translation(
            scale,
            rotation,
            Vec3::from(rng.vec3a(-50.0, 50.0)),
        );
        let local = rect.transformed(&world_from_local);
        let local_from_world = world_from_local.as_dmat4().inverse();
        let triangle = world.map(|w| f(local_from_world.transform_point3(w)));
        assert!(
            local.touches_triangle(&triangle),
            "{kind:?}: {triangle:?} in {local:?}"
        );
        // And the same corner pushed a little way out is not.
        let away = world.map(|w| {
            f(local_from_world.transform_point3(w + outward * 1e-3 * (1.0 + apex.length())))
        });
        assert!(
            !local.touches_triangle(&away),
            "{kind:?}: {away:?} in {local:?}"
        );
    }
}
