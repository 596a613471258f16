//! Ray/sphere against an f64 reference: the verdict may differ only in a thin band around
//! tangency, the entry parameter is accurate, and far, small spheres are still hit.

mod support;

use accel_testkit::Rng;
use glam::{DVec3, Vec3A};
use spatial_accel::{Ray, Sphere};
use support::{d, sphere_f64};

/// Width of the tangency band, relative to the radius, for a case whose centre sits `far`
/// radii from the origin. The line's closest point is found at the magnitude of `origin -
/// centre`, so f32 places it to a few ulps of that distance; 2e-6 is about 30 ulps.
fn band(far: f64) -> f64 {
    1e-5 + 2e-6 * far
}

#[derive(Default)]
struct Stats {
    cases: u64,
    hits: u64,
    misses: u64,
    in_band: u64,
    worst_t: f64,
}

/// One ray: the verdict outside the band, and the entry parameter on clear hits, where the
/// error is measured in units of the case's own scale (distance to the far side of the sphere
/// along the ray), since near the origin `t` itself may be tiny.
fn check(ray: &Ray, s: &Sphere, stats: &mut Stats) {
    stats.cases += 1;
    let (o, dir, c, r) = (
        d(ray.origin),
        d(ray.direction),
        d(s.center),
        f64::from(s.radius),
    );
    let reference = sphere_f64(o, dir, c, r);
    let got = ray.intersect_sphere(s);
    let far = (o - c).length() / r;
    let in_range = |(t0, t1): (f64, f64)| t1 >= f64::from(ray.t_min) && t0 <= f64::from(ray.t_max);
    if (reference.closeness - 1.0).abs() <= band(far) {
        stats.in_band += 1;
        return;
    }
    match (reference.roots.filter(|&r| in_range(r)), got) {
        (Some((t0, t1)), Some(t)) => {
            stats.hits += 1;
            let want = t0.max(f64::from(ray.t_min));
            // Near tangency the roots are a square root away from the discriminant's rounding.
            if reference.closeness < 0.99 {
                let scale = t1.abs().max(want.abs()).max(r / dir.length());
                let err = (f64::from(t) - want).abs() / scale;
                stats.worst_t = stats.worst_t.max(err);
                assert!(
                    err < 1e-5,
                    "t = {t}, exact {want} (err {err:e}): {ray:?} {s:?}"
                );
            }
        }
        (None, None) => stats.misses += 1,
        (want, got) => panic!(
            "verdict differs outside the tangency band: exact {want:?}, got {got:?} (closeness {}): {ray:?} {s:?}",
            reference.closeness
        ),
    }
}

/// A direction from `o` through a point `k` radii off the centre, sideways to the line of sight.
fn aim(rng: &mut Rng, o: DVec3, c: DVec3, r: f64, k: f64) -> DVec3 {
    let to_c = c - o;
    let side = d(rng.unit_vector_f64())
        .reject_from(to_c)
        .normalize_or_zero();
    c + side * (r * k) - o
}

#[test]
fn random_rays_match_reference() {
    let mut rng = Rng::new(1);
    let mut stats = Stats::default();
    for _ in 0..500_000 {
        let s = Sphere::new(rng.vec3a(-1e3, 1e3), rng.log_range(1e-3, 1e3));
        let (c, r) = (d(s.center), f64::from(s.radius));
        // Origins from inside the sphere to ten thousand radii away.
        let o = (c + d(rng.unit_vector_f64()) * r * f64::from(rng.log_range(0.1, 1e4))).as_vec3a();
        let k = rng.range_f64(0.0, 2.0);
        let dir = aim(&mut rng, d(o), c, r, k) * f64::from(rng.log_range(1e-3, 1e3));
        let (t_min, t_max) = if rng.below(4) == 0 {
            (rng.range(0.0, 1.0), rng.range(1.0, 2.0))
        } else {
            (0.0, f32::INFINITY)
        };
        check(
            &Ray::with_range(o, dir.as_vec3a(), t_min, t_max),
            &s,
            &mut stats,
        );
    }
    println!(
        "random: {} cases, {} hits, {} misses, {} in the tangency band, worst t error {:e}",
        stats.cases, stats.hits, stats.misses, stats.in_band, stats.worst_t
    );
    assert!(stats.hits > 100_000 && stats.misses > 100_000);
    assert!(
        stats.in_band < stats.cases / 100,
        "band too wide to test anything"
    );
}

/// Spheres of radius 1e-2 at distance 1e5: the textbook quadratic loses every digit here
/// (`c = |f|^2 - r^2` rounds away r^2 entirely). Rays passing the centre closer than 0.4 radii
/// must hit with an accurate entry, rays farther than 1.6 radii must miss. The band between is
/// f32's own limit: the closest point of the line is formed at magnitude 1e5, where the f32
/// spacing is 0.0078 (0.78 radii), so no f32 formulation without fused multiply-adds resolves
/// it more finely.
#[test]
fn far_small_spheres() {
    let mut rng = Rng::new(2);
    let mut stats = Stats::default();
    let (mut hit, mut missed) = (0, 0);
    for i in 0..200_000 {
        // An origin near the world origin, on a 2^-7 grid so that `origin - centre` is exact at
        // 1e5 (where the f32 spacing is 2^-7): what is tested is the algorithm, not the input.
        let o = (d(rng.vec3a(-64.0, 64.0)) * 128.0).round() / 128.0;
        let c = d((rng.unit_vector_f64() * 1e5).round());
        let s = Sphere::new(c.as_vec3a(), 1e-2);
        let r = f64::from(s.radius);
        let k = if i % 2 == 0 {
            rng.range_f64(0.0, 0.5)
        } else {
            rng.range_f64(1.5, 3.0)
        };
        let dir = aim(&mut rng, o, c, r, k).normalize().as_vec3a();
        let ray = Ray::new(o.as_vec3a(), dir);
        // The rounded direction lands a few mm off the aim point at 1e5: the verdict that
        // counts is the reference's on the rounded ray.
        let reference = sphere_f64(o, d(dir), c, r);
        let got = ray.intersect_sphere(&s);
        if reference.closeness < 0.4 {
            let (t0, _) = reference.roots.unwrap();
            let t = got.unwrap_or_else(|| {
                panic!(
                    "far sphere missed (closeness {}): {ray:?} {s:?}",
                    reference.closeness
                )
            });
            let err = (f64::from(t) - t0).abs() / t0;
            stats.worst_t = stats.worst_t.max(err);
            assert!(err < 1e-5, "t = {t}, exact {t0}: {ray:?} {s:?}");
            hit += 1;
        } else if reference.closeness > 1.6 {
            assert!(
                got.is_none(),
                "far sphere falsely hit (closeness {}): {ray:?} {s:?}",
                reference.closeness
            );
            missed += 1;
        }
    }
    println!(
        "far: {hit} clear hits, {missed} clear misses, worst relative t error {:e}",
        stats.worst_t
    );
    assert!(hit > 50_000 && missed > 50_000);
}

#[test]
fn named_cases() {
    let unit = Sphere::new(Vec3A::ZERO, 1.0);
    // Inside: the solid sphere is entered at t_min.
    assert_eq!(
        Ray::new(Vec3A::ZERO, Vec3A::X).intersect_sphere(&unit),
        Some(0.0)
    );
    assert_eq!(
        Ray::with_range(Vec3A::ZERO, Vec3A::X, 0.25, 9.0).intersect_sphere(&unit),
        Some(0.25)
    );
    // Behind the origin, or beyond t_max: a miss.
    assert_eq!(
        Ray::new(Vec3A::new(3.0, 0.0, 0.0), Vec3A::X).intersect_sphere(&unit),
        None
    );
    assert_eq!(
        Ray::with_range(Vec3A::new(-3.0, 0.0, 0.0), Vec3A::X, 0.0, 1.5).intersect_sphere(&unit),
        None
    );
    // Unnormalised direction: t in units of its length.
    assert_eq!(
        Ray::new(Vec3A::new(-3.0, 0.0, 0.0), Vec3A::X * 2.0).intersect_sphere(&unit),
        Some(1.0)
    );
    // Zero radius: a point, hit dead on.
    let point = Sphere::new(Vec3A::new(5.0, 0.0, 0.0), 0.0);
    assert_eq!(
        Ray::new(Vec3A::ZERO, Vec3A::X).intersect_sphere(&point),
        Some(5.0)
    );
    assert!(
        Ray::new(Vec3A::ZERO, Vec3A::Y)
            .intersect_sphere(&point)
            .is_none()
    );
}
